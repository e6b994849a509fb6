"""``po3d train viewpoint`` and ``po3d eval viewpoint``: the viewpoint network (an azimuth reading of each
object's crop, combined with the render-and-compare pose table), trained from scratch on a built dataset.

Register with ``"viewpoint"`` in ``po3d_ppl.cli._MODULES``.
"""

from __future__ import annotations

import shlex
from pathlib import Path
from typing import Annotated

import typer

from po3d_ppl.cli._common import build_command, comma_list, dataset_manifest, write_report
from po3d_ppl.cli.attributes import _load as _load_crops


def _load(console, data: Path, split: str, config, cache: Path | None):
    from po3d_ppl.perception.train_viewpoint import load_viewpoint_split

    return _load_crops(console, data, split, config, cache, load_viewpoint_split)


def _print_measure(console, title: str, report: dict) -> None:
    from rich.table import Table

    from po3d_ppl.cli._common import literal

    table = Table(title=literal(title))
    for col in ("measure", "value"):
        table.add_column(col, justify="left" if col == "measure" else "right")
    for key, value in report.items():
        table.add_row(key, f"{value:.4f}" if isinstance(value, float) else str(value))
    console.print(table)


def train_viewpoint_command(
    data: Annotated[list[Path], typer.Option(
        "--data", help="Dataset directory from `po3d dataset build` (repeatable: --splits of each are trained on; "
                       "--val-split is taken from the first).")],
    out: Annotated[Path | None, typer.Option("--out", help="Where to write the model (default: models/).")] = None,
    seed: Annotated[int, typer.Option("--seed", help="Seed of initialisation, data order and augmentation.")] = 0,
    epochs: Annotated[int, typer.Option("--epochs", min=1, help="Passes over the training objects.")] = 24,
    batch_size: Annotated[int, typer.Option("--batch-size", min=1, help="Objects a step.")] = 32,
    lr: Annotated[float, typer.Option("--lr", help="Peak learning rate (one-cycle).")] = 3e-3,
    max_steps: Annotated[int | None, typer.Option("--max-steps", min=1, help="Stop after this many steps.")] = None,
    mask_cut: Annotated[float, typer.Option(
        "--mask-cut", min=0.0, max=1.0, help="Probability of cutting a crop's mask along a random line (the "
                                             "parser's masks of occluded objects miss a side of what shows).")] = 0.0,
    splits: Annotated[str, typer.Option("--splits", help="Comma-separated splits of each --data to train on.")
                      ] = "train",
    val_split: Annotated[str, typer.Option("--val-split", help="Split of the first --data for the temperature.")
                         ] = "val",
    eval_data: Annotated[Path | None, typer.Option(
        "--eval-data", help="Held-out dataset (another seed) to measure on (all its splits, ground-truth masks).")
    ] = None,
    cache: Annotated[Path | None, typer.Option(
        "--cache", help="Crop cache directory (default: <data>/../attribute_crops).")] = None,
    device: Annotated[str, typer.Option("--device", help="torch device, e.g. cpu or cuda.")] = "cpu",
    threads: Annotated[int, typer.Option("--threads", min=1, help="torch CPU threads.")] = 1,
) -> None:
    """Train the viewpoint network on ground-truth-mask crops, fit its temperature on --val-split, and write
    models/viewpoint.safetensors with its manifest entry."""
    import torch
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from po3d_ppl.cli._common import check_seed
    from po3d_ppl.model_store import models_dir
    from po3d_ppl.perception.train_viewpoint import (
        ViewpointData,
        ViewpointTrainConfig,
        calibrate_viewpoint,
        measure,
        split_counts,
        train_viewpoint,
    )
    from po3d_ppl.perception.viewpoint import save_viewpoint_net

    check_seed(seed)
    torch.set_num_threads(threads)
    console = Console()
    config = ViewpointTrainConfig(seed=seed, epochs=epochs, batch_size=batch_size, lr=lr, max_steps=max_steps,
                                  mask_cut=mask_cut)
    split_list = comma_list(splits)
    train = ViewpointData.concat([_load(console, d, s, config.net, cache) for d in data for s in split_list])
    val = _load(console, data[0], val_split, config.net, cache)
    console.print(f"training on {train.num_objects} objects {split_counts(train)}; calibrating on "
                  f"{val.num_objects}", highlight=False)
    with Progress(TextColumn("[bold]train viewpoint"), BarColumn(), MofNCompleteColumn(),
                  TextColumn("epoch {task.fields[epoch]:.1f} loss {task.fields[loss]:.3f}"), TimeRemainingColumn(),
                  console=console) as bar:
        task = bar.add_task("train", total=None, epoch=0.0, loss=float("nan"))
        trained = train_viewpoint(train, config, device=device,
                                  progress=lambda step, total, info: bar.update(task, completed=step, total=total,
                                                                                epoch=info["epoch"],
                                                                                loss=info["loss"]))
    net = trained.net
    calibration = calibrate_viewpoint(net, val)
    _print_measure(console, f"viewpoint on {data[0].name}/{val_split} (GT masks, >= 200 px)", calibration["val_after"])
    metrics: dict = {"train_objects": train.num_objects, "train_seconds": round(trained.seconds, 1),
                     "step_seconds": round(trained.step_seconds, 4), "steps": trained.steps, "threads": threads,
                     "device": device, "parameters": net.num_parameters(), "history": trained.history,
                     "calibration": calibration}
    manifests = [dataset_manifest(d) for d in data]
    seeds = [m.get("seed") for m in manifests]
    if eval_data is not None:
        held = ViewpointData.concat([_load(console, eval_data, s, config.net, cache) for s in ("train", "val", "test")])
        held_manifest = dataset_manifest(eval_data)
        report = measure(net, held)
        metrics[f"eval_seed{held_manifest.get('seed')}"] = {**report, "data": str(eval_data),
                                                            "masks": "ground-truth visible masks"}
        _print_measure(console, f"viewpoint on {eval_data} (GT masks, >= 200 px)", report)
        manifests.append(held_manifest)
    words = ["po3d", "train", "viewpoint", *[w for d in data for w in ("--data", str(d))], "--seed", str(seed),
             "--epochs", str(epochs), "--batch-size", str(batch_size), "--lr", str(lr),
             "--splits", ",".join(split_list), "--val-split", val_split, "--threads", str(threads)]
    if max_steps is not None:
        words += ["--max-steps", str(max_steps)]
    if mask_cut > 0:
        words += ["--mask-cut", str(mask_cut)]
    if eval_data is not None:
        words += ["--eval-data", str(eval_data)]
    if out is not None:
        words += ["--out", str(out)]
    path = save_viewpoint_net(net.to("cpu"), Path(out) if out is not None else models_dir(),
                              command=shlex.join(words),
                              data_commands=[build_command(d, m) for d, m in
                                             zip([*data, *([eval_data] if eval_data else [])], manifests)],
                              data_seed=seeds[0] if len(seeds) == 1 else seeds, train_config=config.to_dict(),
                              metrics=metrics)
    console.print(f"wrote {path} ({path.stat().st_size / 1e6:.2f} MB) after {trained.seconds:.0f} s of training "
                  f"({trained.step_seconds:.3f} s a step); temperature {calibration['temperature']:.3f}",
                  markup=False, highlight=False)


def eval_viewpoint_command(
    data: Annotated[Path, typer.Option("--data", help="Held-out dataset directory (a seed never trained on).")],
    model_dir: Annotated[Path | None, typer.Option("--model-dir", help="Model directory (default: models/).")] = None,
    splits: Annotated[str, typer.Option("--splits", help="Splits of --data to measure on.")] = "train,val,test",
    json_out: Annotated[Path | None, typer.Option("--json", help="Also write the report to this JSON file.")] = None,
    cache: Annotated[Path | None, typer.Option("--cache", help="Crop cache directory.")] = None,
    threads: Annotated[int, typer.Option("--threads", min=1)] = 1,
) -> None:
    """Azimuth within 30 degrees (per category), front/back flips and ECE of the viewpoint network alone, on
    ground-truth-mask crops (``po3d eval evidence`` measures the combined pose on the parser's own masks)."""
    import torch
    from rich.console import Console

    from po3d_ppl.perception.train_viewpoint import ViewpointData, measure
    from po3d_ppl.perception.viewpoint import load_viewpoint_net

    torch.set_num_threads(threads)
    console = Console()
    net = load_viewpoint_net(model_dir)
    split_list = comma_list(splits)
    held = ViewpointData.concat([_load(console, data, s, net.config, cache) for s in split_list])
    report = {**measure(net, held), "data": str(data), "splits": split_list}
    _print_measure(console, f"viewpoint on {data} (GT masks, >= 200 px)", report)
    write_report(json_out, report)


def register(app: typer.Typer, train_app: typer.Typer, eval_app: typer.Typer) -> None:
    train_app.command("viewpoint")(train_viewpoint_command)
    eval_app.command("viewpoint")(eval_viewpoint_command)

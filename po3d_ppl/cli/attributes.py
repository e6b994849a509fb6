"""``po3d train attributes`` and ``po3d eval attributes``: the attribute network of issue "Perception II" (object
subtype, colour, material, size; part looks), trained from scratch on a built dataset, calibrated on its
validation split and measured on held-out images.

Register with ``"attributes"`` in ``po3d_ppl.cli._MODULES``.
"""

from __future__ import annotations

import dataclasses
import shlex
from pathlib import Path
from typing import Annotated

import typer

from po3d_ppl.cli._common import build_command, comma_list, dataset_manifest, write_report


def _bar(console, what: str):
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    return Progress(TextColumn(f"[bold]{what}"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn(),
                    console=console)


def _load(console, data: Path, split: str, config, cache: Path | None, loader=None, **options):
    """One split's crops (``loader``: ``train_attributes.load_split`` or a reader with its signature; ``options``
    go to it) under a progress bar."""
    if loader is None:
        from po3d_ppl.perception.train_attributes import load_split as loader

    with _bar(console, f"crops {data.name}/{split}") as bar:
        task = bar.add_task(split, total=None)
        return loader(data, split, config, cache=cache,
                      progress=lambda done, total: bar.update(task, completed=done, total=total), **options)


def _print_report(console, report: dict, title: str) -> None:
    from rich.table import Table

    from po3d_ppl.cli._common import literal

    groups = ["all", *sorted({g for row in report["objects"].values() for g in row if g != "all"
                              and not g.startswith("n_")})]
    table = Table(title=literal(title))
    table.add_column("measure")
    table.add_column("n", justify="right")
    for g in groups:
        table.add_column(g, justify="right")
    for name, row in report["objects"].items():
        table.add_row(name, str(row.get("n_all", "")), *(f"{row[g]:.3f}" if g in row else "-" for g in groups))
    console.print(table)
    ece = Table(title="ECE (15 bins): T = 1 vs fitted temperature")
    for col in ("head", "T", "before", "after"):
        ece.add_column(col, justify="right" if col != "head" else "left")
    for name, row in report["ece"].items():
        ece.add_row(name, f"{report['temperatures'].get(name, float('nan')):.3f}", f"{row['before']:.4f}",
                    f"{row['after']:.4f}")
    console.print(ece)


def train_attributes_command(
    data: Annotated[list[Path], typer.Option(
        "--data", help="Dataset directory from `po3d dataset build` (repeatable: --splits of each are trained on; "
                       "--val-split is taken from the first).")],
    out: Annotated[Path | None, typer.Option("--out", help="Where to write the model (default: models/).")] = None,
    seed: Annotated[int, typer.Option("--seed", help="Seed of initialisation, data order and augmentation.")] = 0,
    epochs: Annotated[int, typer.Option("--epochs", min=1, help="Passes over the training objects.")] = 28,
    batch_size: Annotated[int, typer.Option("--batch-size", min=1, help="Objects a step (parts: in step).")] = 32,
    lr: Annotated[float, typer.Option("--lr", help="Peak learning rate (one-cycle).")] = 3e-3,
    part_fraction: Annotated[float, typer.Option(
        "--part-fraction", help="Fraction of the training parts seen per epoch (a random subset).")] = 0.25,
    part_shift: Annotated[float, typer.Option(
        "--part-shift", min=0.0, max=0.5,
        help="Move part crops' image against their mask by up to this fraction of the side (projected masks are "
             "off the part).")] = 0.12,
    part_masks: Annotated[str, typer.Option(
        "--part-masks", help="Cut part crops around the true visible masks ('truth') or around the parts of each "
                             "scene re-rendered at jittered poses, as the parser projects them ('jittered').")
                          ] = "truth",
    members: Annotated[int, typer.Option(
        "--members", min=1, help="Networks to train (seeds --seed, --seed + 1, ...) and ship as one ensemble; they "
                                 "share the crops of --seed's jittered projections.")] = 1,
    max_steps: Annotated[int | None, typer.Option("--max-steps", min=1, help="Stop after this many steps.")] = None,
    splits: Annotated[str, typer.Option("--splits", help="Comma-separated splits of each --data to train on.")
                      ] = "train",
    val_split: Annotated[str, typer.Option(
        "--val-split", help="Split of the first --data to fit temperatures on.")] = "val",
    eval_data: Annotated[Path | None, typer.Option(
        "--eval-data", help="Held-out dataset (another seed) to measure on through the public API.")] = None,
    cache: Annotated[Path | None, typer.Option(
        "--cache", help="Crop cache directory (default: <data>/../attribute_crops).")] = None,
    device: Annotated[str, typer.Option("--device", help="torch device, e.g. cpu or cuda.")] = "cpu",
    threads: Annotated[int, typer.Option(
        "--threads", min=1, help="torch CPU threads (one is fastest on a busy 2-core machine).")] = 1,
) -> None:
    """Train the attribute network (or --members networks, one after another, read as one ensemble) on crops around
    true or jittered masks, fit each network's temperatures on --val-split, and write
    models/attributes.safetensors with its manifest entry."""
    import torch
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from po3d_ppl.cli._common import check_seed
    from po3d_ppl.errors import InputError
    from po3d_ppl.model_store import models_dir
    from po3d_ppl.perception.attributes import AttributeEnsemble, save_attribute_net
    from po3d_ppl.perception.train_attributes import (
        AttributeData,
        ProjectionJitter,
        TrainConfig,
        calibrate,
        evaluate_dataset,
        train_attributes,
    )

    check_seed(seed)
    if part_masks not in ("truth", "jittered"):
        raise InputError("--part-masks", f"expected 'truth' or 'jittered', got {part_masks!r}")
    jitter = ProjectionJitter(seed=seed) if part_masks == "jittered" else None
    torch.set_num_threads(threads)
    console = Console()
    config = TrainConfig(seed=seed, epochs=epochs, batch_size=batch_size, lr=lr, part_fraction=part_fraction,
                         part_shift=part_shift, max_steps=max_steps)
    split_list = comma_list(splits)
    train = AttributeData.concat([_load(console, d, s, config.net, cache, jitter=jitter)
                                  for d in data for s in split_list])
    val = _load(console, data[0], val_split, config.net, cache, jitter=jitter)
    console.print(f"training on {train.num_objects} objects and {train.num_parts} parts "
                  f"({float(train.part_label('recoloured').float().mean()):.3f} recoloured); "
                  f"calibrating on {val.num_objects} objects, {val.num_parts} parts", highlight=False)
    trained_members, member_metrics = [], []
    for k in range(members):
        member_config = dataclasses.replace(config, seed=seed + k)
        label = "train attributes" if members == 1 else f"train attributes {k + 1}/{members}"
        with Progress(TextColumn(f"[bold]{label}"), BarColumn(), MofNCompleteColumn(),
                      TextColumn("epoch {task.fields[epoch]:.1f} loss {task.fields[loss]:.3f}"), TimeRemainingColumn(),
                      console=console) as bar:
            task = bar.add_task("train", total=None, epoch=0.0, loss=float("nan"))
            trained = train_attributes(train, member_config, device=device,
                                       progress=lambda step, total, info: bar.update(
                                           task, completed=step, total=total, epoch=info["epoch"], loss=info["loss"]))
        calibration = calibrate(trained.net, val)
        trained_members.append(trained)
        member_metrics.append({"seed": seed + k, "train_seconds": round(trained.seconds, 1),
                               "step_seconds": round(trained.step_seconds, 4), "steps": trained.steps,
                               "history": trained.history, "calibration": calibration})
    net = trained_members[0].net if members == 1 else AttributeEnsemble([t.net for t in trained_members])
    metrics: dict = {"train_objects": train.num_objects, "train_parts": train.num_parts,
                     "train_seconds": round(sum(t.seconds for t in trained_members), 1), "threads": threads,
                     "device": device, "parameters": net.num_parameters()}
    if members == 1:
        metrics |= {k: v for k, v in member_metrics[0].items() if k not in ("seed", "train_seconds")}
    else:
        metrics["members"] = member_metrics
    data_manifests = [dataset_manifest(d) for d in data]
    seeds = [m.get("seed") for m in data_manifests]
    if eval_data is not None:
        held = dataset_manifest(eval_data)
        with _bar(console, f"measure {eval_data.name}") as bar:
            task = bar.add_task("eval", total=None)
            report = evaluate_dataset(net, eval_data, progress=lambda d, t: bar.update(task, completed=d, total=t))
        metrics[f"eval_seed{held.get('seed')}"] = {**report, "data": str(eval_data), "data_seed": held.get("seed")}
        _print_report(console, report, f"attributes on {eval_data} ({report['images']} images, GT masks)")
        data_manifests.append(held)
    directory = Path(out) if out is not None else models_dir()
    words = ["po3d", "train", "attributes", *[w for d in data for w in ("--data", str(d))], "--seed", str(seed),
             "--epochs", str(epochs),
             "--batch-size", str(batch_size), "--lr", str(lr), "--part-fraction", str(part_fraction),
             "--part-shift", str(part_shift), "--part-masks", part_masks,
             *(["--members", str(members)] if members > 1 else []),
             "--splits", ",".join(split_list), "--val-split", val_split, "--threads", str(threads)]
    if max_steps is not None:
        words += ["--max-steps", str(max_steps)]
    if eval_data is not None:
        words += ["--eval-data", str(eval_data)]
    if out is not None:
        words += ["--out", str(out)]
    path = save_attribute_net(net.to("cpu"), directory, command=shlex.join(words),
                              data_commands=[build_command(d, m) for d, m in
                                             zip([*data, eval_data], data_manifests)],
                              data_seed=seeds[0] if len(seeds) == 1 else seeds, train_config={**config.to_dict(),
                                            "part_masks": dataclasses.asdict(jitter) if jitter else "truth"},
                              metrics=metrics)
    console.print(f"wrote {path} ({path.stat().st_size / 1e6:.2f} MB) after {metrics['train_seconds']:.0f} s of "
                  f"training; temperatures {net.temperatures()}", markup=False, highlight=False)


def eval_attributes_command(
    data: Annotated[Path, typer.Option("--data", help="Held-out dataset directory (a seed never trained on).")],
    model_dir: Annotated[Path | None, typer.Option("--model-dir", help="Model directory (default: models/).")] = None,
    splits: Annotated[str, typer.Option("--splits", help="Splits of --data to measure on.")] = "train,val,test",
    limit: Annotated[int | None, typer.Option("--limit", min=1, help="Measure on the first N images only.")] = None,
    json_out: Annotated[Path | None, typer.Option("--json", help="Also write the report to this JSON file.")] = None,
    device: Annotated[str, typer.Option("--device", help="torch device, e.g. cpu or cuda.")] = "cpu",
    threads: Annotated[int, typer.Option("--threads", min=1)] = 1,
    record: Annotated[bool, typer.Option("--record", help="Store the result in the model's manifest entry.")] = False,
) -> None:
    """Object subtype / colour / material / size and part look / colour / material accuracy (per category), and
    ECE before and after the temperatures, with ground-truth masks standing in for the parser's."""
    import torch
    from rich.console import Console

    from po3d_ppl.perception.attributes import MODEL_NAME, load_attribute_net
    from po3d_ppl.perception.train_attributes import evaluate_dataset

    torch.set_num_threads(threads)
    console = Console()
    net = load_attribute_net(model_dir, device=device)
    split_list = comma_list(splits)
    with _bar(console, f"measure {data.name}") as bar:
        task = bar.add_task("eval", total=None)
        report = evaluate_dataset(net, data, split_list, limit,
                                  progress=lambda d, t: bar.update(task, completed=d, total=t))
    manifest = dataset_manifest(data)
    words = ["po3d", "eval", "attributes", "--data", str(data), "--splits", ",".join(split_list)]
    if limit is not None:
        words += ["--limit", str(limit)]
    report = {**report, "data": str(data), "data_seed": manifest.get("seed"), "command": shlex.join(words)}
    _print_report(console, report, f"attributes on {data} ({report['images']} images, GT masks)")
    write_report(json_out, report)
    if record:
        from po3d_ppl.model_store import models_dir, record_metrics

        record_metrics(MODEL_NAME, f"eval_seed{manifest.get('seed')}", report, model_dir or models_dir())


def register(app: typer.Typer, train_app: typer.Typer, eval_app: typer.Typer) -> None:
    train_app.command("attributes")(train_attributes_command)
    eval_app.command("attributes")(eval_attributes_command)

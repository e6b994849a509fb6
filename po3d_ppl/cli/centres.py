"""``po3d train centres`` and ``po3d eval centres``: the centre head (where objects stand, read from the object
parser's features), trained from scratch on built datasets.

Register with ``"centres"`` in ``po3d_ppl.cli._MODULES``.
"""

from __future__ import annotations

import shlex
from pathlib import Path
from typing import Annotated

import typer

from po3d_ppl.cli._common import build_command, comma_list, dataset_manifest, write_report


def _load(console, data: Path, splits: list[str], model_dir: Path | None = None):
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from po3d_ppl.perception.train_centres import load_centre_data

    with Progress(TextColumn(f"[bold]features {data.name}"), BarColumn(), MofNCompleteColumn(),
                  TimeRemainingColumn(), console=console) as bar:
        task = bar.add_task("features", total=None)
        return load_centre_data(data, splits, model_dir=model_dir,
                                progress=lambda n, total: bar.update(task, completed=n, total=total))


def _print_measure(console, title: str, report: dict) -> None:
    from rich.table import Table

    from po3d_ppl.cli._common import literal

    table = Table(title=literal(title))
    for col in ("threshold", "recall", "recall, occluded", "peaks / image", "stray peaks / image"):
        table.add_column(col, justify="right")
    for key, row in report.items():
        if key.startswith("threshold_"):
            table.add_row(key.removeprefix("threshold_"), f"{row['recall']:.3f}", f"{row['recall_occluded']:.3f}",
                          f"{row['peaks_per_image']:.2f}", f"{row['stray_peaks_per_image']:.2f}")
    console.print(table)
    console.print(f"{report['images']} images, {report['objects']} objects >= 200 px "
                  f"({report['occluded_objects']} occluded)", highlight=False)


def train_centres_command(
    data: Annotated[list[Path], typer.Option(
        "--data", help="Dataset directory from `po3d dataset build` (repeatable: --splits of each are trained on).")],
    out: Annotated[Path | None, typer.Option("--out", help="Where to write the model (default: models/).")] = None,
    seed: Annotated[int, typer.Option("--seed", help="Seed of initialisation and data order.")] = 0,
    epochs: Annotated[int, typer.Option("--epochs", min=1, help="Passes over the training images.")] = 12,
    batch_size: Annotated[int, typer.Option("--batch-size", min=1, help="Images a step.")] = 16,
    lr: Annotated[float, typer.Option("--lr", help="Peak learning rate (one-cycle).")] = 2e-3,
    max_steps: Annotated[int | None, typer.Option("--max-steps", min=1, help="Stop after this many steps.")] = None,
    splits: Annotated[str, typer.Option("--splits", help="Comma-separated splits of each --data to train on.")
                      ] = "train,val,test",
    eval_data: Annotated[Path | None, typer.Option(
        "--eval-data", help="Held-out dataset (another seed) to measure on (all its splits).")] = None,
    model_dir: Annotated[Path | None, typer.Option(
        "--model-dir", help="Where the feature model is read from (default: models/).")] = None,
    device: Annotated[str, typer.Option("--device", help="torch device, e.g. cpu or cuda.")] = "cpu",
    threads: Annotated[int, typer.Option("--threads", min=1, help="torch CPU threads.")] = 1,
) -> None:
    """Train the centre head on the shipped feature extractor's features and write models/centres.safetensors with
    its manifest entry."""
    import torch
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from po3d_ppl.cli._common import check_seed
    from po3d_ppl.model_store import models_dir
    from po3d_ppl.perception.centres import CentreConfig, features_sha256, save_centre_net
    from po3d_ppl.perception.train_centres import CentreData, CentreTrainConfig, measure, train_centres

    check_seed(seed)
    torch.set_num_threads(threads)
    console = Console()
    split_list = comma_list(splits)
    train = CentreData.concat([_load(console, d, split_list, model_dir) for d in data])
    # the head reads the feature model's features: its input width is theirs
    config = CentreTrainConfig(seed=seed, epochs=epochs, batch_size=batch_size, lr=lr, max_steps=max_steps,
                               net=CentreConfig(feature_dim=int(train.features.shape[1])))
    console.print(f"training on {len(train)} images, {len(train.objects)} objects", highlight=False)
    with Progress(TextColumn("[bold]train centres"), BarColumn(), MofNCompleteColumn(),
                  TextColumn("epoch {task.fields[epoch]:.1f} loss {task.fields[loss]:.3f}"), TimeRemainingColumn(),
                  console=console) as bar:
        task = bar.add_task("train", total=None, epoch=0.0, loss=float("nan"))
        trained = train_centres(train, config, device=device,
                                progress=lambda step, total, info: bar.update(task, completed=step, total=total,
                                                                              epoch=info["epoch"], loss=info["loss"]))
    metrics: dict = {"train_images": len(train), "train_seconds": round(trained.seconds, 1), "steps": trained.steps,
                     "threads": threads, "device": device, "parameters": trained.net.num_parameters(),
                     "history": trained.history}
    manifests = [dataset_manifest(d) for d in data]
    seeds = [m.get("seed") for m in manifests]
    if eval_data is not None:
        held_manifest = dataset_manifest(eval_data)
        report = measure(trained.net, _load(console, eval_data, ["train", "val", "test"], model_dir))
        metrics[f"eval_seed{held_manifest.get('seed')}"] = {**report, "data": str(eval_data)}
        _print_measure(console, f"centres on {eval_data}", report)
        manifests.append(held_manifest)
    words = ["po3d", "train", "centres", *[w for d in data for w in ("--data", str(d))], "--seed", str(seed),
             "--epochs", str(epochs), "--batch-size", str(batch_size), "--lr", str(lr),
             "--splits", ",".join(split_list), "--threads", str(threads)]
    if max_steps is not None:
        words += ["--max-steps", str(max_steps)]
    if eval_data is not None:
        words += ["--eval-data", str(eval_data)]
    if model_dir is not None:
        words += ["--model-dir", str(model_dir)]
    if out is not None:
        words += ["--out", str(out)]
    path = save_centre_net(trained.net, Path(out) if out is not None else models_dir(), features_sha256(model_dir),
                           command=shlex.join(words),
                           data_commands=[build_command(d, m) for d, m in
                                          zip([*data, *([eval_data] if eval_data else [])], manifests)],
                           data_seed=seeds[0] if len(seeds) == 1 else seeds, train_config=config.to_dict(),
                           metrics=metrics)
    console.print(f"wrote {path} ({path.stat().st_size / 1e6:.2f} MB) after {trained.seconds:.0f} s of training",
                  markup=False, highlight=False)


def eval_centres_command(
    data: Annotated[Path, typer.Option("--data", help="Held-out dataset directory (a seed never trained on).")],
    model_dir: Annotated[Path | None, typer.Option("--model-dir", help="Model directory (default: models/).")] = None,
    splits: Annotated[str, typer.Option("--splits", help="Splits of --data to measure on.")] = "train,val,test",
    thresholds: Annotated[str, typer.Option("--thresholds", help="Comma-separated peak thresholds.")
                          ] = "0.2,0.3,0.5",
    json_out: Annotated[Path | None, typer.Option("--json", help="Also write the report to this JSON file.")] = None,
    threads: Annotated[int, typer.Option("--threads", min=1)] = 1,
) -> None:
    """Recall of the centre head's peaks (all objects >= 200 px, occluded ones) and stray peaks per image."""
    import torch
    from rich.console import Console

    from po3d_ppl.errors import InputError
    from po3d_ppl.perception.centres import load_centre_net
    from po3d_ppl.perception.train_centres import measure

    torch.set_num_threads(threads)
    try:
        levels = [float(t) for t in comma_list(thresholds)]
    except ValueError:
        raise InputError("--thresholds", f"expected comma-separated numbers, got {thresholds!r}") from None
    console = Console()
    net = load_centre_net(model_dir)
    report = {**measure(net, _load(console, data, comma_list(splits), model_dir), levels), "data": str(data)}
    _print_measure(console, f"centres on {data}", report)
    write_report(json_out, report)


def register(app: typer.Typer, train_app: typer.Typer, eval_app: typer.Typer) -> None:
    train_app.command("centres")(train_centres_command)
    eval_app.command("centres")(eval_centres_command)

"""``po3d train perception`` and ``po3d eval perception``: the feature extractor and neural meshes of
render-and-compare (issue "Perception I"), trained from scratch on a built dataset and measured on held-out images.

Register with ``"perception"`` in ``po3d_ppl.cli._MODULES``.
"""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import typer

from po3d_ppl.cli._common import comma_list


def _read_images(console, data: list[Path], splits: list[str], limit: int | None, what: str):
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from po3d_ppl.perception.train_features import load_dataset_images

    images, manifests = [], []
    with Progress(TextColumn(f"[bold]{what}"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn(),
                  console=console) as bar:
        for directory in data:
            task = bar.add_task(str(directory), total=None)
            images += load_dataset_images(directory, splits, limit,
                                          progress=lambda done, total, t=task: bar.update(t, completed=done,
                                                                                          total=total))
            path = Path(directory) / "manifest.json"
            manifests.append(json.loads(path.read_text()) if path.exists() else {})
    return images, manifests


def _metrics_table(console, rows: dict[str, dict], title: str) -> None:
    from rich.table import Table

    from po3d_ppl.cli._common import literal

    keys = ("within_exact", "within_radius", "within_radius_2x", "across_exact", "across_radius",
            "across_radius_2x", "category_top1", "fg_bg_auc", "fg_bg_auc_vs_clutter")
    table = Table(title=literal(title))
    table.add_column("measure")
    for name in rows:
        table.add_column(literal(name), justify="right")
    for k in keys:
        table.add_row(k, *(f"{row[k]:.3f}" for row in rows.values()))
    console.print(table)


def train_perception_command(
    data: list[Path] = typer.Option(..., "--data", help="Dataset directory from `po3d dataset build` (repeatable)."),
    out: Path = typer.Option(None, "--out", help="Where to write the model (default: models/)."),
    seed: int = typer.Option(0, "--seed", help="Seed of initialisation, data order, crops and samples (>= 0)."),
    epochs: int = typer.Option(20, "--epochs", min=1, help="Passes over the training images (one crop each)."),
    batch_size: int = typer.Option(8, "--batch-size", min=1),
    crop: str = typer.Option("256x320", "--crop", help="Training crop HEIGHTxWIDTH, multiples of 8."),
    lr: float = typer.Option(2e-3, "--lr", help="Peak learning rate (one-cycle)."),
    dim: int = typer.Option(64, "--dim", min=4, help="Feature dimension."),
    max_steps: int = typer.Option(None, "--max-steps", min=1, help="Stop after this many steps."),
    splits: str = typer.Option("train", "--splits", help="Comma-separated splits of --data to train on."),
    limit: int = typer.Option(None, "--limit", min=1, help="Use only the first N images of each --data."),
    eval_data: Path = typer.Option(None, "--eval-data", help="Held-out dataset (another seed) to measure the "
                                                            "features on, side by side with the untrained network."),
    eval_limit: int = typer.Option(60, "--eval-limit", min=1, help="Images of --eval-data to measure on."),
    device: str = typer.Option("cpu", "--device", help="torch device, e.g. cpu or cuda."),
    threads: int = typer.Option(1, "--threads", min=1, help="torch CPU threads (one is fastest on a busy "
                                                           "2-core machine)."),
) -> None:
    """Train the stride-8 feature extractor with the neural textures and clutter bank (contrastive, momentum
    bank) on ground-truth poses, and write models/perception_features.safetensors with its manifest entry."""
    import time

    import torch
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from po3d_ppl.cli._common import check_seed
    from po3d_ppl.errors import InputError
    from po3d_ppl.model_store import models_dir
    from po3d_ppl.perception.features import FeatureConfig
    from po3d_ppl.perception.neural_mesh import save_feature_model
    from po3d_ppl.perception.train_features import TrainConfig, evaluate_features, train_features, untrained_baseline

    check_seed(seed)
    try:
        crop_hw = tuple(int(v) for v in crop.lower().split("x"))
    except ValueError:
        crop_hw = ()
    if len(crop_hw) != 2:
        raise InputError("--crop", f"expected HEIGHTxWIDTH such as 256x320, got {crop!r}")
    split_list = comma_list(splits)
    torch.set_num_threads(threads)
    console = Console()
    config = TrainConfig(seed=seed, epochs=epochs, batch_size=batch_size, crop=crop_hw, lr=lr, max_steps=max_steps,
                         feature=FeatureConfig(dim=dim))
    images, manifests = _read_images(console, data, split_list, limit, "supervision")
    console.print(f"training on {len(images)} images, {sum(len(i.objects) for i in images)} objects",
                  highlight=False)
    with Progress(TextColumn("[bold]train perception"), BarColumn(), MofNCompleteColumn(),
                  TextColumn("epoch {task.fields[epoch]} loss {task.fields[loss]:.3f} top1 {task.fields[top1]:.3f}"),
                  TimeRemainingColumn(), console=console) as bar:
        task = bar.add_task("train", total=None, epoch=0, loss=float("nan"), top1=float("nan"))

        def progress(step: int, total: int, info: dict) -> None:
            bar.update(task, completed=step, total=total, epoch=info["epoch"], loss=info["loss"], top1=info["top1"])

        trained = train_features(images, config, device=device, progress=progress)
    metrics: dict = {"train_images": len(images), "train_seconds": round(trained.seconds, 1),
                     "step_seconds": round(trained.step_seconds, 3), "threads": threads, "device": device,
                     "parameters": trained.model.extractor.num_parameters(), "history": trained.history}
    if eval_data is not None:
        held, held_manifests = _read_images(console, [eval_data], ["train", "val", "test"], eval_limit, "held-out")
        start = time.perf_counter()
        trained_metrics = evaluate_features(trained.model.to("cpu"), held)
        untrained = evaluate_features(untrained_baseline(images[:100], config), held)
        key = f"eval_seed{held_manifests[0].get('seed')}"
        metrics[key] = {"trained": trained_metrics, "untrained_fitted_textures": untrained,
                        "data": str(eval_data), "data_seed": held_manifests[0].get("seed"),
                        "eval_seconds": round(time.perf_counter() - start, 1)}
        _metrics_table(console, {"trained": trained_metrics, "untrained (fitted textures)": untrained},
                       f"features on {eval_data} ({len(held)} images)")
    directory = Path(out) if out is not None else models_dir()
    path = save_feature_model(trained.model.to("cpu"), directory,
                              command=_train_command(data, config, split_list, limit, eval_data, eval_limit, out,
                                                     threads),
                              data_seed=[m.get("seed") for m in manifests],
                              data_config=[m.get("config") for m in manifests],
                              train_config=config.to_dict(), metrics=metrics)
    console.print(f"wrote {path} ({path.stat().st_size / 1e6:.2f} MB) after {trained.seconds:.0f} s of training "
                  f"({trained.step_seconds:.2f} s a step)", markup=False, highlight=False)


def eval_perception_command(
    data: Path = typer.Option(..., "--data", help="Held-out dataset directory (a seed never trained on)."),
    model_dir: Path = typer.Option(None, "--model-dir", help="Directory with the model (default: models/)."),
    limit: int = typer.Option(60, "--limit", min=1, help="Images to measure on."),
    baseline_data: Path = typer.Option(None, "--baseline-data", help="Training dataset to fit the untrained "
                                                                    "network's textures on, for a side-by-side row."),
    seed: int = typer.Option(0, "--seed", help="Initialisation seed of the untrained baseline."),
    threads: int = typer.Option(1, "--threads", min=1),
    record: bool = typer.Option(False, "--record", help="Store the result in the model's manifest entry."),
) -> None:
    """Nearest-vertex accuracy (within and across categories) and fg/bg ROC-AUC of the shipped features."""
    import torch
    from rich.console import Console

    from po3d_ppl.perception.neural_mesh import MODEL_NAME, load_feature_model
    from po3d_ppl.perception.train_features import TrainConfig, evaluate_features, untrained_baseline

    torch.set_num_threads(threads)
    console = Console()
    model = load_feature_model(model_dir)
    held, manifests = _read_images(console, [data], ["train", "val", "test"], limit, "held-out")
    rows = {"trained": evaluate_features(model, held)}
    if baseline_data is not None:
        fit, _ = _read_images(console, [baseline_data], ["train"], 100, "baseline fit")
        config = TrainConfig(seed=seed, feature=model.extractor.config)
        rows["untrained_fitted_textures"] = evaluate_features(untrained_baseline(fit, config), held)
    _metrics_table(console, rows, f"features on {data} ({len(held)} images)")
    if record:
        from po3d_ppl.model_store import models_dir, record_metrics

        words = ["po3d", "eval", "perception", "--data", str(data), "--limit", str(limit)]
        if baseline_data is not None:
            words += ["--baseline-data", str(baseline_data), "--seed", str(seed)]
        record_metrics(MODEL_NAME, f"eval_seed{manifests[0].get('seed')}",
                       {**rows, "command": shlex.join(words), "data_seed": manifests[0].get("seed")},
                       model_dir or models_dir())


def _train_command(data, config, splits, limit, eval_data, eval_limit, out, threads) -> str:
    """The training command with every setting spelled out, to reproduce the weights."""
    words = ["po3d", "train", "perception"]
    for directory in data:
        words += ["--data", str(directory)]
    words += ["--seed", str(config.seed), "--epochs", str(config.epochs), "--batch-size", str(config.batch_size),
              "--crop", f"{config.crop[0]}x{config.crop[1]}", "--lr", str(config.lr), "--dim",
              str(config.feature.dim), "--splits", ",".join(splits), "--threads", str(threads)]
    if config.max_steps is not None:
        words += ["--max-steps", str(config.max_steps)]
    if limit is not None:
        words += ["--limit", str(limit)]
    if eval_data is not None:
        words += ["--eval-data", str(eval_data), "--eval-limit", str(eval_limit)]
    if out is not None:
        words += ["--out", str(out)]
    return shlex.join(words)


def register(app: typer.Typer, train_app: typer.Typer, eval_app: typer.Typer) -> None:
    train_app.command("perception")(train_perception_command)
    eval_app.command("perception")(eval_perception_command)

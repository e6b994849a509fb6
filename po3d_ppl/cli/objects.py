"""``po3d train calibration`` and ``po3d eval objects``: the object parser's tables calibrated on a validation
dataset, and every Done-means figure of the object parser on a held-out one (issue "Perception I").

Register with ``"objects"`` in ``po3d_ppl.cli._MODULES``.
"""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import typer

_DATA = typer.Option(..., "--data", help="Dataset directory from `po3d dataset build` (another seed than training).")
_SPLIT = typer.Option(None, "--split", help="Split of --data (default: every image).")
_LIMIT = typer.Option(None, "--limit", min=1, help="Only the first N images.")
_THREADS = typer.Option(1, "--threads", min=1, help="torch CPU threads (one is fastest on a busy 2-core machine).")


def _parse_all(data: Path, split, limit, calibration, console, label: str):
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from po3d_ppl.evaluation.objects import parse_dataset
    from po3d_ppl.perception.object_parser import parse_objects

    def parse(image):
        return parse_objects(image, calibration=calibration)

    with Progress(TextColumn(f"[bold]{label}"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn(),
                  console=console) as bar:
        task = bar.add_task(label, total=None)
        return parse_dataset(data, split, limit, parse,
                             progress=lambda done, total: bar.update(task, completed=done, total=total))


def train_calibration_command(
    data: Path = _DATA, split: str = _SPLIT, limit: int = _LIMIT, threads: int = _THREADS,
    out: Path = typer.Option(None, "--out", help="Where to write the calibration (default: models/)."),
    outcomes: Path = typer.Option(None, "--outcomes", help="Also write the per-image outcomes (JSON lines)."),
) -> None:
    """Fit the object parser's category and pose temperatures and its existence scale (Platt) on a validation
    dataset; write models/object_calibration.safetensors with its manifest entry."""
    import torch
    from rich.console import Console

    from po3d_ppl.evaluation.objects import fit_calibration, save_outcomes
    from po3d_ppl.model_store import models_dir, write_entry
    from po3d_ppl.perception.calibration import MODEL_NAME, TableCalibration

    torch.set_num_threads(threads)
    console = Console()
    results = _parse_all(data, split, limit, TableCalibration(), console, "parse (raw scores)")
    if outcomes is not None:
        save_outcomes(results, outcomes)
    calibration, report = fit_calibration(results)
    directory = Path(out) if out is not None else models_dir()
    directory.mkdir(parents=True, exist_ok=True)
    path = calibration.save(directory)
    manifest = json.loads((Path(data) / "manifest.json").read_text()) if (Path(data) / "manifest.json").exists() \
        else {}
    words = ["po3d", "train", "calibration", "--data", str(data), "--threads", str(threads)]
    words += ["--split", split] if split else []
    words += ["--limit", str(limit)] if limit else []
    words += ["--out", str(out)] if out is not None else []
    write_entry(MODEL_NAME, [path], directory, command=shlex.join(words),
                data_seed=manifest.get("seed"),
                data_config=manifest.get("config"), values=calibration.to_dict(), metrics=report)
    console.print_json(json.dumps({"calibration": calibration.to_dict(), **report}))


def eval_objects_command(
    data: Path = _DATA, split: str = _SPLIT, limit: int = _LIMIT, threads: int = _THREADS,
    json_out: Path = typer.Option(None, "--json", help="Write the figures here."),
    outcomes: Path = typer.Option(None, "--outcomes", help="Also write the per-image outcomes (JSON lines)."),
) -> None:
    """Detection, category, azimuth, position, depth order and category calibration of the object parser (with
    the shipped calibration), overall, for objects >= 20% occluded and per category."""
    import torch
    from rich.console import Console

    from po3d_ppl.evaluation.objects import save_outcomes, summarise

    torch.set_num_threads(threads)
    console = Console()
    results = _parse_all(data, split, limit, None, console, "parse")
    if outcomes is not None:
        save_outcomes(results, outcomes)
    figures = summarise(results)
    if json_out is not None:
        Path(json_out).write_text(json.dumps(figures, indent=1) + "\n")
    console.print_json(json.dumps(figures))


def register(app: typer.Typer, train_app: typer.Typer, eval_app: typer.Typer) -> None:
    train_app.command("calibration")(train_calibration_command)
    eval_app.command("objects")(eval_objects_command)

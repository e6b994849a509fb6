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


def _parse_all(data: Path, split, limit, calibration, console, label: str, model_dir: Path | None = None,
               config=None):
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from po3d_ppl.evaluation.objects import parse_dataset
    from po3d_ppl.perception.object_parser import parse_objects

    model = background = None
    if model_dir is not None:  # the models being trained, not the shipped ones
        from po3d_ppl.perception.background import load_background
        from po3d_ppl.perception.neural_mesh import load_feature_model

        model, background = load_feature_model(model_dir), load_background(model_dir)
    with Progress(TextColumn(f"[bold]{label}"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn(),
                  console=console) as bar:
        task = bar.add_task(label, total=None)
        return parse_dataset(data, split, limit,
                             lambda image: parse_objects(image, model, config, calibration, background),
                             progress=lambda done, total: bar.update(task, completed=done, total=total))


def _record(name: str, path: Path, directory: Path, data: Path, words: list[str], **metadata) -> None:
    """The model's manifest entry: its file, the exact command, the dataset's seed and config."""
    from po3d_ppl.model_store import write_entry
    from po3d_ppl.questions.dataset import load_dataset

    manifest = load_dataset(data).manifest
    write_entry(name, [path], directory, command=shlex.join(words), data_seed=manifest.get("seed"),
                data_config=manifest.get("config"), **metadata)


def train_calibration_command(
    data: Path = _DATA, split: str = _SPLIT, limit: int = _LIMIT, threads: int = _THREADS,
    out: Path = typer.Option(None, "--out", help="Where to write the calibration (default: models/)."),
    outcomes: Path = typer.Option(None, "--outcomes", help="Also write the per-image outcomes (JSON lines)."),
    model_dir: Path = typer.Option(None, "--model-dir", help="Feature and background models to calibrate "
                                                             "(default: the shipped models/)."),
) -> None:
    """Fit the object parser's category and pose temperatures and its existence scale (Platt) on a validation
    dataset; write models/object_calibration.safetensors with its manifest entry."""
    import torch
    from rich.console import Console

    from po3d_ppl.evaluation.objects import fit_calibration, save_outcomes
    from po3d_ppl.model_store import models_dir
    from po3d_ppl.perception.calibration import MODEL_NAME, TableCalibration
    from po3d_ppl.perception.object_parser import ParserConfig

    torch.set_num_threads(threads)
    console = Console()
    # the 3D-NMS's proposals only: centre proposals take their existence from the centre head, not from this fit
    results = _parse_all(data, split, limit, TableCalibration(), console, "parse (raw scores)", model_dir,
                         ParserConfig(centre_threshold=None))
    if outcomes is not None:
        save_outcomes(results, outcomes)
    calibration, report = fit_calibration(results)
    directory = Path(out) if out is not None else models_dir()
    directory.mkdir(parents=True, exist_ok=True)
    words = ["po3d", "train", "calibration", "--data", str(data), "--threads", str(threads)]
    words += ["--split", split] if split else []
    words += ["--limit", str(limit)] if limit else []
    words += ["--out", str(out)] if out is not None else []
    words += ["--model-dir", str(model_dir)] if model_dir is not None else []
    _record(MODEL_NAME, calibration.save(directory), directory, data, words, values=calibration.to_dict(),
            metrics=report)
    console.print_json(json.dumps({"calibration": calibration.to_dict(), **report}))


def eval_objects_command(
    data: Path = _DATA, split: str = _SPLIT, limit: int = _LIMIT, threads: int = _THREADS,
    json_out: Path = typer.Option(None, "--json", help="Write the figures here."),
    outcomes: Path = typer.Option(None, "--outcomes", help="Also write the per-image outcomes (JSON lines)."),
) -> None:
    """Detection, category, azimuth, position, depth order and category calibration of the object parser (with
    the shipped calibration), overall, for objects >= 20% occluded and per category. The same figures under
    the scene parser's camera and tables: `po3d eval evidence`."""
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


def train_background_command(
    data: Path = _DATA, split: str = typer.Option("train", "--split", help="Split of --data to fit on."),
    limit: int = typer.Option(80, "--limit", min=5, help="Images to fit on (the median needs few)."),
    out: Path = typer.Option(None, "--out", help="Where to write the model (default: models/)."),
) -> None:
    """Fit the background model (the bare ground, lit and shadowed, per pixel) on a dataset's images; write
    models/background.safetensors with its manifest entry."""
    import cv2
    import numpy as np
    from rich.console import Console
    from rich.progress import track

    from po3d_ppl.errors import InputError
    from po3d_ppl.model_store import models_dir
    from po3d_ppl.perception.background import MODEL_NAME, fit_background
    from po3d_ppl.questions.dataset import load_dataset
    from po3d_ppl.world import rle

    console = Console()
    dataset = load_dataset(data)
    images, covered = [], []
    for i in track(dataset.split_indices(split)[:limit], description="reading images", console=console):
        scene = dataset.scene(i)
        image = cv2.imread(str(dataset.image_path(i)))
        if image is None:
            raise InputError("--data", f"cannot read {dataset.image_path(i)}")
        images.append(np.ascontiguousarray(image[..., ::-1]))
        mask = np.zeros(image.shape[:2], dtype=bool)
        for obj in scene.objects:
            mask |= rle.decode(obj.annotation.visible_mask, image.shape[0], image.shape[1])
        covered.append(mask)
    model = fit_background(images, covered)
    directory = Path(out) if out is not None else models_dir()
    directory.mkdir(parents=True, exist_ok=True)
    path = model.save(directory)
    words = ["po3d", "train", "background", "--data", str(data), "--split", split, "--limit", str(limit)]
    words += ["--out", str(out)] if out is not None else []
    _record(MODEL_NAME, path, directory, data, words,
            metrics={"images": len(images), "shadow_ratio": model.shadow_ratio, "threshold": model.threshold})
    console.print(f"background of {len(images)} images, shadow ratio {model.shadow_ratio:.3f} -> {path}",
                  markup=False, highlight=False)


def _evidence_cache(data: Path, cache: Path | None):
    """The evidence cache `po3d eval vqa --perception image` shares (default DATA/eval_cache)."""
    from po3d_ppl.evaluation.cache import EvidenceCache

    return EvidenceCache(cache if cache is not None else Path(data) / "eval_cache")


def _cached_evidence(data: Path, split: str, limit: int | None, store, backend, console, label: str):
    """(evidence, scene) of every image of ``split``, each parsed once into the evidence cache ``store``."""
    from rich.progress import track

    from po3d_ppl.evaluation.backends import Observation
    from po3d_ppl.questions.dataset import load_dataset

    dataset = load_dataset(data)
    indices = dataset.split_indices(split)
    indices = indices[:limit] if limit else indices
    identity = backend.identity()
    for index in track(indices, description=label, console=console):
        observation = Observation(index, dataset.image_path(index), dataset.scene(index))
        evidence = store.get(observation.image_path, identity, lambda seen=observation: backend.evidence(seen))
        yield backend.calibrate(evidence), observation.scene


_CACHE = typer.Option(None, "--cache", help="Evidence cache directory (shared with `po3d eval vqa --perception "
                                            "image`; default: DATA/eval_cache).")


def evidence_figures(data: Path, split: str, limit: int | None, store, console, backend=None,
                     gallery: Path | None = None, gallery_images: int = 12) -> dict:
    """Perception's figures on ``split`` from the evidence cache ``store`` (each image parsed once): attributes,
    parts and occlusion, the objects under the scene parser's camera, and the calibration of the projected tables
    (each read as its posterior under the priors the image pipeline uses) and of the object tables. ``backend``: a
    loaded ``ImageBackend`` to reuse. ``gallery``: also draw the ``gallery_images`` images with the most detection
    failures there (:mod:`po3d_ppl.evaluation.failure_gallery`)."""
    from po3d_ppl.evaluation.backends import ImageBackend
    from po3d_ppl.evaluation.evidence_scores import EvidenceCounts
    from po3d_ppl.evaluation.objects import EvidenceAsProposals, score_image, summarise
    from po3d_ppl.evaluation.projection import as_tensors, measure
    from po3d_ppl.perception.priors import load_priors

    backend = backend or ImageBackend()
    counts, outcomes = EvidenceCounts(priors=backend.scene_priors(load_priors())), []
    for evidence, scene in _cached_evidence(data, split, limit, store, backend, console, "evidence"):
        counts.add(evidence, scene)
        outcomes.append(score_image(EvidenceAsProposals.of(evidence), scene, scene.image_filename, 0.0))
    if gallery is not None:
        from po3d_ppl.evaluation.failure_gallery import write_gallery

        index = write_gallery(outcomes, [Path(data) / "images" / img.image for img in outcomes], gallery,
                              gallery_images)
        console.print(f"detection failures drawn: {index}", markup=False, highlight=False)
    return {"evidence": counts.figures(), "objects": summarise(outcomes),
            "projected_tables": measure(None, as_tensors(counts.entries)),
            "object_tables": counts.object_tables(),
            "cache": {"hits": store.hits, "misses": store.misses}}


def eval_evidence_command(
    data: Path = _DATA, split: str = typer.Option("all", "--split", help="Split of --data (all: every image)."),
    limit: int = _LIMIT, threads: int = _THREADS, cache: Path = _CACHE,
    json_out: Path = typer.Option(None, "--json", help="Write the figures here."),
    gallery: Path = typer.Option(None, "--gallery", help="Also draw the images with the most detection failures "
                                                         "(missed objects and false proposals by kind) here, with "
                                                         "an index.md."),
    gallery_images: int = typer.Option(12, "--gallery-images", min=1, help="How many images --gallery draws."),
) -> None:
    """Perception's evidence against ground truth: attributes, parts and occlusion (evaluation.evidence_scores),
    the projected tables' calibration, and the object figures under the scene parser's camera, from the same
    cached evidence `po3d eval vqa --perception image` uses (each image is parsed once)."""
    import torch
    from rich.console import Console

    torch.set_num_threads(threads)
    console = Console()
    figures = evidence_figures(data, split, limit, _evidence_cache(data, cache), console, gallery=gallery,
                               gallery_images=gallery_images)
    if json_out is not None:
        Path(json_out).write_text(json.dumps(figures, indent=1) + "\n")
    console.print_json(json.dumps(figures))


def train_projection_command(
    data: Path = _DATA, split: str = typer.Option("all", "--split", help="Split of --data (all: every image)."),
    limit: int = _LIMIT, threads: int = _THREADS, cache: Path = _CACHE,
    out: Path = typer.Option(None, "--out", help="Where to write the calibration (default: models/)."),
    model_dir: Path = typer.Option(None, "--model-dir", help="The perception models whose projections to "
                                                             "calibrate (default: the shipped models/)."),
) -> None:
    """Fit one Platt scaling per projected table (occlusion, occluders, part visibility, part occlusion), one scale
    on the part-look table and one on each object table (subtype, colour, material, size) on a validation dataset's
    raw evidence; write models/projection_calibration.safetensors with its manifest entry and each table's ECE
    before and after."""
    import torch
    from rich.console import Console

    from po3d_ppl.evaluation.backends import ImageBackend
    from po3d_ppl.evaluation.projection import collect, fit_projection_calibration
    from po3d_ppl.model_store import models_dir
    from po3d_ppl.perception.projection_calibration import MODEL_NAME, edge_logodds

    torch.set_num_threads(threads)
    console = Console()
    raw = ImageBackend(calibrated_projection=False, models_dir=model_dir)
    edge = edge_logodds(raw.parser.config.projection_floor)
    calibration, report = fit_projection_calibration(collect(
        _cached_evidence(data, split, limit, _evidence_cache(data, cache), raw, console,
                         "evidence (raw projected tables)")), edge)
    directory = Path(out) if out is not None else models_dir()
    directory.mkdir(parents=True, exist_ok=True)
    words = ["po3d", "train", "projection", "--data", str(data), "--split", split, "--threads", str(threads)]
    words += ["--limit", str(limit)] if limit else []
    words += ["--out", str(out)] if out is not None else []
    words += ["--model-dir", str(model_dir)] if model_dir is not None else []
    _record(MODEL_NAME, calibration.save(directory), directory, data, words, values=calibration.to_dict(),
            metrics=report)
    console.print_json(json.dumps({"platt": calibration.to_dict(), "tables": report}))


def register(app: typer.Typer, train_app: typer.Typer, eval_app: typer.Typer) -> None:
    eval_app.command("evidence")(eval_evidence_command)
    train_app.command("projection")(train_projection_command)
    train_app.command("calibration")(train_calibration_command)
    train_app.command("background")(train_background_command)
    eval_app.command("objects")(eval_objects_command)

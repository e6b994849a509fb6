"""``po3d eval vqa``, ``po3d eval calibration`` and ``po3d eval ceilings``: accuracy against the baselines,
difficulty, calibration, and which evidence table limits the answers.

Evidence comes from the simulated sensor (``--perception simulated``) or from perception on the images
(``--perception image``, the shipped models); either is cached per image under ``--cache``.
"""

from __future__ import annotations

import json
from pathlib import Path

import typer

from po3d_ppl.cli._common import comma_list

_DATA = typer.Option(..., "--data", help="Dataset directory from `po3d dataset build`.")
_SPLIT = typer.Option("test", "--split", help="train, val, test, or all (every image: a dataset seed held out as a "
                                               "whole).")
_METHODS = typer.Option("ours,thresholded,soft,oracle", "--methods",
                        help="Comma-separated: ours (reported given presuppositions and joint), thresholded "
                             "(NS-VQA), soft (P-NSVQA), oracle (reference executor on the true scene).")
_NOISE = typer.Option(0.05, "--noise", help="Simulated sensor noise in [0, 1).")
_SEED = typer.Option(0, "--seed", help="Sensor seed (each image draws from SeedSequence([seed, index])).")
_LIMIT = typer.Option(None, "--limit", min=1, help="Only the first N images of the split.")
_CACHE = typer.Option(None, "--cache", help="Evidence cache directory (default: DATA/eval_cache).")
_THREADS = typer.Option(1, "--threads", min=1, help="torch CPU threads.")
_DEVICE = typer.Option("cpu", "--device", help="torch device for the evidence and inference (cpu, cuda).")
_PRIORS = typer.Option("shipped", "--priors", help="The scene model's priors: shipped (fitted to the world, "
                       "models/priors.json), hand-set (ScenePriors()), or a model directory with a priors.json.")
_PERCEPTION = typer.Option("simulated", "--perception",
                           help="Evidence back-end: simulated (the sensor on the true scene, --noise, --seed) or "
                                "image (the render-and-compare parser on the pixels; shipped models).")


def _progress(console, label: str):
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    return Progress(TextColumn(f"[bold]{label}"), BarColumn(), MofNCompleteColumn(), TextColumn("images"),
                    TimeElapsedColumn(), TimeRemainingColumn(), console=console)


def resolve_priors(priors: str, model_dir: Path | None = None):
    """``--priors``: shipped (those of ``model_dir`` when given), hand-set or a model directory."""
    from po3d_ppl.errors import InputError
    from po3d_ppl.evidence import ScenePriors
    from po3d_ppl.perception.priors import load_priors

    if priors == "hand-set":
        return ScenePriors()
    if priors == "shipped":
        return load_priors(model_dir)
    if not Path(priors).is_dir():
        raise InputError("--priors", f"{priors!r} is neither shipped, hand-set nor a model directory")
    return load_priors(Path(priors))


def make_backend(perception: str, noise: float, seed: int, model_dir: Path | None = None):
    """The evidence back-end named by ``--perception``: the simulated sensor or the shipped (or ``model_dir``'s)
    image parser, whose models load once per back-end."""
    from po3d_ppl.errors import InputError
    from po3d_ppl.evaluation.backends import ImageBackend, SimulatedBackend

    if perception not in ("simulated", "image"):
        raise InputError("--perception", f"{perception!r} is not a back-end; use simulated or image")
    return SimulatedBackend(noise, seed) if perception == "simulated" else ImageBackend(models_dir=model_dir)


def _run(data: Path, split: str, methods: str, noise: float, seed: int, limit, cache: Path | None, parse: bool,
         device: str, threads: int, console, label: str, perception: str = "simulated", semantics: str = "intended",
         priors: str = "shipped", model_dir: Path | None = None, recalibrate: bool = True, backend=None):
    """(dataset, run, cache) of one evaluation; with image evidence, each method with a shipped answer calibration
    is also reported recalibrated by it (``ours_calibrated``, ``soft_calibrated``, ...). ``backend``: an already made
    :func:`make_backend` to reuse (its models are read once)."""
    import torch

    from po3d_ppl.evaluation.cache import EvidenceCache
    from po3d_ppl.evaluation.runner import CALIBRATABLE, evaluate, parse_methods
    from po3d_ppl.questions.dataset import load_dataset
    from po3d_ppl.reasoning.answer_calibration import load_answer_calibration

    torch.set_num_threads(threads)
    chosen = parse_methods(methods)
    dataset = load_dataset(data)
    backend = backend or make_backend(perception, noise, seed, model_dir)
    calibrations = {}
    if recalibrate and perception == "image":  # every calibration is fitted on the image's evidence
        calibrations = {m: c for m in chosen if m in CALIBRATABLE
                        for c in [load_answer_calibration(model_dir, m)] if c is not None}
    store = EvidenceCache(cache if cache is not None else Path(data) / "eval_cache")
    with _progress(console, label) as bar:
        task = bar.add_task(label, total=None)
        run = evaluate(dataset, split, backend, chosen, cache=store, limit=limit, parse=parse, device=device,
                       priors=resolve_priors(priors, model_dir), answer_calibrations=calibrations,
                       progress=lambda done, total: bar.update(task, completed=done, total=total),
                       semantics=semantics)
    return dataset, run, store


def vqa_command(
    data: Path = _DATA, split: str = _SPLIT, methods: str = _METHODS, noise: float = _NOISE, seed: int = _SEED,
    limit: int = _LIMIT,
    json_out: Path = typer.Option(None, "--json", help="Write the full report (tables, families, difficulty)."),
    md_out: Path = typer.Option(None, "--md", help="Write the Markdown report."),
    figures: Path = typer.Option(None, "--figures", help="Directory for the difficulty plot (PNG)."),
    records_out: Path = typer.Option(None, "--records", help="Write one JSON line per question (the question, "
                                     "truth, difficulty, whether perception found its referents, every "
                                     "variant's answer) for error analysis."),
    parse: bool = typer.Option(False, "--parse", help="Answer through the question parser "
                                                      "(po3d_ppl.pipeline.answer_question) instead of the "
                                                      "ground-truth programs."),
    cache: Path = _CACHE, device: str = _DEVICE, threads: int = _THREADS, perception: str = _PERCEPTION,
    semantics: str = typer.Option("intended", "--semantics", help="intended (default) or public: score against the "
                                  "public Super-CLEVR-3D code's answers (a dataset built with --semantics public)."),
    priors: str = _PRIORS,
) -> None:
    """Accuracy per question type (the paper's Table 1 columns, CLEVR core, families) and difficulty analysis."""
    from rich.console import Console

    from po3d_ppl.evaluation.metrics import table1, table1_markdown
    from po3d_ppl.evaluation.plots import difficulty_plot
    from po3d_ppl.evaluation.report import difficulty_panels, question_rows, vqa_json, vqa_markdown, write_text

    console = Console()
    _, run, store = _run(data, split, methods, noise, seed, limit, cache, parse, device, threads, console,
                         "eval vqa", perception, semantics, priors)
    figure = None
    if figures is not None:
        figure = difficulty_plot(difficulty_panels(run), Path(figures) / "difficulty.png")
    if json_out is not None:
        write_text(json_out, json.dumps(vqa_json(run), indent=1, default=str) + "\n")
    if md_out is not None:
        rel = None if figure is None else _relative(figure, Path(md_out).parent)
        write_text(md_out, vqa_markdown(run, rel))
    if records_out is not None:
        write_text(records_out, "".join(json.dumps(row, default=str) + "\n" for row in question_rows(run)))
    console.print(table1_markdown(table1(run), paper=False), markup=False, highlight=False, soft_wrap=True)
    console.print(f"{len(run.records)} questions on {run.images} images; evidence cache: {store.hits} hits, "
                  f"{store.misses} misses", markup=False, highlight=False, soft_wrap=True)


def _relative(path: Path, start: Path) -> str:
    import os

    return os.path.relpath(path, start)


def calibration_command(
    data: Path = _DATA, split: str = _SPLIT, methods: str = _METHODS, noise: float = _NOISE, seed: int = _SEED,
    limit: int = _LIMIT,
    out: Path = typer.Option(..., "--out", help="Directory for calibration.json, calibration.md and the PNGs."),
    sweep: str = typer.Option("0,0.01,0.02,0.05,0.1,0.15,0.2", "--sweep",
                              help="Noise levels of the sweep (comma-separated; empty to skip it)."),
    sweep_limit: int = typer.Option(None, "--sweep-limit", min=1, help="Images per sweep point (default: --limit)."),
    cache: Path = _CACHE, device: str = _DEVICE, threads: int = _THREADS, perception: str = _PERCEPTION,
    priors: str = _PRIORS,
) -> None:
    """ECE (15 bins), MCE, Brier, NLL and reliability diagrams per method, and a noise sweep (the sweep always
    uses the simulated sensor: it varies its noise)."""
    from rich.console import Console

    from po3d_ppl.errors import InputError
    from po3d_ppl.evaluation.calibration import calibration_markdown, calibration_reports
    from po3d_ppl.evaluation.plots import noise_sweep_plot, reliability_diagrams
    from po3d_ppl.evaluation.report import noise_sweep, sweep_markdown, write_text
    from po3d_ppl.evaluation.runner import parse_methods
    from po3d_ppl.evaluation.significance import against_baselines, differences_markdown

    try:
        noises = [float(x) for x in sweep.split(",") if x.strip()]
    except ValueError:
        raise InputError("--sweep", f"expected comma-separated numbers in [0, 1), got {sweep!r}") from None
    console = Console()
    source = f"noise {noise:g}" if perception == "simulated" else "perception on the images"
    dataset, run, store = _run(data, split, methods, noise, seed, limit, cache, False, device, threads, console,
                               f"calibration ({source})", perception, priors=priors)
    reports = calibration_reports(run)
    out = Path(out)
    reliability_diagrams(reports, out / "reliability.png", f"split {split}, {source}, "
                                                           f"{len(run.records)} questions")
    differences = against_baselines(run.records, run.variants)
    md = [f"# Calibration: split {split}, {source}, {run.images} images, {len(run.records)} questions", "",
          calibration_markdown(reports), "", "![reliability](reliability.png)", ""]
    if differences:
        md += ["## Ours against the baselines, paired", "", differences_markdown(differences), ""]
    payload = {"split": split, "noise": noise if perception == "simulated" else None, "backend": run.backend,
               "reports": [{**r.row(), "bins": [b.__dict__ for b in r.bins]} for r in reports],
               "differences": [d.__dict__ for d in differences]}
    if noises:
        with _progress(console, "noise sweep") as bar:
            task = bar.add_task("sweep", total=None)
            points = noise_sweep(dataset, split, noises, parse_methods(methods), seed=seed, cache=store,
                                 limit=sweep_limit or limit, priors=resolve_priors(priors),
                                 progress=lambda n, d, t: bar.update(task, completed=d, total=t,
                                                                     description=f"noise {n:g}"))
        noise_sweep_plot(points, out / "noise_sweep.png", f"split {split}: accuracy and ECE against noise")
        md += ["## Noise sweep", "", sweep_markdown(points), "", "![noise sweep](noise_sweep.png)", ""]
        payload["sweep"] = [p.__dict__ for p in points]
    md += [("The perception evidence's tables are temperature-scaled on a validation seed (object tables: "
            "`po3d train calibration`; attribute heads: `po3d train attributes`), not on the test split. Fitted "
            "`ScenePriors` against the hand-set ones: `po3d eval report`."), ""]
    write_text(out / "calibration.json", json.dumps(payload, indent=1, default=str) + "\n")
    write_text(out / "calibration.md", "\n".join(md))
    console.print(calibration_markdown(reports), markup=False, highlight=False, soft_wrap=True)
    if differences:
        console.print(differences_markdown(differences), markup=False, highlight=False, soft_wrap=True)
    console.print(f"wrote {out / 'calibration.md'}", markup=False, highlight=False, soft_wrap=True)


def train_answer_calibration_command(
    data: list[Path] = typer.Option(..., "--data", help="VALIDATION dataset directory (repeatable: several seeds "
                                    "make the fit less tied to one seed's accuracy)."),
    split: str = typer.Option("all", "--split", help="Split of each VALIDATION dataset (all: every image of a "
                                                     "held-out seed)."),
    limit: int = _LIMIT, cache: Path = _CACHE, device: str = _DEVICE, threads: int = _THREADS,
    perception: str = typer.Option("image", "--perception", help="Evidence the calibration is for: image (the "
                                   "shipped perception; what the pipeline applies it to) or simulated."),
    noise: float = _NOISE, seed: int = _SEED, priors: str = _PRIORS,
    out: Path = typer.Option(None, "--out", help="Model directory to write the calibration file and its manifest "
                                                 "entry into (default: the shipped models/)."),
    model_dir: Path = typer.Option(None, "--model-dir", help="The perception models and priors whose answers to "
                                                             "calibrate (default: the shipped models/)."),
    objective: str = typer.Option("nll", "--objective", help="Proper scoring rule the fit minimises per answer "
                                                             "type: nll, or brier (the full distribution's)."),
    method: str = typer.Option("ours", "--method", help="Whose answers to calibrate: ours (what the pipeline "
                               "returns), or a baseline (soft, thresholded), which the evaluation then also reports "
                               "recalibrated, for a like-for-like ECE comparison."),
    top_answer: bool = typer.Option(True, "--top-answer/--no-top-answer", help="Also fit the top-answer map (the "
                                    "top outcome's probability -> how often it is right, every type pooled) after "
                                    "the per-type temperatures and smoothings."),
) -> None:
    """Fit the answer calibration (a temperature and a smoothing per answer type, then a map of the top outcome's
    probability) on a VALIDATION dataset's questions answered from the image, and ship it: the pipeline applies
    ours to every answer from an image; a baseline's is applied by the evaluation only. Never fit it on the split
    you report."""
    import shlex

    from rich.console import Console

    from po3d_ppl.cli._common import build_command
    from po3d_ppl.evaluation.answer_calibration import check_objective, fit
    from po3d_ppl.evaluation.calibration import calibration_report
    from po3d_ppl.errors import InputError
    from po3d_ppl.evaluation.runner import CALIBRATABLE, calibrated_variant, recalibrated
    from po3d_ppl.model_store import models_dir, write_entry
    from po3d_ppl.reasoning.answer_calibration import PIPELINE_METHOD, model_name

    check_objective(objective, "--objective")  # before the hours of answering, not after
    if method not in CALIBRATABLE:
        raise InputError("--method", f"unknown {method!r}; choose from {', '.join(CALIBRATABLE)}")
    console = Console()
    backend = make_backend(perception, noise, seed, model_dir)  # one model load for every dataset
    records, images, manifests = [], 0, []
    for dataset_dir in data:
        dataset, run, _ = _run(dataset_dir, split, method, noise, seed, limit, cache, False, device, threads, console,
                               f"answer calibration ({dataset_dir.name})", perception, priors=priors,
                               model_dir=model_dir, recalibrate=False, backend=backend)
        records += run.records
        images += run.images
        manifests.append(dataset.manifest)
    calibration, per_type = fit(records, method, objective=objective, top_answer=top_answer)
    for record in records:
        record.predictions[calibrated_variant(method)] = recalibrated(record, calibration, method)
    before, after = calibration_report(records, method), calibration_report(records, calibrated_variant(method))
    directory = Path(out) if out is not None else models_dir()
    directory.mkdir(parents=True, exist_ok=True)
    words = ["po3d", "train", "answer-calibration"]
    for dataset_dir in data:
        words += ["--data", str(dataset_dir)]
    words += ["--split", split, "--perception", perception, "--priors", priors, "--objective", objective]
    words += ["--method", method] if method != PIPELINE_METHOD else []
    words += [] if top_answer else ["--no-top-answer"]
    words += ["--limit", str(limit)] if limit else []
    words += ["--noise", str(noise), "--seed", str(seed)] if perception == "simulated" else []
    words += ["--out", str(out)] if out is not None else []
    words += ["--model-dir", str(model_dir)] if model_dir is not None else []
    words += ["--cache", str(cache)] if cache is not None else []
    metrics = {"questions": len(records), "images": images, "types": per_type,
               "fit_split": {"before": {k: before.row()[k] for k in ("accuracy", "mean_confidence", "ece", "nll")},
                             "after": {k: after.row()[k] for k in ("accuracy", "mean_confidence", "ece", "nll")}}}
    saved = calibration.save(directory, method)
    write_entry(model_name(method), [saved], directory, command=shlex.join(words),
                data_commands=[build_command(d, m) for d, m in zip(data, manifests)],
                data_seed=[m.get("seed") for m in manifests], data_config=[m.get("config") for m in manifests],
                metrics=metrics)
    console.print_json(json.dumps({"calibration": calibration.to_dict(), **metrics}))
    fitted_on = ", ".join(map(str, data))
    console.print(f"answer calibration of {method} -> {saved} (fitted on {fitted_on}; report it on another seed)",
                  markup=False, highlight=False)


def ceilings_command(
    data: Path = _DATA, split: str = _SPLIT, limit: int = _LIMIT,
    oracles: str = typer.Option(None, "--oracles", help="Comma-separated oracles (default: every registered one: "
                                "existence, subtype, attributes, pose, occlusion, part_visibility, part_style, "
                                "part_occlusion)."),
    files: str = typer.Option(None, "--files", help="Comma-separated question files (default: all; each variant "
                              "answers every question again, about 0.1 s each)."),
    json_out: Path = typer.Option(None, "--json", help="Write the accuracies per variant, file and column."),
    md_out: Path = typer.Option(None, "--md", help="Write the Markdown table."),
    figure: Path = typer.Option(None, "--figure", help="Write the bar chart of each oracle's gain (PNG)."),
    cache: Path = _CACHE, threads: int = _THREADS,
    perception: str = typer.Option("image", "--perception", help="Evidence back-end: image (default: the shipped "
                                   "parser, cached) or simulated (--noise, --seed)."),
    noise: float = _NOISE, seed: int = _SEED, priors: str = _PRIORS,
) -> None:
    """Which evidence table limits the answers: ``ours`` with each table replaced by the truth on the matched
    proposals (an analysis that reads the scenes, like the oracle column), against perception as it is."""
    import torch
    from rich.console import Console

    from po3d_ppl.evaluation.cache import EvidenceCache
    from po3d_ppl.evaluation.ceilings import evaluate_ceilings
    from po3d_ppl.evaluation.plots import ceiling_plot
    from po3d_ppl.evaluation.report import write_text
    from po3d_ppl.questions.dataset import load_dataset

    torch.set_num_threads(threads)
    console = Console()
    dataset = load_dataset(data)
    backend = make_backend(perception, noise, seed)
    store = EvidenceCache(cache if cache is not None else Path(data) / "eval_cache")
    chosen = None if oracles is None else comma_list(oracles)
    with _progress(console, "eval ceilings") as bar:
        task = bar.add_task("ceilings", total=None)
        report = evaluate_ceilings(dataset, split, backend, cache=store, limit=limit, oracles=chosen,
                                   files=None if files is None else comma_list(files),
                                   priors=resolve_priors(priors),
                                   progress=lambda v, d, t: bar.update(task, completed=d, total=t,
                                                                       description=v))
    table = report.markdown()
    if json_out is not None:
        write_text(json_out, json.dumps(report.to_json(), indent=1) + "\n")
    if md_out is not None:
        write_text(md_out, f"# Answer ceilings: {data.name}, split {split}, {report.images} images\n\n{table}")
    if figure is not None:
        ceiling_plot(report, figure, f"{data.name}, split {split}: one table replaced by the truth")
    console.print(table, markup=False, highlight=False, soft_wrap=True)
    console.print(f"evidence cache: {store.hits} hits, {store.misses} misses", markup=False, highlight=False,
                  soft_wrap=True)


def register(app: typer.Typer, train_app: typer.Typer, eval_app: typer.Typer) -> None:
    eval_app.command("vqa")(vqa_command)
    eval_app.command("ceilings")(ceilings_command)
    eval_app.command("calibration")(calibration_command)
    train_app.command("answer-calibration")(train_answer_calibration_command)

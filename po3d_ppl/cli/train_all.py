"""``po3d train all``: every training stage in dependency order, from the datasets to the fitted priors.

The stages are the existing ``po3d train X`` commands with the settings of the shipped models (``--scale full``:
the ``command`` and ``data_commands`` of each entry of models/manifest.json) or with a handful of scenes and steps
(``--scale tiny``: the whole chain in CI). By default they run as processes, as many at once as the machine has
cores, each command as soon as the datasets and models it reads are made (:mod:`po3d_ppl.cli.train_schedule`);
``--jobs 1`` runs them one after another in this process, each with its command's own progress bars. Every
command and stage is timed (wall and CPU seconds, and when it started); the timings are printed as a table and
written to ``OUT/train_all.json`` next to the weights and their manifest, with a timeline, ``OUT/train_all.png``.

Stages read what earlier stages wrote into ``--out`` (the object calibration parses images with the feature model
and the background model of ``--out``), so ``--stages`` can resume a chain; a missing prerequisite is an
:class:`~po3d_ppl.errors.InputError` that names the stage to run first. Seed 713 is the held-out test seed: no
dataset of this command uses it.

Register with ``"train_all"`` in ``po3d_ppl.cli._MODULES``.
"""

from __future__ import annotations

import inspect
import json
import os
import shlex
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Annotated, Any

import typer

from po3d_ppl.cli._common import comma_list
from po3d_ppl.cli.train_schedule import Finished, run_commands

#: Every stage, in the order they run (each reads only what the ones before it wrote).
STAGES = ("datasets", "parser", "perception", "background", "centres", "calibration", "attributes", "viewpoint",
          "projection", "priors", "answer_calibration")
#: The held-out test seed: never built or read by ``po3d train all``.
TEST_SEED = 713
#: The report written next to the weights.
REPORT = "train_all.json"
#: the chain's timeline (one bar a command), written next to the report
TIMELINE = "train_all.png"

_DESCRIPTIONS = {
    "datasets": "po3d dataset build: rendered training and validation scenes",
    "parser": "po3d train parser and parser-calibration for each ensemble member, then po3d train parser-ensemble",
    "perception": "po3d train perception: feature extractor, neural meshes, clutter bank",
    "background": "po3d train background: the bare ground, lit and shadowed",
    "centres": "po3d train centres: where objects stand, from --out's features",
    "calibration": "po3d train calibration: object parser tables (uses --out's features and background)",
    "attributes": "po3d train attributes: subtype, colour, material, size, part looks",
    "viewpoint": "po3d train viewpoint: azimuth network and its temperature",
    "projection": "po3d train projection: Platt scaling of the projected tables (parses val with --out's models)",
    "priors": "po3d train priors: the world's rates, written to priors.json",
    "answer_calibration": "po3d train answer-calibration: answers from val's images recalibrated per answer type",
}
#: model name in the manifest -> (stage that writes it, what it is)
_MODELS = {
    "question_parser": ("parser", "question parser"),
    "question_parser_cr_seed0": ("parser", "question parser ensemble member"),
    "question_parser_w2_seed2": ("parser", "question parser ensemble member"),
    "question_parser_ensemble": ("parser", "question parser ensemble"),
    "perception_features": ("perception", "perception features"),
    "background": ("background", "background model"),
    "centres": ("centres", "centre head"),
    "object_calibration": ("calibration", "object calibration"),
    "attributes": ("attributes", "attribute network"),
    "viewpoint": ("viewpoint", "viewpoint network"),
    "projection_calibration": ("projection", "projection calibration"),
    "priors": ("priors", "fitted scene priors"),
    "answer_calibration": ("answer_calibration", "answer calibration"),
    "answer_calibration_thresholded": ("answer_calibration", "thresholded baseline's answer calibration"),
    "answer_calibration_soft": ("answer_calibration", "soft baseline's answer calibration"),
}
#: models each stage reads from --out (written by an earlier stage)
_NEEDS_MODELS = {"centres": ("perception_features",),
                 "calibration": ("perception_features", "background"),
                 "projection": ("perception_features", "background", "centres", "object_calibration", "attributes",
                                "viewpoint"),
                 "answer_calibration": ("perception_features", "background", "centres", "object_calibration",
                                        "attributes", "viewpoint", "projection_calibration", "priors")}


@dataclass(frozen=True)
class DatasetSpec:
    """One dataset of the chain: ``DATA/<name>`` built with ``po3d dataset build --scenes N --seed S``."""

    name: str
    seed: int
    scenes: int


@dataclass(frozen=True)
class ParserMember:
    """One parser of the shipped ensemble: trained as ``name`` with the chain's seed plus ``seed_offset`` on the
    corpus with the opt-in ``extra_families`` (calibrated on the same families)."""

    name: str
    seed_offset: int = 0
    extra_families: tuple[str, ...] = ()


@dataclass(frozen=True)
class Scale:
    """The datasets and each stage's settings (options of its ``po3d train`` command, by parameter name)."""

    name: str
    datasets: tuple[DatasetSpec, ...]
    parser: dict[str, Any]
    parser_calibration: dict[str, Any]
    perception: dict[str, Any]
    background: dict[str, Any]
    centres: dict[str, Any]
    calibration: dict[str, Any]
    attributes: dict[str, Any]
    viewpoint: dict[str, Any]
    projection: dict[str, Any]
    answer_calibration: dict[str, Any] = field(default_factory=dict)
    #: the question parser's members (the first is the single parser, ``question_parser``) and the ensemble's
    #: own settings (``po3d train parser-ensemble``; empty: the single parser is shipped alone)
    parser_members: tuple[ParserMember, ...] = (ParserMember("question_parser"),)
    parser_ensemble: dict[str, Any] = field(default_factory=dict)
    #: which datasets (by name) each stage trains on; ``val`` is the validation / calibration dataset
    train_sets: dict[str, tuple[str, ...]] = field(default_factory=dict)
    val: str = "val_s712"
    #: whether the perception, attribute and viewpoint stages also measure on ``val`` (as the shipped runs did)
    evaluate: bool = True
    #: stages whose command runs on at least this many torch threads whatever ``--threads`` says
    min_threads: dict[str, int] = field(default_factory=dict)


#: The shipped models' settings (models/manifest.json: each entry's command and data_commands).
FULL = Scale(
    name="full",
    datasets=(DatasetSpec("train_s711", 711, 400), DatasetSpec("train_s714", 714, 600),
              DatasetSpec("train_s715", 715, 800), DatasetSpec("val_s712", 712, 120),
              DatasetSpec("val_s716", 716, 120), DatasetSpec("val_s717", 717, 120), DatasetSpec("val_s718", 718, 120)),
    parser={"corpus": 150000, "corpus_seed": 1, "corpus_val": 2000, "ngram_buckets": 4096, "word_dropout": 0.05,
            "max_minutes": 38.0, "epochs": 4, "batch_size": 64, "lr": 0.002, "hidden": 128, "embed": 64},
    parser_calibration={"corpus_seed": 2001, "questions": 1500},
    parser_members=(ParserMember("question_parser"), ParserMember("question_parser_cr_seed0", 0, ("compare_relate",)),
                    ParserMember("question_parser_w2_seed2", 2, ("compare_relate", "wording2"))),
    parser_ensemble={"rule": "mixture", "corpus_seed": 2001, "questions": 1500,
                     "extra_families": ["compare_relate", "wording2"]},
    perception={"epochs": 34, "batch_size": 8, "crop": "256x320", "lr": 0.002, "dim": 64, "splits": "train,val",
                "eval_limit": 60},
    background={"split": "train", "limit": 80},
    centres={"epochs": 12, "batch_size": 16, "lr": 0.002, "splits": "train,val,test"},
    # the shipped calibration used a 60-scene build of seed 712: the first 60 images of the 120-scene one
    calibration={"limit": 60},
    # two members (seeds 0 and 1) read as one ensemble: about 0.5 points more part looks right than one network
    attributes={"epochs": 26, "batch_size": 32, "lr": 0.003, "part_fraction": 0.5, "part_shift": 0.0,
                "part_masks": "jittered", "splits": "train,test", "val_split": "val", "members": 2},
    # half the crops' masks cut along a line: the parser's masks of occluded objects miss a side of what shows
    viewpoint={"epochs": 30, "batch_size": 32, "lr": 0.003, "splits": "train,test", "val_split": "val",
               "mask_cut": 0.5},
    projection={"split": "all"},
    answer_calibration={"split": "all"},
    train_sets={"perception": ("train_s711",), "background": ("train_s711",), "priors": ("train_s711",),
                "attributes": ("train_s711", "train_s714", "train_s715"),
                "viewpoint": ("train_s711", "train_s714", "train_s715"),
                "centres": ("train_s711", "train_s714", "train_s715"),
                # four validation seeds: one seed's accuracy differs from another's by a few points, and the
                # top outcome's map follows the seeds it is fitted on (docs/evaluation.md)
                "answer_calibration": ("val_s712", "val_s716", "val_s717", "val_s718")},
    # two threads, as the shipped command: in the object parser's chain the centre head trains last and alone, and
    # on one thread it left a core idle for 24 minutes; beside the attribute and viewpoint networks (Perception I
    # and II together) it shares the cores instead: 1,824 s wall, 2,256 CPU s (docs/architecture.md)
    min_threads={"centres": 2},
)

#: A handful of scenes and a few steps a stage: the whole chain in CI (minutes become seconds; toy weights).
TINY = Scale(
    name="tiny",
    datasets=(DatasetSpec("train_s711", 711, 8), DatasetSpec("val_s712", 712, 3)),
    parser={"corpus": 200, "corpus_seed": 1, "corpus_val": 20, "ngram_buckets": 64, "word_dropout": 0.05,
            "epochs": 1, "batch_size": 16, "lr": 0.002, "hidden": 16, "embed": 16, "max_steps": 3},
    parser_calibration={"corpus_seed": 2001, "questions": 50},
    parser_members=(ParserMember("question_parser"), ParserMember("question_parser_cr_seed0", 0, ("compare_relate",))),
    parser_ensemble={"rule": "mixture", "corpus_seed": 2001, "questions": 50, "extra_families": ["compare_relate"]},
    # enough steps for the toy features to propose objects, real and spurious: the calibration's Platt fit needs both
    perception={"epochs": 200, "batch_size": 2, "crop": "128x160", "lr": 0.005, "dim": 16, "splits": "train",
                "max_steps": 200},
    background={"split": "train", "limit": 5},
    centres={"epochs": 1, "batch_size": 2, "lr": 0.002, "splits": "train", "max_steps": 2},
    calibration={"limit": 3},
    attributes={"epochs": 1, "batch_size": 4, "lr": 0.003, "part_fraction": 0.25, "part_shift": 0.0,
                "part_masks": "jittered", "splits": "train", "val_split": "val", "max_steps": 2},
    viewpoint={"epochs": 1, "batch_size": 4, "lr": 0.003, "splits": "train", "val_split": "val", "max_steps": 2},
    projection={"split": "all", "limit": 2},
    answer_calibration={"split": "all", "limit": 1},
    train_sets={"perception": ("train_s711",), "background": ("train_s711",), "priors": ("train_s711",),
                "attributes": ("train_s711",), "viewpoint": ("train_s711",), "centres": ("train_s711",),
                "answer_calibration": ("val_s712",)},
    evaluate=False,
)
SCALES = {"full": FULL, "tiny": TINY}


@dataclass
class Step:
    """One command of a stage: ``fn(**kwargs)``, and the equivalent command line."""

    label: str
    fn: Callable[..., Any]
    kwargs: dict[str, Any]
    words: list[str]
    bar: bool = False  # the command has no progress bar of its own: show one around it (``--jobs 1``)
    #: steps of one group run one after another; different groups of a stage may run at once (``--jobs``)
    group: str | None = None
    #: the stage the step belongs to and the labels of the steps it waits for (set by :func:`link`)
    stage: str = ""
    after: tuple[str, ...] = ()


def invoke(fn: Callable[..., Any], **kwargs: Any) -> Any:
    """Call a typer command function with ``kwargs``, every other parameter at its command-line default (typer
    keeps those in ``OptionInfo`` defaults, which a plain call would pass through as they are)."""
    from typer.models import ParameterInfo

    parameters = inspect.signature(fn).parameters
    unknown = set(kwargs) - set(parameters)
    if unknown:
        raise TypeError(f"{fn.__name__} has no parameter {', '.join(sorted(unknown))}")
    call = {}
    for name, parameter in parameters.items():
        if name in kwargs:
            call[name] = kwargs[name]
            continue
        default = parameter.default
        if isinstance(default, ParameterInfo):
            default = default.default
        if default is inspect.Parameter.empty or default is ...:
            raise TypeError(f"{fn.__name__}: {name} is required")
        call[name] = default
    return fn(**call)


def command_words(prefix: list[str], kwargs: dict[str, Any]) -> list[str]:
    """The command line equivalent to calling a command with ``kwargs`` (``--some-option value``; lists repeat)."""
    words = list(prefix)
    for name, value in kwargs.items():
        if value is None or value is False:
            continue
        option = "--" + name.replace("_", "-")
        if value is True:
            words.append(option)
        elif isinstance(value, (list, tuple)):
            for item in value:
                words += [option, str(item)]
        else:
            words += [option, str(value)]
    return words


def plan(scale: Scale, data: Path, out: Path, seed: int, threads: int) -> dict[str, list[Step]]:
    """Every stage's steps for ``scale``, datasets under ``data``, models into ``out``."""
    from po3d_ppl.cli.attributes import train_attributes_command
    from po3d_ppl.cli.centres import train_centres_command
    from po3d_ppl.cli.dataset import build
    from po3d_ppl.cli.evaluate import train_answer_calibration_command
    from po3d_ppl.cli.objects import train_background_command, train_calibration_command, train_projection_command
    from po3d_ppl.cli.perception import train_perception_command
    from po3d_ppl.cli.priors import train_priors
    from po3d_ppl.cli.viewpoint import train_viewpoint_command
    from po3d_ppl.evaluation.runner import CALIBRATABLE
    from po3d_ppl.reasoning.answer_calibration import PIPELINE_METHOD

    def path(name: str) -> Path:
        return data / name

    def sets(stage: str) -> list[Path]:
        return [path(n) for n in scale.train_sets[stage]]

    val = path(scale.val)
    held = val if scale.evaluate else None

    def threads_of(stage: str) -> int:
        return max(threads, scale.min_threads.get(stage, 1))

    def step(label: str, fn, prefix: list[str], bar: bool = False, group: str | None = None, **kwargs):
        return Step(label, fn, kwargs, command_words(prefix, kwargs), bar, group)

    steps: dict[str, list[Step]] = {
        "datasets": [step(f"dataset {d.name}", build, ["po3d", "dataset", "build"], out=path(d.name),
                          scenes=d.scenes, seed=d.seed, workers=1) for d in scale.datasets],
        "parser": parser_steps(scale, out, seed, threads, step),
        "perception": [step("perception", train_perception_command, ["po3d", "train", "perception"],
                            data=sets("perception"), seed=seed, **scale.perception,
                            threads=threads_of("perception"), eval_data=held, out=out)],
        "background": [step("background", train_background_command, ["po3d", "train", "background"],
                            data=sets("background")[0], **scale.background, out=out)],
        "centres": [step("centres", train_centres_command, ["po3d", "train", "centres"], data=sets("centres"),
                         seed=seed, **scale.centres, threads=threads_of("centres"), eval_data=held, model_dir=out,
                         out=out)],
        "calibration": [step("calibration", train_calibration_command, ["po3d", "train", "calibration"],
                             data=val, **scale.calibration, threads=threads_of("calibration"), out=out,
                             model_dir=out)],
        "attributes": [step("attributes", train_attributes_command, ["po3d", "train", "attributes"],
                            data=sets("attributes"), seed=seed, **scale.attributes,
                            threads=threads_of("attributes"), eval_data=held, out=out)],
        "viewpoint": [step("viewpoint", train_viewpoint_command, ["po3d", "train", "viewpoint"],
                           data=sets("viewpoint"), seed=seed, **scale.viewpoint, threads=threads_of("viewpoint"),
                           eval_data=held, out=out)],
        "projection": [step("projection", train_projection_command, ["po3d", "train", "projection"], data=val,
                            **scale.projection, threads=threads_of("projection"), out=out, model_dir=out)],
        "priors": [step("priors", train_priors, ["po3d", "train", "priors"], data=sets("priors")[0], split="train",
                        out=out)],
        "answer_calibration": [step("answer calibration" + ("" if method == PIPELINE_METHOD else f" ({method})"),
                                    train_answer_calibration_command, ["po3d", "train", "answer-calibration"],
                                    data=sets("answer_calibration"), **scale.answer_calibration,
                                    threads=threads_of("answer_calibration"), out=out, model_dir=out,
                                    **({} if method == PIPELINE_METHOD else {"method": method}))
                               for method in CALIBRATABLE],
    }
    return steps


def parser_steps(scale: Scale, out: Path, seed: int, threads: int, step: Callable[..., Step]) -> list[Step]:
    """Each member trained and calibrated under its own name (one group per member: members may train at once),
    then the ensemble's calibration (which makes the members the shipped parser). The first member's steps keep
    the single parser's labels."""
    from po3d_ppl.cli.language import calibrate_parser_command, train_ensemble_command, train_parser_command

    steps = []
    for n, member in enumerate(scale.parser_members):
        suffix = "" if n == 0 else f" {member.name}"
        named = {} if member.name == "question_parser" else {"name": member.name}
        extra = {"extra_families": list(member.extra_families)} if member.extra_families else {}
        steps.append(step(f"parser{suffix}", train_parser_command, ["po3d", "train", "parser"], group=member.name,
                          **scale.parser, **extra, seed=seed + member.seed_offset, threads=threads, out=out,
                          **named))
        steps.append(step(f"parser calibration{suffix}", calibrate_parser_command,
                          ["po3d", "train", "parser-calibration"], bar=True, group=member.name, model_dir=out,
                          **scale.parser_calibration, **extra, threads=threads, **named))
    if scale.parser_ensemble:
        steps.append(step("parser ensemble", train_ensemble_command, ["po3d", "train", "parser-ensemble"], bar=True,
                          member=[m.name for m in scale.parser_members], **scale.parser_ensemble, model_dir=out,
                          threads=threads))
    return steps


def datasets_needed(scale: Scale, stages: list[str]) -> list[DatasetSpec]:
    """The datasets the selected stages read (all of them for the datasets stage itself)."""
    if "datasets" in stages:
        return list(scale.datasets)
    names = set()
    for stage in stages:
        names |= set(scale.train_sets.get(stage, ()))
        measured = scale.evaluate and stage in ("perception", "centres", "attributes", "viewpoint")
        if stage in ("calibration", "projection", "answer_calibration") or measured:
            names.add(scale.val)
    return [d for d in scale.datasets if d.name in names]


def check_prerequisites(stages: list[str], out: Path, command: str) -> None:
    """A typed error naming the stage to run first when a selected stage reads a model that is not in ``out``
    and is not made by a stage that runs before it."""
    from po3d_ppl.errors import InputError, ModelFileError
    from po3d_ppl.model_store import MANIFEST, model_files

    for stage in stages:
        for name in _NEEDS_MODELS.get(stage, ()):
            maker, what = _MODELS[name]
            if maker in stages and stages.index(maker) < stages.index(stage):
                continue
            try:
                model_files(name, out)
            except ModelFileError as exc:
                raise InputError("--stages", f"stage {stage!r} needs the {what} of stage {maker!r}, which "
                                             f"{out / MANIFEST} does not hold ({exc}); run stage {maker!r} first: "
                                             f"{command} --stages {maker}") from None


def _cpu_seconds() -> float:
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def _read_report(path: Path) -> dict:
    try:
        report = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}
    return report if isinstance(report, dict) and isinstance(report.get("stages"), dict) else {}


def train_all(data: Path, out: Path, *, seed: int = 0, scale: str = "full", stages: list[str] | None = None,
              threads: int = 1, jobs: int | None = None, console=None) -> dict:
    """Run ``stages`` (default: all) at ``scale``; return the report also written to ``out/train_all.json``.
    Datasets the stages read are built first when ``data`` lacks them. ``jobs`` commands run at once (default:
    one a CPU core), each in a process of its own on ``threads`` threads as soon as what it reads is made;
    ``jobs=1`` runs them in :data:`STAGES` order in this process."""
    import torch
    from rich.console import Console

    from po3d_ppl.cli._common import check_seed
    from po3d_ppl.errors import InputError, UnknownNameError

    check_seed(seed)
    if scale not in SCALES:
        raise UnknownNameError("scale", scale, SCALES, "pass --scale full or --scale tiny")
    if threads < 1:
        raise InputError("--threads", f"must be at least 1, got {threads}")
    if jobs is not None and jobs < 1:
        raise InputError("--jobs", f"must be at least 1, got {jobs}")
    chosen = list(STAGES) if not stages else stages
    for name in chosen:
        if name not in STAGES:
            raise UnknownNameError("stage", name, STAGES, f"--stages takes a comma-separated subset of "
                                                          f"{','.join(STAGES)}")
    spec = SCALES[scale]
    data, out = Path(data), Path(out)
    if data.exists() and not data.is_dir():
        raise InputError("--data", f"{data} exists and is not a directory")
    if out.exists() and not out.is_dir():
        raise InputError("--out", f"{out} exists and is not a directory")
    assert all(d.seed != TEST_SEED for d in spec.datasets), "the held-out test seed is never trained on"
    jobs = jobs or os.cpu_count() or 1
    base = ["po3d", "train", "all", "--data", str(data), "--out", str(out), "--seed", str(seed), "--scale", scale,
            "--threads", str(threads), "--jobs", str(jobs)]
    # the datasets stage runs whenever a selected stage reads a dataset (building only what is missing)
    needed = datasets_needed(spec, chosen)
    run = [s for s in STAGES if s in chosen or (s == "datasets" and needed)]
    check_prerequisites(run, out, shlex.join(base))
    steps = plan(spec, data, out, seed, threads)
    steps["datasets"] = [s for s in steps["datasets"] if s.kwargs["out"].name in {d.name for d in needed}]

    console = console or Console()
    torch.set_num_threads(threads)
    out.mkdir(parents=True, exist_ok=True)
    report_path = out / REPORT
    recorded = _read_report(report_path).get("stages", {})
    started = time.strftime("%Y-%m-%dT%H:%M:%S%z")
    ordered = link(steps, run, spec)
    records: dict[str, list[dict]] = {stage: [] for stage in run}
    origin = time.perf_counter()
    report: dict = {}

    def on_finish(step: Step, finished: Finished) -> None:
        """Keep a step's record; after a stage's last step, record the stage and write the report (so an
        interrupted chain keeps the timings of what it finished)."""
        nonlocal report
        records[step.stage].append(asdict(finished))
        if len(records[step.stage]) < len(steps[step.stage]):
            return
        rows = records[step.stage]
        first, last = min(r["start"] for r in rows), max(r["end"] for r in rows)
        recorded[step.stage] = {"seconds": round(last - first, 1),
                                "cpu_seconds": round(sum(r["cpu_seconds"] for r in rows), 1), "scale": scale,
                                "run": started, "start": first, "end": last,
                                "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "steps": rows,
                                "outputs": _outputs(step.stage, steps[step.stage], out)}
        report = {"command": shlex.join(base + ["--stages", ",".join(run)]), "scale": scale, "seed": seed,
                  "threads": threads, "jobs": jobs, "data": str(data), "out": str(out), "started": started,
                  "cpu_count": os.cpu_count(), "device": "cpu", "wall_seconds": round(time.perf_counter() - origin, 1),
                  "stages": {s: recorded[s] for s in STAGES if s in recorded}}
        report["total_seconds"] = round(sum(s["seconds"] for s in report["stages"].values()), 1)
        report["total_cpu_seconds"] = round(sum(s["cpu_seconds"] for s in report["stages"].values()), 1)
        _write_json(report_path, report)

    if jobs == 1:
        _run_in_process(ordered, run, console, origin, on_finish)
    else:
        console.rule(f"[bold]{len(run)} stages[/]: {', '.join(run)}", style="cyan")
        console.print(f"{len(ordered)} commands, {jobs} at a time, each as soon as what it reads is trained; "
                      f"logs in {out / 'logs'}", markup=False, highlight=False)
        run_commands(ordered, jobs, out / "logs", console, _command, on_finish, origin=origin)
    print_report(report, console, ran=run)
    console.print(f"report -> {report_path}", markup=False, highlight=False)
    figure = plot_timeline(report, out / TIMELINE)
    console.print(f"timeline -> {figure}", markup=False, highlight=False)
    return report


def link(steps: dict[str, list[Step]], run: list[str], scale: Scale) -> list[Step]:
    """The steps of the stages in ``run``, in order, each one's ``stage`` and ``after`` set: a stage waits for the
    builds of the datasets it reads and for every step of the stages whose models it reads (``_NEEDS_MODELS``);
    within a stage, a step of a group follows the earlier steps of its group, a step of no group every earlier
    step (the parser's members train side by side, the ensemble after them)."""
    built = {s.kwargs["out"].name: s.label for s in steps["datasets"]} if "datasets" in run else {}
    ordered: list[Step] = []
    for stage in run:
        makers = [maker for maker in run if maker in {_MODELS[name][0] for name in _NEEDS_MODELS.get(stage, ())}]
        before = [s.label for maker in makers for s in steps[maker]]
        if stage != "datasets":
            before += [built[d.name] for d in datasets_needed(scale, [stage]) if d.name in built]
        earlier: list[Step] = []
        for step in steps[stage]:
            own = [s.label for s in earlier if step.group is None or s.group in (step.group, None)]
            step.stage, step.after = stage, tuple(before + own)
            earlier.append(step)
        ordered += steps[stage]
    return ordered


def _run_in_process(ordered: list[Step], run: list[str], console, origin: float,
                    on_finish: Callable[[Step, Finished], None]) -> None:
    """``--jobs 1``: every step in this process, one after another, each with its command's own progress bars."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    stage = None
    for step in ordered:
        if step.stage != stage:
            stage = step.stage
            console.rule(f"[bold]{run.index(stage) + 1}/{len(run)} {stage}[/]: {_DESCRIPTIONS[stage]}", style="cyan")
        console.print("$ " + shlex.join(step.words), markup=False, highlight=False, style="dim", soft_wrap=True)
        start, cpu = time.perf_counter(), _cpu_seconds()
        if step.bar:
            with Progress(TextColumn(f"[bold]{step.label}"), BarColumn(), TimeElapsedColumn(), console=console) as bar:
                bar.add_task(step.label, total=None)
                invoke(step.fn, **step.kwargs)
        else:
            invoke(step.fn, **step.kwargs)
        end = time.perf_counter()
        on_finish(step, Finished(step.label, shlex.join(step.words), round(end - start, 1),
                                 round(_cpu_seconds() - cpu, 1), round(start - origin, 1), round(end - origin, 1)))


def _command(step: Step) -> list[str]:
    """The process that runs ``step`` (this interpreter, the step's command line)."""
    return [sys.executable, "-c", "from po3d_ppl.cli import main; main()", *step.words[1:]]


def _outputs(stage: str, steps: list[Step], out: Path) -> list[str]:
    if stage == "datasets":
        return [str(s.kwargs["out"]) for s in steps]
    from po3d_ppl.model_store import read_manifest

    manifest = read_manifest(out)
    return sorted(f for name, (maker, _) in _MODELS.items() if maker == stage
                  for f in manifest.get(name, {}).get("files", {}))


def _write_json(path: Path, value: dict) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps(value, indent=1) + "\n")
    os.replace(tmp, path)


def print_report(report: dict, console, ran: list[str] | None = None) -> None:
    """The per-stage timing table (stages from an earlier run of the report are marked)."""
    from rich.table import Table

    from po3d_ppl.cli._common import literal

    table = Table(title=literal(f"po3d train all --scale {report['scale']}: {report['out']}"),
                  caption=f"{report.get('threads', 1)} torch thread(s) on {report.get('cpu_count')} CPU core(s)")
    for column in ("stage", "seconds", "CPU seconds", "outputs"):
        table.add_column(column, justify="right" if "seconds" in column else "left")
    for stage, row in report["stages"].items():
        note = "" if ran is None or stage in ran else " (earlier run)"
        outputs = ", ".join(Path(o).name for o in row.get("outputs", []))
        table.add_row(literal(stage + note), f"{row['seconds']:.1f}", f"{row['cpu_seconds']:.1f}", literal(outputs))
    table.add_row("total (stages summed)", f"{report['total_seconds']:.1f}", f"{report['total_cpu_seconds']:.1f}",
                  "", style="bold")
    if "wall_seconds" in report:
        table.add_row(f"this run, wall clock ({report.get('jobs')} at a time)", f"{report['wall_seconds']:.1f}", "",
                      "", style="bold")
    console.print(table)


def plot_timeline(report: dict, path: Path) -> Path:
    """One bar a command of the report's latest run (stages of earlier runs are left out), coloured by stage:
    which commands shared the cores and where one waited for another."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    latest = {stage: row for stage, row in report["stages"].items() if row.get("run") == report["started"]}
    rows = [(stage, step) for stage, row in latest.items() for step in row["steps"]]
    rows.sort(key=lambda item: item[1]["start"])
    colours = {stage: plt.get_cmap("tab20")(index % 20) for index, stage in enumerate(STAGES)}
    figure, axes = plt.subplots(figsize=(11, 1.5 + 0.3 * len(rows)))
    for y, (stage, step) in enumerate(rows):
        axes.barh(y, step["end"] - step["start"], left=step["start"], color=colours[stage], edgecolor="black",
                  linewidth=0.5)
    axes.set_yticks(range(len(rows)), [step["step"] for _, step in rows], fontsize=8)
    axes.invert_yaxis()
    axes.set_xlabel("seconds since the run started")
    axes.set_title(f"po3d train all --scale {report['scale']}: {report.get('wall_seconds', 0):.0f} s wall clock, "
                   f"{report.get('jobs')} commands at a time on {report.get('cpu_count')} cores", fontsize=9)
    handles = [plt.Rectangle((0, 0), 1, 1, color=colours[stage]) for stage in latest]
    axes.legend(handles, list(latest), fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    plt.close(figure)
    return path


def train_all_command(
    data: Annotated[Path, typer.Option(
        "--data", help="Root of the datasets (DATA/train_s711, DATA/val_s712 ...); built first where missing.")],
    out: Annotated[Path | None, typer.Option(
        "--out", help="Where to write every model, the manifest, priors.json and train_all.json "
                      "(default: models/; --scale tiny needs another directory).")] = None,
    seed: Annotated[int, typer.Option("--seed", help="Training seed of every stage (dataset seeds are fixed).")] = 0,
    scale: Annotated[str, typer.Option(
        "--scale", help="full: the shipped models' settings (models/manifest.json); tiny: a few scenes and steps "
                        "a stage (CI).")] = "full",
    stages: Annotated[str | None, typer.Option(
        "--stages", help=f"Comma-separated subset of {','.join(STAGES)} (default: all); later stages read earlier "
                         "ones' models from --out.")] = None,
    threads: Annotated[int, typer.Option("--threads", min=1, help="torch CPU threads of every stage.")] = 1,
    jobs: Annotated[int | None, typer.Option(
        "--jobs", min=1, help="Commands run at once, each in a process of its own as soon as what it reads is made "
                              "(default: one a CPU core; 1: one after another in this process).")] = None,
) -> None:
    """Train every model in dependency order (datasets, parser, perception, background, calibration, attributes,
    viewpoint, projection, priors) with a progress bar on each stage, and report the seconds each took."""
    from po3d_ppl.errors import InputError
    from po3d_ppl.model_store import models_dir

    shipped = models_dir().resolve()
    if out is None:
        if scale == "tiny":
            raise InputError("--out", "--scale tiny trains toy models; give an --out directory other than the "
                                      f"shipped {shipped}")
        out = shipped
    elif scale == "tiny" and out.resolve() == shipped:
        raise InputError("--out", f"--scale tiny would overwrite the shipped models in {shipped}; give another "
                                  "directory")
    chosen = comma_list(stages) if stages else None
    if stages is not None and not chosen:
        raise InputError("--stages", f"name at least one stage of {','.join(STAGES)}")
    train_all(data, out, seed=seed, scale=scale, stages=chosen, threads=threads, jobs=jobs)


def register(app: typer.Typer, train_app: typer.Typer, eval_app: typer.Typer) -> None:
    train_app.command("all")(train_all_command)

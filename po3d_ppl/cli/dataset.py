"""``po3d dataset build|stats``: build a Super-CLEVR-3D-style dataset and inspect its question files."""

from __future__ import annotations

from pathlib import Path

import typer

dataset_app = typer.Typer(help="Build datasets of rendered scenes with questions, and inspect them.",
                          no_args_is_help=True)


@dataset_app.command("build")
def build(
    out: Path = typer.Option(..., "--out", help="Output directory (re-running the same command resumes it)."),
    scenes: int = typer.Option(..., "--scenes", help="Number of scenes to render."),
    seed: int = typer.Option(0, "--seed", help="Dataset seed; scene i derives its seed from (seed, i)."),
    workers: int = typer.Option(1, "--workers", help="Worker processes."),
    width: int = typer.Option(640, "--width", help="Image width in pixels."),
    height: int = typer.Option(480, "--height", help="Image height in pixels."),
    height_depth: bool = typer.Option(False, "--height-depth",
                                      help="Elevate aeroplanes and add height/depth questions."),
    semantics: str = typer.Option("intended", "--semantics",
                                  help="intended (default) or public: answers and generator rules of the public "
                                       "Super-CLEVR-3D code (docs/semantics.md)."),
) -> None:
    """Render scenes, generate balanced questions and write images, scenes.json, questions/, splits, manifest."""
    from rich.console import Console

    from po3d_ppl.cli._common import check_seed
    from po3d_ppl.questions.dataset import BuildConfig, build_dataset

    check_seed(seed)
    config = BuildConfig(scenes=scenes, seed=seed, width=width, height=height, height_depth=height_depth,
                         semantics=semantics)
    notes = Console(stderr=True)
    report = build_dataset(out, config, workers=workers, progress=True,
                           notify=lambda note: notes.print(f"repair: {note}", markup=False, highlight=False,
                                                           soft_wrap=True))
    counts = report.manifest["counts"]["questions"]
    repaired = f", {len(report.repaired)} of them damaged and rebuilt" if report.repaired else ""
    Console().print(f"{out}: {config.scenes} scenes ({report.built} built{repaired}, {report.skipped} already "
                    "done), " + ", ".join(f"{n} {name}" for name, n in counts.items()) + " questions",
                    markup=False, highlight=False)


@dataset_app.command("stats")
def stats(directory: Path = typer.Argument(..., help="A built dataset directory.")) -> None:
    """Per-family question counts, answer entropy and top-answer share."""
    from rich.console import Console
    from rich.table import Table

    from po3d_ppl.cli._common import literal
    from po3d_ppl.questions.dataset import load_dataset
    from po3d_ppl.questions.stats import family_stats

    data = load_dataset(directory)
    table = Table(title=literal(f"{directory}: {len(data.public_scenes)} scenes"))
    for col in ("set", "template", "family", "questions", "answers", "entropy (bits)", "top answer", "top share"):
        table.add_column(col, justify="right" if col not in ("set", "template", "top answer") else "left")
    for row in family_stats(data.questions):
        table.add_row(*map(literal, (row.question_set, row.template_filename, row.family, row.count,
                                     row.distinct_answers, f"{row.entropy_bits:.2f}", row.top_answer,
                                     f"{row.top_share:.0%}")))
    Console().print(table)


def register(app: typer.Typer, train_app: typer.Typer, eval_app: typer.Typer) -> None:
    app.add_typer(dataset_app, name="dataset")

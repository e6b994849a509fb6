"""``po3d execute``: run a public program on a scene with the reference executor."""

from __future__ import annotations

from pathlib import Path

import typer


def execute(
    scene: Path = typer.Option(..., "--scene", help="A scene file, or a scenes file ({info, scenes})."),
    program: str = typer.Option(..., "--program",
                                help="A JSON program list (or question with a 'program'), or a file holding one."),
    index: int = typer.Option(None, "--index", help="Which scene of a scenes file (its position; default: the "
                                                     "only one)."),
    semantics: str = typer.Option("intended", "--semantics", help="intended (default) or public: the public "
                                  "Super-CLEVR-3D code's answers (docs/semantics.md)."),
) -> None:
    """Print the reference answer of PROGRAM on the scene (raw value and the public verbalised answer)."""
    from rich.console import Console

    from po3d_ppl.cli._common import load_scene_arg, read_program_arg
    from po3d_ppl.questions.executor import execute as run
    from po3d_ppl.questions.verbalise import verbalise_answer

    result = run(load_scene_arg(scene, index), read_program_arg(program), semantics=semantics)
    console = Console()
    if not result.valid:
        console.print(f"invalid: {result.reason}", markup=False, highlight=False)
        raise typer.Exit(1)
    answer = result.answer
    shown = result.public_outputs()[-1]
    if result.answer_type in ("ObjectSet", "PartSet", "Object", "Part"):
        console.print(f"{shown}  ({result.answer_type})", markup=False, highlight=False)
    else:
        console.print(f"{answer!r} -> {verbalise_answer(answer, result.answer_type)!r}  ({result.answer_type})",
                      markup=False, highlight=False)


def register(app: typer.Typer, train_app: typer.Typer, eval_app: typer.Typer) -> None:
    app.command("execute")(execute)

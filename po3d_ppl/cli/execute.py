"""``po3d execute``: run a public program on a scene with the reference executor."""

from __future__ import annotations

from pathlib import Path

import typer


def _read_program(text: str):
    import json

    from po3d_ppl.errors import InputError

    source = "--program"
    stripped = text.lstrip()
    if not stripped.startswith(("[", "{")):
        path = Path(text)
        if not path.is_file():
            raise InputError("--program", f"{text!r} is neither a JSON program list nor an existing file")
        source, stripped = str(path), path.read_text(encoding="utf-8")
    try:
        return json.loads(stripped)
    except json.JSONDecodeError as exc:
        raise InputError(source, f"not valid JSON ({exc.msg} at line {exc.lineno} column {exc.colno})") from None


def execute(
    scene: Path = typer.Option(..., "--scene", help="A scene file, or a scenes file ({info, scenes})."),
    program: str = typer.Option(..., "--program",
                                help="A JSON program list (or question with a 'program'), or a file holding one."),
    index: int = typer.Option(None, "--index", help="Which scene of a scenes file (its position; default: the "
                                                     "only one)."),
) -> None:
    """Print the reference answer of PROGRAM on the scene (raw value and the public verbalised answer)."""
    from rich.console import Console

    from po3d_ppl.errors import InputError
    from po3d_ppl.questions.executor import execute as run
    from po3d_ppl.questions.verbalise import verbalise_answer
    from po3d_ppl.world.scene_io import load_scenes

    scenes = load_scenes(scene)
    if index is None:
        if len(scenes) != 1:
            raise InputError("--index", f"{scene} holds {len(scenes)} scenes; pick one with --index 0..{len(scenes)-1}")
        index = 0
    if not 0 <= index < len(scenes):
        raise InputError("--index", f"must be in 0..{len(scenes) - 1}, got {index}")
    result = run(scenes[index], _read_program(program))
    console = Console()
    if not result.valid:
        console.print(f"invalid: {result.reason}", highlight=False)
        raise typer.Exit(1)
    answer = result.answer
    shown = result.public_outputs()[-1]
    if result.answer_type in ("ObjectSet", "PartSet", "Object", "Part"):
        console.print(f"{shown}  ({result.answer_type})", highlight=False)
    else:
        console.print(f"{answer!r} -> {verbalise_answer(answer, result.answer_type)!r}  ({result.answer_type})",
                      highlight=False)


def register(app: typer.Typer, train_app: typer.Typer, eval_app: typer.Typer) -> None:
    app.command("execute")(execute)

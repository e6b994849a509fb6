"""Argument helpers shared by the command modules."""

from __future__ import annotations

import json
from pathlib import Path

from po3d_ppl.errors import InputError


def load_scene_arg(path: Path, index: int | None, option: str = "--index"):
    """The scene ``path`` holds (a single-scene file, or ``{info, scenes}`` with ``index`` picking one)."""
    from po3d_ppl.world.scene_io import load_scenes

    scenes = load_scenes(path)
    if index is None:
        if len(scenes) != 1:
            raise InputError(option, f"{path} holds {len(scenes)} scenes; pick one with {option} 0..{len(scenes) - 1}")
        index = 0
    if not 0 <= index < len(scenes):
        raise InputError(option, f"must be in 0..{len(scenes) - 1}, got {index}")
    return scenes[index]


def read_program_arg(text: str, option: str = "--program", allow_text: bool = False):
    """A program given on the command line: a JSON node list (or a question record with a ``program``), program
    text in the po3d syntax (when ``allow_text``), or the path of a file holding either."""
    source, body = option, text
    stripped = text.lstrip()
    if not stripped.startswith(("[", "{")) and Path(text).is_file():
        source, body = str(Path(text)), Path(text).read_text(encoding="utf-8")
        stripped = body.lstrip()
    if stripped.startswith(("[", "{")):
        try:
            data = json.loads(stripped)
        except json.JSONDecodeError as exc:
            raise InputError(source, f"not valid JSON ({exc.msg} at line {exc.lineno} column {exc.colno})") from None
        return data["program"] if isinstance(data, dict) and "program" in data else data
    if allow_text:
        return body
    raise InputError(option, f"{text!r} is neither a JSON program list nor an existing file")

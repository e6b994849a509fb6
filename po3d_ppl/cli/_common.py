"""Argument and printing helpers shared by the command modules."""

from __future__ import annotations

import json
from pathlib import Path

from rich.text import Text

from po3d_ppl.errors import InputError

#: The largest seed every consumer accepts (numpy's SeedSequence, torch.manual_seed, the world's int64 seeds).
MAX_SEED = 2**63 - 1


def check_seed(value: int, option: str = "--seed") -> int:
    """``value`` if it is a usable seed. Negative seeds reach numpy as a bare ValueError otherwise."""
    if not 0 <= value <= MAX_SEED:
        raise InputError(option, f"must be an integer in 0..{MAX_SEED}, got {value}; pass e.g. {option} 0")
    return value


def literal(text: object) -> Text:
    """``text`` as a rich renderable printed as it is: paths, programs, questions and answers hold ``[...]``,
    which rich would otherwise read as markup (dropping it, or failing on ``[/x]``)."""
    return Text(str(text))


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
        source, body = str(Path(text)), read_text_file(Path(text), option)
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


def read_text_file(path: Path, option: str) -> str:
    """The UTF-8 text of ``path`` (given with ``option``), or a typed error naming the file and the fix."""
    try:
        return path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(option, f"{path} is not UTF-8 text (byte 0x{exc.object[exc.start]:02x} at offset "
                                 f"{exc.start}); save it as UTF-8") from None
    except OSError as exc:
        raise InputError(option, f"cannot read {path}: {exc.strerror or exc}") from None


def dataset_manifest(data: Path) -> dict:
    """The ``manifest.json`` of a dataset directory (empty when it has none)."""
    path = Path(data) / "manifest.json"
    return json.loads(path.read_text()) if path.exists() else {}


def build_command(data: Path, manifest: dict) -> str:
    """The ``po3d dataset build`` command that makes ``data`` (for a model's ``data_commands``)."""
    import shlex

    config = manifest.get("config", {})
    return shlex.join(["po3d", "dataset", "build", "--out", str(data), "--scenes", str(config.get("scenes")),
                       "--seed", str(manifest.get("seed"))])


def comma_list(text: str) -> list[str]:
    """The non-empty, stripped items of a comma-separated option (``"a, b,"`` -> ``["a", "b"]``)."""
    return [item.strip() for item in text.split(",") if item.strip()]


def write_report(path: Path | None, report: dict) -> None:
    """Write ``report`` as indented JSON to ``path`` (its folder made), when an output was asked for."""
    if path is None:
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(report, indent=2) + "\n")

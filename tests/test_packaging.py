"""A non-editable install carries every subpackage and the shipped data (grammar, models, templates, spec data)."""

from __future__ import annotations

import shutil
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_every_subpackage_is_declared():
    declared = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    on_disk = {".".join(p.parent.relative_to(ROOT).parts) for p in (ROOT / "po3d_ppl").rglob("*.py")}
    assert on_disk <= declared, f"add to pyproject.toml [tool.setuptools] packages: {sorted(on_disk - declared)}"


def test_wheel_carries_grammar_models_templates_and_spec_data(tmp_path):
    pytest.importorskip("setuptools")
    source = tmp_path / "source"  # setuptools writes build/ and *.egg-info beside the sources: not in the checkout
    for name in ("pyproject.toml", "README.md"):
        source.mkdir(exist_ok=True)
        shutil.copy(ROOT / name, source / name)
    for name in ("po3d_ppl", "grammar", "models"):
        shutil.copytree(ROOT / name, source / name, ignore=shutil.ignore_patterns("__pycache__"))
    proc = subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation",
                           str(source), "-w", str(tmp_path / "wheel")], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    names = set(zipfile.ZipFile(next((tmp_path / "wheel").glob("*.whl"))).namelist())
    expected = {"po3d_ppl/grammar/program.lark", "po3d_ppl/world/data/part_dict.json",
                "po3d_ppl/world/data/properties.json", "po3d_ppl/models/manifest.json"}
    expected |= {f"po3d_ppl/models/{p.name}" for p in (ROOT / "models").iterdir() if p.is_file()}
    expected |= {f"po3d_ppl/questions/templates/{p.name}" for p in (ROOT / "po3d_ppl/questions/templates").glob("*.json")}
    assert expected <= names, sorted(expected - names)

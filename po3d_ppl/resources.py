"""Locate the data that ships with the package (grammars, trained models, spec data).

`grammar/` and `models/` sit at the repository root and are installed as `po3d_ppl.grammar` and
`po3d_ppl.models` (see pyproject.toml). An editable install does not map those two directories, so we fall back to
the source tree next to the package.
"""

from __future__ import annotations

import importlib.resources
from pathlib import Path

_PACKAGE_ROOT = Path(__file__).resolve().parent


def resource_dir(name: str) -> Path:
    """Directory of the shipped resource ``name`` ('grammar' or 'models')."""
    try:
        found = importlib.resources.files(f"po3d_ppl.{name}")
        path = Path(str(found))
        if path.is_dir():
            return path
    except ModuleNotFoundError:
        pass
    path = _PACKAGE_ROOT.parent / name
    if not path.is_dir():
        raise FileNotFoundError(f"po3d_ppl resource directory {name!r} not found (looked in {path})")
    return path

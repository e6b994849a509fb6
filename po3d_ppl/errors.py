"""Typed errors shared by every stage.

Every error a user can trigger with bad input derives from :class:`Po3dError`, so the CLI can print it as one
clear line (no traceback) and library users can catch one base class. Errors that concern a name the user typed
carry the closest known names, computed by :func:`close_matches`.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable


class Po3dError(Exception):
    """Base class of all user-facing errors."""


class InputError(Po3dError, ValueError):
    """An argument or field has an invalid value. The message names the field and how to fix it."""

    def __init__(self, field: str, message: str):
        self.field = field
        super().__init__(f"{field}: {message}")


class SceneFormatError(Po3dError, ValueError):
    """A scene file is unreadable or malformed. The message names the file and the offending field."""


class ImageError(Po3dError, ValueError):
    """An image file is missing or unreadable."""


class ModelFileError(Po3dError, OSError):
    """A model file is missing, or its checksum does not match the manifest."""


def close_matches(word: str, candidates: Iterable[str], n: int = 3) -> list[str]:
    """The known names closest to ``word`` (for 'did you mean' hints)."""
    return difflib.get_close_matches(word, list(candidates), n=n, cutoff=0.5)


class UnknownNameError(Po3dError, KeyError):
    """An unknown operation, value, word or method. ``suggestions`` holds the closest known names."""

    def __init__(self, kind: str, name: str, known: Iterable[str], hint: str = ""):
        self.kind, self.name = kind, name
        self.suggestions = close_matches(name, known)
        text = f"unknown {kind} {name!r}"
        if self.suggestions:
            text += "; did you mean " + ", ".join(repr(s) for s in self.suggestions) + "?"
        if hint:
            text += f" ({hint})"
        super().__init__(text)

    def __str__(self) -> str:  # KeyError would add quotes around the message
        return self.args[0]


class DamagedFileError(Po3dError, ValueError):
    """A file a previous run wrote is truncated or corrupt. The message names the file and how to repair it."""

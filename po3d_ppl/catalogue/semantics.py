"""Which meaning programs are run under: declared once, read by the reference executor and every inference method.

- ``intended`` (the default): what the questions say (docs/semantics.md, the po3d_ppl column);
- ``public``: what the public Super-CLEVR-3D code computes (docs/semantics.md, the public column), for scoring
  against the public answers.

A stage that honours the setting keeps its own table of the operations whose meaning differs under ``public``
(``questions/public.py`` for the reference, ``reasoning/semantics.py`` for latent worlds); this module only names
the settings, so both stages (which may not import each other) agree on them.
"""

from __future__ import annotations

from po3d_ppl.errors import InputError, UnknownNameError

INTENDED = "intended"
PUBLIC = "public"
#: The settings, default first.
SEMANTICS: tuple[str, ...] = (INTENDED, PUBLIC)
DEFAULT_SEMANTICS = INTENDED


class SemanticsError(InputError):
    """A program has no meaning under the chosen semantics (``relate[above]`` under ``public``: the public scene
    files hold no height or depth relations)."""

    def __init__(self, message: str):
        super().__init__("semantics", message)


def check_semantics(value: object) -> str:
    """``value`` if it names a semantics, else an :class:`UnknownNameError` naming the valid ones."""
    if not isinstance(value, str) or value not in SEMANTICS:
        raise UnknownNameError("semantics", str(value), SEMANTICS, hint="valid: " + ", ".join(SEMANTICS))
    return value

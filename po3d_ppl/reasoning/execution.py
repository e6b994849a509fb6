"""Running a type-checked program on a latent world (every inference method's execution step)."""

from __future__ import annotations

from functools import partial

import po3d_ppl.reasoning.operations  # noqa: F401  (attaches the built-in operations' latent-world code)
from po3d_ppl.catalogue.semantics import DEFAULT_SEMANTICS
from po3d_ppl.errors import Po3dError
from po3d_ppl.language.interpret import interpret
from po3d_ppl.reasoning.semantics import world_implementation
from po3d_ppl.reasoning.world import LatentWorld


class NotExecutableError(Po3dError):
    """A program uses an operation without a latent-world implementation."""


def run_program(typed, world: LatentWorld, semantics: str = DEFAULT_SEMANTICS):
    """Execute ``typed`` (a :class:`~po3d_ppl.language.TypedProgram`) on ``world`` under ``semantics``
    (:mod:`po3d_ppl.reasoning.semantics`); return the root's value."""

    def implementation(op):
        fn = world_implementation(op, semantics)
        if fn is None:
            raise NotExecutableError(
                f"operation {op.name}{op.signature} has no latent-world implementation (it is reference-only); "
                "attach one with po3d_ppl.catalogue.register_world"
            )
        return partial(fn, world)

    return interpret(typed, implementation).result

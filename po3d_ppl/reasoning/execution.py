"""Running a type-checked program on a latent world: the one interpreter every inference method shares."""

from __future__ import annotations

import po3d_ppl.reasoning.operations  # noqa: F401  (attaches the built-in operations' latent-world code)
from po3d_ppl.errors import Po3dError
from po3d_ppl.reasoning.world import LatentWorld


class NotExecutableError(Po3dError):
    """A program uses an operation without a latent-world implementation."""


def run_program(typed, world: LatentWorld):
    """Execute ``typed`` (a :class:`~po3d_ppl.language.TypedProgram`) node by node; return the root's value."""
    results: list = []
    for typed_node in typed.nodes:
        node, op = typed_node.node, typed_node.operation
        if op.world_fn is None:
            raise NotExecutableError(
                f"operation {op.name}{op.signature} has no latent-world implementation (it is reference-only); "
                "register one with po3d_ppl.reasoning.register_operation"
            )
        args = [results[i] for i in node.inputs]
        if node.value is not None:
            args.append(node.value)
        results.append(op.world_fn(world, *args))
    return results[-1]

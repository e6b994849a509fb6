"""The one program interpreter: run a type-checked program node by node with implementations chosen per operation.

Every executor is this loop with its own implementations: the reference executor (ground-truth semantics on a
scene), compiled execution on a latent world (every inference method), and the soft baseline's probability
propagation. Programs are post-ordered node lists (``TypedProgram.nodes``), so one pass in order suffices.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from po3d_ppl.catalogue import Operation


@dataclass(frozen=True)
class Interpretation:
    """Every node's output that was computed; ``stopped_at`` is the node that raised one of ``stop_on`` (its
    exception in ``reason``), or None when the program ran to the end."""

    outputs: tuple
    stopped_at: int | None = None
    reason: BaseException | None = None

    @property
    def result(self):
        """The root's value (None when the run stopped early)."""
        return self.outputs[-1] if self.stopped_at is None else None


def interpret(typed, implementation: Callable[[Operation], Callable],
              stop_on: type[BaseException] | tuple[type[BaseException], ...] = ()) -> Interpretation:
    """Run ``typed`` (a :class:`~po3d_ppl.language.TypedProgram`): each node calls ``implementation(op)`` with its
    input nodes' outputs and, for value operations, its literal value. ``implementation`` raises the caller's own
    error for an operation it cannot run; an exception in ``stop_on`` ends the run at that node."""
    outputs: list = []
    for index, typed_node in enumerate(typed.nodes):
        node = typed_node.node
        fn = implementation(typed_node.operation)
        args = [outputs[i] for i in node.inputs] + ([] if node.value is None else [node.value])
        try:
            outputs.append(fn(*args))
        except stop_on as reason:
            return Interpretation(tuple(outputs), index, reason)
    return Interpretation(tuple(outputs))

"""The deterministic reference executor: runs a public program on a ground-truth scene.

Programs are type-checked against the operation registry first (so an ill-formed program is an error that names
its node, never a wrong answer), then run node by node with the reference semantics of
:mod:`po3d_ppl.questions.reference`. Like the public ``answer_question`` it stops at the first invalid step and
reports which node it was.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

from po3d_ppl.catalogue.semantics import PUBLIC, check_semantics
from po3d_ppl.errors import InputError
from po3d_ppl.language import as_typed_program
from po3d_ppl.language.interpret import interpret
from po3d_ppl.questions import reference
from po3d_ppl.questions.context import SceneContext
from po3d_ppl.questions.program import to_public_output
from po3d_ppl.questions.reference import InvalidStep
from po3d_ppl.world.scene import Scene

__all__ = ["ExecutionResult", "InvalidStep", "execute", "execute_nodes", "reference"]


@dataclass(frozen=True)
class ExecutionResult:
    """Outputs of every node that ran; ``invalid_node`` is the first node without a valid result (or None)."""

    outputs: tuple
    types: tuple[str, ...]
    invalid_node: int | None = None
    reason: str | None = None

    @property
    def valid(self) -> bool:
        return self.invalid_node is None

    @property
    def answer(self):
        """The last node's value (None if the program is invalid)."""
        return self.outputs[-1] if self.valid else None

    @property
    def answer_type(self) -> str:
        return self.types[-1]

    def public_outputs(self) -> list:
        """Every node's output encoded like the public ``_output`` field."""
        return [to_public_output(v, t) for v, t in zip(self.outputs, self.types, strict=False)]


def _context(scene: Scene | SceneContext, semantics: str | None) -> SceneContext:
    if not isinstance(scene, SceneContext):
        return SceneContext(scene, semantics or "intended")
    if semantics is not None and check_semantics(semantics) != scene.semantics:
        raise InputError("semantics", f"the scene context was built for {scene.semantics!r} semantics, not "
                         f"{semantics!r}; build one with SceneContext(scene, {semantics!r})")
    return scene


def implementation_for(ctx: SceneContext):
    """``op -> its reference implementation`` under the context's semantics."""
    if ctx.semantics == PUBLIC:
        from po3d_ppl.questions.public import public_implementation

        return public_implementation
    return lambda op: op.reference_fn


def execute_nodes(ctx: SceneContext, typed) -> ExecutionResult:
    """Run an already type-checked program (a ``po3d_ppl.language.TypedProgram``) under the context's
    semantics."""
    pick = implementation_for(ctx)
    run = interpret(typed, lambda op: partial(pick(op), ctx), stop_on=InvalidStep)
    if run.stopped_at is None:
        return ExecutionResult(run.outputs, typed.types)
    node = typed.nodes[run.stopped_at].node
    return ExecutionResult(run.outputs, typed.types, run.stopped_at,
                           f"program[{run.stopped_at}] ({node.function}): {run.reason}")


def execute(scene: Scene | SceneContext, program: object, semantics: str | None = None) -> ExecutionResult:
    """Run a public program (list of nodes; ``_output`` is ignored), a ``Program`` or a ``TypedProgram`` on a
    scene, under ``semantics`` (``"intended"``, the default, or ``"public"``; a ``SceneContext`` carries its own).

    Raises the language stage's typed errors (``ProgramError`` subclasses, ``UnknownNameError``, ``InputError``)
    for an ill-formed program and ``SceneFormatError`` for a malformed scene; an invalid step is a result, not an
    error.
    """
    typed = as_typed_program(program, allow_text=False)  # public programs: a string is JSON text
    for index, typed_node in enumerate(typed.nodes):
        op = typed_node.operation
        if op.reference_fn is None:
            raise NotImplementedError(f"program[{index}]: operation {op.name}{op.signature} has no reference "
                                      "semantics (register one with register_reference)")
    return execute_nodes(_context(scene, semantics), typed)

"""The operation registry: one place that knows every program function, its types and its implementations.

Modelled on detectron2/timm registries: an operation is registered by name with a decorator, and everything else
(the grammar's vocabulary, the type checker, the reference executor, the Pyro compiler and the generated docs)
reads it from here. A researcher adds an operation by writing one decorated function in their own module::

    from po3d_ppl.reasoning import register_operation

    @register_operation("relate_above", inputs=["Object"], output="ObjectSet")
    def relate_above(world, obj):
        "Objects whose centre is higher than the given object's."
        return world.exists & (world.position[..., 2] > world.at(obj).position[..., 2] + 0.2)

An operation name may have several *overloads* that differ in input types (``unique`` on an ObjectSet gives an
Object, on a PartSet a Part); the type checker picks the overload whose inputs match.

This module imports nothing heavy (no torch, no pyro) so the language tools stay fast to start.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

from po3d_ppl.errors import Po3dError, UnknownNameError
from po3d_ppl.world import ontology

#: Types of intermediate program values (spec §2.3).
ENTITY_TYPES: tuple[str, ...] = ("ObjectSet", "Object", "PartSet", "Part", "Integer", "Bool")
#: ``Direction`` is what ``query_pose`` answers (front/back/left/right); ``Pose`` is a filter value (front_pose...).
VALUE_TYPES: tuple[str, ...] = ("Color", "Material", "Size", "Shape", "Partname", "Pose", "Relation", "Direction")
ALL_TYPES: tuple[str, ...] = ENTITY_TYPES + VALUE_TYPES


def value_vocabulary(value_type: str) -> tuple[str, ...]:
    """Allowed literal values of a value type (``Direction`` is an answer type with the four facing directions)."""
    if value_type == "Direction":
        return ontology.POSES
    try:
        return ontology.VALUE_VOCABULARY[value_type]
    except KeyError:
        raise UnknownNameError("value type", value_type, VALUE_TYPES) from None


class RegistryError(Po3dError):
    """An operation was registered inconsistently (bad type name, clashing overload)."""


@dataclass(frozen=True)
class Signature:
    """Program inputs (types of the child nodes), optional literal value input, and output type."""

    inputs: tuple[str, ...]
    output: str
    value: str | None = None

    def __str__(self) -> str:
        val = f"[{self.value}]" if self.value else ""
        return f"{val}({', '.join(self.inputs)}) -> {self.output}"


@dataclass
class Operation:
    """One overload of a program function."""

    name: str
    signature: Signature
    #: Implementation over the latent world (see ``po3d_ppl.reasoning.world``); None for reference-only ops.
    world_fn: Callable | None
    doc: str
    #: Which family the operation belongs to in the docs (core, part, pose, occlusion, or the user's module).
    family: str
    #: Implementation over a ground-truth :class:`~po3d_ppl.world.scene.Scene` (the reference executor).
    reference_fn: Callable | None = None
    #: Structural operations (aggregations over objects or parts, pivots) are implemented by each inference
    #: engine rather than by ``world_fn``.
    structural: bool = False
    module: str = ""

    @property
    def inputs(self) -> tuple[str, ...]:
        return self.signature.inputs

    @property
    def output(self) -> str:
        return self.signature.output

    @property
    def value(self) -> str | None:
        return self.signature.value


@dataclass
class OperationRegistry:
    _ops: dict[str, list[Operation]] = field(default_factory=dict)

    def register(self, op: Operation, replace: bool = False) -> Operation:
        for t in (*op.signature.inputs, op.signature.output):
            if t not in ALL_TYPES:
                raise RegistryError(f"operation {op.name!r}: unknown type {t!r} (known: {', '.join(ALL_TYPES)})")
        if op.signature.value is not None and op.signature.value not in VALUE_TYPES:
            raise RegistryError(f"operation {op.name!r}: unknown value type {op.signature.value!r}")
        if not op.name.isidentifier():
            raise RegistryError(f"operation name {op.name!r} must be an identifier")
        overloads = self._ops.setdefault(op.name, [])
        for i, other in enumerate(overloads):
            if other.signature.inputs == op.signature.inputs:
                if not replace:
                    raise RegistryError(
                        f"operation {op.name}{other.signature} is already registered (from {other.module}); "
                        "pass replace=True to override it"
                    )
                overloads[i] = op
                return op
        overloads.append(op)
        return op

    def names(self) -> list[str]:
        return sorted(self._ops)

    def __contains__(self, name: str) -> bool:
        return name in self._ops

    def __iter__(self) -> Iterator[Operation]:
        for name in sorted(self._ops):
            yield from self._ops[name]

    def overloads(self, name: str) -> list[Operation]:
        try:
            return list(self._ops[name])
        except KeyError:
            raise UnknownNameError("operation", name, self._ops) from None

    def resolve(self, name: str, input_types: tuple[str, ...]) -> Operation | None:
        """The overload of ``name`` whose inputs equal ``input_types`` (None if no overload accepts them)."""
        for op in self.overloads(name):
            if op.signature.inputs == tuple(input_types):
                return op
        return None

    def unregister(self, name: str) -> None:
        self._ops.pop(name, None)


#: The process-wide registry used by the grammar, the executors and the compiler.
REGISTRY = OperationRegistry()


def register_operation(
    name: str,
    *,
    inputs: list[str] | tuple[str, ...],
    output: str,
    value: str | None = None,
    family: str | None = None,
    structural: bool = False,
    replace: bool = False,
    registry: OperationRegistry | None = None,
) -> Callable[[Callable], Callable]:
    """Decorator: register ``fn(world, *inputs[, value])`` as (an overload of) operation ``name``.

    The docstring of ``fn`` becomes the operation's documentation.
    """

    def decorate(fn: Callable) -> Callable:
        module = getattr(fn, "__module__", "") or ""
        fam = family or (module.rsplit(".", 1)[-1] if module.startswith("po3d_ppl.") else module)
        op = Operation(
            name=name,
            signature=Signature(tuple(inputs), output, value),
            world_fn=fn,
            doc=inspect.cleandoc(fn.__doc__ or ""),
            family=fam,
            structural=structural,
            module=module,
        )
        (registry or REGISTRY).register(op, replace=replace)
        return fn

    return decorate


def register_reference(name: str, inputs: tuple[str, ...] | list[str] | None = None,
                       registry: OperationRegistry | None = None) -> Callable[[Callable], Callable]:
    """Decorator: attach a ground-truth implementation ``fn(scene_context, *inputs[, value])`` to ``name``.

    ``inputs`` selects one overload; by default the implementation serves every overload of the name.
    """

    def decorate(fn: Callable) -> Callable:
        reg = registry or REGISTRY
        for op in reg.overloads(name):
            if inputs is None or op.signature.inputs == tuple(inputs):
                op.reference_fn = fn
        return fn

    return decorate

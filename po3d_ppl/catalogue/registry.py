"""The operation catalogue: every program function's name, signature, documentation and implementations.

Modelled on detectron2/timm registries. An operation is *declared* once here (name, input types, optional literal
value type, output type, docs); each stage then *attaches* the implementation it owns by name:

- the reasoning stage attaches ``world_fn(world, *inputs[, value])``, tensor code over a latent world
  (:func:`register_world`, in ``po3d_ppl.reasoning.operations``);
- the question stage attaches ``reference_fn(scene_context, *inputs[, value])``, ground-truth semantics
  (:func:`register_reference`, in ``po3d_ppl.questions.reference``).

So the grammar's vocabulary, the type checker and the question generator read the catalogue without importing
torch, and no stage has to import another to learn what an operation is. A researcher adds an operation with one
decorator that declares it and attaches its latent-world implementation together::

    from po3d_ppl.catalogue import register_operation

    @register_operation("relate_above", inputs=["Object"], output="ObjectSet")
    def relate_above(world, obj):
        "Objects whose centre is higher than the given object's."
        return world.exists & (world.positions[..., 2] > world.at(obj).position[..., 2] + 0.2)

An operation name may have several *overloads* that differ in input types (``unique`` on an ObjectSet gives an
Object, on a PartSet a Part); the type checker picks the overload whose inputs match.

This module imports nothing heavy (no torch, no pyro).
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field

from po3d_ppl import ontology
from po3d_ppl.errors import Po3dError, UnknownNameError

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
    """An operation was declared or implemented inconsistently (bad type name, clashing overload, no such
    operation)."""


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
    """One overload of a program function: its declaration and the implementations attached to it."""

    name: str
    signature: Signature
    doc: str
    #: Which family the operation belongs to in the docs (core, parts, pose, occlusion, or the user's module).
    family: str
    #: Where it was declared (named in clash errors).
    module: str = ""
    #: Implementation over a latent world (``po3d_ppl.reasoning.world``); None until the reasoning stage loads.
    world_fn: Callable | None = None
    #: Implementation over a ground-truth scene (the reference executor); None until the question stage loads.
    reference_fn: Callable | None = None

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


#: The process-wide catalogue used by the grammar, the executors and the compiler.
REGISTRY = OperationRegistry()


def declare(name: str, inputs: Sequence[str], output: str, doc: str, *, value: str | None = None,
            family: str, module: str = "po3d_ppl.catalogue.builtin", replace: bool = False,
            registry: OperationRegistry | None = None) -> Operation:
    """Declare (an overload of) operation ``name``; implementations are attached later by name."""
    op = Operation(name, Signature(tuple(inputs), output, value), inspect.cleandoc(doc), family, module)
    return (registry or REGISTRY).register(op, replace=replace)


def _attach(kind: str, name: str, inputs: Sequence[str] | None, registry: OperationRegistry | None):
    def decorate(fn: Callable) -> Callable:
        matched = [op for op in (registry or REGISTRY).overloads(name)
                   if inputs is None or op.signature.inputs == tuple(inputs)]
        if not matched:
            raise RegistryError(f"operation {name!r} has no overload with inputs {list(inputs or ())}")
        for op in matched:
            setattr(op, kind, fn)
        return fn

    return decorate


def register_world(name: str, inputs: Sequence[str] | None = None,
                   registry: OperationRegistry | None = None) -> Callable[[Callable], Callable]:
    """Decorator: attach a latent-world implementation ``fn(world, *inputs[, value])`` to a declared operation.

    ``inputs`` selects one overload; by default the implementation serves every overload of the name.
    """
    return _attach("world_fn", name, inputs, registry)


def register_reference(name: str, inputs: Sequence[str] | None = None,
                       registry: OperationRegistry | None = None) -> Callable[[Callable], Callable]:
    """Decorator: attach a ground-truth implementation ``fn(scene_context, *inputs[, value])`` to ``name``.

    ``inputs`` selects one overload; by default the implementation serves every overload of the name.
    """
    return _attach("reference_fn", name, inputs, registry)


def register_operation(name: str, *, inputs: Sequence[str], output: str, value: str | None = None,
                       family: str | None = None, replace: bool = False,
                       registry: OperationRegistry | None = None) -> Callable[[Callable], Callable]:
    """Decorator: declare operation ``name`` and attach ``fn(world, *inputs[, value])`` as its latent-world
    implementation, in one step (the way to add an operation from user code).

    The docstring of ``fn`` becomes the operation's documentation; ``family`` defaults to ``fn``'s module.
    """

    def decorate(fn: Callable) -> Callable:
        module = getattr(fn, "__module__", "") or ""
        op = declare(name, inputs, output, fn.__doc__ or "", value=value, family=family or module, module=module,
                     replace=replace, registry=registry)
        op.world_fn = fn
        return fn

    return decorate

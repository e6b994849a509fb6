"""Type checking: resolve every node to a registry overload and its output type.

The registry's signatures are the type system: entity types (ObjectSet, Object, PartSet, Part, Integer, Bool)
flow between nodes, value types (Color, Shape, Pose, ...) type the bracketed literals and the answers. Checking is
a single pass in node order because inputs always precede their consumers.
"""

from __future__ import annotations

from dataclasses import dataclass

from po3d_ppl.catalogue import REGISTRY, Operation, OperationRegistry, value_vocabulary
from po3d_ppl.language.ast import Node, Program
from po3d_ppl.language.errors import (
    ProgramArityError,
    ProgramTypeError,
    ProgramValueError,
    UnknownProgramNameError,
)


def default_registry() -> OperationRegistry:
    """The process-wide catalogue (the built-in operations are declared when ``po3d_ppl.catalogue`` loads)."""
    return REGISTRY


@dataclass(frozen=True, eq=False)
class TypedNode:
    """A node with the overload that executes it and the type of its output."""

    node: Node
    operation: Operation
    type: str


@dataclass(frozen=True, eq=False)
class TypedProgram:
    """A checked program: ``nodes[i]`` types ``program[i]``; ``type`` is the type of the result."""

    program: Program
    nodes: tuple[TypedNode, ...]

    @property
    def type(self) -> str:
        return self.nodes[-1].type

    @property
    def types(self) -> tuple[str, ...]:
        return tuple(n.type for n in self.nodes)

    @property
    def operations(self) -> tuple[Operation, ...]:
        return tuple(n.operation for n in self.nodes)


def check_node(node: Node, input_types: tuple[str, ...], registry: OperationRegistry, *, index: int | None = None,
               source: str | None = None) -> Operation:
    """The overload of ``node.function`` that accepts ``input_types`` and ``node.value``, or a typed error."""
    where = {"span": node.span, "source": source, "node": index}
    if node.function not in registry:
        raise UnknownProgramNameError("operation", node.function, registry.names(), width=len(node.function),
                                      **where)
    overloads = registry.overloads(node.function)
    candidates = [op for op in overloads if len(op.inputs) == len(input_types)]
    if not candidates:
        raise ProgramArityError(node.function, (len(op.inputs) for op in overloads), len(input_types), **where)
    for position, actual in enumerate(input_types):
        fitting = [op for op in candidates if op.inputs[position] == actual]
        if not fitting:
            raise ProgramTypeError(node.function, position, (op.inputs[position] for op in candidates), actual,
                                   **where)
        candidates = fitting
    operation = candidates[0]
    value_type = operation.value
    if value_type is None:
        if node.value is not None:
            raise ProgramValueError(node.function, None, node.value, **where)
    else:
        vocabulary = value_vocabulary(value_type)
        if node.value is None:
            raise ProgramValueError(node.function, value_type, None, example=vocabulary[0], **where)
        if node.value not in vocabulary:
            raise UnknownProgramNameError(f"{value_type} value", node.value, vocabulary,
                                          hint=f"input of {node.function}",
                                          width=len(node.function) + len(node.value) + 2, **where)
    return operation


def check_program(program: Program, registry: OperationRegistry | None = None) -> TypedProgram:
    """Type-check ``program`` against ``registry`` (default: the built-in operations).

    Raises :class:`UnknownProgramNameError` (operation or value), :class:`ProgramArityError`,
    :class:`ProgramValueError` or :class:`ProgramTypeError`, each with the node's position.
    """
    registry = registry if registry is not None else default_registry()
    typed: list[TypedNode] = []
    for index, node in enumerate(program):
        input_types = tuple(typed[i].type for i in node.inputs)
        operation = check_node(node, input_types, registry, index=index, source=program.source)
        typed.append(TypedNode(node, operation, operation.output))
    return TypedProgram(program, tuple(typed))

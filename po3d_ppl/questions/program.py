"""Public program lists (spec §2.1): parsing, static type checking and the ``_output`` encoding.

A program is a list of nodes ``{"type" | "function": name, "inputs": [earlier node indices],
"value_inputs" | "side_inputs": [literals], "_output": cached result}``. Parsing validates the structure once,
so that the executor and the generator can run on plain tuples; :func:`check_program` resolves every node to an
overload of the operation registry, which is also what decides the run-time type of each intermediate value.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import po3d_ppl.reasoning.operations  # noqa: F401  (populates REGISTRY)
from po3d_ppl.errors import InputError, UnknownNameError
from po3d_ppl.reasoning.registry import REGISTRY, Operation, value_vocabulary


class ProgramError(InputError):
    """A program node is malformed: unknown function, bad reference, wrong arity, wrong input types."""


@dataclass(frozen=True)
class ProgramNode:
    """One node of a program, with the public key spellings normalised."""

    function: str
    inputs: tuple[int, ...] = ()
    value_inputs: tuple[str, ...] = ()

    def to_public(self) -> dict:
        return {"type": self.function, "inputs": list(self.inputs), "value_inputs": list(self.value_inputs)}


def _field(index: int, function: str | None = None) -> str:
    return f"program[{index}]" + (f" ({function})" if function else "")


def parse_node(raw: object, index: int) -> ProgramNode:
    """Validate the shape of one public node (not its meaning)."""
    if isinstance(raw, ProgramNode):
        return raw
    if not isinstance(raw, Mapping):
        raise ProgramError(_field(index), f"a node must be a JSON object, got {type(raw).__name__}")
    function = raw.get("type", raw.get("function"))
    if not isinstance(function, str) or not function:
        raise ProgramError(_field(index), "a node needs a 'type' (or 'function') string naming its operation")
    inputs = raw.get("inputs", [])
    if not isinstance(inputs, Sequence) or isinstance(inputs, str) or not all(
        isinstance(i, int) and not isinstance(i, bool) for i in inputs
    ):
        raise ProgramError(_field(index, function), f"'inputs' must be a list of node indices, got {inputs!r}")
    values = raw.get("value_inputs", raw.get("side_inputs", []))
    if not isinstance(values, Sequence) or isinstance(values, str) or not all(isinstance(v, str) for v in values):
        raise ProgramError(_field(index, function), f"'value_inputs' must be a list of strings, got {values!r}")
    for i in inputs:
        if not 0 <= i < index:
            raise ProgramError(
                _field(index, function),
                f"input {i} does not name an earlier node (a node may only use nodes 0..{index - 1})",
            )
    return ProgramNode(function, tuple(inputs), tuple(values))


def parse_program(program: object) -> list[ProgramNode]:
    """Parse a public program list into nodes (structure only)."""
    if isinstance(program, Mapping) and "program" in program:
        program = program["program"]
    if not isinstance(program, Sequence) or isinstance(program, str):
        raise ProgramError("program", f"expected a list of nodes, got {type(program).__name__}")
    if not program:
        raise ProgramError("program", "the program is empty")
    return [parse_node(raw, i) for i, raw in enumerate(program)]


def resolve_node(node: ProgramNode, index: int, input_types: tuple[str, ...]) -> Operation:
    """The registry overload that ``node`` denotes given its input types, with a typed error otherwise."""
    if node.function not in REGISTRY:
        raise UnknownNameError(f"operation in {_field(index)}", node.function, REGISTRY.names())
    overloads = REGISTRY.overloads(node.function)
    arities = sorted({len(op.inputs) for op in overloads})
    if len(node.inputs) not in arities:
        raise ProgramError(
            _field(index, node.function),
            f"takes {' or '.join(map(str, arities))} input(s), got {len(node.inputs)}",
        )
    op = REGISTRY.resolve(node.function, input_types)
    if op is None:
        accepted = "; ".join(f"({', '.join(o.inputs)})" for o in overloads)
        raise ProgramError(
            _field(index, node.function), f"accepts {accepted}, but its inputs are ({', '.join(input_types)})"
        )
    wanted = 1 if op.value else 0
    if len(node.value_inputs) != wanted:
        what = f"one {op.value} value" if op.value else "no value input"
        raise ProgramError(_field(index, node.function), f"takes {what}, got {list(node.value_inputs)}")
    if op.value:
        vocab = value_vocabulary(op.value)
        if node.value_inputs[0] not in vocab:
            raise UnknownNameError(f"{op.value} value in {_field(index, node.function)}", node.value_inputs[0], vocab)
    return op


def check_program(nodes: Sequence[ProgramNode]) -> list[Operation]:
    """Resolve every node to its overload; node i's output type is ``ops[i].output``."""
    ops: list[Operation] = []
    for index, node in enumerate(nodes):
        input_types = tuple(ops[i].output for i in node.inputs)
        ops.append(resolve_node(node, index, input_types))
    return ops


def part_key(part: tuple[int, int]) -> str:
    """Public part id ``"<obj>_<part>"``."""
    return f"{part[0]}_{part[1]}"


def to_public_output(value: object, value_type: str) -> object:
    """Encode a value the way public ``_output`` fields hold it (sorted lists, ``"i_p"`` part ids)."""
    if value_type == "ObjectSet":
        return sorted(value)
    if value_type == "PartSet":
        return [part_key(p) for p in sorted(value)]
    if value_type == "Part":
        return part_key(value)
    return value

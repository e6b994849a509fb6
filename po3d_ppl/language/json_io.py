"""Public JSON programs (spec §2.1) <-> :class:`~po3d_ppl.language.ast.Program`.

Reading accepts both public spellings: the operation under ``type`` (emitted programs) or ``function``, the value
under ``value_inputs`` (emitted) or ``side_inputs`` (templates), and ignores ``_output`` (a cached execution
result). Writing uses the emitted-program spelling (``type``, ``inputs``, ``value_inputs``), so our files read in
the public tools. Node order and sharing are kept as they are: the round trip is exact.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from typing import Any

from po3d_ppl.errors import InputError
from po3d_ppl.language.ast import Node, Program


def _node_from_json(index: int, raw: Any, where: str) -> Node:
    field = f"{where}[{index}]"
    if not isinstance(raw, Mapping):
        raise InputError(field, f"a program node must be an object with 'type' and 'inputs', got {raw!r}")
    function = raw.get("type", raw.get("function"))
    if not isinstance(function, str) or not function:
        raise InputError(field, "needs the operation name under 'type' (or 'function')")
    inputs = raw.get("inputs", [])
    if not isinstance(inputs, Sequence) or isinstance(inputs, str) or not all(
            isinstance(i, int) and not isinstance(i, bool) for i in inputs):
        raise InputError(f"{field}.inputs", f"must be a list of node indices, got {inputs!r}")
    values = raw.get("value_inputs", raw.get("side_inputs", []))
    if values is None:
        values = []
    if isinstance(values, str) or not isinstance(values, Sequence) or not all(isinstance(v, str) for v in values):
        raise InputError(f"{field}.value_inputs", f"must be a list of strings, got {values!r}")
    if len(values) > 1:
        raise InputError(f"{field}.value_inputs", f"an operation takes at most one value, got {list(values)!r}")
    return Node(function, tuple(inputs), values[0] if values else None)


def program_from_json(data: Sequence[Mapping] | Mapping | str, where: str = "program") -> Program:
    """A :class:`Program` from a public node list, a question record holding one under ``program``, or their
    JSON text. ``where`` names the source in error messages."""
    if isinstance(data, str):
        try:
            data = json.loads(data)
        except json.JSONDecodeError as exc:
            raise InputError(where, f"not valid JSON ({exc})") from None
    if isinstance(data, Mapping):
        if "program" not in data:
            raise InputError(where, "expected a list of program nodes or an object with a 'program' list")
        data, where = data["program"], f"{where}.program"
    if isinstance(data, str) or not isinstance(data, Sequence):
        raise InputError(where, f"expected a list of program nodes, got {type(data).__name__}")
    if not data:
        raise InputError(where, "the program is empty")
    return Program(tuple(_node_from_json(i, raw, where) for i, raw in enumerate(data)))


def program_to_json(program: Program) -> list[dict[str, Any]]:
    """The public emitted-program node list: ``[{"type", "inputs", "value_inputs"}, ...]``."""
    return [
        {"type": node.function, "inputs": list(node.inputs),
         "value_inputs": [] if node.value is None else [node.value]}
        for node in program
    ]

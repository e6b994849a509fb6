"""Program -> text, such that parsing the text gives back the identical node list.

Nodes read by more than one consumer are printed as bindings (``n3 = ...``, named after their node index so the
text can be matched against the JSON). The parser numbers nodes in post-order; when a program's order differs
(possible for programs loaded from JSON), more nodes are bound, in index order, until re-parsing reproduces the
numbering exactly. So ``parse_program(program_to_text(p)) == p`` for every valid program.
"""

from __future__ import annotations

import json
import re
from typing import Literal

from po3d_ppl.language.ast import Program

_BARE_VALUE = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_\-]*")


def format_value(value: str | None) -> str:
    """``[red]``, or ``["two words"]`` when the value is not a bare word; empty for no value."""
    if value is None:
        return ""
    text = value if _BARE_VALUE.fullmatch(value) else json.dumps(value, ensure_ascii=False)
    return f"[{text}]"


def binding_name(index: int) -> str:
    return f"n{index}"


def _bound_nodes(program: Program) -> set[int]:
    """Nodes that must be printed as bindings for the parser to reproduce the node numbering."""
    bound = {i for i, c in enumerate(program.consumers) if len(c) > 1} | {program.root}
    while True:
        order: list[int] = []
        for b in sorted(bound):
            _inline_postorder(program, b, bound, order)
        mismatch = next((k for k, i in enumerate(order) if i != k), None)
        if mismatch is None:
            return bound
        bound.add(mismatch)


def _inline_postorder(program: Program, top: int, bound: set[int], out: list[int]) -> None:
    stack: list[tuple[int, bool]] = [(top, False)]
    while stack:
        i, expanded = stack.pop()
        if expanded:
            out.append(i)
            continue
        stack.append((i, True))
        for j in reversed(program[i].inputs):
            if j not in bound:
                stack.append((j, False))


def program_to_text(program: Program, style: Literal["nested", "pipeline"] = "nested") -> str:
    """Text form of ``program``: nested calls (``query_shape(unique(scene()))``) or pipelines
    (``scene() | unique | query_shape``). Shared sub-programs become bindings on their own lines."""
    if style not in ("nested", "pipeline"):
        from po3d_ppl.errors import InputError

        raise InputError("style", f"unknown style {style!r}; use 'nested' or 'pipeline'")
    bound = _bound_nodes(program)

    def render(i: int, top: bool) -> str:
        if i in bound and not top:
            return binding_name(i)
        node = program[i]
        head = node.function + format_value(node.value)
        if style == "pipeline" and node.inputs:
            first, *rest = node.inputs
            args = f"({', '.join(render(j, False) for j in rest)})" if rest else ""
            return f"{render(first, False)} | {head}{args}"
        return f"{head}({', '.join(render(j, False) for j in node.inputs)})"

    lines = [f"{binding_name(b)} = {render(b, True)}" for b in sorted(bound) if b != program.root]
    lines.append(render(program.root, True))
    return "\n".join(lines)

"""Text -> :class:`~po3d_ppl.language.ast.Program`: the lark grammar plus a Transformer that builds the node list.

The grammar (``grammar/program.lark``) is parsed with lark's LALR parser (linear time, good error positions).
The Transformer runs bottom-up, left to right, so appending a node as each call is reduced yields post-order
node numbering; a binding records its node index and every later reference reuses it, which is how the text
expresses DAGs.
"""

from __future__ import annotations

import json
from functools import cache

import lark
from lark import Transformer, v_args

from po3d_ppl.catalogue import OperationRegistry
from po3d_ppl.language.ast import Node, Program, Span
from po3d_ppl.language.errors import ProgramStructureError, ProgramSyntaxError, UnknownProgramNameError
from po3d_ppl.resources import resource_dir

#: How terminals are described in "expected ..." messages.
_TERMINAL_WORDS = {
    "NAME": "a name",
    "VALUE_WORD": "a value",
    "ESCAPED_STRING": "a quoted value",
    "$END": "end of program",
}


@cache
def grammar_text() -> str:
    """The text of ``grammar/program.lark`` (the syntax specification)."""
    return (resource_dir("grammar") / "program.lark").read_text()


@cache
def _lark() -> lark.Lark:
    return lark.Lark(grammar_text(), parser="lalr", propagate_positions=True, maybe_placeholders=False)


def _describe(terminal: str) -> str:
    if terminal in _TERMINAL_WORDS:
        return _TERMINAL_WORDS[terminal]
    try:
        pattern = _lark().get_terminal(terminal).pattern
    except KeyError:
        return terminal
    return repr(pattern.value) if pattern.type == "str" else terminal


def _span(where) -> Span | None:
    """The span of a lark ``Meta`` (None when it covers nothing) or ``Token``."""
    if getattr(where, "empty", False):
        return None
    return Span(where.line, where.column, where.end_line, where.end_column, where.start_pos, where.end_pos)


class _ProgramBuilder(Transformer):
    """Builds the node list while lark reduces the tree; each expression becomes the index of its node."""

    def __init__(self, source: str, registry: OperationRegistry | None):
        super().__init__()
        self.source, self.registry = source, registry
        self.nodes: list[Node] = []
        self.bindings: dict[str, int] = {}

    def _add(self, name_token, value: str | None, inputs: list[int], span: Span | None) -> int:
        name = str(name_token)
        if self.registry is not None and name not in self.registry:
            raise UnknownProgramNameError("operation", name, self.registry.names(), _span(name_token), self.source,
                                          len(self.nodes))
        self.nodes.append(Node(name, tuple(inputs), value, span))
        return len(self.nodes) - 1

    @staticmethod
    def _parts(children: list) -> tuple[object, str | None, list[int]]:
        name, value, inputs = children[0], None, []
        for child in children[1:]:
            if isinstance(child, tuple) and child[0] == "value":
                value = child[1]
            elif isinstance(child, list):
                inputs = child
        return name, value, inputs

    @v_args(meta=True)
    def call(self, meta, children) -> int:
        name, value, inputs = self._parts(children)
        return self._add(name, value, inputs, _span(meta))

    @v_args(meta=True)
    def stage(self, meta, children) -> tuple:
        return ("stage", *self._parts(children), _span(meta))

    def pipe(self, children) -> int:
        first, (_, name, value, inputs, span) = children
        return self._add(name, value, [first, *inputs], span)

    def arguments(self, children) -> list[int]:
        return list(children)

    def value(self, children) -> tuple[str, str]:
        (token,) = children
        text = str(token)
        if token.type != "ESCAPED_STRING":
            return ("value", text)
        try:
            return ("value", json.loads(text))
        except json.JSONDecodeError as exc:
            raise ProgramSyntaxError(f"bad quoted value {text} ({exc.msg})", token.line, token.column + exc.pos,
                                     ("a JSON string escape such as \\\" or \\n",), self.source) from None

    def reference(self, children) -> int:
        (token,) = children
        try:
            return self.bindings[str(token)]
        except KeyError:
            hint = "bindings must be defined before use" if self.bindings else (
                "define it with `name = expression` first, or call an operation with parentheses")
            raise UnknownProgramNameError("binding", str(token), self.bindings, _span(token), self.source,
                                          hint=hint) from None

    def binding(self, children) -> None:
        token, index = children
        if str(token) in self.bindings:
            raise ProgramStructureError(f"{token} is already bound; choose another name", _span(token), self.source)
        self.bindings[str(token)] = index

    def start(self, children) -> int:
        return children[-1]


def parse_program(text: str, registry: OperationRegistry | None = None) -> Program:
    """Parse program text (``grammar/program.lark`` syntax) into a :class:`Program`.

    Checks syntax, bindings and that every operation name is registered (``registry`` defaults to the built-in
    registry). Arity, types and values are checked by :func:`~po3d_ppl.language.typecheck.check_program`.
    """
    from po3d_ppl.language.typecheck import default_registry

    if not isinstance(text, str):
        raise ProgramStructureError(f"program text must be a string, got {type(text).__name__}")
    registry = registry if registry is not None else default_registry()
    try:
        tree = _lark().parse(text)
    except lark.exceptions.UnexpectedCharacters as exc:
        found = text[exc.pos_in_stream] if exc.pos_in_stream < len(text) else ""
        raise ProgramSyntaxError(f"unexpected character {found!r}", exc.line, exc.column,
                                 map(_describe, exc.allowed or ()), text) from None
    except lark.exceptions.UnexpectedEOF as exc:
        line, column = _end_position(text)
        raise ProgramSyntaxError("unexpected end of program", line, column, map(_describe, exc.expected),
                                 text) from None
    except lark.exceptions.UnexpectedToken as exc:
        if exc.token.type == "$END":
            line, column = _end_position(text)
            message = "unexpected end of program"
        else:
            line, column = exc.line, exc.column
            message = f"unexpected {str(exc.token)!r}"
        raise ProgramSyntaxError(message, line, column, map(_describe, exc.expected), text) from None
    builder = _ProgramBuilder(text, registry)
    try:
        root = builder.transform(tree)
    except lark.exceptions.VisitError as exc:
        raise exc.orig_exc from None
    except RecursionError:
        raise ProgramStructureError("the program nests too deeply; name inner sub-programs with bindings") from None
    nodes = builder.nodes
    if root != len(nodes) - 1:
        # The result is a reference to a binding that later bindings follow: those are unused.
        unused = nodes[root + 1]
        raise ProgramStructureError(f"{unused.function}(...) is not used by the result (the last expression)",
                                    unused.span, text, root + 1)
    return Program(tuple(nodes), text)


def _end_position(text: str) -> tuple[int, int]:
    lines = text.split("\n")
    return len(lines), len(lines[-1]) + 1

"""Errors about programs: where in the text (or which node) the problem is, and what would fix it.

Every error carries the node's :class:`~po3d_ppl.language.ast.Span` when the program came from text, and shows the
offending source line with a caret underneath; programs loaded from JSON have no text, so messages name the node
index instead.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

from po3d_ppl.errors import Po3dError, UnknownNameError

if TYPE_CHECKING:
    from po3d_ppl.language.ast import Span


def caret_snippet(source: str, line: int, column: int, width: int = 1) -> str:
    """The source line ``line`` (1-based) with ``^`` under columns ``column .. column+width-1``."""
    lines = source.splitlines() or [""]
    text = lines[line - 1] if 0 < line <= len(lines) else ""
    width = max(1, min(width, len(text) - column + 1)) if text else 1
    return f"  {text}\n  {' ' * (column - 1)}{'^' * width}"


def locate(span: Span | None, source: str | None, node: int | None = None, width: int | None = None) -> str:
    """Human-readable location suffix: ``" at line 2, column 5:\\n  <line>\\n      ^^^"`` or ``" (node 3)"``.

    The caret underlines ``width`` characters (default: the span's first line).
    """
    where = ""
    if span is not None:
        where = f" at line {span.line}, column {span.column}"
        if node is not None:
            where += f" (node {node})"
        if source is not None:
            if width is None:
                width = span.end_column - span.column if span.end_line == span.line else 1
            where += ":\n" + caret_snippet(source, span.line, span.column, width)
    elif node is not None:
        where = f" (node {node})"
    return where


class ProgramError(Po3dError, ValueError):
    """Base class of program errors; ``span`` and ``node`` say where the problem is (either may be None)."""

    def __init__(self, message: str, span: Span | None = None, source: str | None = None, node: int | None = None,
                 width: int | None = None):
        self.span, self.node, self.reason = span, node, message
        super().__init__(message + locate(span, source, node, width))


class ProgramSyntaxError(ProgramError):
    """The text does not follow ``grammar/program.lark``. ``expected`` lists readable descriptions of what fits."""

    def __init__(self, message: str, line: int, column: int, expected: Iterable[str], source: str):
        self.line, self.column = line, column
        self.expected = tuple(sorted(set(expected)))
        text = message
        if self.expected:
            text += "; expected " + ", ".join(self.expected)
        self.span, self.node, self.reason = None, None, text
        Po3dError.__init__(self, f"{text} at line {line}, column {column}:\n{caret_snippet(source, line, column)}")


class ProgramStructureError(ProgramError):
    """The node list is not a well-formed DAG (bad input index, unused node, reused or undefined binding...)."""


class ProgramArityError(ProgramError):
    """An operation got the wrong number of inputs."""

    def __init__(self, operation: str, expected: Iterable[int], actual: int, span: Span | None = None,
                 source: str | None = None, node: int | None = None):
        self.operation, self.expected, self.actual = operation, tuple(sorted(set(expected))), actual
        want = " or ".join(str(n) for n in self.expected)
        super().__init__(f"{operation} takes {want} input(s), got {actual}", span, source, node, len(operation))


class ProgramValueError(ProgramError):
    """An operation that needs a value input has none, or one that takes none has one."""

    def __init__(self, operation: str, expected: str | None, actual: str | None, span: Span | None = None,
                 source: str | None = None, node: int | None = None, example: str | None = None):
        self.operation, self.expected, self.actual = operation, expected, actual
        if expected is None:
            message = f"{operation} takes no value input, got [{actual}]; write {operation}(...) without brackets"
        else:
            message = f"{operation} needs a {expected} value in brackets, e.g. {operation}[{example or '...'}](...)"
        super().__init__(message, span, source, node, len(operation))


_ORDINALS = ("first", "second", "third", "fourth", "fifth")


def ordinal(index: int) -> str:
    """'first' for 0, 'second' for 1 ... (argument positions in messages are words, to avoid 0/1-based doubt)."""
    return _ORDINALS[index] if index < len(_ORDINALS) else f"#{index + 1}"


class ProgramTypeError(ProgramError, TypeError):
    """An input of an operation has the wrong type. ``argument`` is the 0-based input position."""

    def __init__(self, operation: str, argument: int, expected: Iterable[str], actual: str,
                 span: Span | None = None, source: str | None = None, node: int | None = None):
        self.operation, self.argument, self.actual = operation, argument, actual
        self.expected = tuple(sorted(set(expected)))
        message = (f"{operation}: the {ordinal(argument)} input must be {' or '.join(self.expected)}, "
                   f"but it is {actual}")
        super().__init__(message, span, source, node, len(operation))


class UnknownProgramNameError(UnknownNameError, ProgramError):
    """An unknown operation, value or binding name in a program, with the closest known names and the position."""

    def __init__(self, kind: str, name: str, known: Iterable[str], span: Span | None = None,
                 source: str | None = None, node: int | None = None, hint: str = "", width: int | None = None):
        UnknownNameError.__init__(self, kind, name, known, hint)
        self.span, self.node, self.reason = span, node, self.args[0]
        self.args = (self.args[0] + locate(span, source, node, width),)

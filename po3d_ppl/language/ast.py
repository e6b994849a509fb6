"""The typed program AST: a topologically ordered node list, exactly the shape of the public JSON programs.

A :class:`Program` is a tuple of :class:`Node` records. A node's ``inputs`` are indices of *earlier* nodes and
the last node is the result, so a sub-program used twice is one node with two consumers (a DAG) and JSON round
trips are lossless. Spans (where a node came from in the text) never take part in equality.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from functools import cached_property

from po3d_ppl.language.errors import ProgramStructureError


@dataclass(frozen=True)
class Span:
    """Where a node was written: 1-based line/column of its first and one-past-last character, and offsets."""

    line: int
    column: int
    end_line: int
    end_column: int
    start: int
    end: int

    def __str__(self) -> str:
        return f"line {self.line}, column {self.column}"


@dataclass(frozen=True)
class Node:
    """One operation application: ``function[value](inputs...)``; ``inputs`` index earlier nodes."""

    function: str
    inputs: tuple[int, ...] = ()
    value: str | None = None
    span: Span | None = field(default=None, compare=False)

    def __str__(self) -> str:
        value = f"[{self.value}]" if self.value is not None else ""
        return f"{self.function}{value}({', '.join(f'#{i}' for i in self.inputs)})"


@dataclass(frozen=True)
class Program:
    """A program: nodes in topological order, the last one being the result; every node feeds the result.

    Behaves as a read-only sequence of nodes. ``source`` keeps the text the program was parsed from (for error
    snippets); it does not take part in equality.
    """

    nodes: tuple[Node, ...]
    source: str | None = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "nodes", tuple(self.nodes))
        if not self.nodes:
            raise ProgramStructureError("a program needs at least one node")
        for index, node in enumerate(self.nodes):
            if not isinstance(node, Node):
                raise ProgramStructureError(f"node {index} is a {type(node).__name__}, not a Node")
            for i in node.inputs:
                if not isinstance(i, int) or isinstance(i, bool) or not 0 <= i < index:
                    raise ProgramStructureError(
                        f"{node.function}: input {i!r} must be the index of an earlier node (0..{index - 1})",
                        node.span, self.source, index)
        unused = sorted(set(range(len(self.nodes))) - self.ancestors(len(self.nodes) - 1))
        if unused:
            node = self.nodes[unused[0]]
            raise ProgramStructureError(
                f"{node.function}(...) is not used by the result (the last node); remove it or use it",
                node.span, self.source, unused[0])

    def __len__(self) -> int:
        return len(self.nodes)

    def __iter__(self) -> Iterator[Node]:
        return iter(self.nodes)

    def __getitem__(self, index: int) -> Node:
        return self.nodes[index]

    @property
    def root(self) -> int:
        """Index of the result node (always the last)."""
        return len(self.nodes) - 1

    def ancestors(self, index: int) -> set[int]:
        """``index`` and every node it (transitively) reads."""
        seen, todo = set(), [index]
        while todo:
            i = todo.pop()
            if i not in seen:
                seen.add(i)
                todo.extend(self.nodes[i].inputs)
        return seen

    @cached_property
    def consumers(self) -> tuple[tuple[int, ...], ...]:
        """For each node, the nodes that read it (in order, repeated if read twice)."""
        out: list[list[int]] = [[] for _ in self.nodes]
        for index, node in enumerate(self.nodes):
            for i in node.inputs:
                out[i].append(index)
        return tuple(tuple(c) for c in out)

    @property
    def is_tree(self) -> bool:
        """True when no node is read twice (prefix token sequences represent trees exactly)."""
        return all(len(c) <= 1 for c in self.consumers)

    def canonical(self) -> Program:
        """The same computation with nodes in post-order, inputs left to right (the order the parser produces).

        Shared nodes stay shared; only the numbering changes.
        """
        order: list[int] = []
        placed: set[int] = set()

        def visit(i: int) -> None:
            if i in placed:
                return
            for j in self.nodes[i].inputs:
                visit(j)
            placed.add(i)
            order.append(i)

        visit(self.root)
        renumber = {old: new for new, old in enumerate(order)}
        nodes = tuple(Node(n.function, tuple(renumber[i] for i in n.inputs), n.value, n.span)
                      for n in (self.nodes[i] for i in order))
        return Program(nodes, self.source)

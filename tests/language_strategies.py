"""Hypothesis strategies for random well-typed programs, drawn from the operation registry itself."""

from __future__ import annotations

from hypothesis import strategies as st

from po3d_ppl.catalogue import Operation, OperationRegistry, value_vocabulary
from po3d_ppl.language.ast import Node, Program
from po3d_ppl.language.random_programs import min_depths
from po3d_ppl.language.typecheck import default_registry


@st.composite
def programs(draw, registry: OperationRegistry | None = None, max_depth: int = 6, share: bool = True) -> Program:
    """A random well-typed program; with ``share`` some sub-programs are reused (a DAG)."""
    registry = registry or default_registry()
    depth = min_depths(registry)
    nodes: list[Node] = []
    by_type: dict[str, list[int]] = {}

    def build(target: str, budget: int) -> int:
        if share and by_type.get(target) and draw(st.integers(0, 4)) == 0:
            return draw(st.sampled_from(by_type[target]))
        options: list[Operation] = [op for op in registry if op.output == target
                                    and all(depth.get(t, 1 << 30) < budget for t in op.inputs)]
        op = draw(st.sampled_from(options))
        inputs = tuple(build(t, budget - 1) for t in op.inputs)
        value = draw(st.sampled_from(value_vocabulary(op.value))) if op.value else None
        nodes.append(Node(op.name, inputs, value))
        index = len(nodes) - 1
        by_type.setdefault(target, []).append(index)
        return index

    root_types = sorted(t for t, d in depth.items() if d <= max_depth)
    build(draw(st.sampled_from(root_types)), max_depth)
    # Unused shared candidates cannot occur: every built node feeds its caller, which feeds the root.
    return Program(tuple(nodes))


@st.composite
def reordered(draw, program: Program) -> Program:
    """The same computation with another valid topological node order (as a JSON file might have it)."""
    remaining = list(range(len(program)))
    order: list[int] = []
    placed: set[int] = set()
    while remaining:
        ready = [i for i in remaining if i != program.root and all(j in placed for j in program[i].inputs)]
        pick = draw(st.sampled_from(ready)) if ready else program.root
        remaining.remove(pick)
        placed.add(pick)
        order.append(pick)
    new = {old: k for k, old in enumerate(order)}
    return Program(tuple(Node(program[i].function, tuple(new[j] for j in program[i].inputs), program[i].value)
                         for i in order))

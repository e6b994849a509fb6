"""Random well-typed programs drawn from the catalogue's signatures, for fuzzing the engines.

Every operation's input and output types come from the catalogue, so a random program exercises exactly what the
grammar and type checker accept, new operations included. Sub-programs are sometimes reused (a DAG), as the
public programs do.
"""

from __future__ import annotations

import random

from po3d_ppl.catalogue import OperationRegistry, value_vocabulary
from po3d_ppl.language.ast import Node, Program
from po3d_ppl.language.typecheck import default_registry


def min_depths(registry: OperationRegistry) -> dict[str, int]:
    """Smallest program depth that produces each type (a fixed point over the signatures)."""
    depth: dict[str, int] = {}
    changed = True
    while changed:
        changed = False
        for op in registry:
            if all(t in depth for t in op.inputs):
                d = 1 + max((depth[t] for t in op.inputs), default=0)
                if d < depth.get(op.output, 1 << 30):
                    depth[op.output] = d
                    changed = True
    return depth


def random_program(rng: random.Random, root_types: tuple[str, ...], *, max_depth: int = 7,
                   share: float = 0.2, registry: OperationRegistry | None = None) -> Program:
    """A random well-typed program ending in one of ``root_types``, at most ``max_depth`` deep."""
    registry = registry or default_registry()
    depth = min_depths(registry)
    nodes: list[Node] = []
    by_type: dict[str, list[int]] = {}

    def build(target: str, budget: int) -> int:
        if by_type.get(target) and rng.random() < share:
            return rng.choice(by_type[target])
        options = [op for op in registry
                   if op.output == target and all(depth.get(t, 1 << 30) < budget for t in op.inputs)]
        op = rng.choice(options)
        inputs = tuple(build(t, budget - 1) for t in op.inputs)
        value = rng.choice(value_vocabulary(op.value)) if op.value else None
        nodes.append(Node(op.name, inputs, value))
        by_type.setdefault(target, []).append(len(nodes) - 1)
        return len(nodes) - 1

    reachable = sorted(t for t in root_types if depth.get(t, 1 << 30) <= max_depth)
    build(rng.choice(reachable), max_depth)
    return Program(tuple(nodes))

"""Static satisfiability: does a program ask about objects or parts that no scene can contain?

An abstract interpretation over the ontology: every object-valued node gets the set of subtypes its objects may
have, every part-valued node the set of (subtype, raw part name) pairs its parts may be. ``filter_shape`` and
``partfilter_partname`` narrow these sets, the part/object pivots map between them, and every operation this
module does not know (user-registered ones included) is assumed to produce anything, so the analysis never
rejects a program that some scene could satisfy.

Why: the public verbalisation gives 17 pairs of raw part names the same words ("back left wheel" is
``back_left_wheel`` on cars and ``wheel_back_left`` on buses and planes). When a question names the object's
category, only one spelling can exist on it; the question parser uses this analysis to respell such impossible
parses into the possible one.
"""

from __future__ import annotations

from functools import cache

from po3d_ppl.language.ast import Program
from po3d_ppl.world import ontology

_OBJECT_TYPES = ("ObjectSet", "Object")
_PART_TYPES = ("PartSet", "Part")


@cache
def _all_subtypes() -> frozenset[str]:
    return frozenset(ontology.SUBTYPES)


@cache
def _all_parts() -> frozenset[tuple[str, str]]:
    return frozenset((s, p) for s in ontology.SUBTYPES for p in ontology.PARTS[s])


@cache
def _parts_of(subtypes: frozenset[str]) -> frozenset[tuple[str, str]]:
    return frozenset((s, p) for s in subtypes for p in ontology.PARTS[s])


def _abstract(function: str, value: str | None, inputs: list, output_type: str):
    """Abstract output of one node (None when the output is not an object or part value)."""
    first = inputs[0] if inputs else None
    if output_type in _OBJECT_TYPES:
        if function == "scene":
            return _all_subtypes()
        if function == "filter_shape" and value is not None and isinstance(first, frozenset):
            return frozenset(s for s in first if ontology.shape_matches(s, value))
        if function in ("unique",) or (function.startswith("filter_") and isinstance(first, frozenset)):
            return first if isinstance(first, frozenset) else _all_subtypes()
        if function == "part2object" and isinstance(first, frozenset):
            return frozenset(s for s, _ in first)
        if function == "intersect" and len(inputs) == 2 and all(isinstance(i, frozenset) for i in inputs):
            return inputs[0] & inputs[1]
        if function == "union" and len(inputs) == 2 and all(isinstance(i, frozenset) for i in inputs):
            return inputs[0] | inputs[1]
        return _all_subtypes()
    if output_type in _PART_TYPES:
        if function in ("object2part", "object2part_all") and isinstance(first, frozenset):
            return _parts_of(first)
        if function == "partfilter_partname" and value is not None and isinstance(first, frozenset):
            return frozenset((s, p) for s, p in first if ontology.partname_matches(p, value))
        if function in ("unique",) or (function.startswith("partfilter_") and isinstance(first, frozenset)):
            return first if isinstance(first, frozenset) else _all_parts()
        if function == "intersect" and len(inputs) == 2 and all(isinstance(i, frozenset) for i in inputs):
            return inputs[0] & inputs[1]
        if function == "union" and len(inputs) == 2 and all(isinstance(i, frozenset) for i in inputs):
            return inputs[0] | inputs[1]
        return _all_parts()
    return None


def unsatisfiable_node(program: Program, types: tuple[str, ...]) -> int | None:
    """The first node whose objects or parts cannot exist in any scene, or None.

    ``types`` are the nodes' output types (``check_program(program).types``).
    """
    values: list = []
    for index, (node, output_type) in enumerate(zip(program, types)):
        value = _abstract(node.function, node.value, [values[i] for i in node.inputs], output_type)
        if isinstance(value, frozenset) and not value:
            return index
        values.append(value)
    return None


@cache
def _same_words() -> dict[str, tuple[str, ...]]:
    """Part-name values that read the same (``back_left_wheel`` -> ``('wheel_back_left',)``)."""
    groups: dict[str, list[str]] = {}
    for name in ontology.PARTNAME_VALUES:
        groups.setdefault(ontology.readable_name(name), []).append(name)
    return {n: tuple(o for o in g if o != n) for g in groups.values() for n in g}


def _respellings(program: Program):
    """Programs that differ from ``program`` only in part-name spellings with the same words (original first)."""
    from dataclasses import replace
    from itertools import product

    sites = [(i, (node.value, *_same_words()[node.value])) for i, node in enumerate(program)
             if node.function == "partfilter_partname" and _same_words().get(node.value)]
    for choice in product(*(options for _, options in sites)):
        if all(value == program[i].value for (i, _), value in zip(sites, choice)):
            continue
        nodes = list(program.nodes)
        for (i, _), value in zip(sites, choice):
            nodes[i] = replace(nodes[i], value=value)
        yield Program(tuple(nodes))


def spelling_ambiguous(program: Program, types: tuple[str, ...]) -> bool:
    """Whether respelling part-name values into other raw names with the same words (so the same question
    text) gives another satisfiable program: then the text alone cannot decide between them."""
    return any(unsatisfiable_node(other, types) is None for other in _respellings(program))


def respell_satisfiable(program: Program, types: tuple[str, ...]) -> Program | None:
    """For an unsatisfiable program, the first respelling of its part names (same words) that is satisfiable:
    "the left head light of the school bus" must mean ``head_light_left``, the bus spelling."""
    return next((other for other in _respellings(program) if unsatisfiable_node(other, types) is None), None)

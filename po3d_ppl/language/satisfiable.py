"""Static satisfiability: does a program ask about objects or parts that no scene can contain?

An abstract interpretation over the ontology: every object-valued node gets the set of subtypes its objects may
have, every part-valued node the set of (subtype, raw part name) pairs its parts may be. ``filter_shape`` and
``partfilter_partname`` narrow these sets (through ``ontology.shape_matches`` and ``ontology.partname_matches``,
the executor's own rules, so a part name selects both raw spellings that read the same), the part/object pivots
map between them, and every operation this module does not know (user-registered ones included) is assumed to
produce anything, so the analysis never rejects a program that some scene could satisfy.

Why: a question can ask about something no scene has ("the wing of the car"); the question parser flags such
parses (``ParsedProgram.satisfiable``) so callers can tell them from a parse that merely found nothing.
"""

from __future__ import annotations

from functools import cache

from po3d_ppl import ontology
from po3d_ppl.language.ast import Program

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

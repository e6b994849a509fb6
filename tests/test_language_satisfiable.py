"""Static satisfiability of programs over the ontology, and part-name respelling."""

from __future__ import annotations

from po3d_ppl.language import check_program, parse_program
from po3d_ppl.language.satisfiable import respell_satisfiable, spelling_ambiguous, unsatisfiable_node
from po3d_ppl.language.typecheck import default_registry
from po3d_ppl.reasoning.registry import OperationRegistry, register_operation


def _analyse(text: str, registry=None):
    program = parse_program(text, registry=registry)
    return program, check_program(program, registry).types


def test_a_bus_part_name_on_a_car_is_unsatisfiable_and_is_respelled():
    program, types = _analyse("scene() | filter_shape[sedan] | unique | object2part"
                              " | partfilter_partname[bumper_back] | unique | partquery_color")
    assert unsatisfiable_node(program, types) == 4
    fixed = respell_satisfiable(program, types)
    assert fixed[4].value == "back_bumper"
    assert unsatisfiable_node(fixed, types) is None


def test_categories_and_coarse_part_names():
    ok, types = _analyse("scene() | filter_shape[bus] | object2part | partfilter_partname[wheel] | count")
    assert unsatisfiable_node(ok, types) is None
    bad, types = _analyse("scene() | filter_shape[bicycle] | object2part | partfilter_partname[door] | count")
    assert unsatisfiable_node(bad, types) == 3
    assert respell_satisfiable(bad, types) is None


def test_part_to_object_round_trip_keeps_the_subtypes():
    # an object with a car-style back left wheel cannot also have a bus-style front left wheel
    bad, types = _analyse("scene() | object2part | partfilter_partname[back_left_wheel] | unique | part2object"
                          " | object2part | partfilter_partname[wheel_front_left] | unique | partquery_color")
    assert unsatisfiable_node(bad, types) == 6
    assert spelling_ambiguous(bad, types)  # both-bus and both-car spellings are satisfiable


def test_spelling_ambiguity_depends_on_what_the_text_says():
    vague, types = _analyse("scene() | filter_color[red] | unique | object2part"
                            " | partfilter_partname[wheel_back_left] | unique | partquery_color")
    assert spelling_ambiguous(vague, types)
    named, types = _analyse("scene() | filter_shape[school] | unique | object2part"
                            " | partfilter_partname[wheel_back_left] | unique | partquery_color")
    assert not spelling_ambiguous(named, types)


def test_unknown_operations_never_make_a_program_unsatisfiable():
    registry = OperationRegistry()
    for op in default_registry():
        registry.register(op)

    @register_operation("relate_nearby", inputs=["Object"], output="ObjectSet", registry=registry)
    def relate_nearby(world, obj):
        """Objects near the object."""
        return world.exists

    program, types = _analyse("scene() | filter_shape[sedan] | unique | relate_nearby | object2part"
                              " | partfilter_partname[bumper_back] | count", registry)
    assert unsatisfiable_node(program, types) is None

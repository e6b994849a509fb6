"""Static satisfiability of programs over the ontology (part names match by their words)."""

from __future__ import annotations

from po3d_ppl.catalogue import register_operation
from po3d_ppl.language import check_program, parse_program
from po3d_ppl.language.satisfiable import unsatisfiable_node


def _analyse(text: str, registry=None):
    program = parse_program(text, registry=registry)
    return program, check_program(program, registry).types


def test_either_spelling_of_a_part_name_is_satisfiable_on_any_object_with_those_words():
    # bumper_back is the bus spelling of "back bumper"; sedans have back_bumper, which reads the same
    for spelling in ("bumper_back", "back_bumper"):
        for shape in ("sedan", "school"):
            program, types = _analyse(f"scene() | filter_shape[{shape}] | unique | object2part"
                                      f" | partfilter_partname[{spelling}] | unique | partquery_color")
            assert unsatisfiable_node(program, types) is None, (spelling, shape)


def test_a_part_the_object_cannot_have_is_unsatisfiable():
    # cars have front_left_wheel / front_right_wheel; "front wheel" (wheel_front) exists on bikes only
    program, types = _analyse("scene() | filter_shape[car] | unique | object2part"
                              " | partfilter_partname[wheel_front] | unique | partquery_color")
    assert unsatisfiable_node(program, types) == 4
    bad, types = _analyse("scene() | filter_shape[bicycle] | object2part | partfilter_partname[door] | count")
    assert unsatisfiable_node(bad, types) == 3


def test_categories_and_coarse_part_names():
    ok, types = _analyse("scene() | filter_shape[bus] | object2part | partfilter_partname[wheel] | count")
    assert unsatisfiable_node(ok, types) is None
    ok, types = _analyse("scene() | filter_shape[aeroplane] | object2part | partfilter_partname[back_left_wheel]"
                         " | count")
    assert unsatisfiable_node(ok, types) is None  # jets and airliners have wheel_back_left


def test_part_to_object_round_trip_keeps_the_subtypes():
    # an object with a wing (an aeroplane) has no pedal
    bad, types = _analyse("scene() | object2part | partfilter_partname[wing] | unique | part2object"
                          " | object2part | partfilter_partname[pedal] | unique | partquery_color")
    assert unsatisfiable_node(bad, types) == 6
    ok, types = _analyse("scene() | object2part | partfilter_partname[back_left_wheel] | unique | part2object"
                         " | object2part | partfilter_partname[wheel_front_left] | unique | partquery_color")
    assert unsatisfiable_node(ok, types) is None  # cars and buses have both, in either spelling


def test_unknown_operations_never_make_a_program_unsatisfiable(builtin_registry_copy):
    registry = builtin_registry_copy

    @register_operation("relate_nearby", inputs=["Object"], output="ObjectSet", registry=registry)
    def relate_nearby(world, obj):
        """Objects near the object."""
        return world.exists

    direct, types = _analyse("scene() | filter_shape[sedan] | unique | object2part"
                             " | partfilter_partname[wing] | count", registry)
    assert unsatisfiable_node(direct, types) == 4
    program, types = _analyse("scene() | filter_shape[sedan] | unique | relate_nearby | object2part"
                              " | partfilter_partname[wing] | count", registry)
    assert unsatisfiable_node(program, types) is None

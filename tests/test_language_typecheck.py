"""Type checking against the registry, typed errors, and operations registered at run time."""

from __future__ import annotations

import pytest

from po3d_ppl.catalogue import register_operation
from po3d_ppl.errors import UnknownNameError
from po3d_ppl.language import (
    ProgramArityError,
    ProgramTypeError,
    ProgramValueError,
    check_program,
    parse_program,
    program_from_tokens,
    program_to_text,
)


def test_types_of_every_node_and_overload_resolution():
    typed = check_program(parse_program(
        "count(scene() | filter_shape[car] | unique | object2part | partfilter_color[blue])"))
    assert typed.types == ("ObjectSet", "ObjectSet", "Object", "PartSet", "PartSet", "Integer")
    assert typed.type == "Integer"
    # object2part on an Object picks the Object overload, count on a PartSet the PartSet overload
    assert typed.nodes[3].operation.inputs == ("Object",)
    assert typed.nodes[5].operation.inputs == ("PartSet",)


def test_type_error_names_operation_argument_expected_and_actual():
    with pytest.raises(ProgramTypeError) as info:
        check_program(parse_program("equal_color(query_color(unique(scene())), query_shape(unique(scene())))"))
    err = info.value
    assert (err.operation, err.argument, err.expected, err.actual) == ("equal_color", 1, ("Color",), "Shape")
    assert "second input must be Color, but it is Shape" in str(err)
    assert err.span.line == 1 and err.span.column == 1


def test_type_error_lists_every_overload():
    with pytest.raises(ProgramTypeError) as info:
        check_program(parse_program("unique(unique(scene()))"))
    assert info.value.expected == ("ObjectSet", "PartSet")
    assert info.value.actual == "Object"


def test_arity_error():
    with pytest.raises(ProgramArityError) as info:
        check_program(parse_program("union(scene())"))
    assert (info.value.expected, info.value.actual) == ((2,), 1)


def test_missing_and_unexpected_values():
    with pytest.raises(ProgramValueError, match=r"needs a Color value in brackets") as info:
        check_program(parse_program("scene() | filter_color"))
    assert info.value.expected == "Color" and info.value.actual is None
    with pytest.raises(ProgramValueError, match="takes no value input") as info:
        check_program(parse_program("scene() | unique[red]"))
    assert info.value.actual == "red"


def test_unknown_value_suggests_the_vocabulary_of_the_value_type():
    with pytest.raises(UnknownNameError) as info:
        check_program(parse_program("scene()\n | filter_pose[front]"))
    assert info.value.suggestions[0] == "front_pose"
    assert info.value.span.line == 2
    with pytest.raises(UnknownNameError, match="'wheel_back_left'"):
        check_program(parse_program(
            "scene() | unique | object2part | partfilter_partname[wheel_back_lft] | unique | partquery_color"))


def test_json_programs_without_text_report_node_indices():
    from po3d_ppl.language import program_from_json

    program = program_from_json([{"type": "scene"}, {"type": "query_color", "inputs": [0]}])
    with pytest.raises(ProgramTypeError, match=r"\(node 1\)"):
        check_program(program)


def test_user_registered_operation_works_without_touching_the_grammar(builtin_registry_copy):
    registry = builtin_registry_copy

    @register_operation("relate_above", inputs=["Object"], output="ObjectSet", registry=registry)
    def relate_above(world, obj):
        """Objects higher than the object."""
        return world.exists

    @register_operation("filter_tint", inputs=["ObjectSet"], value="Color", output="ObjectSet", registry=registry)
    def filter_tint(world, objects, value):
        """Objects of a colour, registered by a user."""
        return objects

    text = "scene() | filter_tint[red] | unique | relate_above | count"
    program = parse_program(text, registry=registry)
    assert check_program(program, registry=registry).types[-2:] == ("ObjectSet", "Integer")
    assert program_from_tokens(["count", "relate_above", "unique", "filter_tint[red]", "scene"],
                               registry=registry) == program
    assert parse_program(program_to_text(program), registry=registry) == program
    # the process-wide registry is untouched
    with pytest.raises(UnknownNameError, match="relate_above"):
        parse_program(text)
    with pytest.raises(ProgramTypeError):
        check_program(parse_program("scene() | relate_above | count", registry=registry), registry=registry)

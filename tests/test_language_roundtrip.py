"""Lossless conversions: text <-> AST <-> public JSON <-> prefix tokens, on random well-typed programs."""

from __future__ import annotations

import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from language_strategies import programs, reordered

from po3d_ppl.errors import InputError
from po3d_ppl.language import (
    ProgramStructureError,
    check_program,
    parse_program,
    program_from_json,
    program_from_tokens,
    program_to_json,
    program_to_text,
    program_to_tokens,
)

SETTINGS = settings(max_examples=150, deadline=None)


@SETTINGS
@given(programs(), st.sampled_from(["nested", "pipeline"]))
def test_text_round_trip(program, style):
    text = program_to_text(program, style=style)
    again = parse_program(text)
    assert again == program
    check_program(again)


@SETTINGS
@given(programs().flatmap(reordered))
def test_text_round_trip_keeps_any_topological_order(program):
    assert parse_program(program_to_text(program)) == program


@SETTINGS
@given(programs().flatmap(reordered))
def test_json_round_trip_through_text(program):
    data = json.loads(json.dumps(program_to_json(program)))
    assert program_from_json(data) == program
    assert all(set(node) == {"type", "inputs", "value_inputs"} for node in data)


@SETTINGS
@given(programs(share=False))
def test_token_round_trip_is_exact_for_trees(program):
    tokens = program_to_tokens(program)
    assert len(tokens) == len(program)
    assert program_from_tokens(tokens) == program
    assert program_from_tokens(" ".join(tokens)) == program


@SETTINGS
@given(programs())
def test_tokens_expand_shared_nodes_into_an_equivalent_tree(program):
    tree = program_from_tokens(program_to_tokens(program))
    assert tree.is_tree
    assert program_to_tokens(tree) == program_to_tokens(program)
    assert check_program(tree).type == check_program(program).type
    if program.is_tree:
        assert tree == program


def test_token_example_from_the_brief():
    program = parse_program("query_color(unique(filter_shape[car](filter_color[red](scene()))))")
    assert program_to_tokens(program) == ["query_color", "unique", "filter_shape[car]", "filter_color[red]", "scene"]


def test_public_json_spellings_are_read():
    public = [
        {"type": "scene", "inputs": [], "value_inputs": [], "_output": [0, 1, 2]},
        {"function": "filter_size", "inputs": [0], "side_inputs": ["small"]},
        {"type": "filter_color", "inputs": [1], "value_inputs": ["gray"], "_output": [2]},
        {"type": "unique", "inputs": [2]},
        {"type": "relate_occluded", "inputs": [3], "value_inputs": []},
        {"type": "unique", "inputs": [4], "value_inputs": []},
        {"type": "query_shape", "inputs": [5], "value_inputs": [], "_output": "minivan"},
    ]
    program = program_from_json(public)
    assert program_to_text(program, "pipeline") == (
        "scene() | filter_size[small] | filter_color[gray] | unique | relate_occluded | unique | query_shape")
    assert check_program(program).type == "Shape"
    assert program_from_json({"question": "q?", "program": public}) == program
    assert program_from_json(json.dumps(public)) == program


@pytest.mark.parametrize(
    ("data", "field"),
    [
        ([{"inputs": []}], "program[0]"),
        ([{"type": "scene", "inputs": "0"}], "program[0].inputs"),
        ([{"type": "scene"}, {"type": "unique", "inputs": [0], "value_inputs": ["a", "b"]}],
         "program[1].value_inputs"),
        ({"no_program": []}, "program"),
        ("[1, 2", "program"),
        ([], "program"),
    ],
)
def test_malformed_json_names_the_field(data, field):
    with pytest.raises(InputError) as info:
        program_from_json(data)
    assert info.value.field == field


def test_json_input_index_must_point_backwards():
    with pytest.raises(ProgramStructureError, match="earlier node") as info:
        program_from_json([{"type": "unique", "inputs": [1]}, {"type": "scene", "inputs": []}])
    assert info.value.node == 0


@pytest.mark.parametrize(
    ("tokens", "message"),
    [
        (["unique"], "short of a complete program"),
        (["scene", "scene"], "follows a complete program"),
        (["filter_color[red"], "closed with"),
        ([], "empty"),
    ],
)
def test_bad_token_sequences(tokens, message):
    with pytest.raises(ProgramStructureError, match=message):
        program_from_tokens(tokens)


def test_unknown_token_operation_suggests():
    from po3d_ppl.errors import UnknownNameError

    with pytest.raises(UnknownNameError, match="did you mean 'unique'"):
        program_from_tokens(["uniqe", "scene"])


@SETTINGS
@given(programs().flatmap(lambda p: st.tuples(st.just(p), reordered(p))))
def test_canonical_order_is_the_parsers_order(pair):
    program, shuffled = pair
    assert shuffled.canonical() == program
    assert program_to_tokens(shuffled) == program_to_tokens(program)

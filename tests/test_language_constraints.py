"""The decoding automaton: every constrained sequence is a well-typed program within the length budget, and every
well-typed program is reachable."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from language_strategies import programs

from po3d_ppl import ontology
from po3d_ppl.catalogue import ALL_TYPES, register_operation
from po3d_ppl.language import check_program, program_to_tokens
from po3d_ppl.language.seq2seq.constraints import TypeAutomaton
from po3d_ppl.language.seq2seq.data import canonical_targets
from po3d_ppl.language.seq2seq.vocab import TargetVocabulary
from po3d_ppl.language.typecheck import default_registry

ROOTS = ("Bool", "Integer", "Color", "Material", "Size", "Shape", "Partname", "Direction")


def _automaton(max_len: int, registry=None, roots=ROOTS) -> tuple[TypeAutomaton, TargetVocabulary]:
    registry = registry or default_registry()
    targets = TargetVocabulary.from_registry(registry)
    return TypeAutomaton(registry, targets, roots, max_len=max_len), targets


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(4, 40))
def test_random_constrained_walks_are_well_typed_and_fit_the_budget(seed, max_len):
    automaton, targets = _automaton(max_len)
    rng = np.random.default_rng(seed)
    state, ids = automaton.initial(), []
    while not state.complete:
        allowed = np.flatnonzero(automaton.allowed(state))
        assert allowed.size > 0, "dead end"
        token = int(rng.choice(allowed))
        ids.append(token)
        finishes = automaton.completes(state, token)
        state = automaton.advance(state, token)
        assert finishes == state.complete
    assert len(ids) <= max_len
    typed = check_program(targets.decode(ids, default_registry()))
    assert typed.type in ROOTS


@settings(max_examples=100, deadline=None)
@given(programs(share=False))
def test_every_well_typed_program_is_accepted_token_by_token(program):
    """Every well-typed program, with its part names in the canonical spelling (the parser's targets)."""
    automaton, targets = _automaton(200, roots=ALL_TYPES)
    program = canonical_targets(program)
    state = automaton.initial()
    ids = targets.encode(program)
    for token in ids:
        assert automaton.allowed(state)[token], targets.tokens[token]
        finishes = automaton.completes(state, token)
        state = automaton.advance(state, token)
        assert finishes == state.complete
    assert state.complete
    assert targets.decode_tokens(ids) == program_to_tokens(program)


def test_values_follow_their_operation_and_match_its_value_type():
    automaton, targets = _automaton(30)
    state = automaton.advance(automaton.initial(), targets.op_id("query_color"))
    state = automaton.advance(state, targets.op_id("unique"))
    state = automaton.advance(state, targets.op_id("filter_pose"))
    allowed = {targets.tokens[i] for i in np.flatnonzero(automaton.allowed(state))}
    assert allowed == {"front_pose", "back_pose", "left_pose", "right_pose"}
    state = automaton.advance(automaton.initial(), targets.op_id("partquery_color"))
    state = automaton.advance(state, targets.op_id("unique"))
    state = automaton.advance(state, targets.op_id("partfilter_partname"))
    allowed = {targets.tokens[i] for i in np.flatnonzero(automaton.allowed(state))}
    assert allowed == set(ontology.CANONICAL_PARTNAME_VALUES)  # one spelling per wording


def test_slot_types_exclude_operations_of_the_wrong_type():
    automaton, targets = _automaton(30)
    state = automaton.advance(automaton.initial(), targets.op_id("query_color"))  # needs an Object
    allowed = {targets.tokens[i] for i in np.flatnonzero(automaton.allowed(state))}
    assert "unique" in allowed
    assert not allowed & {"scene", "filter_color", "count", "object2part", "red"}


def test_overloads_narrow_when_the_input_completes():
    # count(...) accepts an ObjectSet or a PartSet; union's second input must match its first.
    automaton, targets = _automaton(30)
    state = automaton.initial()
    for name in ("count", "union", "object2part", "scene"):
        state = automaton.advance(state, targets.op_id(name))
    allowed = {targets.tokens[i] for i in np.flatnonzero(automaton.allowed(state))}
    assert "object2part" in allowed and "scene" not in allowed


def test_tight_budget_forces_the_cheapest_completion():
    automaton, targets = _automaton(3, roots=("Integer",))
    allowed = {targets.tokens[i] for i in np.flatnonzero(automaton.allowed(automaton.initial()))}
    assert allowed == {"count"}
    with pytest.raises(ValueError, match="not allowed"):
        automaton.advance(automaton.initial(), targets.op_id("scene"))


def test_user_operation_is_decodable(builtin_registry_copy):
    registry = builtin_registry_copy

    @register_operation("relate_above", inputs=["Object"], output="ObjectSet", registry=registry)
    def relate_above(world, obj):
        """Objects above the object."""
        return world.exists

    automaton, targets = _automaton(30, registry=registry)
    state = automaton.advance(automaton.initial(), targets.op_id("count"))
    assert automaton.allowed(state)[targets.op_id("relate_above")]

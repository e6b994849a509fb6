"""An image with no vehicle gives evidence with no proposals: every method answers over the empty scene
(count 0, exist false, unique invalid), like the reference executor on a scene without objects."""

from __future__ import annotations

import pytest

from po3d_ppl.perception import simulated_evidence
from po3d_ppl.questions.executor import execute
from po3d_ppl.questions.toy_scenes import toy_scene
from po3d_ppl.reasoning import SceneReasoner
from po3d_ppl.reasoning.inference import METHODS

PROGRAMS = {
    "count(scene())": 0,
    "count(filter_shape[car](scene()))": 0,
    "exist(filter_color[red](scene()))": False,
    "exist(object2part(scene()))": False,
    "query_color(unique(scene()))": None,  # invalid
    "partquery_color(unique(object2part(scene())))": None,
    "equal_integer(count(scene()), count(filter_occludee(scene())))": True,
}


@pytest.fixture(scope="module")
def empty():
    scene = toy_scene([])
    return scene, SceneReasoner(simulated_evidence(scene))


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("program", list(PROGRAMS))
def test_every_method_answers_over_an_empty_scene(empty, method, program):
    _, reasoner = empty
    dist = reasoner.infer(program, method)
    expected = PROGRAMS[program]
    if expected is None:
        assert dist.invalid == 1.0 and not dist.probs
    else:
        assert dist.probs == {expected: 1.0} and dist.invalid == 0.0
    assert dist.method == method


@pytest.mark.parametrize("program", list(PROGRAMS))
def test_the_reference_executor_agrees(empty, program):
    scene, reasoner = empty
    from po3d_ppl.language import parse_program

    result = execute(scene, parse_program(program))
    expected = PROGRAMS[program]
    assert (result.answer if result.valid else None) == expected
    for reference in ("dense", "generic"):
        dist = reasoner.reference(program, reference)
        assert (dist.top if dist.invalid == 0 else None) == expected


def test_public_semantics_too(empty):
    scene, _ = empty
    reasoner = SceneReasoner(simulated_evidence(scene), semantics="public")
    assert reasoner.infer("count(scene())", "exact").probs == {0: 1.0}
    assert reasoner.infer("query_pose(unique(scene()))", "exact").invalid == 1.0

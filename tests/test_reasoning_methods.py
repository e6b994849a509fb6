"""Inference methods against each other, the registry's user operations, and the answer distribution record."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pyro
import pyro.poutine as poutine
import pytest
import torch
from reasoning_bruteforce import sparse_random_evidence

from po3d_ppl.catalogue import REGISTRY
from po3d_ppl.errors import UnknownNameError
from po3d_ppl.language import ProgramTypeError, check_program, parse_program
from po3d_ppl.perception import simulated_evidence
from po3d_ppl.questions.executor import execute
from po3d_ppl.questions.toy_scenes import toy_object, toy_scene
from po3d_ppl.reasoning import AnswerDistribution, SceneReasoner, compile_program, infer
from po3d_ppl.reasoning.inference import exact as exact_module
from po3d_ppl.reasoning.values import INVALID

DOCS_EXAMPLE = Path(__file__).resolve().parents[1] / "docs" / "examples" / "height_depth_ops.py"


@pytest.fixture(scope="module")
def scene():
    return toy_scene([
        toy_object("suv", "red", "metal", position=(0.0, 0.0, 0.0), pose_degree=10.0,
                   parts={"hood": ("blue", "rubber")}),
        toy_object("jet", "blue", "rubber", "small", position=(1.0, 2.0, 2.5), pose_degree=100.0,
                   parts={"wing_left": ("red", "metal"), "fin": ("green", "rubber")}, occluded_by=[0],
                   part_occluded_by={"wheel_front": [0]}),
        toy_object("road", "green", position=(-1.5, 1.0, 0.0), pose_degree=190.0,
                   parts={"saddle": ("cyan", "metal")}, part_occluded_by={"saddle": [1]}),
        toy_object("sedan", "red", "rubber", position=(2.0, -1.0, 0.0), pose_degree=200.0, occluded_by=[1, 0]),
    ])


PROGRAMS = [
    "count(filter_color[red](scene()))",
    "query_shape(unique(relate_occluded(unique(filter_shape[jet](scene())))))",
    "query_color(unique(part2object(partfilter_occludee(object2part_all(filter_shape[bicycle](scene()))))))",
    "query_color(unique(same_pose(unique(filter_color[green](scene())))))",
    "partquery_partname(unique(partfilter_color[red](object2part(unique(filter_shape[aeroplane](scene()))))))",
    "greater_than(count(filter_shape[car](scene())), count(filter_material[metal](scene())))",
    "exist(filter_shape[car](relate_part_occluded(unique(partfilter_partname[wheel_front]("
    "object2part_all(unique(filter_shape[jet](scene()))))))))",
]


def _tv(a: AnswerDistribution, b: AnswerDistribution) -> float:
    keys = set(a.probs) | set(b.probs)
    return 0.5 * sum(abs(a.probability(k) - b.probability(k)) for k in keys) + 0.5 * abs(a.invalid - b.invalid)


@pytest.mark.slow
def test_generic_pyro_path_equals_exact(scene):
    reasoner = SceneReasoner(sparse_random_evidence(scene, np.random.default_rng(5), 8))
    for text in PROGRAMS[:4]:
        assert _tv(reasoner.infer(text, "exact"), reasoner.reference(text, "generic")) < 1e-9, text


def test_dense_equals_exact_and_sampling_is_close(scene):
    reasoner = SceneReasoner(sparse_random_evidence(scene, np.random.default_rng(11), 10))
    for text in PROGRAMS:
        exact = reasoner.infer(text, "exact")
        assert _tv(exact, reasoner.reference(text, "dense")) < 1e-9, text
        sampled = reasoner.infer(text, "sampling", num_samples=4096, seed=3)
        assert _tv(exact, sampled) < 0.03, text
        assert sampled.error > 0 and sampled.info["samples"] == 4096


def test_auto_falls_back_to_sampling_when_exact_is_too_costly(scene, monkeypatch):
    reasoner = SceneReasoner(simulated_evidence(scene, noise=0.1, seed=1))
    text = PROGRAMS[2]
    assert reasoner.infer(text, "auto").method == "exact"
    monkeypatch.setattr(exact_module, "MAX_ELEMENTS", 10)
    dist = reasoner.infer(text, "auto")
    assert dist.method == "sampling" and "exact inference needs" in dist.info["fallback"]
    with pytest.raises(exact_module.ExactTooCostly):
        reasoner.infer(text, "exact")


def test_noise_spreads_the_answer_and_certainty_concentrates_it(scene):
    text = "query_color(unique(filter_shape[aeroplane](scene())))"
    certain = infer(text, simulated_evidence(scene), "exact")
    assert certain.probs == {"blue": 1.0} and certain.entropy == 0.0 and certain.top == "blue"
    noisy = infer(text, simulated_evidence(scene, noise=0.2, seed=4), "exact")
    assert noisy.entropy > 0.3 and sum(noisy.probs.values()) + noisy.invalid == pytest.approx(1.0)


def test_invalid_executions_are_reported_not_dropped(scene):
    # two red objects: "the red object" is ambiguous, so the execution is invalid, with certainty
    dist = infer("query_shape(unique(filter_color[red](scene())))", simulated_evidence(scene), "exact")
    assert dist.invalid == pytest.approx(1.0) and dist.probs == {} and dist.top is None
    # a pose query of an object facing a dead-zone direction is invalid too
    dead = toy_scene([toy_object("suv", "red", pose_degree=45.0)])
    assert infer("query_pose(unique(scene()))", simulated_evidence(dead)).invalid == pytest.approx(1.0)


def test_compiled_program_is_a_pyro_model_with_an_answer_site(scene):
    compiled = compile_program("query_color(unique(filter_shape[jet](scene())))")
    evidence = simulated_evidence(scene)
    with pyro.plate("samples", 64, dim=-5):
        trace = poutine.trace(compiled.model).get_trace(evidence)
    answers = trace.nodes["answer"]["value"]
    assert answers.shape == (64,)
    # prior samples: answers are colour ids or invalid, and the latents are sites of the scene model
    assert set(answers.tolist()) <= set(range(8)) | {INVALID}
    assert {"exists", "subtype", "color", "part_state", "occludes"} <= set(trace.nodes)
    # conditioned on the ground truth, the model answers like the reference executor
    truth = {"exists": torch.ones(4, 1), "subtype": torch.tensor([[0], [13], [17], [3]]),
             "color": torch.tensor([[1], [2], [3], [1]])}
    conditioned = poutine.trace(poutine.condition(compiled.model, truth)).get_trace(evidence)
    assert int(conditioned.nodes["answer"]["value"]) == 2  # blue


def test_user_operations_from_the_docs_example_work_everywhere(scene):
    spec = importlib.util.spec_from_file_location("height_depth_ops", DOCS_EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
        reasoner = SceneReasoner(sparse_random_evidence(scene, np.random.default_rng(2), 6))
        for text, builtin in [
            ("query_shape(unique(relate_above(unique(filter_shape[car](filter_material[metal](scene()))))))",
             "query_shape(unique(relate[above](unique(filter_shape[car](filter_material[metal](scene()))))))"),
            ("count(relate_closer(unique(filter_shape[aeroplane](scene()))))",
             "count(relate[closer](unique(filter_shape[aeroplane](scene()))))"),
        ]:
            user = reasoner.infer(text, "exact")
            assert _tv(user, reasoner.infer(builtin, "exact")) < 1e-12
            assert _tv(user, reasoner.reference(text, "dense")) < 1e-12
            assert _tv(user, reasoner.infer(text, "sampling", num_samples=2048)) < 0.05
        # the optional reference semantics lets the question engine run it too
        result = execute(scene, [{"type": "scene", "inputs": []}, {"type": "filter_shape", "inputs": [0],
                                  "value_inputs": ["suv"]}, {"type": "unique", "inputs": [1]},
                                 {"type": "relate_above", "inputs": [2]}, {"type": "count", "inputs": [3]}])
        assert result.answer == 1
    finally:
        for name in ("relate_above", "relate_closer"):
            REGISTRY.unregister(name)


def test_bad_input_gives_typed_errors(scene):
    reasoner = SceneReasoner(simulated_evidence(scene))
    with pytest.raises(UnknownNameError, match="inference method 'exactly'; did you mean 'exact'"):
        reasoner.infer("count(scene())", "exactly")
    with pytest.raises(ProgramTypeError):
        reasoner.infer("query_color(filter_color[red](scene()))")
    with pytest.raises(UnknownNameError, match="did you mean 'red'"):
        reasoner.infer("count(filter_color[redd](scene()))")
    from po3d_ppl.errors import InputError

    with pytest.raises(InputError, match="must end in a query"):
        compile_program("filter_color[red](scene())")


def test_answer_distribution_mixture_and_json():
    a = AnswerDistribution({"red": 0.8, "blue": 0.2}, 0.0, "exact", "Color")
    b = AnswerDistribution({"blue": 0.5}, 0.5, "exact", "Color")
    mix = AnswerDistribution.mixture([(3.0, a), (1.0, b)])
    assert mix.probs == pytest.approx({"red": 0.6, "blue": 0.275}) and mix.invalid == pytest.approx(0.125)
    assert mix.top == "red" and list(mix.probs) == ["red", "blue"]
    assert '"top": "red"' in mix.to_json()
    assert a.words("wheel_back_left") == "back left wheel" and a.words("articulated") == "articulated bus"


def test_typed_programs_from_every_front_end_compile_alike(scene):
    text = "query_color(unique(filter_shape[jet](scene())))"
    typed = check_program(parse_program(text))
    json_program = [{"type": "scene", "inputs": []}, {"type": "filter_shape", "inputs": [0], "value_inputs": ["jet"]},
                    {"type": "unique", "inputs": [1]}, {"type": "query_color", "inputs": [2]}]
    evidence = simulated_evidence(scene)
    answers = {infer(p, evidence).top for p in (text, typed, json_program, compile_program(text))}
    assert answers == {"blue"}


def test_filter_occluder_is_answered_by_sampling_and_matches_the_reference(scene):
    program = "count(filter_occluder(filter_color[red](scene())))"
    reasoner = SceneReasoner(simulated_evidence(scene))
    with pytest.raises(Exception, match="filter_occluder asks whether"):
        reasoner.infer(program, "exact")
    dist = reasoner.infer(program, "auto", num_samples=256)
    assert dist.method == "sampling" and "filter_occluder" in dist.info["fallback"]
    reference = execute(scene, compile_program(program).typed).answer
    assert dist.top == reference and dist.probability(reference) == 1.0
    assert reasoner.reference(program, "dense").probs == {reference: 1.0}
    assert reasoner.infer(program, "soft").top == reference

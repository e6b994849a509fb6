"""No input crashes or exhausts the machine: budgets, refusals, typed errors, and a bounded fuzz suite."""

from __future__ import annotations

import math
import random
import resource
import time

import pytest
import torch
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from po3d_ppl.errors import InputError
from po3d_ppl.language.random_programs import random_program
from po3d_ppl.perception import SimulatedSensor, simulated_evidence
from po3d_ppl.questions.executor import execute
from po3d_ppl.questions.toy_scenes import random_toy_scene, toy_object, toy_scene
from po3d_ppl.reasoning import Budget, BudgetExceeded, SceneReasoner
from po3d_ppl.reasoning.budget import MemoryBudgetExceeded, TimeBudgetExceeded
from po3d_ppl.reasoning.compiler import ANSWER_TYPES

#: The issue's example: a 13-node program that made exact inference allocate 62 GB on a 10-object scene.
HUGE = ("equal_color(partquery_color(unique(object2part(unique(same_color(unique(scene())))))), "
        "partquery_color(unique(relate_occluding_part(unique(part2object(unique(object2part_all(scene()))))))))")
PART_QUESTION = "query_color(unique(part2object(unique(partfilter_color[red](object2part(scene()))))))"


@pytest.fixture(scope="module")
def ten():
    return random_toy_scene(5, num_objects=(10, 10))


@pytest.fixture(scope="module")
def noisy(ten):
    return SceneReasoner(simulated_evidence(ten, noise=0.1, seed=1))


@pytest.fixture(scope="module")
def certain(ten):
    return SceneReasoner(simulated_evidence(ten))


def test_exact_refuses_before_allocating_and_auto_falls_back(noisy):
    small = Budget(max_bytes=64 << 20)
    start = time.perf_counter()
    with pytest.raises(MemoryBudgetExceeded, match="refused before allocating"):
        noisy.infer(HUGE, "exact", budget=small)
    dist = noisy.infer(HUGE, "auto", budget=small, num_samples=256)
    assert dist.method == "sampling" and "refused before allocating" in dist.info["fallback"]
    assert time.perf_counter() - start < 20


def test_a_larger_memory_budget_raises_the_exact_element_cap(noisy, monkeypatch):
    """The exact engine's static element cap suits the default budget; granting more memory raises it."""
    from po3d_ppl.reasoning.inference import exact
    from po3d_ppl.reasoning.inference.exact import ExactTooCostly

    program = "count(same_color(unique(filter_shape[suv](scene()))))"
    monkeypatch.setattr(exact, "MAX_ELEMENTS", 3)
    with pytest.raises(ExactTooCostly):
        noisy.infer(program, "exact")
    dist = noisy.infer(program, "exact", budget=Budget(max_bytes=1 << 40))
    assert dist.method == "exact" and dist.invalid + sum(dist.probs.values()) == pytest.approx(1.0)


def test_the_default_budget_keeps_the_issue_example_under_two_gigabytes(noisy):
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    dist = noisy.infer(HUGE, "auto", num_samples=512)
    assert math.isclose(sum(dist.probs.values()) + dist.invalid, 1.0, abs_tol=1e-9)
    grown = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 - before
    assert grown < 2 << 30


def test_a_time_budget_is_a_typed_refusal(noisy):
    with pytest.raises(TimeBudgetExceeded, match="budget"):
        noisy.infer(PART_QUESTION, "exact", budget=Budget(max_seconds=1e-9))
    with pytest.raises(BudgetExceeded):
        noisy.infer(PART_QUESTION, "sampling", budget=Budget(max_seconds=1e-9))


@pytest.mark.parametrize("bad", [dict(max_bytes=-1), dict(max_bytes=1.5), dict(max_seconds=0),
                                 dict(max_seconds=float("nan")), dict(max_seconds="5")])
def test_bad_budgets_are_typed_errors(bad):
    with pytest.raises(InputError, match="budget"):
        Budget(**bad)


def test_a_certainly_invalid_program_exits_before_contracting():
    scene = toy_scene([toy_object(pose_degree=45.0), toy_object(position=(3.0, 0.0, 0.0), pose_degree=135.0)])
    reasoner = SceneReasoner(simulated_evidence(scene))  # both poses in dead zones: every query_pose is invalid
    dist = reasoner.infer("query_pose(unique(filter_shape[suv](scene())))", "exact")
    assert dist.invalid == 1.0 and not dist.probs
    assert dist.info["peak_elements"] == 0  # nothing was contracted


def test_unique_of_a_large_set_is_invalid_quickly(ten):
    reasoner = SceneReasoner(simulated_evidence(ten, noise=0.1, seed=3))
    start = time.perf_counter()
    dist = reasoner.infer("query_color(unique(scene()))", "auto")
    assert dist.invalid > 0.99 and time.perf_counter() - start < 5


def test_a_count_of_parts_beyond_the_object_count_is_answered(noisy):
    dist = noisy.infer("count(object2part_all(scene()))", "auto", num_samples=256)
    assert max(dist.probs) > 10  # more parts than proposals: was an IndexError


@pytest.mark.parametrize("noise", [1e-300, 5e-324, 1e-12])
def test_tiny_noise_gives_finite_confident_evidence(ten, noise):
    evidence = simulated_evidence(ten, noise=noise)
    for table in (evidence.pose_loglik, evidence.color_loglik, evidence.exist_logodds, evidence.part_style_loglik):
        assert torch.isfinite(table).all()
    dist = SceneReasoner(evidence).infer("count(scene())", "exact")
    assert dist.top == 10 and dist.probs[10] > 1 - 1e-9


@pytest.mark.parametrize("bad", [dict(noise="x"), dict(noise=1.0), dict(noise=-0.1), dict(noise=float("nan")),
                                 dict(seed=-1), dict(seed=1.5), dict(pose_bins=0)])
def test_bad_sensor_settings_are_typed_errors(bad):
    with pytest.raises(InputError):
        SimulatedSensor(**bad)


def test_empty_evidence_error_has_no_pyro_trace_dump():
    from po3d_ppl.reasoning.scene_model import EmptyEvidenceError

    with pytest.raises(EmptyEvidenceError) as error:
        SceneReasoner(simulated_evidence(toy_scene([]))).posteriors  # noqa: B018  (the model refuses; infer answers)
    assert "Trace Shapes" not in str(error.value) and "\n" not in str(error.value)


@settings(max_examples=20, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.randoms(use_true_random=False))
def test_fuzz_random_programs_finish_within_budget_and_agree_with_the_reference(ten, noisy, certain,
                                                                               rng: random.Random):
    program = random_program(rng, ANSWER_TYPES, max_depth=6)
    budget = Budget(max_bytes=2 << 30, max_seconds=5.0)
    start = time.perf_counter()
    try:
        noisy.infer(program, "auto", budget=budget, num_samples=512)
    except BudgetExceeded:
        pass  # a refusal is an answer here; a crash or an overrun is not
    assert time.perf_counter() - start < 8.0  # the budget, plus the first call's one-off posterior tables
    answer = certain.infer(program, "auto", budget=budget, num_samples=64)
    reference = execute(ten, program)
    if reference.valid:
        assert list(answer.probs) == [reference.answer] and abs(answer.probs[reference.answer] - 1.0) < 1e-9
    else:
        assert answer.invalid > 1.0 - 1e-9

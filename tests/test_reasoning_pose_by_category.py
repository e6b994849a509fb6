"""The pose likelihood is conditioned on the category hypothesis ([N, 5, K]): each category's mesh is fitted on its
own, so "a car facing front or a bus facing back" is one proposal whose pose and subtype are correlated."""

from __future__ import annotations

import dataclasses

import pytest
import torch

from po3d_ppl import ontology
from po3d_ppl.evidence import CERTAIN
from po3d_ppl.perception import simulated_evidence
from po3d_ppl.questions.toy_scenes import toy_object, toy_scene
from po3d_ppl.reasoning import SceneReasoner

CAR, BUS = ontology.CATEGORIES.index("car"), ontology.CATEGORIES.index("bus")


@pytest.fixture(scope="module")
def reasoner():
    scene = toy_scene([toy_object("suv", pose_degree=180.0),
                       toy_object("sedan", position=(3.0, 2.0, 0.0), pose_degree=90.0)])
    evidence = simulated_evidence(scene)  # pose grid of proposal 0 anchored at 180 degrees, 15-degree bins
    subtype = evidence.subtype_loglik.clone()
    subtype[0] = -CERTAIN
    subtype[0, ontology.SUBTYPES.index("suv")] = 0.0
    subtype[0, ontology.SUBTYPES.index("school")] = 0.0  # a car or a bus, even odds
    pose = evidence.pose_loglik.clone()
    pose[0, BUS] = -CERTAIN
    pose[0, BUS, 12] = 0.0  # the bus mesh fits best turned round: 180 + 12 * 15 = 0 degrees (back)
    return SceneReasoner(dataclasses.replace(evidence, subtype_loglik=subtype, pose_loglik=pose))


def test_pose_follows_the_subtype_hypothesis(reasoner):
    assert "pose" not in reasoner.posteriors.shared
    for method in ("exact", "sampling"):
        dist = reasoner.infer("query_pose(unique(filter_shape[suv](scene())))", method, num_samples=2048)
        assert dist.probs.get("front", 0.0) == pytest.approx(1.0) or dist.invalid > 0  # a car faces front
        marginal = reasoner.infer("exist(filter_pose[front_pose](filter_shape[bus](scene())))", method,
                                  num_samples=2048)
        assert marginal.probs == {False: pytest.approx(1.0)}  # no bus faces front: the two are correlated
    front = reasoner.infer("count(filter_pose[front_pose](scene()))", "exact").probs
    assert front[0] == pytest.approx(0.5) and front[1] == pytest.approx(0.5)


def test_the_reference_implementations_agree(reasoner):
    for program in ("count(filter_pose[back_pose](scene()))",
                    "query_shape(unique(filter_pose[back_pose](scene())))",
                    "equal_shape(query_shape(unique(filter_pose[front_pose](scene()))), "
                    "query_shape(unique(filter_pose[right_pose](scene()))))"):
        exact = reasoner.infer(program, "exact")
        for reference in ("dense", "generic"):
            other = reasoner.reference(program, reference)  # generic works in log space: 1e-16 crumbs
            for answer in set(exact.probs) | set(other.probs):
                assert other.probs.get(answer, 0.0) == pytest.approx(exact.probs.get(answer, 0.0), abs=1e-9)
            assert other.invalid == pytest.approx(exact.invalid, abs=1e-9)


def test_the_soft_baseline_ignores_the_correlation(reasoner):
    soft = reasoner.infer("exist(filter_pose[front_pose](filter_shape[bus](scene())))", "soft")
    assert soft.probs[True] > 0.2  # P(bus) * P(front) as if independent: what the Pyro model corrects


def test_pose_loglik_needs_a_category_axis():
    from po3d_ppl.evidence import EvidenceError

    evidence = simulated_evidence(toy_scene([toy_object()]))
    with pytest.raises(EvidenceError, match="pose_loglik"):
        dataclasses.replace(evidence, pose_loglik=evidence.pose_loglik[:, 0])
    assert tuple(evidence.pose_loglik.shape) == (1, len(ontology.CATEGORIES), evidence.num_pose_bins)
    assert torch.equal(evidence.pose_loglik[:, 0], evidence.pose_loglik[:, 4])



@pytest.mark.parametrize("noise", [0.0, 0.2])
def test_pose_relations_stay_off_the_subtype_dimension(reasoner, noise):
    """Where the bins' degrees are the same under every subtype hypothesis (every bin possible, as on image
    evidence), they are placed off the subtype's dimension: on it, a pose relation's tensor (pivot x object x both
    poses) is subtypes**2 times larger (1-3 s a question on image evidence, and fallbacks to sampling). Where they
    differ (the fixture's bus and car), they stay on it. Either way exact agrees with the dense (or Pyro's generic)
    reference."""
    from po3d_ppl.reasoning.inference.enum_world import EnumWorld

    if noise > 0:  # every subtype and every bin keeps some probability
        scene = toy_scene([toy_object("suv", pose_degree=180.0),
                           toy_object("sedan", position=(3.0, 2.0, 0.0), pose_degree=90.0)])
        reasoner = SceneReasoner(simulated_evidence(scene, noise=noise, seed=3))
    world = EnumWorld(reasoner.posteriors, reasoner.evidence)
    degrees = world.object_latent("pose")
    subtype = next(d for d in world.dims if d.name == "subtype")
    assert subtype.size > 1 and degrees.dim() >= -subtype.pos
    assert degrees.shape[subtype.pos] == (1 if noise > 0 else subtype.size)
    for program in ("count(opposite_pose(unique(filter_shape[sedan](scene()))))",
                    "query_shape(unique(vertical_pose(unique(filter_shape[sedan](scene())))))"):
        exact = reasoner.infer(program, "exact")
        reference = reasoner.reference(program, "dense" if noise == 0 else "generic")
        for answer in set(exact.probs) | set(reference.probs):
            assert reference.probs.get(answer, 0.0) == pytest.approx(exact.probs.get(answer, 0.0), abs=1e-6)
        assert reference.invalid == pytest.approx(exact.invalid, abs=1e-6)

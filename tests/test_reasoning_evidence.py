"""SceneEvidence: shapes and errors, ground-truth evidence, the noisy sensor model, and the per-site posteriors read
from the Pyro scene model."""

from __future__ import annotations

import dataclasses

import numpy as np
import pyro
import pytest
import torch

from po3d_ppl import ontology
from po3d_ppl.errors import InputError
from po3d_ppl.evidence import EvidenceError, style_index
from po3d_ppl.perception import simulated_evidence
from po3d_ppl.questions.toy_scenes import random_toy_scene, toy_object, toy_scene
from po3d_ppl.reasoning import SceneEvidence, ScenePriors
from po3d_ppl.reasoning import scene_model as scene_model_module
from po3d_ppl.reasoning.posterior import CoupledModelError, site_posteriors


@pytest.fixture(scope="module")
def scene():
    return toy_scene([
        toy_object("suv", "red", "metal", position=(0.0, 0.0, 0.0), pose_degree=100.0,
                   parts={"hood": ("blue", "rubber")}, part_occluded_by={"roof": [1]}),
        toy_object("jet", "blue", "rubber", "small", position=(1.0, 2.0, 0.0), occluded_by=[0]),
    ])


def test_certain_evidence_gives_certain_posteriors(scene):
    post = site_posteriors(simulated_evidence(scene))
    assert post["subtype"].argmax(-1).tolist() == [ontology.SUBTYPES.index("suv"), ontology.SUBTYPES.index("jet")]
    assert post["color"][0, ontology.COLORS.index("red")] == 1.0
    assert post["occludes"][1, 0, 1] == 1.0 and post["occludes"][0, 1, 1] == 0.0  # jet occluded by the suv
    suv = ontology.SUBTYPES.index("suv")
    hood = ontology.PARTS["suv"].index("hood")
    roof = ontology.PARTS["suv"].index("roof")
    assert post["part_state"][0, suv, hood].argmax() == 1 + style_index("blue", "rubber")
    assert post["part_occluded"][0, suv, roof, 1] == 1.0
    assert post["part_occludes"][0, suv, roof, 1, 1] == 1.0
    # the pose grid is anchored at the true azimuth, so index 0 holds it exactly
    assert (post["pose"][0, :, 0] == 1.0).all() and post.support["pose"][0, 0] == pytest.approx(100.0)
    assert torch.equal(post.shared["pose"], post["pose"][:, 0])  # the sensor reads pose alike for every category
    for probs in post.probs.values():
        assert torch.allclose(probs.sum(-1), torch.ones(()).double())


def test_noise_model_is_calibrated():
    """Posterior confidence of the colour matches how often the posterior argmax is right (sensor model)."""
    confidences, hits = [], []
    for seed in range(60):
        scene = random_toy_scene(seed, num_objects=(6, 6))
        post = site_posteriors(simulated_evidence(scene, noise=0.3, seed=seed))
        truth = torch.tensor([ontology.COLORS.index(o.color) for o in scene.objects])
        conf, guess = post["color"].max(-1)
        confidences += conf.tolist()
        hits += (guess == truth).tolist()
    assert abs(np.mean(confidences) - np.mean(hits)) < 0.05
    assert 0.6 < np.mean(hits) < 0.8  # noise 0.3: the sensor is right 70% of the time


def test_same_seed_same_noise_and_different_seed_differs(scene):
    a = simulated_evidence(scene, noise=0.2, seed=3)
    b = simulated_evidence(scene, noise=0.2, seed=3)
    c = simulated_evidence(scene, noise=0.2, seed=4)
    assert torch.equal(a.pose_support, b.pose_support) and not torch.equal(a.pose_support, c.pose_support)


def test_wrong_shapes_and_values_give_typed_errors(scene):
    ev = simulated_evidence(scene)
    fields = {f.name: getattr(ev, f.name) for f in dataclasses.fields(ev)}
    with pytest.raises(EvidenceError, match=r"color_loglik: expected shape \[2, 8\], got \[2, 7\]"):
        SceneEvidence(**{**fields, "color_loglik": torch.zeros(2, 7, dtype=torch.float64)})
    with pytest.raises(EvidenceError, match="occludes_logodds: contains NaN"):
        SceneEvidence(**{**fields, "occludes_logodds": torch.full((2, 2), float("nan"), dtype=torch.float64)})
    with pytest.raises(EvidenceError, match="directions: missing"):
        SceneEvidence(**{**fields, "directions": {"left": torch.zeros(3)}})
    with pytest.raises(InputError, match="noise"):
        simulated_evidence(scene, noise=1.5)
    with pytest.raises(InputError, match="priors.exists"):
        ScenePriors(exists=1.0)


def test_evidence_moves_between_devices(scene):
    ev = simulated_evidence(scene).to("cpu")
    assert ev.subtype_loglik.device.type == "cpu" and ev.num_objects == 2


def test_a_coupled_scene_model_is_refused_by_the_per_site_posteriors(scene, monkeypatch):
    original = scene_model_module.scene_model

    def coupled(evidence, priors=ScenePriors()):
        latents = original(evidence, priors)
        with pyro.plate("coupling", evidence.num_objects, dim=-2):
            pyro.factor("colour_matches_material",
                        (latents["color"] == latents["material"]).to(torch.float64))
        return latents

    monkeypatch.setattr("po3d_ppl.reasoning.posterior.scene_model", coupled)
    with pytest.raises(CoupledModelError, match="couples latents"):
        site_posteriors(simulated_evidence(scene))


def test_priors_matter_only_under_uncertainty(scene):
    ev = simulated_evidence(scene, noise=0.3, seed=1)
    low = site_posteriors(ev, ScenePriors(exists=0.1))["exists"][:, 1]
    high = site_posteriors(ev, ScenePriors(exists=0.9))["exists"][:, 1]
    assert (high > low).all()
    certain = simulated_evidence(scene)
    assert torch.equal(site_posteriors(certain, ScenePriors(exists=0.1))["exists"],
                       site_posteriors(certain, ScenePriors(exists=0.9))["exists"])


@pytest.mark.parametrize("noise", [0.001, 0.01])
def test_a_correct_reading_of_a_recoloured_part_is_believed(scene, noise):
    """A sensor that reads the hood as visible and blue-rubber, and is wrong 1 time in 1/noise, leaves little doubt.
    (A model that scored 'hidden' as explaining every attribute reading put half the mass on 'hidden' here.)"""
    suv, hood = ontology.SUBTYPES.index("suv"), ontology.PARTS["suv"].index("hood")
    ev = simulated_evidence(scene)
    styles = ev.part_style_loglik.shape[-1]
    ev.part_visible_logodds[0, suv, hood] = np.log((1 - noise) / noise)
    ev.part_style_loglik[0, suv, hood] = np.log(noise / (styles - 1))
    ev.part_style_loglik[0, suv, hood, style_index("blue", "rubber")] = np.log(1 - noise)
    state = site_posteriors(ev)["part_state"][0, suv, hood]
    assert state[1 + style_index("blue", "rubber")] > 0.9
    assert state[0] < noise  # hidden


def test_the_scene_model_of_evidence_without_proposals_is_a_typed_refusal():
    # answering over such evidence works (tests/test_reasoning_empty.py); the model's plates cannot be empty
    from po3d_ppl.reasoning.scene_model import EmptyEvidenceError

    with pytest.raises(EmptyEvidenceError, match="no object proposals"):
        site_posteriors(simulated_evidence(toy_scene([])))


def test_duplicate_pairs_finds_overlapping_boxes(scene):
    import dataclasses

    from po3d_ppl.evidence import EvidenceError, duplicate_pairs

    evidence = simulated_evidence(scene)
    n = evidence.num_objects
    boxes = torch.tensor([[10.0 * 40 * i, 0.0, 30.0, 30.0] for i in range(n)], dtype=torch.float64)
    boxes[1] = boxes[0] + torch.tensor([3.0, 3.0, 0.0, 0.0], dtype=torch.float64)  # IoU (27*27) / (2*900 - 729)
    assert duplicate_pairs(dataclasses.replace(evidence, boxes=boxes), min_iou=0.5) == [(0, 1)]
    assert duplicate_pairs(dataclasses.replace(evidence, boxes=boxes), min_iou=0.7) == []
    with pytest.raises(EvidenceError, match="boxes"):
        duplicate_pairs(dataclasses.replace(evidence, boxes=None))

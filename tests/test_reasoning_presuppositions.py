"""Answers given the question's presuppositions (its referents exist and are unique, the values it asks for exist),
with the probability that they fail reported beside them."""

from __future__ import annotations

import math
import warnings

import pytest
from typer.testing import CliRunner

from po3d_ppl.cli import app
from po3d_ppl.perception import simulated_evidence
from po3d_ppl.pipeline import answer_question
from po3d_ppl.questions.toy_scenes import random_toy_scene
from po3d_ppl.reasoning import PresuppositionWarning, SceneReasoner
from po3d_ppl.world import save_scene

PROGRAM = "query_color(unique(filter_material[rubber](scene())))"


@pytest.fixture(scope="module")
def scene():
    return random_toy_scene(4, num_objects=(5, 5))


@pytest.fixture(scope="module")
def reasoner(scene):
    return SceneReasoner(simulated_evidence(scene, noise=0.05, seed=2))


def test_conditioning_renormalises_and_keeps_the_failure_mass(reasoner):
    joint = reasoner.infer(PROGRAM, "exact")
    assert 0.0 < joint.invalid < 1.0 and joint.presupposition_failure is None
    given = joint.given_presuppositions(warn_above=None)
    assert given.invalid == 0.0 and given.presupposition_failure == pytest.approx(joint.invalid)
    assert math.isclose(sum(given.probs.values()), 1.0, rel_tol=1e-12)
    for answer, p in joint.probs.items():
        assert given.probs[answer] == pytest.approx(p / (1.0 - joint.invalid))
    assert given.given_presuppositions() is given  # idempotent
    assert "presuppositions" in str(given) and "(invalid)" not in str(given)


def test_a_probable_failure_warns_and_a_certain_one_leaves_nothing(scene):
    certain = SceneReasoner(simulated_evidence(scene))  # five objects: "the object" never picks one out
    joint = certain.infer("query_color(unique(scene()))", "exact")
    with pytest.warns(PresuppositionWarning, match="presuppositions"):
        given = joint.given_presuppositions()
    assert given.probs == {} and given.presupposition_failure == 1.0 and given.top is None


def test_the_pipeline_conditions_by_default(reasoner):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PresuppositionWarning)
        given, parse = answer_question(reasoner, "What color is the rubber thing?")
        joint, _ = answer_question(reasoner, "What color is the rubber thing?", presuppose=False)
    assert given.presupposition_failure == pytest.approx(joint.invalid)
    assert given.invalid == 0.0 and joint.presupposition_failure is None
    assert math.isclose(sum(given.probs.values()), 1.0, rel_tol=1e-9)


def test_the_cli_prints_both_ways(scene, tmp_path):
    path = tmp_path / "scene.json"
    save_scene(scene, path)
    runner = CliRunner()
    given = runner.invoke(app, ["answer", "--scene", str(path), "--program", PROGRAM, "--noise", "0.05",
                                "--seed", "2", "--method", "exact"])
    joint = runner.invoke(app, ["answer", "--scene", str(path), "--program", PROGRAM, "--noise", "0.05",
                                "--seed", "2", "--method", "exact", "--joint"])
    assert given.exit_code == 0 and joint.exit_code == 0, (given.output, joint.output)
    assert "presuppositions; they fail with probability" in given.output
    assert "(invalid)" in joint.output and "presuppositions" not in joint.output


def test_a_distribution_renders_for_notebooks_in_words():
    from po3d_ppl.reasoning.answer import AnswerDistribution

    dist = AnswerDistribution({"school": 0.7, "suv": 0.3}, 0.0, "exact", "Shape", presupposition_failure=0.25)
    html = dist._repr_html_()
    assert "school bus" in html and "0.7000" in html and "0.2500" in html
    assert "<script" not in AnswerDistribution({"<script>": 1.0}, 0.0, "exact", "Shape")._repr_html_()

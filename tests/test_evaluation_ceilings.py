"""Answer ceilings: oracles write the truth of their tables only, on matched proposals, and the brackets reach the
reference answers when the sensor reads every object (the tiny dataset of conftest, the simulated sensor)."""

from __future__ import annotations

import json

import pytest
import torch

from po3d_ppl import ontology
from po3d_ppl.errors import InputError
from po3d_ppl.evaluation import ceilings
from po3d_ppl.evaluation.backends import SimulatedBackend
from po3d_ppl.evaluation.cache import EvidenceCache
from po3d_ppl.perception.simulated import part_visible, simulated_evidence

TABLES = ("exist_logodds", "subtype_loglik", "color_loglik", "material_loglik", "size_loglik", "pose_support",
          "pose_loglik", "occluded_logodds", "occludes_logodds", "part_visible_logodds", "part_style_loglik",
          "part_occluded_logodds", "part_occludes_logodds")


@pytest.fixture(scope="module")
def tiny(tiny_eval_dataset):
    return tiny_eval_dataset


@pytest.fixture(scope="module")
def noisy(tiny):
    """(scene, evidence read with much noise) of the first scene with at least three objects."""
    for index in tiny.split_indices("all"):
        scene = tiny.scene(index)
        if len(scene.objects) >= 3:
            return scene, simulated_evidence(scene, noise=0.45, seed=5)
    pytest.skip("no scene with three objects")


def _changed(before, after) -> set[str]:
    return {name for name in TABLES if not torch.equal(getattr(before, name), getattr(after, name))}


@pytest.mark.parametrize("name, tables", [
    ("existence", {"exist_logodds"}),
    ("subtype", {"subtype_loglik"}),
    ("attributes", {"color_loglik", "material_loglik", "size_loglik"}),
    ("pose", {"pose_support", "pose_loglik"}),
    ("occlusion", {"occluded_logodds", "occludes_logodds"}),
    ("part_visibility", {"part_visible_logodds"}),
    ("part_style", {"part_style_loglik"}),
    ("part_occlusion", {"part_occluded_logodds", "part_occludes_logodds"}),
])
def test_each_oracle_writes_its_tables_only(noisy, name, tables):
    scene, evidence = noisy
    fixed = ceilings.with_truth(evidence, scene, name)
    assert _changed(evidence, fixed) <= tables and _changed(evidence, fixed)  # noise 0.45 got something wrong
    assert _changed(evidence, ceilings.with_truth(evidence, scene, ceilings.PERCEPTION)) == set()


def test_oracles_write_the_truth(noisy):
    scene, evidence = noisy
    fixed = ceilings.with_truth(evidence, scene, ceilings.EVERY_TABLE)
    for i, obj in enumerate(scene.objects):  # the simulated sensor's boxes are the objects' own: all matched
        s = ontology.SUBTYPES.index(obj.subtype)
        assert int(fixed.subtype_loglik[i].argmax()) == s
        assert ontology.COLORS[int(fixed.color_loglik[i].argmax())] == obj.color
        assert (fixed.occluded_logodds[i] > 0) == obj.occluded
        assert abs(float(fixed.pose_support[i, int(fixed.pose_loglik[i, 0].argmax())]) - obj.pose_degree % 360) < 1e-6
        for p, raw in enumerate(ontology.PARTS[obj.subtype]):
            assert (fixed.part_occluded_logodds[i, s, p] > 0) == obj.part_occluded(raw)
            if part_visible(obj, raw):  # a hidden part's look is left to perception
                assert (int(fixed.part_style_loglik[i, s, p].argmax()) != 0) == (raw in obj.parts)


def test_subset_keeps_the_pair_axes(noisy):
    scene, evidence = noisy
    keep = [2, 0]
    part = ceilings.objects_subset(evidence, keep)
    assert part.num_objects == 2
    assert torch.equal(part.occludes_logodds, evidence.occludes_logodds[keep][:, keep])
    assert torch.equal(part.part_occludes_logodds, evidence.part_occludes_logodds[keep][..., keep])
    assert torch.equal(part.subtype_loglik, evidence.subtype_loglik[keep])


def test_unknown_oracles_and_duplicates_are_refused():
    with pytest.raises(InputError, match="did you mean part_style"):
        ceilings.variants(["part_styel"])
    with pytest.raises(ValueError, match="already defined"):
        ceilings.oracle("subtype")(lambda ctx: None)
    assert ceilings.variants(["pose"]) == ("perception", "pose", "every_table", "matched_truth")


def test_the_brackets_reach_the_reference_on_noisy_evidence(tiny, tmp_path):
    backend = SimulatedBackend(noise=0.3, seed=2)
    report = ceilings.evaluate_ceilings(tiny, "all", backend, cache=EvidenceCache(tmp_path / "cache"), limit=2,
                                        oracles=["subtype", "part_style"])
    rows = {row.variant: row for row in report.rows}
    assert list(rows) == ["perception", "subtype", "part_style", "every_table", "matched_truth"]
    assert rows["perception"].overall < 1.0  # noise 0.3 costs answers
    assert rows["every_table"].overall == 1.0 and rows["matched_truth"].overall == 1.0
    assert sum(report.questions.values()) > 10 and set(rows["subtype"].files) == set(report.questions)
    table = report.markdown()
    assert "| every_table | 100.00 (+" in table and table.count("\n") == len(rows) + 3


def test_the_command_writes_table_json_and_figure(tiny, tmp_path):
    import typer
    from typer.testing import CliRunner

    from po3d_ppl.cli import evaluate as cli

    app, train_app, eval_app = typer.Typer(), typer.Typer(), typer.Typer()
    app.add_typer(eval_app, name="eval")
    cli.register(app, train_app, eval_app)
    result = CliRunner().invoke(app, ["eval", "ceilings", "--data", str(tiny.root), "--split", "all", "--limit", "1",
                                      "--perception", "simulated", "--noise", "0.2", "--oracles", "occlusion",
                                      "--files", "core,occlusion", "--cache", str(tmp_path / "cache"),
                                      "--json", str(tmp_path / "c.json"), "--md", str(tmp_path / "c.md"),
                                      "--figure", str(tmp_path / "c.png")])
    assert result.exit_code == 0, result.output
    payload = json.loads((tmp_path / "c.json").read_text())
    assert [row["variant"] for row in payload["rows"]] == ["perception", "occlusion", "every_table", "matched_truth"]
    assert set(payload["questions"]) <= {"core", "occlusion"}
    assert (tmp_path / "c.png").stat().st_size > 1000 and "matched_truth" in (tmp_path / "c.md").read_text()

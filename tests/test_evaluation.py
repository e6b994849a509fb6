"""The evaluation stage: every method on one evidence per image, the evidence cache, calibration metrics,
difficulty binning and the ``po3d eval`` commands (on the tiny dataset of conftest)."""

from __future__ import annotations

import json
import random

import pytest
import torch

from po3d_ppl.evaluation import difficulty as dif
from po3d_ppl.evaluation.backends import Observation, SimulatedBackend
from po3d_ppl.evaluation.cache import EvidenceCache, evidence_from_tensors, evidence_to_tensors
from po3d_ppl.evaluation.calibration import binned_calibration_error, calibration_report, reliability_bins
from po3d_ppl.evaluation.metrics import table1
from po3d_ppl.evaluation.runner import INVALID, Prediction, evaluate, parse_methods, table1_column
from po3d_ppl.errors import InputError

SPLIT = "train"  # 4 of the 6 scenes


@pytest.fixture(scope="module")
def tiny(tiny_eval_dataset):
    return tiny_eval_dataset


@pytest.fixture(scope="module")
def certain_run(tiny, tmp_path_factory):
    cache = EvidenceCache(tmp_path_factory.mktemp("cache"))
    return evaluate(tiny, SPLIT, SimulatedBackend(noise=0.0), cache=cache, limit=2)


class CountingBackend(SimulatedBackend):
    calls: list

    def evidence(self, observation: Observation):
        self.calls.append(observation.index)
        return super().evidence(observation)


def _counting(noise: float) -> CountingBackend:
    backend = CountingBackend(noise=noise, seed=3)
    object.__setattr__(backend, "calls", [])
    return backend


def test_every_method_is_right_on_certain_evidence(certain_run):
    assert len(certain_run.records) > 20
    for variant in certain_run.variants:
        wrong = [r.item.question for r in certain_run.records if not r.correct(variant)]
        assert not wrong, (variant, wrong[:3])
    rows = {row.method: row for row in table1(certain_run)}
    assert rows["oracle"].overall.value == 1.0 and rows["ours"].overall.value == 1.0
    assert set(rows) == {"ours", "ours_joint", "thresholded", "soft", "oracle"}


def test_ours_matches_the_oracle_answer_by_answer_at_noise_0(certain_run):
    for r in certain_run.records:
        assert r.predictions["ours"].top == r.predictions["oracle"].top
        assert r.predictions["ours"].confidence == pytest.approx(1.0, abs=1e-9)


def test_the_cache_is_hit_on_a_rerun_and_keyed_by_the_backend(tiny, tmp_path):
    cache_dir = tmp_path / "cache"
    first = _counting(0.1)
    run1 = evaluate(tiny, SPLIT, first, ["soft"], cache=EvidenceCache(cache_dir), limit=2)
    assert len(first.calls) == 2
    again = _counting(0.1)
    cache = EvidenceCache(cache_dir)
    run2 = evaluate(tiny, SPLIT, again, ["soft"], cache=cache, limit=2)
    assert again.calls == [] and cache.hits == 2 and cache.misses == 0
    assert [r.predictions["soft"] for r in run1.records] == [r.predictions["soft"] for r in run2.records]
    other = _counting(0.2)  # another noise level is another key
    evaluate(tiny, SPLIT, other, ["soft"], cache=EvidenceCache(cache_dir), limit=1)
    assert len(other.calls) == 1
    assert not list(cache_dir.glob("*.pkl")) and len(list(cache_dir.glob("*.safetensors"))) == 3


def test_evidence_round_trips_through_safetensors(tiny):
    scene = tiny.scene(tiny.splits[SPLIT][0])
    evidence = SimulatedBackend(noise=0.2, seed=1).evidence(Observation(0, tiny.image_path(0), scene))
    back = evidence_from_tensors(*evidence_to_tensors(evidence))
    assert torch.equal(back.part_occludes_logodds, evidence.part_occludes_logodds)
    assert torch.equal(back.directions["left"], evidence.directions["left"])
    assert back.camera == evidence.camera


def test_a_damaged_cache_entry_is_recomputed(tiny, tmp_path):
    backend = _counting(0.1)
    evaluate(tiny, SPLIT, backend, ["thresholded"], cache=EvidenceCache(tmp_path), limit=1)
    (entry,) = tmp_path.glob("*.safetensors")
    entry.write_bytes(b"garbage")
    evaluate(tiny, SPLIT, backend, ["thresholded"], cache=EvidenceCache(tmp_path), limit=1)
    assert len(backend.calls) == 2


def test_ece_of_calibrated_and_overconfident_inputs():
    rng = random.Random(0)
    conf = [rng.random() for _ in range(20000)]
    correct = [rng.random() < c for c in conf]
    assert binned_calibration_error(conf, correct) < 0.02
    over = [0.95] * 1000
    half = [i % 2 == 0 for i in range(1000)]
    assert binned_calibration_error(over, half) == pytest.approx(0.45, abs=1e-6)
    assert binned_calibration_error(over, half, norm="max") == pytest.approx(0.45, abs=1e-6)


def test_certain_correct_answers_are_calibrated_despite_torchmetrics_3510():
    # 0.99 right, 1.0 wrong, 0.999 right: one bin (the last), mean confidence 0.99633, accuracy 2/3
    standard = abs((0.99 + 1.0 + 0.999) / 3 - 2 / 3)
    assert binned_calibration_error([0.99, 1.0, 0.999], [True, False, True]) == pytest.approx(standard, abs=1e-5)
    assert binned_calibration_error([1.0, 1.0, 0.0], [True, True, False]) < 1e-5
    bins = reliability_bins([1.0, 0.0, 0.5], [True, False, True])
    assert bins[-1].count == 1 and bins[0].count == 1 and sum(b.count for b in bins) == 3


def test_calibration_report_of_the_oracle_and_of_a_certain_wrong_method(certain_run):
    report = calibration_report(certain_run.records, "oracle")
    assert report.ece < 1e-5 and report.brier_full == 0 and report.nll == 0 and report.accuracy == 1
    for r in certain_run.records:  # the same records, every answer made certain and wrong
        r.predictions["wrong"] = Prediction((("no such answer", 1.0),), 0.0)
    wrong = calibration_report(certain_run.records, "wrong")
    assert wrong.ece == pytest.approx(1.0, abs=1e-5) and wrong.brier_top == 1.0 and wrong.nll > 13
    assert wrong.brier_full == pytest.approx(2.0)
    for r in certain_run.records:
        del r.predictions["wrong"]


def test_occlusion_ratio_bins():
    assert [dif.occlusion_bin(x) for x in (0.0, 0.049, 0.05, 0.1, 0.2999, 0.3, 0.95, 1.0)] == \
        [0, 0, 5, 10, 25, 30, 30, 30]
    with pytest.raises(ValueError):
        dif.occlusion_bin(1.5)


def test_part_size_bins():
    assert [dif.part_size_bin(x) for x in (5000, 301, 300, 151, 150, 101, 100, 51, 50, 21, 20, 0)] == \
        ["max", "max", 300, 300, 150, 150, 100, 100, 50, 50, 20, 20]


def test_difficulty_comes_from_the_trace(certain_run, tiny):
    pose = [r for r in certain_run.records if r.item.column == "Pose"]
    assert pose and all(r.occlusion_ratio is not None for r in pose)
    from po3d_ppl.questions.executor import execute

    r = pose[0]
    scene = tiny.scene(r.item.image_index)
    result = execute(scene, r.item.program)
    objects = [v for v, t in zip(result.outputs, result.types) if t == "Object"]
    assert r.occlusion_ratio == min(scene.objects[i].annotation.occlusion_ratio for i in objects)
    parts = [r for r in certain_run.records if r.item.column == "Part"]
    assert any(r.part_size is not None and r.part_size > 0 for r in parts)
    rows = dif.difficulty_table(certain_run.records, ["ours"], ["Pose"], "occlusion")
    assert sum(row.n for row in rows) == len(pose) and [row.bin for row in rows] == list(dif.OCCLUSION_BINS)


def test_referents_found_marks_the_questions_about_objects_perception_missed(tiny, certain_run):
    from po3d_ppl.evaluation.ceilings import objects_subset
    from po3d_ppl.evaluation.report import difficulty_markdown
    from po3d_ppl.questions.executor import execute

    assert all(r.referents_found for r in certain_run.records)  # the noiseless sensor's boxes are the truth's

    def without_first_object(evidence, scene):  # as if perception had missed the scene's object 0
        return objects_subset(evidence, list(range(1, evidence.num_objects)))

    run = evaluate(tiny, SPLIT, SimulatedBackend(noise=0.0), ("ours",), limit=2,
                   evidence_transform=without_first_object)
    for r in run.records:
        objects, parts = dif.trace_referents(execute(tiny.scene(r.item.image_index), r.item.program))
        assert r.referents_found == (0 not in objects | {owner for owner, _ in parts}), r.item.question
    missed = [r for r in run.records if not r.referents_found]
    assert missed and len(missed) < len(run.records)
    columns = sorted({r.item.column for r in run.records if r.item.column})
    rows = dif.difficulty_table(run.records, ["ours"], columns, "occlusion")
    binned = [r for r in run.records if r.item.column in columns and r.occlusion_ratio is not None]
    assert sum(row.found for row in rows) == sum(r.referents_found for r in binned) < len(binned)
    for row in rows:
        if row.found:
            right = [r.correct("ours") for r in binned
                     if r.referents_found and dif.occlusion_bin(r.occlusion_ratio) == row.bin]
            assert row.found_accuracy == pytest.approx(sum(right) / len(right))
    assert "every referent found" in difficulty_markdown("pose", rows, {})


def test_table1_columns():
    assert table1_column("parts", []) == "Part" and table1_column("pose", []) == "Pose"
    assert table1_column("occlusion", [{"type": "filter_occludee"}]) == "Occ."
    assert table1_column("obj_occlusion", [{"type": "relate_occluded"}]) == "Occ."
    assert table1_column("occlusion", [{"type": "object2part_all"}, {"type": "partquery_occlusion"}]) == "Part+Occ."
    assert table1_column("core", []) == "CLEVR core" and table1_column("height_depth", []) is None


def test_prediction_top_counts_the_invalid_outcome():
    assert Prediction((("red", 0.3),), 0.7).top == INVALID
    assert Prediction((("red", 0.6),), 0.4).top == "red"
    assert Prediction((), 0.0).top == INVALID
    assert Prediction(((1, 1.0),), 0.0).probability(True) == 0.0  # a count is not a boolean


def test_unknown_method_is_a_typed_error():
    with pytest.raises(InputError, match="--methods"):
        parse_methods("ours,magic")


def test_the_commands_write_their_reports(tiny, tmp_path):
    import typer
    from typer.testing import CliRunner

    from po3d_ppl.cli import evaluate as cli

    app, train_app, eval_app = typer.Typer(), typer.Typer(), typer.Typer()
    app.add_typer(eval_app, name="eval")
    cli.register(app, train_app, eval_app)
    common = ["--data", str(tiny.root), "--split", SPLIT, "--limit", "1", "--noise", "0",
              "--cache", str(tmp_path / "cache")]
    result = CliRunner().invoke(app, ["eval", "vqa", *common, "--json", str(tmp_path / "v.json"),
                                      "--md", str(tmp_path / "v.md"), "--figures", str(tmp_path / "fig"),
                                      "--records", str(tmp_path / "q.jsonl")])
    assert result.exit_code == 0, result.output
    report = json.loads((tmp_path / "v.json").read_text())
    assert {row["method"] for row in report["table1"]} >= {"ours", "oracle"} and report["families"]
    rows = [json.loads(line) for line in (tmp_path / "q.jsonl").read_text().splitlines()]
    assert len(rows) == report["questions"] and all(row["referents_found"] for row in rows)
    assert all(row["answers"]["oracle"]["correct"] and row["answers"]["oracle"]["p_truth"] == 1.0 for row in rows)
    assert all(row["answers"]["ours"]["top"] == row["truth"] for row in rows)
    assert (tmp_path / "fig" / "difficulty.png").stat().st_size > 1000
    result = CliRunner().invoke(app, ["eval", "calibration", *common, "--methods", "ours,soft",
                                      "--out", str(tmp_path / "cal"), "--sweep", "0"])
    assert result.exit_code == 0, result.output
    cal = json.loads((tmp_path / "cal" / "calibration.json").read_text())
    assert all(p["accuracy"] == 1.0 for p in cal["sweep"])
    ece = {p["method"]: p["ece"] for p in cal["sweep"]}
    assert ece["ours"] < 1e-5 and ece["soft"] < 0.01  # soft's independence rules leave a little doubt
    assert (tmp_path / "cal" / "reliability.png").exists() and (tmp_path / "cal" / "noise_sweep.png").exists()
    assert {(d["baseline"], d["metric"]) for d in cal["differences"]} == {("soft", "accuracy"), ("soft", "ece")}
    assert "## Ours against the baselines, paired" in (tmp_path / "cal" / "calibration.md").read_text()

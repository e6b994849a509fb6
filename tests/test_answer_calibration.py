"""Answer calibration: the map (monotone, mass-preserving, smoothing over the type's answers), its file, and a fit
that recovers the overconfidence of a simulated run."""

from __future__ import annotations

import random

import pytest

from po3d_ppl.errors import InputError, ModelFileError
from po3d_ppl.evaluation.answer_calibration import fit
from po3d_ppl.evaluation.calibration import calibration_report
from po3d_ppl.evaluation.runner import CALIBRATED, Prediction, QuestionItem, QuestionRecord, recalibrated, variants_of
from po3d_ppl.reasoning import AnswerDistribution
from po3d_ppl.reasoning.answer_calibration import (
    AnswerCalibration,
    TypeCalibration,
    answer_support,
    load_answer_calibration,
)


def _dist(probs: dict, answer_type: str, invalid: float = 0.0) -> AnswerDistribution:
    return AnswerDistribution(probs, invalid, "auto", answer_type)


def test_apply_is_monotone_keeps_the_mass_and_smooths_over_the_support():
    calibration = AnswerCalibration({"Color": TypeCalibration(2.0, 0.2)})
    dist = _dist({"red": 0.6, "blue": 0.3}, "Color", invalid=0.1)
    out = calibration.apply(dist)
    assert sum(out.probs.values()) == pytest.approx(0.9)  # the invalid mass is untouched
    assert out.invalid == 0.1 and out.top == "red"
    assert set(out.probs) == set(answer_support("Color", []))  # every colour gets a share of the smoothing
    assert out.probs["red"] < 0.6 and out.probs["blue"] > 0.3  # T > 1 flattens
    assert out.probs["green"] == pytest.approx(0.9 * 0.2 / 8)
    sharp = AnswerCalibration({"Color": TypeCalibration(0.5, 0.0)}).apply(dist)
    assert sharp.probs["red"] > 0.6 * 1.0 and "green" not in sharp.probs  # T < 1 sharpens; no smoothing, no new answers
    assert calibration.apply(_dist({True: 1.0}, "Bool")) == _dist({True: 1.0}, "Bool")  # type not listed


def test_integer_support_reaches_the_largest_count():
    assert answer_support("Integer", [3]) == list(range(11))
    assert answer_support("Integer", [14])[-1] == 14
    out = AnswerCalibration({"Integer": TypeCalibration(1.0, 0.1)}).apply(_dist({2: 1.0}, "Integer"))
    assert out.probs[0] == pytest.approx(0.1 / 11) and out.probs[2] == pytest.approx(0.9 + 0.1 / 11)


def test_bad_parameters_and_files_are_typed_errors(tmp_path):
    from po3d_ppl.model_store import write_entry
    from po3d_ppl.reasoning.answer_calibration import FILE, MODEL_NAME, model_name

    with pytest.raises(InputError, match="temperature"):
        TypeCalibration(0.0, 0.1)
    with pytest.raises(InputError, match="smoothing"):
        TypeCalibration(1.0, 1.0)
    assert load_answer_calibration(tmp_path) is None
    calibration = AnswerCalibration({"Bool": TypeCalibration(1.5, 0.3), "Integer": TypeCalibration(2.0, 0.1)})
    write_entry(MODEL_NAME, [calibration.save(tmp_path)], tmp_path, command="test")
    assert load_answer_calibration(tmp_path) == calibration
    assert load_answer_calibration(tmp_path, "soft") is None  # a baseline's is its own file
    soft = AnswerCalibration({"Bool": TypeCalibration(0.7, 0.05)})
    write_entry(model_name("soft"), [soft.save(tmp_path, "soft")], tmp_path, command="test")
    assert (tmp_path / "answer_calibration_soft.json").is_file()
    assert load_answer_calibration(tmp_path, "soft") == soft and load_answer_calibration(tmp_path) == calibration
    with pytest.raises(InputError, match="method"):
        model_name("../soft")
    (tmp_path / FILE).write_text((tmp_path / FILE).read_text().replace("1.5", "2.5"))
    with pytest.raises(ModelFileError, match="sha256"):
        load_answer_calibration(tmp_path)
    (tmp_path / "answer_calibration_soft.json").unlink()
    with pytest.raises(ModelFileError, match="--method soft"):
        load_answer_calibration(tmp_path, "soft")


def _overconfident_records(n: int, seed: int) -> list[QuestionRecord]:
    """Bool questions answered with confidence 0.95 that are right 75% of the time, and colour questions whose
    truth sometimes has no mass at all (as a missed object does)."""
    rng = random.Random(seed)
    records = []
    for i in range(n):
        truth = rng.random() < 0.5
        said = truth if rng.random() < 0.75 else not truth
        item = QuestionItem("core", "f:0", i, 0, "q", (), truth, "CLEVR core")
        records.append(QuestionRecord(item, "Bool", {"ours": Prediction(((said, 0.95), (not said, 0.05)), 0.0)}))
        colour = rng.choice(["red", "blue", "green"])
        said = colour if rng.random() < 0.8 else "gray"
        item = QuestionItem("core", "f:1", i, 1, "q", (), colour, "CLEVR core")
        records.append(QuestionRecord(item, "Color", {"ours": Prediction(((said, 1.0),), 0.0)}))
    return records


def test_fit_recovers_overconfidence_and_the_calibrated_variant_is_better_on_new_records():
    calibration, report = fit(_overconfident_records(400, 0))
    assert report["Bool"]["nll_after"] < report["Bool"]["nll_before"]
    assert calibration.types["Color"].smoothing > 0  # a temperature alone cannot reach a truth with no mass
    held_out = _overconfident_records(400, 1)
    for record in held_out:
        record.predictions[CALIBRATED] = recalibrated(record, calibration)
    raw, calibrated = calibration_report(held_out, "ours"), calibration_report(held_out, CALIBRATED)
    assert calibrated.accuracy == raw.accuracy  # monotone: the top answer never changes
    assert calibrated.ece < 0.05 < raw.ece
    assert variants_of(("ours", "soft"), calibrated=("ours",)) == ("ours", CALIBRATED, "ours_joint", "soft")
    assert variants_of(("ours", "soft"), calibrated=("ours", "soft")) == (
        "ours", CALIBRATED, "ours_joint", "soft", "soft_calibrated")


def test_a_baseline_is_fitted_and_recalibrated_like_ours():
    """A baseline's calibration is fitted on its own answers, and recalibrates those, not ours."""
    records = _overconfident_records(400, 0)
    for record in records:  # the baseline says what ours says, surer still
        record.predictions["soft"] = Prediction(tuple((a, min(1.0, p * 1.02)) for a, p in
                                                      record.predictions["ours"].probs), 0.0)
        record.predictions["ours"] = Prediction(((record.item.truth, 1.0),), 0.0)  # ours is right and sure
    calibration, _ = fit(records, "soft")
    assert calibration.types["Bool"].temperature > 1.0 or calibration.types["Bool"].smoothing > 0
    record = records[0]
    assert recalibrated(record, calibration, "soft") != record.predictions["soft"]
    assert recalibrated(record, calibration, "soft").top == record.predictions["soft"].top


def test_brier_grid_is_the_brier_score_of_the_recalibrated_distribution():
    import torch

    from po3d_ppl.evaluation.answer_calibration import SMOOTHINGS, TEMPERATURES, _tables, brier_grid

    records = _overconfident_records(30, 2)
    logp, sizes, truths = _tables(records, "ours")
    grid = brier_grid(logp, sizes, truths)
    t, s = 7, 5
    calibration = AnswerCalibration({kind: TypeCalibration(float(TEMPERATURES[t]), float(SMOOTHINGS[s]))
                                     for kind in ("Bool", "Color")})
    direct = []
    for record in records:
        dist = calibration.apply(_dist(dict(record.predictions["ours"].probs), record.answer_type))
        support = answer_support(record.answer_type, list(dist.probs))
        direct.append(sum((dist.probs.get(a, 0.0) - (a == record.item.truth)) ** 2 for a in support))
    assert float(grid[t, s]) == pytest.approx(sum(direct) / len(direct), rel=1e-6)
    assert torch.isfinite(grid).all()


def test_fit_by_brier_also_calibrates_and_an_unknown_objective_is_a_typed_error():
    calibration, _ = fit(_overconfident_records(400, 0), objective="brier")
    held_out = _overconfident_records(400, 1)
    for record in held_out:
        record.predictions[CALIBRATED] = recalibrated(record, calibration)
    assert calibration_report(held_out, CALIBRATED).ece < 0.05 < calibration_report(held_out, "ours").ece
    with pytest.raises(InputError, match="objective"):
        fit(held_out, objective="log")


def test_top_answer_map_moves_the_top_outcome_only_and_keeps_it_on_top():
    from po3d_ppl.reasoning.answer_calibration import TopAnswerMap

    top_map = TopAnswerMap((0.5, 0.9), (0.4, 0.8))
    assert top_map(0.7) == pytest.approx(0.6) and top_map(0.99) == 0.8 and top_map(0.1) == 0.4  # flat beyond
    out = AnswerCalibration(top_answer=top_map).apply(_dist({"red": 0.9, "blue": 0.06, "green": 0.03}, "Color",
                                                            invalid=0.01))
    assert out.probs["red"] == pytest.approx(0.8) and out.top == "red"
    assert sum(out.probs.values()) + out.invalid == pytest.approx(1.0)  # the total is kept
    # the other outcomes, the invalid mass among them, share the rest in their old ratios
    assert out.probs["blue"] / out.probs["green"] == pytest.approx(2.0) and out.invalid == pytest.approx(0.02)
    # a map below the runner-up is held at the tie, and the top answer stays first
    tied = AnswerCalibration(top_answer=TopAnswerMap((0.0, 1.0), (0.0, 0.1))).apply(
        _dist({"red": 0.5, "blue": 0.45, "green": 0.05}, "Color"))
    assert tied.top == "red" and tied.probs["red"] == pytest.approx(tied.probs["blue"])
    assert list(tied.probs)[0] == "red"
    # the invalid mass on top is the top outcome: mapped the same way, and the answers take the rest
    failed = AnswerCalibration(top_answer=top_map).apply(_dist({True: 0.3}, "Bool", invalid=0.7))
    assert failed.invalid == pytest.approx(0.6) and failed.probs == {True: pytest.approx(0.4)} and failed.top is None
    # ... unless the map would bring it down to an answer (a tie goes to the answer): then it stays
    low = AnswerCalibration(top_answer=TopAnswerMap((0.0, 1.0), (0.0, 0.1))).apply(_dist({True: 0.4}, "Bool", 0.6))
    assert low.invalid == 0.6 and low.probs == {True: 0.4}
    # a distribution mixing parses of several types has no vocabulary: the map reads its own answers
    mixed = AnswerCalibration(top_answer=top_map).apply(_dist({2: 0.9, "red": 0.1}, "mixed"))
    assert mixed.probs[2] == pytest.approx(0.8) and mixed.probs["red"] == pytest.approx(0.2)
    # one answer with all the mass: what the map takes goes evenly to the type's other answers
    sure = AnswerCalibration(top_answer=top_map).apply(_dist({2: 1.0}, "Integer"))
    assert sure.probs[2] == pytest.approx(0.8) and sure.probs[0] == pytest.approx(0.2 / 10) and len(sure.probs) == 11


def test_top_answer_map_file_round_trip_and_typed_errors(tmp_path):
    from po3d_ppl.model_store import write_entry
    from po3d_ppl.reasoning.answer_calibration import FILE, MODEL_NAME, TopAnswerMap

    for bad in (((0.5, 0.9), (0.4,)), ((0.5, 1.2), (0.4, 0.8)), ((0.9, 0.5), (0.4, 0.8)), ((0.5, 0.9), (0.8, 0.4))):
        with pytest.raises(InputError, match="TopAnswerMap"):
            TopAnswerMap(*bad)
    calibration = AnswerCalibration({"Bool": TypeCalibration(0.8, 0.05)}, TopAnswerMap((0.25, 0.75), (0.3, 0.7)))
    write_entry(MODEL_NAME, [calibration.save(tmp_path)], tmp_path, command="test")
    assert load_answer_calibration(tmp_path) == calibration
    unmapped = AnswerCalibration({"Bool": TypeCalibration(0.8, 0.05)})  # one layout, with or without the map
    assert AnswerCalibration.from_dict(unmapped.to_dict()) == unmapped and unmapped.to_dict()["top_answer"] is None
    (tmp_path / FILE).write_text('{"Bool": {"temperature": 0.8, "smoothing": 0.05}}')  # the layout before the map
    write_entry(MODEL_NAME, [tmp_path / FILE], tmp_path, command="test")
    with pytest.raises(ModelFileError, match="no 'types' or 'top_answer' entry.*po3d train answer-calibration"):
        load_answer_calibration(tmp_path)
    (tmp_path / FILE).write_text('{"types": {}, "top_answer": {"confidence": [0.5], "accuracy": [2.0]}}')
    write_entry(MODEL_NAME, [tmp_path / FILE], tmp_path, command="test")
    with pytest.raises(ModelFileError, match="in \\[0, 1\\]"):
        load_answer_calibration(tmp_path)


def test_fitted_top_answer_map_undoes_a_systematic_underconfidence():
    """Answers right 90% of the time at probability 0.7: the types' fit cannot see it per type when the smoothing
    is held, the pooled top-answer map reads it off and lifts the confidence to the accuracy."""
    from po3d_ppl.evaluation.answer_calibration import MIN_TOP_ANSWER_QUESTIONS, fit_top_answer

    rng = random.Random(3)
    records = []
    for i in range(600):
        truth = rng.random() < 0.5
        said = truth if rng.random() < 0.9 else not truth
        item = QuestionItem("core", "f:0", i, 0, "q", (), truth, "CLEVR core")
        records.append(QuestionRecord(item, "Bool", {"ours": Prediction(((said, 0.7), (not said, 0.3)), 0.0)}))
    top_map = fit_top_answer(records)
    assert top_map is not None and top_map(0.7) == pytest.approx(0.9, abs=0.03)
    assert fit_top_answer(records[:MIN_TOP_ANSWER_QUESTIONS - 1]) is None  # too few questions: no map
    with_map, report = fit(records, top_answer=True)
    without, _ = fit(records, top_answer=False)
    assert with_map.top_answer is not None and without.top_answer is None and report["top_answer"]["knots"] >= 1
    for name, calibration in (("with", with_map), ("without", without)):
        for record in records:
            record.predictions[f"{name}_map"] = recalibrated(record, calibration)
    after = calibration_report(records, "with_map")
    assert after.ece < calibration_report(records, "without_map").ece and after.ece < 0.02

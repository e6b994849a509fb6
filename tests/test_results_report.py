"""`po3d eval report`: one command writes the results page (targets, perception, Table 1, difficulty, calibration,
priors, sweep) and its JSON from the shipped models, on one image of a small dataset."""

from __future__ import annotations

import json

from typer.testing import CliRunner

from po3d_ppl.cli import app


def test_report_writes_every_section_and_the_command_that_made_it(shared_dataset, tmp_path):
    root, _, _ = shared_dataset
    out = tmp_path / "docs" / "results.md"
    result = CliRunner().invoke(app, ["eval", "report", "--data", str(root), "--limit", "1", "--priors-limit", "1",
                                      "--sweep", "0", "--sweep-limit", "1", "--timing-images", "0", "--cache",
                                      str(tmp_path / "cache"), "--out", str(out)])
    assert result.exit_code == 0, result.output
    text = out.read_text()
    assert f"po3d eval report --data {root}" in text
    for heading in ("## Targets", "## Perception", "## Accuracy", "## Difficulty", "## Calibration",
                    "## Fitted against hand-set priors", "## Noise sweep", "## Per-stage time"):
        assert heading in text, heading
    assert (out.parent / "figures" / "results" / "reliability.png").stat().st_size > 0
    payload = json.loads(out.with_suffix(".json").read_text())
    methods = [row["method"] for row in payload["calibration"]]
    assert methods[:2] == ["ours", "ours_calibrated"] and "thresholded" in methods and "oracle" in methods
    assert "soft_calibrated" in methods and "thresholded_calibrated" in methods  # the shipped baselines' maps
    assert "(each recalibrated on the validation seeds)" in text
    assert "### Ours against the baselines, paired" in text and "95% intervals over images" in text
    pairs = {(d["method"], d["baseline"], d["metric"]) for d in payload["differences"]}
    assert ("ours", "soft", "ece") in pairs and ("ours_calibrated", "thresholded_calibrated", "accuracy") in pairs
    table1 = text.split("## Accuracy")[1].split("## Difficulty")[0]
    assert "| ours_calibrated |" in table1 and "soft_calibrated" not in table1  # only the calibration table
    assert {row["priors"] for row in payload["priors"]} == {"hand-set", "fitted (shipped)"}
    assert payload["vqa"]["images"] == 1 and payload["perception"]["cache"]["misses"] == 1
    object_tables = payload["perception"]["object_tables"]  # the evidence's object tables, as reasoning reads them
    assert set(object_tables) == {"subtype_loglik", "color_loglik", "material_loglik", "size_loglik"}
    assert all(row["rows"] == 0 and row["ece"] is None or 0 <= row["ece"] <= 1 for row in object_tables.values())
    assert "| object table (matched proposals) |" in text.split("## Perception")[1].split("## Accuracy")[0]


def test_the_sweep_check_names_the_noise_levels_where_ours_does_not_win():
    from po3d_ppl.cli.results import _sweep_check
    from po3d_ppl.evaluation.calibration import SweepPoint

    def level(noise, ours_ece, soft_ece):
        return [SweepPoint(noise, "ours", 0.9, ours_ece, 10), SweepPoint(noise, "soft", 0.8, soft_ece, 10),
                SweepPoint(noise, "thresholded", 0.5, 0.4, 10)]

    exact = [SweepPoint(0.0, m, 1.0, 0.0, 10) for m in ("ours", "soft", "thresholded")]
    assert _sweep_check(exact + level(0.1, 0.02, 0.03) + level(0.2, 0.03, 0.05))[1:] == (True, "at 2 of 2 noise levels")
    name, met, detail = _sweep_check(exact + level(0.1, 0.04, 0.03) + level(0.2, 0.03, 0.05))
    assert not met and detail == "at 1 of 2 noise levels (not at 0.1)"
    assert not _sweep_check(exact)[1]  # noise 0 alone measures nothing


def test_a_comparison_the_paired_intervals_cannot_resolve_is_judged_not_resolved():
    from po3d_ppl.cli.results import VERDICT_TEXT, paired_verdict
    from po3d_ppl.evaluation.significance import Difference

    def ece(baseline, low, high):
        return Difference("ece", "ours", baseline, (low + high) / 2, low, high, 0.95, 1000)

    better = [ece("soft", -0.02, -0.01), ece("thresholded", -0.2, -0.1)]
    assert paired_verdict(True, better, "ours", "ece") is True
    straddling = [ece("soft", -0.0057, 0.0042), ece("thresholded", -0.2, -0.1)]
    assert VERDICT_TEXT[paired_verdict(True, straddling, "ours", "ece")] == "not resolved"
    assert paired_verdict(False, better, "ours", "ece") is False  # the point estimates decide against
    assert paired_verdict(True, [ece("soft", 0.01, 0.02)], "ours", "ece") is False  # an interval says worse
    assert paired_verdict(True, straddling, "ours", "accuracy") is True  # no intervals for that metric

"""Calibration of the projected tables: the record (apply, validation, files with checksums), the entries read
against a scene, and a Platt fit that finds the rate behind a floored table."""

from __future__ import annotations

import pytest
import torch

from po3d_ppl.errors import InputError, ModelFileError
from po3d_ppl.evaluation.projection import collect, fit_projection_calibration, measure, table_entries
from po3d_ppl.perception import simulated_evidence
from po3d_ppl.perception.projection_calibration import (
    TABLES,
    WEIGHTS,
    ProjectionCalibration,
    load_projection_calibration,
)


@pytest.fixture(scope="module")
def scene():
    from po3d_ppl.world import SceneConfig, generate_scene

    return generate_scene(7, SceneConfig(width=320, height=240, min_objects=5, max_objects=6)).scene


def test_apply_rescales_each_listed_table_and_keeps_the_diagonal(scene):
    evidence = simulated_evidence(scene, noise=0.1, seed=1)
    calibration = ProjectionCalibration({"occludes_logodds": (0.5, -1.0), "part_visible_logodds": (2.0, 0.5)})
    out = calibration.apply(evidence)
    n = evidence.num_objects
    off = ~torch.eye(n, dtype=torch.bool)
    assert torch.allclose(out.occludes_logodds[off], evidence.occludes_logodds[off] * 0.5 - 1.0)
    assert torch.all(out.occludes_logodds.diagonal() == 0)
    assert torch.allclose(out.part_visible_logodds, evidence.part_visible_logodds * 2.0 + 0.5)
    assert torch.equal(out.occluded_logodds, evidence.occluded_logodds)  # not listed: unchanged
    likelihood = ProjectionCalibration({"occluded_logodds": (2.0, 0.5)}, {"occluded_logodds": 0.2}).apply(evidence)
    assert torch.allclose(likelihood.occluded_logodds, evidence.occluded_logodds * 2.0 + 0.5 - torch.logit(
        torch.tensor(0.2, dtype=torch.float64)))  # the fitted base rate is divided out
    with pytest.raises(InputError, match="base rate"):
        ProjectionCalibration({"occluded_logodds": (1.0, 0.0)}, {"occluded_logodds": 1.0})
    with pytest.raises(InputError, match="unknown table"):
        ProjectionCalibration({"pose_loglik": (1.0, 0.0)})
    with pytest.raises(InputError, match="scale"):
        ProjectionCalibration({"occluded_logodds": (0.0, 0.0)})


def test_files_round_trip_and_are_checked(tmp_path):
    from po3d_ppl.model_store import write_entry
    from po3d_ppl.perception.projection_calibration import MODEL_NAME

    assert load_projection_calibration(tmp_path) is None  # none listed: the parser keeps the raw tables
    calibration = ProjectionCalibration({name: (1.0 + k, -0.5 * k) for k, name in enumerate(TABLES)},
                                        {name: 0.1 + 0.1 * k for k, name in enumerate(TABLES)})
    write_entry(MODEL_NAME, [calibration.save(tmp_path)], tmp_path, command="test")
    assert load_projection_calibration(tmp_path) == calibration
    (tmp_path / WEIGHTS).write_bytes((tmp_path / WEIGHTS).read_bytes()[:-3] + b"xyz")
    with pytest.raises(ModelFileError, match="sha256"):
        load_projection_calibration(tmp_path)


def test_entries_read_the_scene_truth(scene):
    """With certain simulated evidence every entry's sign is the truth."""
    evidence = simulated_evidence(scene, noise=0.0)
    entries = table_entries(evidence, scene)
    assert len(entries["occluded_logodds"][0]) == len(scene.objects)
    for name in TABLES:
        values, truth = entries[name]
        assert values, name
        assert all((v > 0) == t for v, t in zip(values, truth)), name


def test_platt_fit_finds_the_rate_behind_a_floored_table(scene):
    """Entries all at the +-2.94 floor whose events happen 2% / 90% of the time: the fit moves the probabilities
    to those rates, and the ECE falls."""
    generator = torch.Generator().manual_seed(0)
    low = torch.rand(4000, generator=generator) < 0.02
    high = torch.rand(1000, generator=generator) < 0.90
    floor = float(torch.logit(torch.tensor(0.95)))
    x = torch.cat([torch.full((4000,), -floor), torch.full((1000,), floor)]).double()
    y = torch.cat([low, high])
    entries = {name: (x, y) for name in TABLES}
    calibration, report = fit_projection_calibration(entries)
    a, b = calibration.platt["occluded_logodds"]
    assert torch.sigmoid(torch.tensor(-floor * a + b)) == pytest.approx(float(low.double().mean()), abs=0.005)
    assert torch.sigmoid(torch.tensor(floor * a + b)) == pytest.approx(float(high.double().mean()), abs=0.01)
    assert calibration.base_rate["occluded_logodds"] == pytest.approx(float(y.double().mean()))
    row = report["occluded_logodds"]
    assert row["after"]["ece"] < row["before"]["ece"] and row["after"]["nll"] < row["before"]["nll"]
    measured = measure(calibration, {"occluded_logodds": (x, y)})["occluded_logodds"]
    assert measured["calibrated"]["ece"] == row["after"]["ece"]
    one_sided = fit_projection_calibration({"occluded_logodds": (x, torch.zeros_like(y))})[1]
    assert one_sided["occluded_logodds"]["fitted"] is None  # nothing to fit without both outcomes
    assert collect([(simulated_evidence(scene, noise=0.0), scene)])["occluded_logodds"][0].numel() == \
        len(scene.objects)


def test_scene_model_posterior_is_the_fitted_one_at_the_world_rate(scene):
    """The calibrated table is a likelihood: with the base rate as the scene model's prior, the posterior of
    "object i is occluded" is the Platt probability, not the base rate counted twice."""
    from dataclasses import replace

    from po3d_ppl.evidence import ScenePriors
    from po3d_ppl.reasoning.posterior import site_posteriors

    evidence = simulated_evidence(scene, noise=0.2, seed=3)
    a, b, rate = 1.3, -0.7, 0.2
    calibrated = ProjectionCalibration({"occluded_logodds": (a, b)}, {"occluded_logodds": rate}).apply(evidence)
    posterior = site_posteriors(calibrated, replace(ScenePriors(), occluded=rate))["occluded"]
    expected = torch.sigmoid(evidence.occluded_logodds * a + b)
    assert torch.allclose(posterior[..., 1].reshape(-1), expected, atol=1e-9)


def test_part_look_scale_is_applied_saved_and_validated(scene, tmp_path):
    from po3d_ppl.model_store import write_entry
    from po3d_ppl.perception.projection_calibration import MODEL_NAME, STYLE_TABLE

    evidence = simulated_evidence(scene, noise=0.1, seed=1)
    out = ProjectionCalibration({"occluded_logodds": (1.0, 0.0)}, {"occluded_logodds": 0.2}, 1.5).apply(evidence)
    assert torch.allclose(out.part_style_loglik, evidence.part_style_loglik * 1.5)
    unscaled = ProjectionCalibration({"occluded_logodds": (1.0, 0.0)}).apply(evidence)
    assert torch.equal(unscaled.part_style_loglik, evidence.part_style_loglik)
    with pytest.raises(InputError, match="part-look scale"):
        ProjectionCalibration(style_scale=0.0)
    calibration = ProjectionCalibration({"occluded_logodds": (1.2, -0.1)}, {"occluded_logodds": 0.3}, 1.25)
    write_entry(MODEL_NAME, [calibration.save(tmp_path)], tmp_path, command="test")
    assert load_projection_calibration(tmp_path) == calibration
    assert calibration.to_dict()[STYLE_TABLE] == [1.25]


def test_part_look_scale_fit_sharpens_an_under_confident_table(scene):
    """Looks drawn from a table's posterior: the same table at half strength gets twice the scale, the fitted
    scale is the NLL's minimum, and the report shows the NLL falling; certain simulated evidence gives look
    entries of every visible part with its true look."""
    from po3d_ppl.evaluation.projection import fit_style_scale, style_entries, style_log_posterior
    from po3d_ppl.perception.projection_calibration import STYLE_TABLE

    generator = torch.Generator().manual_seed(0)
    tables = torch.randn(4000, 17, generator=generator, dtype=torch.float64) * 3
    truth = torch.multinomial(style_log_posterior(tables, 0.3).exp().float(), 1, generator=generator)[:, 0]
    full = fit_style_scale(tables, truth)
    calibration, report = fit_projection_calibration({STYLE_TABLE: (tables / 2, truth)})
    assert calibration.style_scale == pytest.approx(2 * full, rel=0.05)
    rate = float((truth > 0).double().mean())

    def nll(scale: float) -> float:
        return float(-style_log_posterior(tables / 2, rate, scale).gather(1, truth[:, None]).mean())

    best = calibration.style_scale
    assert nll(best) < nll(best * 0.8) and nll(best) < nll(best * 1.25)
    row = report[STYLE_TABLE]
    assert row["after"]["nll"] < row["before"]["nll"] and row["scale"] == pytest.approx(best, abs=1e-4)
    tables, truths = style_entries(simulated_evidence(scene, noise=0.0), scene)
    assert tables and len(tables) == len(truths) and all(len(t) == 17 for t in tables)
    assert any(t > 0 for t in truths) and any(t == 0 for t in truths)
    collected = collect([(simulated_evidence(scene, noise=0.0), scene)])[STYLE_TABLE]
    assert collected[0].shape == (len(truths), 17)

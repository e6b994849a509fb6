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
    edge_logodds,
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
    with pytest.raises(InputError, match="monotone"):
        ProjectionCalibration({"occluded_logodds": (1.0, 0.0, 0.5, 0.0)}, edge=2.0)
    with pytest.raises(InputError, match="need the edge"):
        ProjectionCalibration({"occluded_logodds": (1.0, 0.0, -0.5, 0.0)})


def test_edge_shifts_apply_only_at_the_floor_and_ceiling():
    edge = edge_logodds(0.05)
    table = torch.tensor([-edge, -1.0, 0.0, 1.0, edge], dtype=torch.float32)  # stored tables are float32
    calibration = ProjectionCalibration({"occluded_logodds": (2.0, 0.5, -3.0, 1.5)}, edge=edge)
    out = calibration.posterior_logodds("occluded_logodds", table.double())
    expected = table.double() * 2.0 + 0.5 + torch.tensor([-3.0, 0, 0, 0, 1.5], dtype=torch.float64)
    assert torch.allclose(out, expected)


def test_files_round_trip_and_are_checked(tmp_path):
    from po3d_ppl.model_store import write_entry
    from po3d_ppl.perception.projection_calibration import MODEL_NAME

    assert load_projection_calibration(tmp_path) is None  # none listed: the parser keeps the raw tables
    calibration = ProjectionCalibration({name: (1.0 + k, -0.5 * k, -0.1 * k, 0.2 * k) for k, name in enumerate(TABLES)},
                                        {name: 0.1 + 0.1 * k for k, name in enumerate(TABLES)}, edge=2.5)
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
    a, b, floor_shift, ceiling_shift = calibration.platt["occluded_logodds"]
    assert floor_shift == ceiling_shift == 0.0  # no edge given: plain Platt scaling
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


def test_edge_platt_fit_finds_the_floor_state_a_line_cannot():
    """Entries at the floor are almost never events, those between the edges follow a gentle slope, those at the
    ceiling mostly are: the edge fit recovers all three where one line is pulled flat by the floor's mass, and its
    likelihood is higher."""
    from po3d_ppl.evaluation.projection import fit_edge_platt

    generator = torch.Generator().manual_seed(1)
    edge = edge_logodds(0.05)
    between = (torch.rand(3000, generator=generator) * 2 - 1) * edge * 0.95
    x = torch.cat([torch.full((20000,), -edge), between, torch.full((1000,), edge)]).double()
    rate = torch.cat([torch.full((20000,), 0.002), torch.sigmoid(0.6 * between.double()),
                      torch.full((1000,), 0.85, dtype=torch.float64)])
    y = torch.rand(x.shape, generator=generator, dtype=torch.float64) < rate
    a, b, floor_shift, ceiling_shift = fit_edge_platt(x, y, edge)
    assert a == pytest.approx(0.6, abs=0.1) and b == pytest.approx(0.0, abs=0.15)
    calibration = ProjectionCalibration({"occluded_logodds": (a, b, floor_shift, ceiling_shift)}, edge=edge)
    fitted = torch.sigmoid(calibration.posterior_logodds("occluded_logodds", x))
    assert float(fitted[0]) == pytest.approx(0.002, abs=0.001)
    assert float(fitted[-1]) == pytest.approx(0.85, abs=0.03)
    plain = fit_edge_platt(x, y, None)
    assert plain[2:] == (0.0, 0.0)

    def nll(logits: torch.Tensor) -> float:
        return float(torch.nn.functional.binary_cross_entropy_with_logits(logits, y.double()))

    assert nll(calibration.posterior_logodds("occluded_logodds", x)) < nll(plain[0] * x + plain[1]) - 0.005
    with pytest.raises(InputError, match="both outcomes"):
        fit_edge_platt(x, torch.zeros_like(y), edge)


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


def test_object_table_scales_are_applied_saved_and_validated(scene, tmp_path):
    from safetensors.torch import save_file

    from po3d_ppl.model_store import write_entry
    from po3d_ppl.perception.projection_calibration import FORMAT, MODEL_NAME

    evidence = simulated_evidence(scene, noise=0.1, seed=1)
    out = ProjectionCalibration(object_scales={"subtype_loglik": 0.5, "size_loglik": 0.2}).apply(evidence)
    assert torch.allclose(out.subtype_loglik, evidence.subtype_loglik * 0.5)
    assert torch.allclose(out.size_loglik, evidence.size_loglik * 0.2)
    assert torch.equal(out.color_loglik, evidence.color_loglik) and torch.equal(out.pose_loglik, evidence.pose_loglik)
    for bad in ({"pose_loglik": 0.5}, {"subtype_loglik": 0.0}, {"size_loglik": float("nan")}):
        with pytest.raises(InputError, match="object table"):
            ProjectionCalibration(object_scales=bad)
    calibration = ProjectionCalibration({"occluded_logodds": (1.2, -0.1)}, {"occluded_logodds": 0.3}, 1.25,
                                        object_scales={"subtype_loglik": 0.52, "color_loglik": 1.1})
    write_entry(MODEL_NAME, [calibration.save(tmp_path)], tmp_path, command="test")
    assert load_projection_calibration(tmp_path) == calibration
    assert calibration.to_dict()["subtype_loglik"] == [0.52]
    save_file({"pose_loglik": torch.tensor([0.5], dtype=torch.float64)}, str(tmp_path / WEIGHTS),
              metadata={"format": FORMAT})
    write_entry(MODEL_NAME, [tmp_path / WEIGHTS], tmp_path, command="test")
    with pytest.raises(ModelFileError, match="unknown entries"):
        load_projection_calibration(tmp_path)


def test_object_table_scale_fit_softens_an_over_confident_table(scene):
    """Values drawn from a table's softmax: the same table twice as sharp gets half the scale, the report shows
    the NLL falling and the accuracy unchanged; simulated evidence gives one row per matched object per object
    table, with the scene's true values."""
    from po3d_ppl.evaluation.projection import fit_object_scale, object_entries
    from po3d_ppl.perception.attributes import OBJECT_HEADS
    from po3d_ppl.perception.projection_calibration import OBJECT_TABLES

    generator = torch.Generator().manual_seed(0)
    tables = torch.randn(4000, 21, generator=generator, dtype=torch.float64) * 2
    truth = torch.multinomial(torch.softmax(tables, -1).float(), 1, generator=generator)[:, 0]
    assert fit_object_scale(tables, truth) == pytest.approx(1.0, rel=0.1)
    calibration, report = fit_projection_calibration({"subtype_loglik": (tables * 2, truth)})
    assert calibration.object_scales["subtype_loglik"] == pytest.approx(0.5, rel=0.1)
    row = report["subtype_loglik"]
    assert row["after"]["nll"] < row["before"]["nll"] and row["after"]["accuracy"] == row["before"]["accuracy"]
    entries = object_entries(simulated_evidence(scene, noise=0.0), scene)
    assert set(entries) == set(OBJECT_TABLES)
    rows, truths = entries["color_loglik"]
    assert len(rows) == len(scene.objects) and all(len(r) == len(OBJECT_HEADS["color"]) for r in rows)
    assert sorted(OBJECT_HEADS["color"][t] for t in truths) == sorted(o.color for o in scene.objects)
    assert all(max(range(len(r)), key=r.__getitem__) == t for r, t in zip(rows, truths))  # noiseless: row = truth
    assert collect([(simulated_evidence(scene, noise=0.0), scene)])["size_loglik"][0].shape == (len(scene.objects), 2)

"""Scoring the object parser: matching, temperature and Platt fits recover known values, summary figures."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from po3d_ppl.evaluation.objects import (
    ImageOutcome,
    ObjectOutcome,
    fit_platt,
    fit_temperature,
    match_boxes,
    summarise,
)


def test_matching_is_greedy_one_to_one_above_the_iou_floor():
    import numpy as np

    pred = np.array([[0, 0, 10, 10], [1, 1, 10, 10], [50, 50, 5, 5]], dtype=float)
    truth = np.array([[0, 0, 10, 10], [100, 100, 4, 4]], dtype=float)
    assert match_boxes(pred, truth) == [(0, 0)]


def test_temperature_fit_recovers_the_generating_temperature():
    gen = torch.Generator().manual_seed(0)
    logits = 4.0 * torch.randn(6000, 5, generator=gen, dtype=torch.float64)
    target = torch.multinomial(torch.softmax(logits / 3.0, -1), 1, generator=gen)[:, 0]
    assert fit_temperature(logits, target) == pytest.approx(3.0, rel=0.08)


def test_calibration_fit_scales_an_overconfident_size_table():
    from po3d_ppl.evaluation.objects import fit_calibration

    gen = torch.Generator().manual_seed(2)
    objects, correct = [], 0
    for i in range(400):  # size tables hundreds of nats apart, wrong one time in ten
        truth = i % 2
        right = bool(torch.rand((), generator=gen) > 0.1)
        correct += right
        margin = 300.0 * (1.0 + float(torch.rand((), generator=gen)))
        table = [0.0, 0.0]
        table[truth if right else 1 - truth] = margin
        objects.append(ObjectOutcome("a.png", i, "car", 500, 0.0, 5.0, i, [0.0, -5, -5, -5, -5], 10.0, 0.1, 5.0,
                                     [0.0] * 12, 0, table, truth))
    image = ImageOutcome("a.png", objects, proposals=401, matched_small=0, existence_logodds=[3.0] * 400 + [-2.0],
                         proposal_matched=[True] * 400 + [False], seconds=1.0, timings={})
    calibration, report = fit_calibration([image])
    assert calibration.size_temperature > 50.0  # raw: a wrong size would be impossible for the scene model
    assert report["size_accuracy"] == pytest.approx(correct / 400)
    assert report["fitted"]["size_nll"] < 0.5 < report["raw"]["size_nll"]


def test_platt_fit_recovers_scale_and_bias():
    gen = torch.Generator().manual_seed(1)
    scores = 100.0 * torch.randn(8000, generator=gen, dtype=torch.float64)
    labels = torch.rand(8000, generator=gen, dtype=torch.float64) < torch.sigmoid(0.05 * scores - 1.0)
    a, b = fit_platt(scores, labels)
    assert a == pytest.approx(0.05, rel=0.1) and b == pytest.approx(-1.0, abs=0.15)


def test_summary_counts_detection_depth_order_and_occluded_subset():
    def obj(i, depth, proposal, occ=0.0, az=10.0):
        return ObjectOutcome("a.png", i, "car", 500, occ, depth, proposal, [0.0, -5, -5, -5, -5] if proposal >= 0
                             else [], az if proposal >= 0 else None, 0.1 if proposal >= 0 else None,
                             depth + 0.01 if proposal >= 0 else None)

    image = ImageOutcome("a.png", [obj(0, 5.0, 0), obj(1, 9.0, 1, occ=0.5, az=170.0), obj(2, 7.0, -1)],
                         proposals=3, matched_small=0, existence_logodds=[3.0, 2.0, -1.0],
                         proposal_matched=[True, True, False], seconds=1.0, timings={"coarse": 0.5})
    figures = summarise([image])
    assert set(figures["believed"]) == {"proposals", "precision", "recall", "existence_ece"}
    assert figures["precision"] == pytest.approx(2 / 3)
    assert figures["recall"] == pytest.approx(2 / 3)
    assert figures["azimuth_within_30"] == 0.5
    assert figures["depth_order_correct"] == 1.0 and figures["depth_order_pairs"] == 1
    assert figures["occluded_20pct"]["objects"] == 1 and figures["occluded_20pct"]["azimuth_within_30"] == 0.0
    assert figures["category_accuracy"] == 1.0
    assert not math.isnan(figures["category_ece"])


def test_certain_evidence_scores_perfectly_and_a_misread_is_counted():
    import dataclasses

    from po3d_ppl.evaluation.evidence_scores import EvidenceCounts
    from po3d_ppl.evaluation.objects import EvidenceAsProposals, score_image
    from po3d_ppl.perception import simulated_evidence
    from po3d_ppl.world import generate_scene

    scene = generate_scene(12).scene
    evidence = simulated_evidence(scene)
    counts = EvidenceCounts()
    counts.add(evidence, scene)
    figures = counts.figures()
    assert figures["matched"] == len(scene.objects)
    for key in ("subtype_accuracy", "color_accuracy", "material_accuracy", "size_accuracy",
                "part_attribute_accuracy"):
        assert figures[key] == 1.0, key
    assert figures["object_occlusion_f1"] in (1.0, None) and figures["part_occlusion_f1"] in (1.0, None)
    wrong = evidence.color_loglik.roll(1, dims=-1)  # every colour read as its neighbour
    counts = EvidenceCounts()
    counts.add(dataclasses.replace(evidence, color_loglik=wrong), scene)
    assert counts.figures()["color_accuracy"] == 0.0
    outcome = score_image(EvidenceAsProposals.of(evidence), scene, "x", 0.0)
    assert all(o.proposal >= 0 and o.azimuth_error < 1e-6 for o in outcome.objects if o.visible_pixels >= 200)


def _obj(i, box, proposal, pixels=500):
    return ObjectOutcome("a.png", i, "car", pixels, 0.0, 5.0, proposal, box=box)


def _failing_image() -> ImageOutcome:
    """One found object and one failure of every kind."""
    objects = [_obj(0, [0, 0, 10, 10], 0),  # found
               _obj(1, [8, 0, 10, 10], -1),  # beside it, inside proposal 0's wide box: merged
               _obj(2, [100, 0, 20, 10], -1),  # proposal 1 covers its left half only: wrong extent
               _obj(3, [300, 300, 10, 10], -1),  # nothing near: unseen
               _obj(4, [200, 0, 10, 10], -1, pixels=50)]  # under the pixel floor: not counted
    proposals = [[0, 0, 18, 10], [100, 0, 8, 10], [2, 0, 10, 10], [500, 0, 10, 10]]
    return ImageOutcome("a.png", objects, proposals=4, matched_small=0, existence_logodds=[1.0] * 4,
                        proposal_matched=[True, False, False, False], seconds=0.0, timings={},
                        proposal_boxes=proposals)


def test_detection_failures_sort_misses_and_false_proposals_by_the_box_that_overlaps_them():
    from po3d_ppl.evaluation.objects import detection_failures, image_failures

    obj, image = _obj, _failing_image()
    assert image_failures(image).missed == {1: "merged", 2: "misboxed", 3: "unseen"}
    failures = detection_failures([image])
    assert failures["missed"] == {"merged": 1, "misboxed": 1, "unseen": 1}
    # proposal 2 overlaps the found object 0 (a duplicate), 1 the missed object 2, 3 nothing
    assert failures["false_proposals"] == {"duplicate": 1, "misboxed": 1, "phantom": 1}
    old = ImageOutcome("a.png", [obj(0, [], -1)], 1, 0, [1.0], [False], 0.0, {})  # saved before boxes were kept
    assert detection_failures([old]) == {"missed": {"merged": 0, "misboxed": 0, "unseen": 0},
                                         "false_proposals": {"duplicate": 0, "misboxed": 0, "phantom": 0}}


def test_the_failure_gallery_draws_the_worst_images_and_lists_them(tmp_path):
    import cv2

    from po3d_ppl.errors import InputError
    from po3d_ppl.evaluation.failure_gallery import FALSE, MISSED, write_gallery

    picture = tmp_path / "a.png"
    cv2.imwrite(str(picture), np.full((400, 600, 3), 128, dtype=np.uint8))
    found = [_obj(0, [0, 0, 10, 10], 0)]
    clean = ImageOutcome("b.png", found, 1, 0, [1.0], [True], 0.0, {}, [[0, 0, 10, 10]])
    index = write_gallery([clean, _failing_image()], [picture, picture], tmp_path / "gallery", images=5)
    text = index.read_text()
    assert "a_failures.png" in text and "b_failures" not in text  # only images with failures are drawn
    assert "1 merged, 1 misboxed, 1 unseen" in text and "1 duplicate, 1 misboxed, 1 phantom" in text
    drawn = cv2.imread(str(tmp_path / "gallery" / "a_failures.png"))
    assert drawn.shape[0] > 400  # the legend band below the image
    assert (drawn[300:311, 300] == MISSED).all(axis=-1).any()  # the unseen object's box edge, in red
    assert (drawn[0:11, 500] == FALSE).all(axis=-1).any()  # the phantom proposal's box edge, in orange
    with pytest.raises(InputError, match="image"):
        write_gallery([_failing_image()], [tmp_path / "gone.png"], tmp_path / "other")


def test_believed_detection_drops_the_proposals_existence_disbelieves():
    """A found object whose only proposal has existence log-odds below 0 counts as found in the headline recall
    and as missed among the believed proposals; a disbelieved false proposal leaves the believed precision."""
    from po3d_ppl.evaluation.objects import believed_detection

    objects = [_obj(0, [0, 0, 10, 10], 0), _obj(1, [50, 0, 10, 10], 1), _obj(2, [100, 0, 10, 10], -1)]
    image = ImageOutcome("a.png", objects, proposals=4, matched_small=0, existence_logodds=[3.0, -8.0, 2.0, -1.0],
                         proposal_matched=[True, True, False, False], seconds=0.0, timings={},
                         proposal_boxes=[[0, 0, 10, 10], [50, 0, 10, 10], [300, 0, 10, 10], [400, 0, 10, 10]])
    believed = believed_detection([image])
    assert believed["recall"] == pytest.approx(1 / 3) and believed["precision"] == pytest.approx(1 / 2)
    assert believed["proposals"] == 2 and 0 < believed["existence_ece"] < 1

"""Silhouette alignment: the pixel shift and yaw offset that put a rendered outline on the visible mask, scored only
where no other proposal is, and the world's renders moved back onto a known pose."""

from __future__ import annotations

import numpy as np
import pytest

from po3d_ppl.errors import InputError
from po3d_ppl.perception.alignment import AlignmentConfig, align_silhouette, best_shift


def _box(h: int, w: int, y0: int, x0: int, dy: int, dx: int) -> np.ndarray:
    out = np.zeros((h, w), dtype=bool)
    out[y0:y0 + dy, x0:x0 + dx] = True
    return out


def test_best_shift_recovers_a_known_shift():
    mask = _box(60, 80, 20, 30, 15, 25)
    silhouette = _box(60, 80, 17, 34, 15, 25)  # the mask moved up 3 and right 4
    shift, iou, start = best_shift(silhouette, np.ones_like(mask), mask, radius=6)
    assert shift == (-4, 3)
    assert iou == pytest.approx(1.0) and start < 0.7


def test_best_shift_scores_only_free_pixels():
    mask = _box(60, 80, 20, 30, 15, 10)  # the visible left part of an object
    silhouette = _box(60, 80, 20, 30, 15, 25)  # the whole object, its right part hidden by another proposal
    free = ~_box(60, 80, 0, 40, 60, 40)
    shift, iou, _ = best_shift(silhouette, free, mask, radius=4)
    assert shift == (0, 0) and iou == pytest.approx(1.0)


def test_align_silhouette_picks_the_yaw_offset_and_keeps_small_masks():
    mask = _box(60, 80, 20, 30, 15, 25)

    def render(offset: float) -> np.ndarray:  # a "turn" changes the width; offset 3 fits
        return _box(60, 80, 20, 30, 15, 25 + int(abs(offset - 3.0)))

    found = align_silhouette(render, mask, np.ones_like(mask), AlignmentConfig(yaw_offsets=(-3.0, 0.0, 3.0, 6.0)))
    assert found.yaw_offset == 3.0 and found.iou_after == pytest.approx(1.0) and found.iou_before < 1.0
    tiny = _box(60, 80, 20, 30, 5, 5)
    assert align_silhouette(render, tiny, np.ones_like(tiny)).shift == (0, 0)
    with pytest.raises(InputError):
        AlignmentConfig(yaw_offsets=())


def test_world_render_is_pulled_back_onto_its_pose(torch_one_thread):
    """A subtype mesh rendered 0.15 to the side and 6 degrees off is aligned back to the truth's outline."""
    from po3d_ppl.perception.image_input import CameraPrior
    from po3d_ppl.perception.scene_parser import _silhouette, _spec

    camera = CameraPrior(320, 240).base
    truth = _silhouette(_spec("sedan", "large", 0.4, -0.2, 40.0), camera, (240, 320))

    def render(offset: float) -> np.ndarray:
        return _silhouette(_spec("sedan", "large", 0.55, -0.2, 34.0 + offset), camera, (240, 320))

    found = align_silhouette(render, truth, np.ones_like(truth), AlignmentConfig(min_pixels=50))
    assert found.yaw_offset == 6.0
    assert found.shift != (0, 0)
    assert found.iou_after > 0.9 > found.iou_before

"""Silhouette alignment: the last few pixels and degrees of each proposal's pose, before parts are projected.

The object parser places each object on a stride-8 feature grid (refined by a few gradient steps) with its
azimuth in 15-degree bins, and the category mesh it fits encloses every subtype. That is enough to detect and to
name an object, but not to project its parts: on seed 712 the projected part masks of the right subtype had the
right areas (a wheel of 898 pixels projected as 818) but a median IoU of 0.16 with the true ones. A part of 50
pixels is missed by a shift of 5 pixels or a turn of 7 degrees.

So each proposal's most likely subtype mesh is rendered as the world renders it (embree), at a few yaw offsets
around its best azimuth, and its silhouette is slid over the image by whole pixels: the (yaw, shift) with the
highest IoU against the proposal's visible mask, on the pixels no other proposal owns (an occluded object is
compared only where it can be seen), wins, and the shift is carried back to the ground through the camera. This
is render-and-compare on the one cue the world's renders share exactly with the image (the outline), at the
resolution of the image rather than of the features.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from po3d_ppl.errors import InputError


@dataclass(frozen=True)
class AlignmentConfig:
    """Search of :func:`align_silhouette`."""

    #: Yaw offsets (degrees) tried around the best azimuth bin's centre (bins are 15 degrees wide).
    yaw_offsets: tuple[float, ...] = (-9.0, -6.0, -3.0, 0.0, 3.0, 6.0, 9.0)
    #: Image shifts up to this many pixels in each direction, every pixel.
    max_shift_px: int = 10
    #: Proposals with fewer visible pixels keep their pose (too little outline to align).
    min_pixels: int = 150
    #: A new pose is kept only if it raises the IoU by at least this much (noise guard).
    min_gain: float = 0.01

    def __post_init__(self) -> None:
        if not self.yaw_offsets or not (isinstance(self.max_shift_px, int) and self.max_shift_px >= 0):
            raise InputError("AlignmentConfig", "needs at least one yaw offset and max_shift_px >= 0")


@dataclass(frozen=True)
class Alignment:
    """The best (yaw offset, image shift) of one proposal and the IoU before and after."""

    yaw_offset: float
    shift: tuple[int, int]
    iou_before: float
    iou_after: float


def best_shift(silhouette: np.ndarray, free: np.ndarray, mask: np.ndarray, radius: int
               ) -> tuple[tuple[int, int], float, float]:
    """((dx, dy), IoU there, IoU unshifted) of ``silhouette`` moved by whole pixels within ``radius``, scored as
    IoU(moved silhouette & free, mask). All boolean [H, W]; computed on the padded box around both.

    Every shift at once: the moved silhouette's overlap with ``free & mask`` and with ``free`` are two
    cross-correlations (``cv2.matchTemplate``; counts of 0/1 pixels are exact in float32), so the cost does not
    grow with the number of shifts. Ties go to the first shift in (dy, dx) order."""
    import cv2

    ys, xs = np.nonzero(silhouette | mask)
    if ys.size == 0:
        return (0, 0), 0.0, 0.0
    h, w = mask.shape
    y0, y1 = max(ys.min() - radius, 0), min(ys.max() + radius + 1, h)
    x0, x1 = max(xs.min() - radius, 0), min(xs.max() + radius + 1, w)
    sil = np.pad(silhouette[y0:y1, x0:x1], radius).astype(np.float32)
    target, allowed = mask[y0:y1, x0:x1], free[y0:y1, x0:x1]
    # result[u, v] sums over the window with the silhouette moved by (dy, dx) = (radius - u, radius - v)
    inter = cv2.matchTemplate(sil, (target & allowed).astype(np.float32), cv2.TM_CCORR)[::-1, ::-1]
    moved = cv2.matchTemplate(sil, allowed.astype(np.float32), cv2.TM_CCORR)[::-1, ::-1]
    inter, moved = np.rint(inter).astype(np.int64), np.rint(moved).astype(np.int64)
    union = moved + int(target.sum()) - inter
    iou = np.where(union > 0, inter / np.maximum(union, 1), 0.0)
    dy, dx = np.unravel_index(int(np.argmax(iou)), iou.shape)
    return (int(dx) - radius, int(dy) - radius), float(iou[dy, dx]), float(iou[radius, radius])


def align_silhouette(render, mask: np.ndarray, free: np.ndarray, config: AlignmentConfig = AlignmentConfig()
                     ) -> Alignment:
    """The best yaw offset and image shift for one proposal. ``render(yaw_offset)`` gives the [H, W] silhouette of
    its subtype mesh at that offset from its current yaw; ``mask`` its visible mask; ``free`` the pixels no other
    proposal owns."""
    if int(mask.sum()) < config.min_pixels:
        return Alignment(0.0, (0, 0), 0.0, 0.0)
    results = []
    for offset in config.yaw_offsets:
        shift, iou, start = best_shift(render(offset), free, mask, config.max_shift_px)
        results.append((iou, offset, shift, start))
    before = next((r[3] for r in results if r[1] == 0.0), 0.0)
    iou, offset, shift, _ = max(results, key=lambda r: r[0])
    if iou < before + config.min_gain:
        return Alignment(0.0, (0, 0), before, before)
    return Alignment(float(offset), shift, before, iou)

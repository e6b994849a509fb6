"""Graded occlusion of one projected hypothesis: the world's occlusion rule applied under small image shifts.

A projection reads "part p is occluded by object j" off one rendering, and the world's rule behind it is a
threshold on pixel counts (an occluder hides at least 16 pixels of an entity that keeps the public level 1 or 2:
:func:`~po3d_ppl.world.scene.occluder_mask`). Read off one rendering it is a yes or a no, and a few pixels of error
in where the parser put a proposal relative to its neighbours flip it: on seed 716, a quarter of the truly occluded
parts were read "not occluded" under every hypothesis, and a third of those read "occluded" were not. The parser's
placement error relative to its neighbours is a few pixels, so the rule is averaged over shifts of the proposal's
own rendering against the others' (a Gaussian grid), which turns the yes/no into the probability that the rule
holds under that error. Shifting the solo rendering, rather than re-casting rays at moved positions, keeps it to
array slicing (a 5x5 grid costs a few milliseconds per hypothesis); the hit distances stay those of the unshifted
rays, which for shifts of a few pixels changes no depth order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from po3d_ppl.world.renderer import SoloView
from po3d_ppl.world.scene import occluder_mask


@dataclass(frozen=True)
class ShiftGrid:
    """Image shifts ``(dy, dx)`` in pixels and their weights (summing to 1)."""

    offsets: np.ndarray
    weights: np.ndarray

    @classmethod
    def gaussian(cls, sigma_px: float, steps: int = 2) -> ShiftGrid:
        """A ``(2 * steps + 1)``-square grid at multiples of ``sigma_px``, weighted by a normal of that spread
        (``sigma_px`` 0: the unshifted rendering alone)."""
        if sigma_px <= 0 or steps == 0:
            return cls(np.zeros((1, 2), dtype=np.int64), np.ones(1))
        ticks = np.arange(-steps, steps + 1, dtype=np.float64)
        dy, dx = np.meshgrid(ticks, ticks, indexing="ij")
        weights = np.exp(-0.5 * (dy ** 2 + dx ** 2)).ravel()
        offsets = np.rint(np.stack([dy.ravel(), dx.ravel()], -1) * sigma_px).astype(np.int64)
        return cls(offsets, weights / weights.sum())

    @property
    def margin(self) -> int:
        return int(np.abs(self.offsets).max())


@dataclass(frozen=True)
class GradedOcclusion:
    """Probabilities over the shift grid, for one hypothesis of one proposal among ``J`` others (in the order
    given): the object's and each part's."""

    occluded: float
    occludes: np.ndarray  # [J]
    part_occluded: np.ndarray  # [parts]
    part_occludes: np.ndarray  # [parts, J]
    part_visible: np.ndarray  # [parts]: visible pixels >= the world's part visibility threshold


def _nearest_of(others: list[SoloView], y0: int, x0: int, height: int, width: int) -> tuple[np.ndarray, np.ndarray]:
    """The others composited in the window ``[y0:y0+height, x0:x0+width]``: nearest hit distance and its index."""
    distance = np.full((height, width), np.inf, dtype=np.float32)
    index = np.full((height, width), -1, dtype=np.int64)
    for j, view in enumerate(others):
        h, w = view.face.shape
        top, left = max(y0, view.y0), max(x0, view.x0)
        bottom, right = min(y0 + height, view.y0 + h), min(x0 + width, view.x0 + w)
        if top >= bottom or left >= right:
            continue
        theirs = view.distance[top - view.y0:bottom - view.y0, left - view.x0:right - view.x0]
        window = (slice(top - y0, bottom - y0), slice(left - x0, right - x0))
        nearer = theirs < distance[window]
        distance[window][nearer] = theirs[nearer]
        index[window][nearer] = j
    return distance, index


def graded_occlusion(own: SoloView, others: list[SoloView], parts: int, grid: ShiftGrid,
                     min_visible_part_pixels: int) -> GradedOcclusion:
    """Apply the world's occlusion and visibility rules to ``own`` shifted by every offset of ``grid`` against the
    ``others`` (rendered alone each), and average them with the grid's weights."""
    n_others = len(others)
    margin = grid.margin
    h, w = own.face.shape
    distance, index = _nearest_of(others, own.y0 - margin, own.x0 - margin, h + 2 * margin, w + 2 * margin)
    present = own.face >= 0
    # entity label per pixel: part p -> p, body -> parts (the object is every label together)
    label = np.where(own.parts >= 0, own.parts, parts).astype(np.int64)[present]
    own_distance = own.distance[present]
    rows, cols = np.nonzero(present)
    unoccluded = np.bincount(label, minlength=parts + 1)  # [parts + 1]
    bins = (parts + 1) * (n_others + 1)
    overlaps = np.empty((len(grid.weights), parts + 1, n_others + 1), dtype=np.int64)
    for k, (dy, dx) in enumerate(grid.offsets):
        # own moved by (dy, dx) against the others = the others read at the opposite offset in own's frame
        theirs = distance[rows + margin + dy, cols + margin + dx]
        hidden = theirs < own_distance
        by = index[rows + margin + dy, cols + margin + dx][hidden]
        overlaps[k] = np.bincount(label[hidden] * (n_others + 1) + by + 1, minlength=bins).reshape(parts + 1, -1)
    overlaps = overlaps[:, :, 1:]  # [shifts, labels, others]; every hidden pixel has a nearer other
    part_hidden = overlaps[:, :parts].sum(-1)  # [shifts, parts]
    part_by = occluder_mask(unoccluded[:parts], part_hidden, overlaps[:, :parts])  # [shifts, parts, others]
    object_overlaps = overlaps.sum(1)  # [shifts, others]
    object_by = occluder_mask(unoccluded.sum(), object_overlaps.sum(-1), object_overlaps)  # [shifts, others]
    visible = unoccluded[:parts] - part_hidden >= min_visible_part_pixels
    weights = grid.weights
    return GradedOcclusion(
        occluded=float(weights @ object_by.any(-1)),
        occludes=np.tensordot(weights, object_by, 1),
        part_occluded=np.tensordot(weights, part_by.any(-1), 1),
        part_occludes=np.tensordot(weights, part_by, 1),
        part_visible=np.tensordot(weights, visible, 1),
    )

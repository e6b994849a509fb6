"""Difficulty analysis (paper section 5.4 and its appendix tables): accuracy against occlusion and part size.

A question's *occlusion ratio* is the minimum occlusion ratio (1 - visible / unoccluded pixels) of the objects in
its reasoning trace; its *part size* is the visible area in pixels of the largest part it refers to. The trace is
read from the reference executor's node outputs on the ground-truth scene: ``Object`` and ``Part`` values (the
``unique`` results and what is queried), never whole sets (``scene()`` holds every object).

Bins, as we read the paper's tables (they do not say whether bins are cumulative):

- occlusion ratio, left-closed 5% bins: 0 = [0, 5%), 5 = [5%, 10%), ..., 25 = [25%, 30%), 30 = [30%, 100%];
- part size, intervals (s, t]: max = (300, inf), 300 = (150, 300], 150 = (100, 150], 100 = (50, 100],
  50 = (20, 50], 20 = [0, 20].

The relative drop of a bin is (accuracy of the first bin - its accuracy) / accuracy of the first bin.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from po3d_ppl import ontology

OCCLUSION_BINS = (0, 5, 10, 15, 20, 25, 30)  # percent, lower edges
PART_SIZE_BINS = ("max", 300, 150, 100, 50, 20)  # upper edges in pixels ("max": above 300)


def trace_referents(result) -> tuple[set[int], set[tuple[int, int]]]:
    """The objects and the (object, slot) parts a reference execution's trace refers to."""
    objects, parts = set(), set()
    for value, kind in zip(result.outputs, result.types, strict=False):
        if kind == "Object":
            objects.add(int(value))
        elif kind == "Part":
            parts.add((int(value[0]), int(value[1])))
    return objects, parts


def trace_difficulty(scene, result) -> tuple[float | None, int | None]:
    """(min occlusion ratio of the trace's objects, largest visible part area) from a reference execution."""
    objects, parts = trace_referents(result)
    ratios = [scene.objects[i].annotation.occlusion_ratio for i in sorted(objects)
              if scene.objects[i].annotation is not None]
    sizes = [_part_pixels(scene, i, slot) for i, slot in sorted(parts)]
    sizes = [s for s in sizes if s is not None]
    return (min(ratios) if ratios else None), (max(sizes) if sizes else None)


def referents_found(result, found: set[int] | None) -> bool | None:
    """Whether perception found (matched a proposal to) every object the trace refers to, parts' owners included;
    None when the evidence cannot be matched to the scene (``found`` None)."""
    if found is None:
        return None
    objects, parts = trace_referents(result)
    return (objects | {owner for owner, _ in parts}) <= found


def _part_pixels(scene, obj: int, slot: int) -> int | None:
    o = scene.objects[obj]
    names = ontology.PARTS[o.subtype]
    annotation = o.part_annotations.get(names[slot]) if slot < len(names) else None
    return None if annotation is None else int(annotation.visible_pixels)


def occlusion_bin(ratio: float) -> int:
    """The lower edge (percent) of the 5% bin holding ``ratio``; 30 holds everything from 30% up."""
    if not 0.0 <= ratio <= 1.0 or math.isnan(ratio):
        raise ValueError(f"an occlusion ratio is in [0, 1], got {ratio!r}")
    percent = ratio * 100.0 + 1e-9  # 0.05 stored as 0.04999... belongs to the 5% bin
    return min(int(percent // 5) * 5, OCCLUSION_BINS[-1])


def part_size_bin(pixels: int) -> int | str:
    """The part-size column of a part of ``pixels`` visible pixels (see the module docstring)."""
    if pixels < 0:
        raise ValueError(f"a part area is >= 0 pixels, got {pixels!r}")
    if pixels > 300:
        return "max"
    for upper, lower in zip(PART_SIZE_BINS[1:], (*PART_SIZE_BINS[2:], 0), strict=True):
        if pixels > lower or lower == 0:
            return upper
    raise AssertionError("unreachable")


@dataclass(frozen=True)
class DifficultyRow:
    """Accuracy of one method in one bin."""

    method: str
    bin: int | str
    n: int
    accuracy: float | None
    drop: float | None  # relative to the first bin
    #: Of the ``n`` questions, those whose every referent perception found (None: evidence without boxes), and
    #: the accuracy on them: what separates the objects perception missed from the readings it got wrong.
    found: int | None = None
    found_accuracy: float | None = None


def difficulty_table(records, variants: Sequence[str], columns: Sequence[str], key: str) -> list[DifficultyRow]:
    """Rows per (variant, bin) over records of the given Table 1 columns, binned by ``key``
    (``"occlusion"`` or ``"part_size"``)."""
    bins, bin_of, value = ((OCCLUSION_BINS, occlusion_bin, lambda r: r.occlusion_ratio) if key == "occlusion"
                           else (PART_SIZE_BINS, part_size_bin, lambda r: r.part_size))
    chosen = [r for r in records if r.item.column in columns and value(r) is not None]
    matched = any(r.referents_found is not None for r in chosen)  # the evidence could be matched to the scenes
    rows = []
    for variant in variants:
        groups: dict = {b: [] for b in bins}
        for r in chosen:
            groups[bin_of(value(r))].append(r)
        first = None
        for b in bins:
            n = len(groups[b])
            acc = sum(r.correct(variant) for r in groups[b]) / n if n else None
            if first is None and acc is not None and b == bins[0]:
                first = acc
            drop = (first - acc) / first if (first and acc is not None) else None
            found = [r for r in groups[b] if r.referents_found]
            rows.append(DifficultyRow(variant, b, n, acc, drop, len(found) if matched else None,
                                      sum(r.correct(variant) for r in found) / len(found) if found else None))
    return rows


#: The paper's appendix tables (accuracy %, by bin), for side-by-side reporting.
PAPER_POSE_BY_OCCLUSION = {
    "PNSVQA": (87.43, 74.09, 74.09, 63.16, 62.01, 60.33, 58.52),
    "PNSVQA + Projection": (86.30, 74.61, 67.20, 66.78, 60.26, 56.52, 55.56),
    "PO3D-VQA": (86.43, 86.05, 84.32, 75.00, 79.44, 73.22, 67.98),
}
PAPER_PART_BY_SIZE = {
    "PNSVQA": (57.31, 51.00, 37.50, 44.18, 40.85, 29.73),
    "PNSVQA + Projection": (58.89, 57.54, 42.64, 43.20, 46.73, 38.67),
    "PO3D-VQA": (64.04, 64.80, 60.16, 57.03, 49.05, 55.41),
}
PAPER_PART_OCC_BY_SIZE = {
    "PNSVQA": (58.18, 54.98, 54.05, 52.09, 45.20, 21.28),
    "PNSVQA + Projection": (61.85, 50.64, 56.77, 53.97, 55.29, 45.83),
    "PO3D-VQA": (81.68, 75.32, 77.20, 71.54, 67.00, 53.19),
}

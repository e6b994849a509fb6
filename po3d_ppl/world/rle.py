"""The public Super-CLEVR-3D mask encoding (spec §1.5).

A mask is flattened row-major and written as comma-separated run lengths that alternate zeros / ones, starting
with a run of **zeros** (which is 0 when the first pixel is set). The last run is always written, so the runs sum
to ``height * width`` (an empty 480x640 mask is ``"307200"``, a full one ``"0,307200"``).

pycocotools' RLE is column-major and uses a different text form, so it cannot be reused; the codec is a few numpy
lines. :func:`encode_indices` encodes straight from sorted flat pixel indices, which lets the annotator encode a
mask cropped to an object's box without materialising a full-image array.
"""

from __future__ import annotations

import numpy as np

from po3d_ppl.errors import InputError


def encode(mask: np.ndarray) -> str:
    """Encode a boolean mask (any shape, flattened row-major) in the public RLE."""
    flat = np.asarray(mask).astype(bool, copy=False).ravel()
    if flat.size == 0:
        raise InputError("mask", "cannot encode an empty array")
    change = np.flatnonzero(flat[1:] != flat[:-1]) + 1
    bounds = np.concatenate(([0], change, [flat.size]))
    runs = np.diff(bounds)
    if flat[0]:
        runs = np.concatenate(([0], runs))
    return ",".join(map(str, runs.tolist()))


def encode_indices(indices: np.ndarray, total: int) -> str:
    """Encode the mask whose set pixels are the strictly increasing flat ``indices`` of a ``total``-pixel image."""
    idx = np.asarray(indices, dtype=np.int64).ravel()
    if idx.size == 0:
        return str(int(total))
    if idx[0] < 0 or idx[-1] >= total:
        raise InputError("indices", f"pixel indices must lie in [0, {total}), got {idx[0]}..{idx[-1]}")
    breaks = np.flatnonzero(np.diff(idx) != 1) + 1
    starts = idx[np.concatenate(([0], breaks))]
    ends = idx[np.concatenate((breaks - 1, [idx.size - 1]))] + 1
    runs = np.empty(2 * starts.size + 1, dtype=np.int64)
    runs[0] = starts[0]
    runs[1:-1:2] = ends - starts
    runs[2:-1:2] = starts[1:] - ends[:-1]
    runs[-1] = total - ends[-1]
    if runs[-1] == 0:
        runs = runs[:-1]
    return ",".join(map(str, runs.tolist()))


def runs_of(rle: str) -> np.ndarray:
    """The run lengths of an RLE string, validated (non-negative integers)."""
    if not isinstance(rle, str) or not rle.strip():
        raise InputError("rle", f"expected a comma-separated list of run lengths, got {rle!r:.40}")
    try:
        runs = np.array([int(tok) for tok in rle.split(",")], dtype=np.int64)
    except ValueError:
        raise InputError("rle", f"run lengths must be integers, got {rle!r:.40}") from None
    if (runs < 0).any():
        raise InputError("rle", "run lengths must be non-negative")
    return runs


def count(rle: str) -> int:
    """Number of set pixels (the sum of the odd-indexed runs)."""
    return int(runs_of(rle)[1::2].sum())


def decode(rle: str, height: int, width: int) -> np.ndarray:
    """Decode to a boolean ``(height, width)`` mask. The runs must cover exactly ``height * width`` pixels."""
    runs = runs_of(rle)
    total = int(runs.sum())
    if total != height * width:
        raise InputError("rle", f"runs cover {total} pixels, expected {height}x{width} = {height * width}")
    values = np.zeros(runs.size, dtype=bool)
    values[1::2] = True
    return np.repeat(values, runs).reshape(height, width)


def bbox_of(mask: np.ndarray) -> tuple[int, int, int, int]:
    """The public ``[x, y, w, h]`` box of a 2D mask (x2/y2 exclusive), all zeros when the mask is empty."""
    m = np.asarray(mask, dtype=bool)
    cols = np.flatnonzero(m.any(axis=0))
    if cols.size == 0:
        return (0, 0, 0, 0)
    rows = np.flatnonzero(m.any(axis=1))
    return (int(cols[0]), int(rows[0]), int(cols[-1] - cols[0] + 1), int(rows[-1] - rows[0] + 1))

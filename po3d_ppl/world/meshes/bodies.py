"""Lofted vehicle bodies (cars, buses) and panels that lie exactly on them.

A body is a list of key cross-sections along x, each a closed polygon in the (y, z) plane with the same
vertices (see :func:`shell_section`), skinned by :func:`primitives.loft`. Because the skin is piecewise linear
between keys, :meth:`SectionedBody.profile_at` interpolates the exact surface at any x, so labelled panels (doors,
hood, roof, trunk) and glass can be built as thin shells lying on the body surface: the body stays one simple
closed mesh and every part is real geometry exactly where it belongs.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import trimesh

from po3d_ppl.world.meshes.primitives import loft

#: Vertex indices of :func:`shell_section` polylines (left = +y).
LEFT_SIDE = (1, 2)
RIGHT_SIDE = (7, 8)
LEFT_GLASS = (2, 3)
RIGHT_GLASS = (6, 7)
TOP = (3, 4, 5, 6)


@dataclass(frozen=True)
class Section:
    """Parameters of one body cross-section (see :func:`shell_section`)."""

    x: float
    half_width: float
    bottom: float
    belt: float
    top: float
    top_half_width: float
    chamfer: float = 0.05
    round: float = 0.08


def shell_section(s: Section) -> np.ndarray:
    """Counter-clockwise (y right, z up) 10-point section: a chamfered bottom, vertical sides up to the belt line
    and a greenhouse that narrows (tumblehome) to a rounded roof. Indices: see the polyline constants."""
    hw, hwt, c, r = s.half_width, s.top_half_width, s.chamfer, min(s.round, 0.45 * (s.top - s.belt) + 1e-3)
    r = min(r, 0.45 * s.top_half_width)
    pts = [
        (hw - c, s.bottom),
        (hw, s.bottom + c),
        (hw, s.belt),
        (hwt, s.top - r),
        (hwt - r, s.top),
    ]
    mirrored = [(-y, z) for y, z in reversed(pts)]
    return np.asarray(pts + mirrored, dtype=np.float64)


def _polyline_normals(poly: np.ndarray) -> np.ndarray:
    """Outward normals (for a counter-clockwise outline) at the vertices of an open polyline, mitred."""
    d = np.diff(poly, axis=0)
    seg = np.stack([d[:, 1], -d[:, 0]], -1)
    seg /= np.maximum(np.linalg.norm(seg, axis=-1, keepdims=True), 1e-12)
    normals = np.concatenate([seg[:1], seg[:-1] + seg[1:], seg[-1:]])
    normals /= np.maximum(np.linalg.norm(normals, axis=-1, keepdims=True), 1e-12)
    # mitre: keep the offset surface parallel to both neighbouring segments
    for k in range(1, len(poly) - 1):
        cos = float(normals[k] @ seg[k - 1])
        normals[k] /= max(cos, 0.5)
    return normals


def _slice_polyline(poly: np.ndarray, t0: float, t1: float) -> np.ndarray:
    """Sub-polyline between parameters t0 < t1, where segment i spans t in [i/k, (i+1)/k] (k segments).

    The parameterisation is per segment (not arc length) so that every section yields the same vertex count."""
    k = len(poly) - 1
    ts = [t0] + [i / k for i in range(1, k) if t0 < i / k < t1] + [t1]
    out = []
    for t in ts:
        i = min(int(t * k), k - 1)
        f = t * k - i
        out.append(poly[i] * (1 - f) + poly[i + 1] * f)
    return np.asarray(out)


class SectionedBody:
    """A body lofted through key sections ordered from front (+x) to back (-x)."""

    def __init__(self, sections: Sequence[Section]):
        xs = [s.x for s in sections]
        if any(a <= b for a, b in zip(xs, xs[1:])):
            raise ValueError("body sections must be ordered by strictly decreasing x (front to back)")
        self.sections = list(sections)
        self._xs = np.asarray(xs)
        self._profiles = np.stack([shell_section(s) for s in sections])

    @property
    def front(self) -> float:
        return float(self._xs[0])

    @property
    def back(self) -> float:
        return float(self._xs[-1])

    def mesh(self) -> trimesh.Trimesh:
        return loft([self._lift(x, p) for x, p in zip(self._xs, self._profiles)])

    @staticmethod
    def _lift(x: float, profile: np.ndarray) -> np.ndarray:
        return np.column_stack([np.full(len(profile), x), profile])

    def profile_at(self, x: float) -> np.ndarray:
        """The (y, z) outline of the skin at ``x`` (linear between key sections)."""
        xs = self._xs[::-1]
        profiles = self._profiles[::-1]
        x = float(np.clip(x, xs[0], xs[-1]))
        i = int(np.clip(np.searchsorted(xs, x) - 1, 0, len(xs) - 2))
        f = (x - xs[i]) / (xs[i + 1] - xs[i])
        return profiles[i] * (1 - f) + profiles[i + 1] * f

    def _xs_between(self, x0: float, x1: float) -> list[float]:
        lo, hi = min(x0, x1), max(x0, x1)
        inner = [float(x) for x in self._xs if lo < x < hi]
        return sorted({lo, hi, *inner}, reverse=True)

    def panel(self, x0: float, x1: float, indices: Sequence[int], t0: float = 0.0, t1: float = 1.0,
              thickness: float = 0.012) -> trimesh.Trimesh:
        """A thin shell on the skin between ``x0`` and ``x1``, over the outline polyline ``indices`` restricted to
        the parameter range [t0, t1] (0 = first index, 1 = last; each segment spans an equal share)."""
        sections = []
        for x in self._xs_between(x0, x1):
            poly = _slice_polyline(self.profile_at(x)[list(indices)], t0, t1)
            n = _polyline_normals(poly)
            outer = poly + n * thickness
            inner = poly - n * thickness * 0.25
            sections.append(self._lift(x, np.concatenate([outer, inner[::-1]])))
        return loft(sections, cap="strip")

    def end_panel(self, end: str, z_min: float, z_max: float, inset: float | tuple[float, float],
                  thickness: float = 0.012, y_max: float | None = None) -> trimesh.Trimesh:
        """A flat panel on the front or back face of the body (tailgates, grilles, windscreens): the end outline
        clipped to ``z_min <= z <= z_max`` (and ``|y| <= y_max``), shrunk by ``inset`` (one value, or (y, z)) and
        pushed out by ``thickness``."""
        x = self.front if end == "front" else self.back
        outline = self.profile_at(x)
        outline = _clip(outline, 1, z_min, keep_above=True)
        outline = _clip(outline, 1, z_max, keep_above=False)
        if y_max is not None:
            outline = _clip(outline, 0, y_max, keep_above=False)
            outline = _clip(outline, 0, -y_max, keep_above=True)
        c = outline.mean(axis=0)
        size = outline.max(axis=0) - outline.min(axis=0)
        scale = np.maximum(1.0 - 2.0 * np.broadcast_to(inset, (2,)) / np.maximum(size, 1e-9), 0.1)
        outline = c + (outline - c) * scale
        sign = 1.0 if end == "front" else -1.0
        a = self._lift(x - sign * thickness * 0.25, outline)
        b = self._lift(x + sign * thickness, outline)
        return loft([a, b])


def _clip(poly: np.ndarray, axis: int, value: float, keep_above: bool) -> np.ndarray:
    """Sutherland-Hodgman clip of a closed 2D polygon against one axis-aligned line."""
    out = []
    n = len(poly)
    for k in range(n):
        p, q = poly[k], poly[(k + 1) % n]
        pin = p[axis] >= value if keep_above else p[axis] <= value
        qin = q[axis] >= value if keep_above else q[axis] <= value
        if pin:
            out.append(p)
        if pin != qin:
            f = (value - p[axis]) / (q[axis] - p[axis])
            out.append(p + f * (q - p))
    return np.asarray(out)


class RevolvedBody:
    """A body of revolution along x (fuselages, nacelles): ``profile`` lists (x, radius) from front to back around
    a horizontal axis at height ``z``; ``squash`` scales the sections vertically."""

    def __init__(self, profile: Sequence[tuple[float, float]], z: float, squash: float = 1.0, sections: int = 20):
        self.profile = np.asarray(profile, dtype=np.float64)
        if np.any(np.diff(self.profile[:, 0]) >= 0):
            raise ValueError("profile x values must decrease from front to back")
        self.z, self.squash, self.sections = z, squash, sections

    def _ring(self, x: float, radius: float, angles: np.ndarray) -> np.ndarray:
        """Points at ``angles`` (degrees from +y towards +z) around the axis."""
        a = np.radians(angles)
        return np.column_stack([np.full(len(a), x), radius * np.cos(a), self.z + self.squash * radius * np.sin(a)])

    def radius_at(self, x: float) -> float:
        xs, rs = self.profile[::-1, 0], self.profile[::-1, 1]
        return float(np.interp(x, xs, rs))

    def mesh(self) -> trimesh.Trimesh:
        angles = np.linspace(0, 360, self.sections, endpoint=False)
        return loft([self._ring(x, max(r, 1e-4), angles) for x, r in self.profile])

    def panel(self, x0: float, x1: float, a0: float, a1: float, thickness: float, n: int = 6) -> trimesh.Trimesh:
        """A thin shell on the skin between ``x0`` and ``x1`` and angles ``a0``..``a1`` (degrees from +y towards +z,
        so 0 = left side, 90 = top, 180 = right side, 270 = bottom)."""
        lo, hi = min(x0, x1), max(x0, x1)
        xs = sorted({lo, hi, *[float(x) for x in self.profile[:, 0] if lo < x < hi]}, reverse=True)
        angles = np.linspace(a0, a1, n)
        sections = []
        for x in xs:
            r = self.radius_at(x)
            outer = self._ring(x, r + thickness, angles)
            inner = self._ring(x, r - thickness * 0.5, angles)
            sections.append(np.concatenate([outer, inner[::-1]]))
        return loft(sections, cap="strip")

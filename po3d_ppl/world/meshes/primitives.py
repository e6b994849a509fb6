"""Shape helpers shared by the vehicle builders: boxes, tubes, lofts, sweeps, tyres, wings.

All helpers return closed, outward-wound ``trimesh.Trimesh`` objects in the caller's coordinates (vehicle design
frame: +x front, +y left, +z up, ground at z = 0).

Lofting between *different* cross-sections and sweeping a profile along a 3D path are hand-written here
(:func:`loft`, :func:`sweep`): trimesh offers ``sweep_polygon``/``extrude_polygon`` only on top of shapely (not a
dependency of this project) and has no loft between varying sections, which is what car bodies, fuselages and
fenders need. Everything else wraps ``trimesh.creation`` and ``trimesh.convex``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import trimesh

Point = Sequence[float]


def _oriented(vertices: np.ndarray, faces: np.ndarray) -> trimesh.Trimesh:
    """A mesh whose winding makes its (closed) volume positive, i.e. normals point outward."""
    mesh = trimesh.Trimesh(np.asarray(vertices, dtype=np.float64), np.asarray(faces, dtype=np.int64), process=False)
    if mesh.volume < 0:
        mesh.invert()
    return mesh


def _ring_faces(n_rings: int, n: int, closed_loop: bool) -> np.ndarray:
    """Quads (as triangle pairs) between consecutive rings of ``n`` vertices each."""
    ring_pairs = n_rings if closed_loop else n_rings - 1
    i = np.arange(ring_pairs)[:, None]
    j = np.arange(n)[None, :]
    a = i * n + j
    b = i * n + (j + 1) % n
    c = ((i + 1) % n_rings) * n + (j + 1) % n
    d = ((i + 1) % n_rings) * n + j
    tri = np.stack([np.stack([a, b, c], -1), np.stack([a, c, d], -1)], axis=2)
    return tri.reshape(-1, 3)


def loft(sections: Sequence[np.ndarray], *, closed_loop: bool = False, cap: str = "fan") -> trimesh.Trimesh:
    """Skin a sequence of closed 3D polygons (all with the same vertex count) into a solid.

    ``cap``: ``"fan"`` closes each end with a fan from its centroid (star-shaped sections), ``"strip"`` treats each
    section as ``outer + reversed(inner)`` of a thin band and closes the ends band-wise. ``closed_loop`` joins the
    last section back to the first (rings, chains) and needs no caps.
    """
    rings = [np.asarray(s, dtype=np.float64) for s in sections]
    n = rings[0].shape[0]
    if any(r.shape != (n, 3) for r in rings) or len(rings) < 2:
        raise ValueError("loft needs at least two sections of identical shape (n, 3)")
    vertices = np.concatenate(rings)
    faces = [_ring_faces(len(rings), n, closed_loop)]
    if not closed_loop:
        last = (len(rings) - 1) * n
        if cap == "fan":
            extra = [rings[0].mean(axis=0), rings[-1].mean(axis=0)]
            c0, c1 = len(vertices), len(vertices) + 1
            vertices = np.concatenate([vertices, np.asarray(extra)])
            j = np.arange(n)
            faces.append(np.stack([np.full(n, c0), (j + 1) % n, j], -1))
            faces.append(np.stack([np.full(n, c1), last + j, last + (j + 1) % n], -1))
        elif cap == "strip":
            m = n // 2
            k = np.arange(m - 1)
            for base, flip in ((0, True), (last, False)):
                o0, o1 = base + k, base + k + 1
                i0, i1 = base + n - 1 - k, base + n - 2 - k
                quads = np.concatenate([np.stack([o0, o1, i1], -1), np.stack([o0, i1, i0], -1)])
                faces.append(quads[:, ::-1] if flip else quads)
        else:
            raise ValueError(f"unknown cap mode {cap!r}")
    return _oriented(vertices, np.concatenate(faces))


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def path_frames(path: np.ndarray, up: Point, closed_loop: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Per-point (normal, binormal) frames along a polyline: the normal is ``up`` made orthogonal to the tangent
    (where the path runs nearly parallel to ``up``, the world axis most orthogonal to it is used instead)."""
    p = np.asarray(path, dtype=np.float64)
    if closed_loop:
        tangent = np.roll(p, -1, axis=0) - np.roll(p, 1, axis=0)
    else:
        tangent = np.gradient(p, axis=0)
    tangent = _unit(tangent)
    u = np.broadcast_to(np.asarray(up, dtype=np.float64), tangent.shape).copy()
    parallel = np.abs(np.sum(u * tangent, axis=1)) > 0.95
    if parallel.any():
        fallback = np.eye(3)[np.argmin(np.abs(tangent[parallel]), axis=1)]
        u[parallel] = fallback
    normal = _unit(u - np.sum(u * tangent, axis=1, keepdims=True) * tangent)
    binormal = np.cross(tangent, normal)
    return normal, binormal


def sweep(path: np.ndarray, profile: np.ndarray, *, up: Point = (0, 0, 1),
          closed_loop: bool = False) -> trimesh.Trimesh:
    """Sweep a closed 2D ``profile`` (m, 2) along a 3D ``path`` (n, 3).

    Profile coordinates (a, b) map to ``a * normal + b * binormal`` where ``normal`` is ``up`` made orthogonal to
    the path.
    """
    p = np.asarray(path, dtype=np.float64)
    prof = np.asarray(profile, dtype=np.float64)
    normal, binormal = path_frames(p, up, closed_loop)
    sections = [p[k] + (prof[:, :1] * normal[k] + prof[:, 1:] * binormal[k]) for k in range(len(p))]
    return loft(sections, closed_loop=closed_loop)


def circle(radius: float, sections: int = 12) -> np.ndarray:
    t = np.linspace(0, 2 * np.pi, sections, endpoint=False)
    return np.stack([radius * np.cos(t), radius * np.sin(t)], -1)


def rectangle(width_a: float, width_b: float) -> np.ndarray:
    a, b = width_a / 2, width_b / 2
    return np.array([[a, b], [-a, b], [-a, -b], [a, -b]])


def box(center: Point, size: Point) -> trimesh.Trimesh:
    return trimesh.creation.box(extents=size, transform=trimesh.transformations.translation_matrix(center))


def rounded_box(center: Point, size: Point, bevel: float) -> trimesh.Trimesh:
    """A box with chamfered edges: the convex hull of three boxes each shrunk by ``bevel`` along two axes."""
    size = np.asarray(size, dtype=np.float64)
    bevel = min(bevel, 0.49 * size.min())
    pts = []
    for axis in range(3):
        s = size - 2 * bevel
        s[axis] = size[axis]
        pts.append(trimesh.bounds.corners(np.array([-s / 2, s / 2])))
    return hull(np.concatenate(pts) + np.asarray(center))


def hull(points: np.ndarray) -> trimesh.Trimesh:
    """Convex hull of a point cloud (qhull through trimesh)."""
    mesh = trimesh.convex.convex_hull(np.asarray(points, dtype=np.float64))
    if mesh.volume < 0:
        mesh.invert()
    return mesh


def hull_of(*meshes: trimesh.Trimesh) -> trimesh.Trimesh:
    """Convex hull of several solids together (tanks, seats, fairings blended from ellipsoids; crank arms)."""
    return hull(np.concatenate([m.vertices for m in meshes]))


def ellipsoid(center: Point, radii: Point, subdivisions: int = 2) -> trimesh.Trimesh:
    mesh = trimesh.creation.icosphere(subdivisions=subdivisions)
    mesh.apply_scale(np.asarray(radii, dtype=np.float64))
    mesh.apply_translation(center)
    return mesh


def tube(p0: Point, p1: Point, radius: float, sections: int = 10) -> trimesh.Trimesh:
    """A cylinder between two points."""
    return trimesh.creation.cylinder(radius=radius, sections=sections, segment=np.array([p0, p1], dtype=np.float64))


def polyline_tube(points: np.ndarray, radius: float, sections: int = 8, up: Point = (0, 0, 1)) -> trimesh.Trimesh:
    """A round tube along a polyline (handlebars, exhaust pipes, frame bends)."""
    return sweep(np.asarray(points, dtype=np.float64), circle(radius, sections), up=up)


def revolve(origin: Point, axis: Point, profile: Sequence[tuple[float, float]], sections: int = 16,
            squash: tuple[float, float] = (1.0, 1.0), up: Point = (0, 0, 1)) -> trimesh.Trimesh:
    """Surface of revolution: ``profile`` lists (t, r) = (distance along ``axis`` from ``origin``, radius).

    ``squash`` scales the circle along (up, up x axis) to make oval sections (fuselages, tanks). Ends are capped.
    """
    o = np.asarray(origin, dtype=np.float64)
    ax = _unit(np.asarray(axis, dtype=np.float64))
    n = _unit(np.asarray(up, dtype=np.float64) - (np.asarray(up) @ ax) * ax)
    b = np.cross(ax, n)
    ang = np.linspace(0, 2 * np.pi, sections, endpoint=False)
    ring = np.cos(ang)[:, None] * n * squash[0] + np.sin(ang)[:, None] * b * squash[1]
    return loft([o + t * ax + max(r, 1e-6) * ring for t, r in profile])


def tyre(center: Point, radius: float, width: float, *, sections: int = 24, axis: Point = (0, 1, 0),
         rim: float = 0.62) -> trimesh.Trimesh:
    """A tyre with rounded shoulders and a recessed hub, revolved around ``axis`` (default: the y axis)."""
    w = width / 2
    r_in = radius * rim
    profile = [
        (-w * 0.55, r_in * 0.35),
        (-w * 0.9, r_in * 0.9),
        (-w, radius * 0.8),
        (-w * 0.85, radius * 0.96),
        (-w * 0.5, radius),
        (w * 0.5, radius),
        (w * 0.85, radius * 0.96),
        (w, radius * 0.8),
        (w * 0.9, r_in * 0.9),
        (w * 0.55, r_in * 0.35),
    ]
    return revolve(center, axis, profile, sections=sections, up=(0, 0, 1) if abs(axis[2]) < 0.9 else (1, 0, 0))


def torus(center: Point, axis: Point, major: float, minor: float, major_sections: int = 24,
          minor_sections: int = 6) -> trimesh.Trimesh:
    """A ring (thin bicycle tyres, rims)."""
    ax = _unit(np.asarray(axis, dtype=np.float64))
    ref = np.array([0, 0, 1.0]) if abs(ax[2]) < 0.9 else np.array([1.0, 0, 0])
    e1 = _unit(ref - (ref @ ax) * ax)
    e2 = np.cross(ax, e1)
    t = np.linspace(0, 2 * np.pi, major_sections, endpoint=False)
    path = np.asarray(center) + major * (np.cos(t)[:, None] * e1 + np.sin(t)[:, None] * e2)
    return sweep(path, circle(minor, minor_sections), up=ax, closed_loop=True)


def arc_points(center: Point, radius: float, a0: float, a1: float, n: int) -> np.ndarray:
    """Points on a circular arc in the xz plane (angles in degrees, measured from +x towards +z)."""
    t = np.radians(np.linspace(a0, a1, n))
    c = np.asarray(center, dtype=np.float64)
    return c + radius * np.stack([np.cos(t), np.zeros_like(t), np.sin(t)], -1)


def fender(center: Point, radius: float, a0: float, a1: float, width: float, thickness: float,
           n: int = 12) -> trimesh.Trimesh:
    """A mudguard: a band of ``width`` (along y) following a circular arc in the xz plane (angles in degrees)."""
    path = arc_points(center, radius + thickness / 2, a0, a1, n)
    return sweep(path, rectangle(width, thickness), up=(0, 1, 0))


def wing(root_le: Point, root_chord: float, tip_le: Point, tip_chord: float, thickness: float,
         vertical: bool = False) -> trimesh.Trimesh:
    """A tapered, possibly swept and dihedral wing panel: hull of a lens-shaped root and tip aerofoil section.

    Chords run along -x from the leading edges; ``thickness`` is relative to the chord. ``vertical`` makes the
    aerofoil's thickness run along y (fins) instead of z.
    """
    def section(le: Point, chord: float) -> np.ndarray:
        le = np.asarray(le, dtype=np.float64)
        xs = np.array([0.0, 0.05, 0.3, 0.7, 1.0])
        half = np.array([0.0, 0.6, 1.0, 0.55, 0.05]) * thickness * chord / 2
        pts = []
        for sgn in (1, -1):
            for x, h in zip(xs, half):
                off = np.array([-x * chord, sgn * h, 0.0]) if vertical else np.array([-x * chord, 0.0, sgn * h])
                pts.append(le + off)
        return np.asarray(pts)

    return hull(np.concatenate([section(root_le, root_chord), section(tip_le, tip_chord)]))


def chain_loop(c0: Point, r0: float, c1: Point, r1: float, width: float, thickness: float,
               n: int = 28) -> trimesh.Trimesh:
    """A belt around two circles in an xz plane (drive chains): a thin band following their outer tangents."""
    p0, p1 = np.asarray(c0, dtype=np.float64), np.asarray(c1, dtype=np.float64)
    d = p1 - p0
    dist = np.hypot(d[0], d[2])
    base = np.arctan2(d[2], d[0])
    # angle of the tangent points relative to the centre line (outer tangents of two circles)
    phi = np.arccos(np.clip((r0 - r1) / dist, -1, 1))
    half = n // 2
    a0 = np.linspace(base + phi, base + 2 * np.pi - phi, half)
    a1 = np.linspace(base - phi, base + phi, n - half)
    pts0 = p0 + r0 * np.stack([np.cos(a0), np.zeros_like(a0), np.sin(a0)], -1)
    pts1 = p1 + r1 * np.stack([np.cos(a1), np.zeros_like(a1), np.sin(a1)], -1)
    path = np.concatenate([pts0, pts1])
    return sweep(path, rectangle(width, thickness), up=(0, 1, 0), closed_loop=True)


def disc(center: Point, radius: float, thickness: float, axis: Point = (0, 1, 0), sections: int = 20) -> trimesh.Trimesh:
    """A flat cylinder (hubs, brake rotors, lamps, mirrors) with its axis along ``axis``."""
    c = np.asarray(center, dtype=np.float64)
    a = _unit(np.asarray(axis, dtype=np.float64))
    return tube(c - a * thickness / 2, c + a * thickness / 2, radius, sections)

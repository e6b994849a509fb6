"""Category-level neural-mesh geometry: one closed surface of about 1,000 vertices per category that encloses all
of the category's subtypes (paper §4.2, after NeMo's category-level meshes).

Render-and-compare fits one mesh per *category*, not per subtype, so the mesh must cover every subtype's
silhouette at any pose while staying close to it. The convex hull is far too coarse for bicycles (the space
between the wheels) and aeroplanes (between the wings and tail), so the surface is built as a wrap of the union:

1. the union of the subtypes' part-labelled meshes (canonical frame: front +x, up +z, resting on z = 0) is voxelised
   on a fine grid (surface samples on a barycentric lattice, so every triangle is hit, then the shells' interiors
   filled);
2. a coarse lattice point is occupied if its cell holds any of that solid (max-pooling: no handlebar or wing tip
   falls between lattice points); the occupancy is closed once (bridging spokes and slits) and filled; lattice
   points under the ground stay empty, so the mesh's base lies on z = 0;
3. the boundary is extracted with naive surface nets (one vertex per boundary cell, so the vertex spacing is the
   lattice spacing: near-uniform, as a neural texture wants), after making the occupancy well-composed (no
   diagonal-only contacts) so the surface is a closed 2-manifold; Taubin smoothing removes the staircase, and
   vertices that smoothing pulled into thin features are pushed back out along their normals to a clearance;
4. the lattice spacing is bisected so the mesh has about ``TARGET_VERTICES`` vertices.

Everything is deterministic (no random sampling) and cached per process; all five build in a few seconds.
:func:`pose_category_mesh` places a category mesh in the world with the conventions of
``world.sampler.ObjectSpec.transform`` (yaw counter-clockwise about z, size scale ``ontology.SIZE_SCALE``,
base at the elevation).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np
import torch

from po3d_ppl import ontology
from po3d_ppl.errors import InputError, UnknownNameError

#: Vertex count the spacing search aims at, and the accepted band around it.
TARGET_VERTICES = 1000
VERTEX_BAND = (900, 1100)
#: Fine voxel pitch (canonical units; vehicles are about 0.9 long) of the union's solid.
FINE_PITCH = 0.008
#: After smoothing, every vertex is pushed to at least this many lattice spacings outside the solid (0.3 lets
#: smoothed thin features poke out by up to ~1% of a vehicle's length; 0.4 keeps every subtype vertex inside).
CLEARANCE = 0.4
#: Rounds of (Taubin smoothing iterations, lambda and mu as in trimesh's defaults; then the push-out).
SMOOTHING_ROUNDS, SMOOTHING_ITERATIONS = 4, 10


@dataclass(frozen=True, eq=False)
class CategoryMesh:
    """A category's mesh in the canonical frame (unscaled, front +x, up +z, base on z = 0, centred in x and y).

    ``vertices`` float32 [V, 3], ``faces`` int64 [F, 3] (counter-clockwise seen from outside), ``vertex_normals``
    float32 [V, 3] unit outward normals, ``spacing`` the lattice spacing (the typical edge length).
    """

    category: str
    vertices: np.ndarray
    faces: np.ndarray
    vertex_normals: np.ndarray
    spacing: float
    subtypes: tuple[str, ...]

    @property
    def num_vertices(self) -> int:
        return int(self.vertices.shape[0])

    @property
    def bounds(self) -> np.ndarray:
        """``[[xmin, ymin, zmin], [xmax, ymax, zmax]]`` in the canonical frame."""
        return np.stack([self.vertices.min(axis=0), self.vertices.max(axis=0)]).astype(np.float64)

    def edge_lengths(self) -> np.ndarray:
        """Length of every edge (each once): how uniform the vertex spacing is."""
        e = np.sort(np.concatenate([self.faces[:, [0, 1]], self.faces[:, [1, 2]], self.faces[:, [2, 0]]]), axis=1)
        e = np.unique(e, axis=0)
        return np.linalg.norm(self.vertices[e[:, 0]].astype(np.float64) - self.vertices[e[:, 1]], axis=1)

    def trimesh(self):
        """A ``trimesh.Trimesh`` copy (for containment, ray casting, export)."""
        import trimesh

        return trimesh.Trimesh(self.vertices.astype(np.float64), self.faces, process=False)

    def tensors(self, device: torch.device | str | None = None, dtype: torch.dtype = torch.float32
                ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """(vertices, faces, vertex normals) as torch tensors on ``device`` (copies: the arrays are read-only)."""
        return (torch.tensor(np.array(self.vertices), dtype=dtype, device=device),
                torch.tensor(np.array(self.faces), dtype=torch.long, device=device),
                torch.tensor(np.array(self.vertex_normals), dtype=dtype, device=device))


def subtypes_of(category: str) -> tuple[str, ...]:
    """The category's subtypes, in ``ontology.SUBTYPES`` order."""
    if category not in ontology.CATEGORIES:
        raise UnknownNameError("category", category, ontology.CATEGORIES)
    return tuple(s for s in ontology.SUBTYPES if ontology.CATEGORY_OF[s] == category)


@cache
def category_mesh(category: str) -> CategoryMesh:
    """The category's mesh (built once per process, then cached; its arrays are read-only)."""
    return build_category_mesh(category)


def build_category_mesh(category: str) -> CategoryMesh:
    """Build the category's mesh from its subtypes' meshes (deterministic; about 0.3-0.5 s; prefer the cached
    :func:`category_mesh`)."""
    subtypes = subtypes_of(category)
    solid = _union_solid(subtypes)
    vertices, faces, spacing = _search_spacing(solid)
    mesh = _as_trimesh(vertices, faces)
    out = CategoryMesh(category, np.asarray(mesh.vertices, dtype=np.float32), np.asarray(mesh.faces, dtype=np.int64),
                       np.asarray(mesh.vertex_normals, dtype=np.float32), float(spacing), subtypes)
    for array in (out.vertices, out.faces, out.vertex_normals):
        array.setflags(write=False)
    return out


def all_category_meshes() -> dict[str, CategoryMesh]:
    """Every category's mesh, in ``ontology.CATEGORIES`` order."""
    return {c: category_mesh(c) for c in ontology.CATEGORIES}


# --- step 1: the union as a fine solid ----------------------------------------------------------------------------


@dataclass(frozen=True)
class _Solid:
    """Occupancy of the union on a fine grid: voxel (i, j, k) has centre ``origin + (i, j, k) * pitch``."""

    origin: np.ndarray
    pitch: float
    occupied: np.ndarray
    #: Signed distance to the solid's boundary (negative inside), for sampling between voxel centres.
    signed: np.ndarray
    bounds: np.ndarray

    def signed_distance(self, points: np.ndarray) -> np.ndarray:
        """Trilinear signed distance at points [P, 3] (positive outside; far outside the grid: its edge value)."""
        from scipy import ndimage

        coords = ((np.asarray(points) - self.origin) / self.pitch).T
        return ndimage.map_coordinates(self.signed, coords, order=1, mode="nearest")


def _union_solid(subtypes: tuple[str, ...], pitch: float = FINE_PITCH, margin: float = 0.08) -> _Solid:
    from scipy import ndimage

    from po3d_ppl.world.meshes import vehicle_mesh

    meshes = [vehicle_mesh(s).mesh for s in subtypes]
    lo = np.min([m.bounds[0] for m in meshes], axis=0)
    hi = np.max([m.bounds[1] for m in meshes], axis=0)
    origin = lo - margin
    shape = tuple(int(n) for n in np.ceil((hi - lo + 2 * margin) / pitch).astype(int) + 1)
    shell = np.zeros(shape, dtype=bool)
    for mesh in meshes:
        points = _surface_lattice(np.asarray(mesh.vertices), np.asarray(mesh.faces), pitch)
        idx = np.rint((points - origin) / pitch).astype(np.int64)
        shell[idx[:, 0], idx[:, 1], idx[:, 2]] = True
    # One dilation seals any sampling gaps before the interiors of the (closed) part shells are filled; one erosion
    # then gives the seal back (the shell itself is kept, so thin plates and spokes survive).
    occupied = ndimage.binary_fill_holes(ndimage.binary_dilation(shell))
    occupied = ndimage.binary_erosion(occupied) | shell
    distance = ndimage.distance_transform_edt(~occupied, sampling=pitch).astype(np.float32)
    depth = ndimage.distance_transform_edt(occupied, sampling=pitch).astype(np.float32)
    signed = np.where(occupied, pitch / 2 - depth, distance - pitch / 2)
    return _Solid(origin, pitch, occupied, signed, np.stack([lo, hi]))


def _surface_lattice(vertices: np.ndarray, faces: np.ndarray, spacing: float) -> np.ndarray:
    """Points on every triangle on a barycentric lattice fine enough that neighbouring points are at most
    ``spacing`` apart (deterministic, unlike random surface sampling, and no triangle is missed)."""
    tri = vertices[faces]
    edge = np.max(np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2), axis=1)
    steps = np.maximum(1, np.ceil(edge / spacing).astype(np.int64))
    out = [vertices]
    for n in np.unique(steps):
        a, b = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
        keep = a + b <= n
        w = np.stack([a[keep], b[keep]], axis=1) / n  # barycentric weights of corners 1 and 2
        t = tri[steps == n]
        pts = t[:, None, 0] + w[None, :, :1] * (t[:, None, 1] - t[:, None, 0]) + w[None, :, 1:] * (
            t[:, None, 2] - t[:, None, 0])
        out.append(pts.reshape(-1, 3))
    return np.concatenate(out)


# --- step 2: coarse occupancy -------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Lattice:
    """Coarse lattice: point (i, j, k) at ``origin + (i, j, k) * spacing``; z levels sit at odd multiples of
    ``spacing / 2`` so the boundary between the first level above ground and the one below is exactly z = 0."""

    origin: np.ndarray
    spacing: float
    occupied: np.ndarray


def _coarse_occupancy(solid: _Solid, spacing: float, pad: int = 3) -> _Lattice:
    from scipy import ndimage

    lo, hi = solid.bounds
    # Symmetric in x and y about the canonical centre, so a left-right symmetric union gives a symmetric mesh.
    half = np.ceil(np.maximum(np.abs(lo[:2]), np.abs(hi[:2])) / spacing).astype(int) + pad
    top = int(np.ceil(hi[2] / spacing)) + pad
    levels = [np.arange(-half[0], half[0] + 1) * spacing, np.arange(-half[1], half[1] + 1) * spacing,
              (np.arange(-pad, top + 1) + 0.5) * spacing]
    origin = np.array([axis[0] for axis in levels])
    above = np.broadcast_to(levels[2] > 0, tuple(len(axis) for axis in levels))
    occ = _max_pool(solid, origin, spacing, above.shape)
    occ = ndimage.binary_closing(occ, structure=ndimage.generate_binary_structure(3, 1)) & above
    occ = ndimage.binary_fill_holes(occ)
    return _Lattice(origin, spacing, _well_composed(occ))


def _max_pool(solid: _Solid, origin: np.ndarray, spacing: float, shape: tuple[int, ...]) -> np.ndarray:
    """Lattice points whose cell (the cube of side ``spacing`` around them) holds solid: nothing of the solid, however
    thin (a handlebar, a wing tip), falls between lattice points. Solid under the lowest level counts for it."""
    centres = solid.origin + np.argwhere(solid.occupied) * solid.pitch
    idx = np.rint((centres - origin) / spacing).astype(np.int64)
    idx[:, 2] = np.maximum(idx[:, 2], int(np.rint(-origin[2] / spacing + 0.5)))  # the first level above ground
    out = np.zeros(shape, dtype=bool)
    out[idx[:, 0], idx[:, 1], idx[:, 2]] = True
    return out


def _well_composed(occ: np.ndarray, max_rounds: int = 50) -> np.ndarray:
    """Fill voxels until no two occupied (or two empty) voxels touch only along an edge or at a corner.

    Such contacts are where a dual surface would be non-manifold (an edge shared by four faces, a vertex joining
    two sheets). Only voxels are added, so the surface still encloses everything it enclosed.
    """
    occ = occ.copy()
    for _ in range(max_rounds):
        fill = _critical_2d(occ) | _critical_3d(occ)
        fill &= ~occ
        if not fill.any():
            return occ
        occ |= fill
    return occ


def _critical_2d(occ: np.ndarray) -> np.ndarray:
    """Voxels to fill to remove 2x2 diagonal patterns in every axis-aligned plane."""
    fill = np.zeros_like(occ)
    for u, v in ((0, 1), (0, 2), (1, 2)):
        p00, p10, p01, p11 = (_shifted(occ, o) for o in ({}, {u: 1}, {v: 1}, {u: 1, v: 1}))
        diag = p00 & p11 & ~p10 & ~p01
        anti = p10 & p01 & ~p00 & ~p11
        bad = diag | anti
        for offsets in ({}, {u: 1}, {v: 1}, {u: 1, v: 1}):
            fill |= _unshift(bad, offsets, occ.shape)
    return fill


def _critical_3d(occ: np.ndarray) -> np.ndarray:
    """Voxels to fill in 2x2x2 cubes where two opposite corners differ from the other six."""
    fill = np.zeros_like(occ)
    corners = [(a, b, c) for a in (0, 1) for b in (0, 1) for c in (0, 1)]
    vals = {c: _shifted(occ, {ax: o for ax, o in enumerate(c) if o}) for c in corners}
    total = sum(v.astype(np.int8) for v in vals.values())
    for c in corners[:4]:
        d = tuple(1 - x for x in c)
        pair_on = vals[c] & vals[d] & (total == 2)
        pair_off = ~vals[c] & ~vals[d] & (total == 6)
        bad = pair_on | pair_off
        for corner in corners:
            fill |= _unshift(bad, {ax: o for ax, o in enumerate(corner) if o}, occ.shape)
    return fill


def _shifted(occ: np.ndarray, offsets: dict[int, int]) -> np.ndarray:
    """``occ[i + offsets]`` over the cells (i) of the lattice (shape minus one along every axis)."""
    sl = tuple(slice(offsets.get(ax, 0), occ.shape[ax] - 1 + offsets.get(ax, 0)) for ax in range(3))
    return occ[sl]


def _unshift(cells: np.ndarray, offsets: dict[int, int], shape: tuple[int, ...]) -> np.ndarray:
    out = np.zeros(shape, dtype=bool)
    sl = tuple(slice(offsets.get(ax, 0), shape[ax] - 1 + offsets.get(ax, 0)) for ax in range(3))
    out[sl] = cells
    return out


# --- step 3: surface nets -----------------------------------------------------------------------------------------

#: The 12 edges of a cell as pairs of corner offsets.
_CELL_EDGES = [((0, 0, 0), (1, 0, 0)), ((0, 1, 0), (1, 1, 0)), ((0, 0, 1), (1, 0, 1)), ((0, 1, 1), (1, 1, 1)),
               ((0, 0, 0), (0, 1, 0)), ((1, 0, 0), (1, 1, 0)), ((0, 0, 1), (0, 1, 1)), ((1, 0, 1), (1, 1, 1)),
               ((0, 0, 0), (0, 0, 1)), ((1, 0, 0), (1, 0, 1)), ((0, 1, 0), (0, 1, 1)), ((1, 1, 0), (1, 1, 1))]


def surface_nets(occ: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Naive surface nets of a boolean lattice whose border is empty: (vertices in lattice units [V, 3], faces
    [F, 3]) with outward (counter-clockwise) winding. A well-composed lattice gives a closed 2-manifold."""
    cells = np.array(occ.shape) - 1
    acc = np.zeros((*cells, 3))
    count = np.zeros(tuple(cells))
    for a, b in _CELL_EDGES:
        va = _shifted(occ, {ax: o for ax, o in enumerate(a) if o})
        vb = _shifted(occ, {ax: o for ax, o in enumerate(b) if o})
        cross = va != vb
        acc[cross] += (np.asarray(a) + np.asarray(b)) / 2.0
        count += cross
    active = count > 0
    index = np.full(tuple(cells), -1, dtype=np.int64)
    index[active] = np.arange(int(active.sum()))
    cell_ijk = np.argwhere(active)
    vertices = cell_ijk + acc[active] / count[active][:, None]
    quads = [_axis_quads(occ, index, axis) for axis in range(3)]
    quads = np.concatenate([q for q in quads if len(q)])
    faces = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    return vertices, faces


def _axis_quads(occ: np.ndarray, index: np.ndarray, axis: int) -> np.ndarray:
    """Quads dual to the lattice edges along ``axis`` that cross the boundary, wound so their normal points from
    the occupied end to the empty one."""
    u, v = (axis + 1) % 3, (axis + 2) % 3
    lo = np.take(occ, np.arange(occ.shape[axis] - 1), axis=axis)
    hi = np.take(occ, np.arange(1, occ.shape[axis]), axis=axis)
    edges = np.argwhere(lo != hi)  # lattice point p and p + e_axis differ
    outward_plus = lo[tuple(edges.T)]
    ring = [(-1, -1), (0, -1), (0, 0), (-1, 0)]  # counter-clockwise about +axis in the (u, v) plane
    quad = np.empty((len(edges), 4), dtype=np.int64)
    for n, (du, dv) in enumerate(ring):
        c = edges.copy()
        c[:, u] += du
        c[:, v] += dv
        quad[:, n] = index[tuple(c.T)]
    quad[~outward_plus] = quad[~outward_plus][:, ::-1]
    return quad


# --- step 4: spacing search ---------------------------------------------------------------------------------------


def _extract(solid: _Solid, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """The smoothed surface (canonical units) at one lattice spacing: surface nets, then rounds of Taubin smoothing
    each followed by the push back out to the clearance (smoothing under the constraint of enclosure)."""
    import trimesh

    lattice = _coarse_occupancy(solid, spacing)
    verts, faces = surface_nets(lattice.occupied)
    mesh = _as_trimesh(lattice.origin + verts * lattice.spacing, faces)
    laplacian = trimesh.smoothing.laplacian_calculation(mesh)
    for _ in range(SMOOTHING_ROUNDS):
        trimesh.smoothing.filter_taubin(mesh, iterations=SMOOTHING_ITERATIONS, laplacian_operator=laplacian)
        verts = np.asarray(mesh.vertices).copy()
        verts[:, 2] = np.maximum(verts[:, 2], 0.0)  # the base stays on the ground
        mesh.vertices = _push_out(verts, faces, solid, CLEARANCE * spacing)
    return np.asarray(mesh.vertices), faces


def _push_out(verts: np.ndarray, faces: np.ndarray, solid: _Solid, clearance: float, rounds: int = 4) -> np.ndarray:
    """Move vertices outward along their normals until each is ``clearance`` outside the solid.

    Smoothing rounds off thin features (wing tips, tyre edges) and pulls the surface into the solid there; this
    restores enclosure locally without fattening the rest of the mesh."""
    verts = verts.copy()
    for _ in range(rounds):
        deficit = clearance - solid.signed_distance(verts)
        if not (deficit > 1e-4).any():
            break
        normals = np.asarray(_as_trimesh(verts, faces).vertex_normals)
        verts += np.clip(deficit, 0.0, None)[:, None] * normals
        verts[:, 2] = np.maximum(verts[:, 2], 0.0)
    return verts


def _search_spacing(solid: _Solid, target: int = TARGET_VERTICES, band: tuple[int, int] = VERTEX_BAND,
                    rounds: int = 12) -> tuple[np.ndarray, np.ndarray, float]:
    """Bisect the lattice spacing (vertex count ~ area / spacing^2) until the count is within ``band``."""
    extent = solid.bounds[1] - solid.bounds[0]
    area = 2 * (extent[0] * extent[1] + extent[1] * extent[2] + extent[0] * extent[2])
    lo, hi = math.sqrt(area / (target * 4)), math.sqrt(area / (target / 4))
    best = None
    for _ in range(rounds):
        spacing = math.sqrt(lo * hi)
        verts, faces = _extract(solid, spacing)
        n = len(verts)
        if best is None or abs(n - target) < abs(len(best[0]) - target):
            best = (verts, faces, spacing)
        if band[0] <= n <= band[1]:
            break
        lo, hi = (spacing, hi) if n > target else (lo, spacing)
    return best


def _as_trimesh(vertices: np.ndarray, faces: np.ndarray):
    import trimesh

    return trimesh.Trimesh(np.asarray(vertices, dtype=np.float64), np.asarray(faces), process=False)


def distance_to_surface(points: np.ndarray, vertices: np.ndarray, faces: np.ndarray, chunk: int = 256
                        ) -> np.ndarray:
    """Unsigned distance of each point [P, 3] to a triangle mesh (exact, brute force over the faces in chunks of
    points: meant for checks on a few thousand points against ~2,000 faces; trimesh's version needs rtree)."""
    tri = np.asarray(vertices, dtype=np.float64)[np.asarray(faces)]
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    out = np.empty(len(points))
    pts = np.asarray(points, dtype=np.float64)
    for start in range(0, len(pts), chunk):
        p = pts[start:start + chunk, None, :]
        out[start:start + chunk] = np.sqrt(np.min(_squared_triangle_distance(p, a, b, c), axis=1))
    return out


def _squared_triangle_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Squared distance of points p [P, 1, 3] to triangles (a, b, c) [F, 3]: the closest point of each triangle
    (inside, on an edge or at a corner), vectorised over the regions of Ericson's test."""
    ab, ac = b - a, c - a
    ap = p - a
    d1, d2 = np.sum(ab * ap, -1), np.sum(ac * ap, -1)
    bp = p - b
    d3, d4 = np.sum(ab * bp, -1), np.sum(ac * bp, -1)
    cp = p - c
    d5, d6 = np.sum(ab * cp, -1), np.sum(ac * cp, -1)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = va + vb + vc
        v = np.where(denom != 0, vb / denom, 0.0)
        w = np.where(denom != 0, vc / denom, 0.0)
        closest = a + v[..., None] * ab + w[..., None] * ac  # interior
        t_ab = np.clip(d1 / np.where(d1 - d3 != 0, d1 - d3, 1), 0, 1)
        t_ac = np.clip(d2 / np.where(d2 - d6 != 0, d2 - d6, 1), 0, 1)
        e = (d4 - d3) + (d5 - d6)
        t_bc = np.clip((d4 - d3) / np.where(e != 0, e, 1), 0, 1)
    edge_ab = (vc <= 0) & (d1 >= 0) & (d3 <= 0)
    edge_ac = (vb <= 0) & (d2 >= 0) & (d6 <= 0)
    edge_bc = (va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0)
    closest = np.where(edge_bc[..., None], b + t_bc[..., None] * (c - b), closest)
    closest = np.where(edge_ac[..., None], a + t_ac[..., None] * ac, closest)
    closest = np.where(edge_ab[..., None], a + t_ab[..., None] * ab, closest)
    closest = np.where(((d6 >= 0) & (d5 <= d6))[..., None], c, closest)
    closest = np.where(((d3 >= 0) & (d4 <= d3))[..., None], b, closest)
    closest = np.where(((d1 <= 0) & (d2 <= 0))[..., None], a, closest)
    return np.sum((p - closest) ** 2, -1)


# --- posing -------------------------------------------------------------------------------------------------------


def pose_matrix(x: float, y: float, rotation: float, scale: float, elevation: float = 0.0) -> np.ndarray:
    """4x4 canonical-to-world matrix: scale, yaw ``rotation`` degrees counter-clockwise about z (front = +x
    rotated), then move the canonical origin (the x/y centre of the base) to (x, y, elevation).

    This is ``ObjectSpec.transform`` for a mesh centred in x and y with its base on z = 0, which every subtype's
    canonical mesh and every category mesh is.
    """
    th = math.radians(rotation)
    c, s = math.cos(th), math.sin(th)
    M = np.eye(4)
    M[:3, :3] = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) * scale
    M[:3, 3] = [x, y, elevation]
    return M


def pose_category_mesh(mesh: CategoryMesh, x: float, y: float, rotation: float, scale: float | str,
                       elevation: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """World (vertices float64 [V, 3], unit vertex normals [V, 3]) of ``mesh`` placed like an object with yaw
    ``rotation`` (degrees) at (x, y) on the ground (or ``elevation`` above it). ``scale``: a number or a size name
    (``'large'``/``'small'``, via ``ontology.SIZE_SCALE``)."""
    if isinstance(scale, str):
        if scale not in ontology.SIZE_SCALE:
            raise UnknownNameError("size", scale, ontology.SIZE_SCALE)
        scale = float(ontology.SIZE_SCALE[scale])
    if not (isinstance(scale, (int, float)) and math.isfinite(scale) and scale > 0):
        raise InputError("scale", f"must be a positive number or a size name, got {scale!r}")
    M = pose_matrix(x, y, rotation, float(scale), elevation)
    verts = mesh.vertices.astype(np.float64) @ M[:3, :3].T + M[:3, 3]
    normals = mesh.vertex_normals.astype(np.float64) @ (M[:3, :3] / scale).T
    return verts, normals


def pose_vertices_torch(vertices: torch.Tensor, x: torch.Tensor, y: torch.Tensor, rotation: torch.Tensor,
                        scale: torch.Tensor | float, elevation: torch.Tensor | float = 0.0) -> torch.Tensor:
    """Differentiable, batched :func:`pose_category_mesh`: canonical ``vertices`` [V, 3] and pose parameters of
    any common batch shape B (``rotation`` in degrees) -> world vertices [*B, V, 3]."""
    x, y, rotation = (torch.as_tensor(t, dtype=vertices.dtype, device=vertices.device) for t in (x, y, rotation))
    scale = torch.as_tensor(scale, dtype=vertices.dtype, device=vertices.device)
    elevation = torch.as_tensor(elevation, dtype=vertices.dtype, device=vertices.device)
    x, y, rotation, scale, elevation = torch.broadcast_tensors(x, y, rotation, scale, elevation)
    th = torch.deg2rad(rotation)[..., None]
    c, s = torch.cos(th), torch.sin(th)
    vx, vy, vz = vertices[..., 0], vertices[..., 1], vertices[..., 2]
    wx = scale[..., None] * (c * vx - s * vy) + x[..., None]
    wy = scale[..., None] * (s * vx + c * vy) + y[..., None]
    wz = scale[..., None] * vz + elevation[..., None]
    return torch.stack([wx, wy, wz], dim=-1)


# --- a look -------------------------------------------------------------------------------------------------------


def category_sheet(*, tile: tuple[int, int] = (240, 180), view: tuple[float, float] = (40.0, 25.0)) -> np.ndarray:
    """A contact sheet (BGR uint8): one row per category, its mesh first (grey, with its vertex count), then each
    subtype (parts coloured) from the same camera with the category mesh's outline overlaid in red."""
    import cv2

    from po3d_ppl.world.contact_sheet import shade, view_camera
    from po3d_ppl.world.meshes import vehicle_mesh
    from po3d_ppl.world.raycast import RayCaster, camera_rays

    w, h = tile
    columns = 1 + max(len(subtypes_of(c)) for c in ontology.CATEGORIES)
    rows = []
    for category in ontology.CATEGORIES:
        cm = category_mesh(category)
        camera = view_camera(cm.bounds[1] - cm.bounds[0], *view, w, h, fill=0.8)
        origins, dirs = camera_rays(camera)
        hits = RayCaster([cm.trimesh()]).cast(origins, dirs)
        cells = [_bgr8(_grey_shading(hits, dirs, h, w))]
        _text(cells[0], f"{category}: {cm.num_vertices} vertices")
        contours, _ = cv2.findContours(hits.hit.reshape(h, w).astype(np.uint8), cv2.RETR_EXTERNAL,
                                       cv2.CHAIN_APPROX_NONE)
        for subtype in cm.subtypes:
            cell = _bgr8(shade(vehicle_mesh(subtype), camera))
            cv2.drawContours(cell, contours, -1, (0, 0, 230), 1)
            _text(cell, subtype)
            cells.append(cell)
        cells += [np.full_like(cells[0], 255)] * (columns - len(cells))
        rows.append(np.concatenate(cells, axis=1))
    sheet = np.concatenate(rows, axis=0)
    sheet[::h, :] = 200
    sheet[:, ::w] = 200
    return sheet


def _grey_shading(hits, dirs: np.ndarray, h: int, w: int) -> np.ndarray:
    """Two-sided Lambert shading of ray hits on a white background (RGB float [h, w, 3])."""
    img = np.ones((len(hits), 3))
    n = hits.normal[hits.hit].astype(np.float64)
    view = -dirs[hits.hit].astype(np.float64)
    n *= np.sign(np.sum(n * view, axis=1, keepdims=True) + 1e-12)
    key = np.array([0.3, 0.5, 0.8]) / np.linalg.norm([0.3, 0.5, 0.8])
    light = 0.3 + 0.45 * np.clip(n @ key, 0, 1) + 0.25 * np.clip(np.sum(n * view, axis=1), 0, 1)
    img[hits.hit] = 0.75 * light[:, None]
    return img.reshape(h, w, 3)


def _bgr8(rgb: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray((np.clip(rgb, 0, 1) * 255).round().astype(np.uint8)[..., ::-1])


def _text(img: np.ndarray, text: str) -> None:
    import cv2

    cv2.putText(img, text, (6, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (20, 20, 20), 1, cv2.LINE_AA)


def write_category_sheet(path: str | Path) -> Path:
    """Write :func:`category_sheet` as a PNG (for a person to look at the meshes)."""
    from po3d_ppl.world.contact_sheet import write_png

    return write_png(path, category_sheet())


__all__ = [
    "CategoryMesh", "all_category_meshes", "build_category_mesh", "category_mesh", "category_sheet",
    "distance_to_surface", "pose_category_mesh", "pose_matrix", "pose_vertices_torch", "subtypes_of", "surface_nets",
    "write_category_sheet",
]

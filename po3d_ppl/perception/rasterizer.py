"""A hard z-buffer triangle rasteriser in torch, for render-and-compare perception.

**Why hand-written.** PyTorch3D does not install here (no wheel for our torch, and building it from source wants a
CUDA toolchain this machine lacks) and nvdiffrast is CUDA-only, while perception must run on 2 CPU cores as well
as on a GPU. What render-and-compare needs is small: which triangle each pixel sees, and barycentrics that carry
gradients to the pose. So it is written here in plain torch (CPU and CUDA alike; tensors are made on the inputs'
device).

**Two passes.**

1. *Coverage* (no autograd, vectorised, float64): each triangle is expanded into the pixel rows of its bounding
   box, each row into the exact span of pixel centres between the triangle's edges, and each covered pixel into
   a (depth, face) key; the nearest triangle per pixel is a scatter-min over int64 keys packing the float32 depth
   bits above the face index, so the z-buffer is one ``scatter_reduce``. No Python loop runs over pixels or
   triangles (only over chunks of ~1M candidates, to bound memory), and the buffer covers only each batch item's
   pixel box. Edge crossings are computed from a canonical endpoint order, so a pixel centre on an edge shared by
   two triangles is never lost (no cracks).
2. *Barycentrics* (autograd): for the winning triangle of each covered pixel, perspective-correct barycentrics
   and depth are recomputed in torch from the differentiable projected vertices. Gradients w.r.t. vertex
   positions (hence pose) and camera flow through :meth:`Fragments.interpolate` and the depth. As in every hard
   rasteriser, *which* triangle wins is piecewise constant: silhouette edges carry no gradient.

**Speed** (``benchmarks/bench_rasterizer.py``): cost grows with triangles plus covered pixels times depth
complexity, so batch many meshes x poses per call (a call has a fixed ~1 ms of op dispatch) and render at the
feature-map stride when that is all a loss needs. ``cull_backfaces=True`` halves the work on closed meshes. The
work is many medium-sized torch ops: on a busy 2-core machine OpenMP's spin-waiting makes two intra-op threads
up to 10x slower than one, so set ``OMP_WAIT_POLICY=passive`` or ``torch.set_num_threads(1)`` there.

**Conventions are the world's** (:class:`po3d_ppl.world.scene.Camera`, :mod:`po3d_ppl.world.raycast`): the camera
frame is Blender/OpenGL (looks along -z, +y up); pixel coordinates start at the top-left *corner* of the image
with y down, and pixel (column u, row v) is sampled at its centre (u + 0.5, v + 0.5), exactly where the embree
renderer casts its rays, so silhouettes agree pixel for pixel at equal resolution. Depth is the distance along the
viewing axis (``Camera.project``'s third coordinate). Triangles with a vertex nearer than ``near`` (or behind the
camera) are dropped rather than clipped: perception never places an object across the camera plane.

    >>> cam = camera_tensors(make_camera(640, 480), stride=8)                 # 80 x 60 feature-map camera
    >>> frags = rasterize(vertices, faces, cam.intrinsics, cam.image_size, cam.world_to_camera)
    >>> frags.face_map, frags.depth_map, frags.mask, frags.interpolate(vertex_features)   # [B,H,W(,C)]
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from itertools import pairwise

import numpy as np
import torch

from po3d_ppl.errors import InputError
from po3d_ppl.world.scene import Camera

#: Default cap on the bounding-box pixel centres of the triangles rasterised at once: bounds the coverage pass's
#: memory (a few tens of bytes per candidate row and pixel).
MAX_CANDIDATES = 1 << 20
#: Triangles whose projected doubled area is below this (pixels^2) are dropped: their barycentrics would be 0/0.
MIN_AREA = 1e-12
_NO_HIT = torch.iinfo(torch.int64).max
_LOW32 = 0xFFFFFFFF


@dataclass(frozen=True, eq=False)
class CameraTensors:
    """A world :class:`Camera` as rasteriser inputs: ``intrinsics`` [3, 3], ``world_to_camera`` [4, 4] (OpenGL
    camera frame) and ``image_size`` (height, width)."""

    intrinsics: torch.Tensor
    world_to_camera: torch.Tensor
    image_size: tuple[int, int]


def scaled_intrinsics(intrinsics: torch.Tensor, stride: float) -> torch.Tensor:
    """Intrinsics of an image downsampled by ``stride`` (a stride-8 feature map of a 640x480 image is 80x60).

    With the pixel origin at the top-left corner, output pixel u covers input pixels [s u, s u + s), so focal
    lengths and the principal point both divide by s.
    """
    scale = torch.tensor([1.0 / stride, 1.0 / stride, 1.0], dtype=intrinsics.dtype, device=intrinsics.device)
    return intrinsics * scale[:, None]


def camera_tensors(camera: Camera, *, stride: int = 1, dtype: torch.dtype = torch.float32,
                   device: torch.device | str | None = None) -> CameraTensors:
    """The rasteriser's view of a world camera, optionally at a coarser ``stride`` (image size rounded up, as a
    padded stride-s CNN would give)."""
    if not isinstance(stride, int) or stride < 1:
        raise InputError("stride", f"must be a positive integer, got {stride!r}")
    K = torch.as_tensor(camera.K, dtype=dtype, device=device)
    w2c = torch.as_tensor(np.linalg.inv(camera.matrix_world), dtype=dtype, device=device)
    size = (-(-camera.height // stride), -(-camera.width // stride))
    return CameraTensors(scaled_intrinsics(K, stride) if stride > 1 else K, w2c, size)


def project_vertices(vertices: torch.Tensor, intrinsics: torch.Tensor, world_to_camera: torch.Tensor | None = None,
                     *, min_depth: float | None = None) -> torch.Tensor:
    """[B, V, 3] vertices -> [B, V, 3] of (x pixel, y pixel from the top, depth), as ``Camera.project``.

    ``world_to_camera`` ([4, 4] or [B, 4, 4], OpenGL frame) maps world points to the camera; ``None`` means the
    vertices are already in the camera frame. Differentiable. ``min_depth`` clamps the divisor (the depth column
    stays true) so vertices on or behind the camera plane give finite values and finite gradients.
    """
    cam = vertices
    if world_to_camera is not None:
        R, t = world_to_camera[..., :3, :3], world_to_camera[..., :3, 3]
        cam = vertices @ R.transpose(-1, -2) + t.unsqueeze(-2)
    depth = -cam[..., 2]
    div = depth if min_depth is None else depth.clamp_min(min_depth)
    # OpenGL (x right, y up, -z forward) -> OpenCV (x right, y down, +z forward), then the pinhole K.
    xn, yn = cam[..., 0] / div, -cam[..., 1] / div
    K = intrinsics.unsqueeze(-3) if intrinsics.dim() == 3 else intrinsics
    x = K[..., 0, 0] * xn + K[..., 0, 1] * yn + K[..., 0, 2]
    y = K[..., 1, 1] * yn + K[..., 1, 2]
    return torch.stack([x, y, depth], dim=-1)


@dataclass(frozen=True, eq=False)
class Fragments:
    """What each pixel sees, stored sparsely over the covered pixels (``pixel`` ascending) with dense views.

    ``pixel`` holds flat indices ``b * H * W + row * W + column``; ``face`` the winning triangle (a row of
    ``faces``); ``bary`` [N, 3] its perspective-correct barycentrics and ``depth`` [N] the view depth, both
    differentiable w.r.t. the vertices and camera.
    """

    batch: int
    height: int
    width: int
    pixel: torch.Tensor
    face: torch.Tensor
    bary: torch.Tensor
    depth: torch.Tensor
    #: [F, 3] shared or [B, F, 3] per batch item; kept to gather per-vertex features.
    faces: torch.Tensor

    @property
    def batch_index(self) -> torch.Tensor:
        """[N] batch item of each covered pixel."""
        return torch.div(self.pixel, self.height * self.width, rounding_mode="floor")

    @property
    def vertex_index(self) -> torch.Tensor:
        """[N, 3] vertex indices of each covered pixel's triangle."""
        return _vertex_index(self.faces, self.batch_index, self.face)

    def _dense(self, values: torch.Tensor, fill: float) -> torch.Tensor:
        shape = (self.batch * self.height * self.width, *values.shape[1:])
        out = torch.full(shape, fill, dtype=values.dtype, device=values.device)
        return out.index_copy(0, self.pixel, values).view(self.batch, self.height, self.width, *values.shape[1:])

    @property
    def mask(self) -> torch.Tensor:
        """[B, H, W] bool: the pixel sees a triangle."""
        return self._dense(torch.ones_like(self.pixel, dtype=torch.bool), False)

    @property
    def face_map(self) -> torch.Tensor:
        """[B, H, W] int64 triangle index, -1 on the background."""
        return self._dense(self.face, -1)

    @property
    def depth_map(self) -> torch.Tensor:
        """[B, H, W] view depth, ``inf`` on the background (as the world's depth maps)."""
        return self._dense(self.depth, float("inf"))

    @property
    def bary_map(self) -> torch.Tensor:
        """[B, H, W, 3] barycentrics, zero on the background."""
        return self._dense(self.bary, 0.0)

    def interpolate_sparse(self, features: torch.Tensor) -> torch.Tensor:
        """[N, C] features of the covered pixels (cheaper than the dense map when a loss only needs these)."""
        feats = _check_features(features, self)
        rows = self.vertex_index
        if feats.dim() == 3:
            rows = rows + (self.batch_index * feats.shape[1])[:, None]
        corner = feats.reshape(-1, feats.shape[-1]).index_select(0, rows.reshape(-1)).view(-1, 3, feats.shape[-1])
        return (self.bary.unsqueeze(-1).to(corner.dtype) * corner).sum(dim=1)

    def interpolate(self, features: torch.Tensor, background: float = 0.0) -> torch.Tensor:
        """Per-vertex ``features`` ([B, V, C], or [V, C] shared by the batch) -> [B, H, W, C] per pixel."""
        return self._dense(self.interpolate_sparse(features), background)


def rasterize(vertices: torch.Tensor, faces: torch.Tensor, intrinsics: torch.Tensor, image_size: Sequence[int],
              world_to_camera: torch.Tensor | None = None, *, near: float = 1e-3, cull_backfaces: bool = False,
              max_candidates: int = MAX_CANDIDATES) -> Fragments:
    """Rasterise B meshes (or one mesh in B poses) into B images of ``image_size`` = (height, width).

    ``vertices`` [B, V, 3] float (world frame, or camera frame when ``world_to_camera`` is None); ``faces`` [F, 3]
    shared or [B, F, 3] per item (rows with a negative index are padding, see :func:`pad_meshes`);
    ``intrinsics`` [3, 3] or [B, 3, 3]; ``world_to_camera`` [4, 4] or [B, 4, 4]. ``cull_backfaces`` skips
    triangles facing away (about half the work); it is exact for closed, outward-wound meshes seen from outside,
    like the world's vehicles, and off by default because it is wrong for open or inconsistently wound ones.
    """
    height, width = _check_inputs(vertices, faces, intrinsics, image_size, world_to_camera, near, max_candidates)
    projected = project_vertices(vertices, intrinsics, world_to_camera, min_depth=near)
    pixel, face = _coverage(projected.detach(), faces, height, width, near, max_candidates, cull_backfaces)
    bary, depth = _barycentrics(projected, faces, pixel, face, width, height)
    return Fragments(vertices.shape[0], height, width, pixel, face, bary, depth, faces)


def rasterize_camera(vertices: torch.Tensor, faces: torch.Tensor, camera: Camera, *, stride: int = 1,
                     near: float = 1e-3, cull_backfaces: bool = False) -> Fragments:
    """:func:`rasterize` through a world :class:`Camera` (world-frame vertices), optionally at a coarser stride."""
    cam = camera_tensors(camera, stride=stride, dtype=vertices.dtype, device=vertices.device)
    return rasterize(vertices, faces, cam.intrinsics, cam.image_size, cam.world_to_camera, near=near,
                     cull_backfaces=cull_backfaces)


def pad_meshes(meshes: Sequence[tuple[torch.Tensor, torch.Tensor]]) -> tuple[torch.Tensor, torch.Tensor]:
    """Batch meshes of different sizes: [(vertices [V_i, 3], faces [F_i, 3])] -> ([B, V, 3], [B, F, 3]), padding
    vertices with zeros and faces with -1 rows (which :func:`rasterize` skips)."""
    if not meshes:
        raise InputError("meshes", "give at least one (vertices, faces) pair")
    nv = max(v.shape[0] for v, _ in meshes)
    nf = max(f.shape[0] for _, f in meshes)
    v0, f0 = meshes[0]
    verts = v0.new_zeros((len(meshes), nv, 3))
    tris = torch.full((len(meshes), nf, 3), -1, dtype=torch.int64, device=f0.device)
    for i, (v, f) in enumerate(meshes):
        verts[i, : v.shape[0]] = v
        tris[i, : f.shape[0]] = f.to(torch.int64)
    return verts, tris


# --- pass 1: coverage (no autograd) -------------------------------------------------------------------------------
#
# Layout: per-triangle work runs on [coordinate, corner, triangle] tensors (structure of arrays) so that every op is
# elementwise over long contiguous rows; torch's reductions over a trailing axis of size 3 are ~10x slower. Gathers
# use ``index_select`` with non-decreasing indices (streaming reads), several times faster than advanced indexing.


@torch.no_grad()
def _coverage(projected: torch.Tensor, faces: torch.Tensor, height: int, width: int, near: float,
              max_candidates: int, cull_backfaces: bool) -> tuple[torch.Tensor, torch.Tensor]:
    """Flat pixel index and winning face of every covered pixel (ascending pixel order)."""
    batch, n_faces, device = projected.shape[0], faces.shape[-2], projected.device
    corners, real = _corners(projected, faces)
    x, y, z = corners
    first_col, n_cols = _pixel_range(x.amin(0), x.amax(0), width)
    first_row, n_rows = _pixel_range(y.amin(0), y.amax(0), height)
    keep = torch.nonzero(real & (z.amin(0) >= near) & (n_cols * n_rows > 0)).squeeze(1)
    # float64: float32 inverse-depth planes mis-order nearly touching parts (1e-3 of the pixels, against 3e-5)
    edges, area = _setup(corners.index_select(2, keep).to(torch.float64))
    ok = area.abs() > MIN_AREA
    if cull_backfaces:  # outward (counter-clockwise) winding projects clockwise in the y-down image
        ok &= area < 0
    # Dropped triangles keep their rows in the tables but get no pixel rows (cheaper than compacting them).
    n_cols, n_rows, first_col, first_row = (t.index_select(0, keep) for t in (n_cols, n_rows, first_col, first_row))
    n_rows = n_rows * ok
    item, face_id = torch.div(keep, n_faces, rounding_mode="floor"), keep % n_faces
    boxes = _ItemBoxes.of(item, first_col, n_cols * ok, first_row, n_rows, batch)
    key = torch.full((boxes.size,), _NO_HIT, dtype=torch.int64, device=device)
    if keep.numel():
        base, stride = boxes.addressing(item)
        table = torch.stack([first_row, n_rows, base, stride, face_id], dim=1)
        for run in _chunks(n_cols * n_rows, max_candidates):
            _scan(edges[run], table[run], width, key)
    slot = torch.nonzero(key != _NO_HIT).squeeze(1)
    return boxes.pixels(slot, height, width), key[slot] & _LOW32


@dataclass(frozen=True)
class _ItemBoxes:
    """The z-buffer holds only each batch item's pixel box (the union of its triangles' boxes), one after the
    other: a small object in a 640x480 image then costs its box, not the whole image, to fill and to scan."""

    first_row: torch.Tensor
    first_col: torch.Tensor
    cols: torch.Tensor
    start: torch.Tensor
    end: torch.Tensor

    @property
    def size(self) -> int:
        return int(self.end[-1]) if self.end.numel() else 0

    @classmethod
    def of(cls, item: torch.Tensor, first_col: torch.Tensor, n_cols: torch.Tensor, first_row: torch.Tensor,
           n_rows: torch.Tensor, batch: int) -> _ItemBoxes:
        def reduce(values: torch.Tensor, how: str, empty: int) -> torch.Tensor:
            out = torch.full((batch,), empty, dtype=torch.int64, device=item.device)
            return out.scatter_reduce_(0, item, values, reduce=how, include_self=False)

        r0, c0 = reduce(first_row, "amin", 0), reduce(first_col, "amin", 0)
        r1, c1 = reduce(first_row + n_rows, "amax", 0), reduce(first_col + n_cols, "amax", 0)
        rows, cols = (r1 - r0).clamp_min(0), (c1 - c0).clamp_min(0)
        end = torch.cumsum(rows * cols, 0)
        return cls(r0, c0, cols, end - rows * cols, end)

    def addressing(self, item: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Per triangle (of batch ``item``) the buffer slot of pixel (row 0, column 0) and the row stride."""
        stride = self.cols.index_select(0, item)
        base = self.start.index_select(0, item) - self.first_row.index_select(0, item) * stride \
            - self.first_col.index_select(0, item)
        return base, stride

    def pixels(self, slot: torch.Tensor, height: int, width: int) -> torch.Tensor:
        """Buffer slots (ascending) -> flat image pixel indices (ascending)."""
        item = torch.searchsorted(self.end, slot, right=True)
        local = slot - self.start.index_select(0, item)
        cols = self.cols.index_select(0, item)
        line = self.first_row.index_select(0, item) + torch.div(local, cols, rounding_mode="floor")
        col = self.first_col.index_select(0, item) + local % cols
        return item * (height * width) + line * width + col


def _corners(projected: torch.Tensor, faces: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """[3 (x, y, depth), 3 corners, B * F] projected triangle corners, and [B * F] which rows are real faces (a row
    with a negative index is padding)."""
    batch, n_vertices = projected.shape[:2]
    f = faces.to(torch.int64)
    real = (f >= 0).all(dim=-1).expand(batch, -1).reshape(-1)
    f = f.clamp_min(0).expand(batch, -1, -1)
    ids = f.permute(2, 0, 1) + (torch.arange(batch, device=f.device) * n_vertices)[None, :, None]
    table = projected.reshape(-1, 3).t().contiguous()
    return table.index_select(1, ids.reshape(-1)).view(3, 3, -1), real


def _pixel_range(lo: torch.Tensor, hi: torch.Tensor, size: int) -> tuple[torch.Tensor, torch.Tensor]:
    """First index and count of the pixel centres (u + 0.5) within [lo, hi], clipped to [0, size)."""
    first = torch.ceil(lo.clamp(-1.0, size) - 0.5).clamp_min(0).to(torch.int64)
    last = torch.floor(hi.clamp(-1.0, size + 1.0) - 0.5).to(torch.int64).clamp_max(size - 1)
    return first, (last - first + 1).clamp_min(0)


def _setup(corners: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Per triangle a row of 15: for each corner k its opposite edge's start x, start y, dx, dy (3 each) with
    the inside where ``dx (py - y) - dy (px - x) >= 0``, then the inverse depth as a plane ``a px + b py + c``
    (it is affine in the image); and the doubled signed area (negative when clockwise in the y-down image).

    An edge starts at its lexicographically smaller endpoint, and its direction is ``(b - a) * sign(area)``,
    which is bit for bit the negation of the neighbour's ``(a - b) * sign(area')`` (IEEE subtraction is
    antisymmetric). The two triangles sharing an edge therefore compute bit-identical crossings of it with each
    pixel row, one as its left bound and the other as its right: a pixel centre on the edge is covered by one of
    them at least, never by neither (no cracks).
    """
    x, y, z = corners
    nxt, nxt2 = [1, 2, 0], [2, 0, 1]  # corner k's opposite edge runs from corner k+1 to corner k+2
    ax, ay, bx, by = x[nxt], y[nxt], x[nxt2], y[nxt2]
    swap = (ax > bx) | ((ax == bx) & (ay > by))
    sx, sy = torch.where(swap, bx, ax), torch.where(swap, by, ay)
    area = (x[1] - x[0]) * (y[2] - y[0]) - (y[1] - y[0]) * (x[2] - x[0])
    # The edge function of (a, b) has the sign of ``area`` inside, whatever the winding: flip it by that sign.
    sign = torch.where(area < 0, -1.0, 1.0).to(x.dtype)
    dx, dy = (bx - ax) * sign, (by - ay) * sign
    # Edge functions are barycentrics times |area|, so 1/z = sum_k w_k(p) / z_k / |area| is affine in p.
    scale = 1.0 / (z * area.abs().clamp_min(MIN_AREA))
    plane = [(-dy * scale).sum(0), (dx * scale).sum(0), ((dy * sx - dx * sy) * scale).sum(0)]
    return torch.stack([*sx, *sy, *dx, *dy, *plane], dim=1), area


def _chunks(counts: torch.Tensor, max_candidates: int) -> list[slice]:
    """Consecutive runs of triangles whose bounding boxes hold about ``max_candidates`` pixel centres at most (a
    lone big triangle gets a run of its own): bounds the memory of one :func:`_scan`."""
    ends = torch.cumsum(counts, 0)
    total = int(ends[-1])
    if total <= max_candidates:
        return [slice(0, counts.numel())]
    cuts = torch.searchsorted(ends, torch.arange(max_candidates, total, max_candidates, device=counts.device),
                              right=True)
    bounds = sorted({0, *cuts.tolist(), counts.numel()})
    return [slice(lo, hi) for lo, hi in pairwise(bounds)]


def _expand(counts: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """For items with ``counts`` sub-items each: the (non-decreasing) item of every sub-item and its rank in it."""
    total = int(counts.sum())
    owner = torch.repeat_interleave(torch.arange(counts.numel(), device=counts.device), counts, output_size=total)
    start = torch.cumsum(counts, 0) - counts
    return owner, torch.arange(total, device=counts.device) - start.index_select(0, owner)


def _max3(t: torch.Tensor) -> torch.Tensor:
    return torch.maximum(torch.maximum(t[:, 0], t[:, 1]), t[:, 2])


def _min3(t: torch.Tensor) -> torch.Tensor:
    return torch.minimum(torch.minimum(t[:, 0], t[:, 1]), t[:, 2])


def _scan(edges: torch.Tensor, table: torch.Tensor, width: int, key: torch.Tensor) -> None:
    """Rasterise a run of triangles into ``key`` (scatter-min of packed depth and face).

    Two expansions: triangles into the pixel rows of their boxes, where the exact column span is cut by the three
    edges; then rows into their covered pixels, which only evaluate the inverse-depth plane. ``edges`` rows are
    :func:`_setup`'s, ``table`` rows (first row, row count, buffer slot of pixel (0, 0), row stride, face).
    """
    tri, rank = _expand(table[:, 1])
    line = table[:, 0].index_select(0, tri) + rank
    py = line.to(edges.dtype)[:, None] + 0.5
    e = edges.index_select(0, tri)
    x0, y0, dx, dy = e[:, 0:3], e[:, 3:6], e[:, 6:9], e[:, 9:12]
    # Inside iff dx (py - y0) >= dy (px - x0): a right bound where dy > 0, a left bound where dy < 0, and a whole
    # row in or out where the edge is horizontal.
    rise = dx * (py - y0)
    cross = x0 + rise / torch.where(dy == 0, 1.0, dy)
    left = _max3(torch.where(dy < 0, cross, -torch.inf)).clamp(-1.0, width + 1.0)
    right = _min3(torch.where(dy > 0, cross, torch.inf)).clamp(-1.0, width + 1.0)
    shut = _max3(((dy == 0) & (rise < 0)).to(torch.uint8)).bool()
    first, span = _pixel_range(left, right, width)
    rows = torch.nonzero(span.masked_fill_(shut, 0)).squeeze(1)
    if rows.numel() == 0:
        return
    tri, first, span, line = (t.index_select(0, rows) for t in (tri, first, span, line))
    plane = e[:, 12:15].index_select(0, rows)
    info = table.index_select(0, tri)
    row_inv_depth = plane[:, 1] * (line.to(edges.dtype) + 0.5) + plane[:, 2]
    owner, rank = _expand(span)
    col = first.index_select(0, owner) + rank
    inv_depth = plane[:, 0].index_select(0, owner) * (col.to(edges.dtype) + 0.5) \
        + row_inv_depth.index_select(0, owner)
    depth = (1.0 / inv_depth.clamp_min(1e-30)).to(torch.float32)
    packed = (depth.view(torch.int32).to(torch.int64) << 32) | info[:, 4].index_select(0, owner)
    slot = (info[:, 2] + line * info[:, 3]).index_select(0, owner) + col
    key.scatter_reduce_(0, slot, packed, reduce="amin")


# --- pass 2: differentiable barycentrics -------------------------------------------------------------------------


def _vertex_index(faces: torch.Tensor, item: torch.Tensor, face: torch.Tensor) -> torch.Tensor:
    """[N, 3] vertex indices of the given faces (``index_select``: advanced indexing is slow on the CPU)."""
    flat = faces.reshape(-1, 3)
    row = face if faces.dim() == 2 else item * faces.shape[1] + face
    return flat.index_select(0, row).to(torch.int64)


def _barycentrics(projected: torch.Tensor, faces: torch.Tensor, pixel: torch.Tensor, face: torch.Tensor,
                  width: int, height: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Perspective-correct barycentrics [N, 3] and view depth [N] of each covered pixel, from the differentiable
    projected corners of its winning triangle.

    Computed in float64 from the same corners the coverage pass tested, so they lie in [0, 1] even for slivers
    (float32 edge functions of a 100-pixel sliver can be off by more than its area), then cast back.
    """
    item, within = torch.div(pixel, height * width, rounding_mode="floor"), pixel % (height * width)
    vertex = _vertex_index(faces, item, face) + (item * projected.shape[1])[:, None]
    corners = projected.reshape(-1, 3).index_select(0, vertex.t().reshape(-1)).view(3, -1, 3).to(torch.float64)
    px = (within % width).to(torch.float64) + 0.5
    py = torch.div(within, width, rounding_mode="floor").to(torch.float64) + 0.5
    x, y, z = corners[..., 0] - px, corners[..., 1] - py, corners[..., 2]  # [3 corners, N], pixel at the origin
    # Edge functions at the pixel centre; corner k's opposite edge runs from corner k+1 to corner k+2.
    w = torch.stack([x[1] * y[2] - y[1] * x[2], x[2] * y[0] - y[2] * x[0], x[0] * y[1] - y[0] * x[1]])
    q = w / z  # barycentrics over depth, times the doubled signed area
    total = q.sum(dim=0)
    depth = w.sum(dim=0) / total
    return (q / total).t().to(projected.dtype), depth.to(projected.dtype)


# --- input checks ------------------------------------------------------------------------------------------------


def _check_inputs(vertices: torch.Tensor, faces: torch.Tensor, intrinsics: torch.Tensor, image_size: Sequence[int],
                  world_to_camera: torch.Tensor | None, near: float, max_candidates: int) -> tuple[int, int]:
    if not isinstance(vertices, torch.Tensor) or vertices.dim() != 3 or vertices.shape[-1] != 3:
        raise InputError("vertices", f"must be a [B, V, 3] tensor, got {_describe(vertices)} (add a batch axis "
                                     "with vertices[None] for one mesh)")
    if not vertices.is_floating_point():
        raise InputError("vertices", f"must be floating point, got {vertices.dtype} (use .float())")
    if not bool(torch.isfinite(vertices).all()):
        raise InputError("vertices", "must be finite (found NaN or inf)")
    batch, device = vertices.shape[0], vertices.device
    if not isinstance(faces, torch.Tensor) or faces.dim() not in (2, 3) or faces.shape[-1] != 3 \
            or (faces.dim() == 3 and faces.shape[0] != batch):
        raise InputError("faces", f"must be a [F, 3] or [{batch}, F, 3] tensor, got {_describe(faces)}")
    if faces.is_floating_point() or faces.dtype == torch.bool:
        raise InputError("faces", f"must hold integer vertex indices, got {faces.dtype} (use .long())")
    if faces.numel() and int(faces.max()) >= vertices.shape[1]:
        raise InputError("faces", f"index {int(faces.max())} is out of range for {vertices.shape[1]} vertices")
    _check_matrix("intrinsics", intrinsics, 3, batch)
    if world_to_camera is not None:
        _check_matrix("world_to_camera", world_to_camera, 4, batch)
    for name, t in (("faces", faces), ("intrinsics", intrinsics), ("world_to_camera", world_to_camera)):
        if t is not None and t.device != device:
            raise InputError(name, f"is on {t.device} but vertices are on {device}; move it with .to({device!s})")
    size = tuple(image_size)
    if len(size) != 2 or not all(isinstance(s, (int, np.integer)) and s > 0 for s in size):
        raise InputError("image_size", f"must be (height, width) positive integers, got {image_size!r}")
    if not near > 0:
        raise InputError("near", f"must be positive, got {near!r}")
    if max_candidates < 1:
        raise InputError("max_candidates", f"must be at least 1, got {max_candidates!r}")
    return int(size[0]), int(size[1])


def _check_matrix(name: str, m: torch.Tensor, n: int, batch: int) -> None:
    if not isinstance(m, torch.Tensor) or m.shape[-2:] != (n, n) or m.dim() not in (2, 3) \
            or (m.dim() == 3 and m.shape[0] != batch):
        raise InputError(name, f"must be a [{n}, {n}] or [{batch}, {n}, {n}] tensor, got {_describe(m)}")
    if not m.is_floating_point():
        raise InputError(name, f"must be floating point, got {m.dtype} (use .float())")


def _check_features(features: torch.Tensor, fragments: Fragments) -> torch.Tensor:
    if not isinstance(features, torch.Tensor) or features.dim() not in (2, 3) \
            or (features.dim() == 3 and features.shape[0] != fragments.batch):
        raise InputError("features", f"must be a [V, C] or [{fragments.batch}, V, C] tensor, "
                                     f"got {_describe(features)}")
    if features.device != fragments.pixel.device:
        raise InputError("features", f"is on {features.device}, the fragments on {fragments.pixel.device}")
    return features


def _describe(x: object) -> str:
    return f"shape {list(x.shape)}" if isinstance(x, torch.Tensor) else type(x).__name__


__all__ = [
    "CameraTensors", "Fragments", "camera_tensors", "pad_meshes", "project_vertices", "rasterize",
    "rasterize_camera", "scaled_intrinsics",
]

"""A hard z-buffer triangle rasteriser in torch, for render-and-compare perception.

**Why hand-written.** PyTorch3D does not install here (no wheel for our torch, and building it from source wants a
CUDA toolchain this machine lacks) and nvdiffrast is CUDA-only, while perception must run on 2 CPU cores as well
as on a GPU. What render-and-compare needs is small: which triangle each pixel sees, and barycentrics that carry
gradients to the pose. So it is written here in plain torch (CPU and CUDA alike; tensors are made on the inputs'
device).

**Two passes.**

1. *Coverage* (no autograd, vectorised): every triangle's pixel-centre bounding box is expanded into
   (triangle, pixel) candidates in one chunked ``repeat_interleave``; each candidate is tested with edge
   functions and the nearest triangle per pixel is kept by a scatter-min over an int64 key packing (float32 depth
   bits, face index), so the z-buffer is one ``scatter_reduce``. Edge functions are evaluated from a canonical
   endpoint order, so a pixel centre on an edge shared by two triangles is never lost (no cracks).
2. *Barycentrics* (autograd): for the winning triangle of each covered pixel, perspective-correct barycentrics
   and depth are recomputed in torch from the differentiable projected vertices. Gradients w.r.t. vertex
   positions (hence pose) and camera flow through :meth:`Fragments.interpolate` and the depth. As in every hard
   rasteriser, *which* triangle wins is piecewise constant: silhouette edges carry no gradient.

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

import numpy as np
import torch

from po3d_ppl.errors import InputError
from po3d_ppl.world.scene import Camera

#: Default cap on (triangle, pixel) candidates tested at once: bounds the coverage pass's memory (~60 B each).
MAX_CANDIDATES = 1 << 20
#: Triangles whose projected doubled area is below this (pixels^2) cover no pixel centre robustly: dropped.
MIN_AREA = 1e-12
_NO_HIT = torch.iinfo(torch.int64).max
_LOW32 = 0xFFFFFFFF


@dataclass(frozen=True)
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


@dataclass(frozen=True)
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

    def _dense(self, values: torch.Tensor, fill: float | int) -> torch.Tensor:
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
        idx = self.vertex_index
        corner = feats[idx] if feats.dim() == 2 else feats[self.batch_index[:, None], idx]
        return (self.bary.unsqueeze(-1).to(corner.dtype) * corner).sum(dim=1)

    def interpolate(self, features: torch.Tensor, background: float = 0.0) -> torch.Tensor:
        """Per-vertex ``features`` ([B, V, C], or [V, C] shared by the batch) -> [B, H, W, C] per pixel."""
        return self._dense(self.interpolate_sparse(features), background)


def rasterize(vertices: torch.Tensor, faces: torch.Tensor, intrinsics: torch.Tensor, image_size: Sequence[int],
              world_to_camera: torch.Tensor | None = None, *, near: float = 1e-3,
              max_candidates: int = MAX_CANDIDATES) -> Fragments:
    """Rasterise B meshes (or one mesh in B poses) into B images of ``image_size`` = (height, width).

    ``vertices`` [B, V, 3] float (world frame, or camera frame when ``world_to_camera`` is None); ``faces`` [F, 3]
    shared or [B, F, 3] per item (rows with a negative index are padding, see :func:`pad_meshes`);
    ``intrinsics`` [3, 3] or [B, 3, 3]; ``world_to_camera`` [4, 4] or [B, 4, 4].
    """
    height, width = _check_inputs(vertices, faces, intrinsics, image_size, world_to_camera, near, max_candidates)
    projected = project_vertices(vertices, intrinsics, world_to_camera, min_depth=near)
    pixel, face = _coverage(projected.detach(), faces, height, width, near, max_candidates)
    bary, depth = _barycentrics(projected, faces, pixel, face, width, height)
    return Fragments(vertices.shape[0], height, width, pixel, face, bary, depth, faces)


def rasterize_camera(vertices: torch.Tensor, faces: torch.Tensor, camera: Camera, *, stride: int = 1,
                     near: float = 1e-3) -> Fragments:
    """:func:`rasterize` through a world :class:`Camera` (world-frame vertices), optionally at a coarser stride."""
    cam = camera_tensors(camera, stride=stride, dtype=vertices.dtype, device=vertices.device)
    return rasterize(vertices, faces, cam.intrinsics, cam.image_size, cam.world_to_camera, near=near)


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


@torch.no_grad()
def _coverage(projected: torch.Tensor, faces: torch.Tensor, height: int, width: int, near: float,
              max_candidates: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Flat pixel index and winning face of every covered pixel (ascending pixel order)."""
    batch, n_faces = projected.shape[0], faces.shape[-2]
    tri, valid = _triangles(projected, faces)
    item, face_id = _triangle_ids(batch, n_faces, projected.device)
    edges, ok = _edge_table(tri, near)
    box, counts = _pixel_boxes(tri, height, width)
    keep = torch.nonzero(valid & ok & (counts > 0)).squeeze(1)
    key = torch.full((batch * height * width,), _NO_HIT, dtype=torch.int64, device=projected.device)
    if keep.numel():
        base = item[keep] * (height * width)
        table = torch.stack([box[keep, 0], box[keep, 1], box[keep, 2], base, face_id[keep]], dim=1)
        for rows in _chunks(counts[keep], max_candidates):
            _scan(edges[keep[rows]], table[rows], counts[keep[rows]], width, key)
    pixel = torch.nonzero(key != _NO_HIT).squeeze(1)
    return pixel, key[pixel] & _LOW32


def _triangles(projected: torch.Tensor, faces: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """[B * F, 3, 3] projected corners (x, y, depth) and [B * F] validity (no padding index)."""
    batch = projected.shape[0]
    f = faces.to(torch.int64)
    valid = (f >= 0).all(dim=-1)
    f = f.clamp_min(0)
    if f.dim() == 2:
        tri = projected[:, f]
        valid = valid.expand(batch, -1)
    else:
        tri = projected[torch.arange(batch, device=projected.device)[:, None, None], f]
    return tri.reshape(-1, 3, 3), valid.reshape(-1)


def _triangle_ids(batch: int, n_faces: int, device: torch.device) -> tuple[torch.Tensor, torch.Tensor]:
    item = torch.arange(batch, device=device).repeat_interleave(n_faces)
    return item, torch.arange(n_faces, device=device).repeat(batch)


def _edge_table(tri: torch.Tensor, near: float) -> tuple[torch.Tensor, torch.Tensor]:
    """Per triangle, for each corner k the edge opposite it as (ax, ay, dx, dy, 1/depth_k), oriented so that inside
    points have all three edge functions >= 0; and which triangles can be drawn (in front, non-degenerate).

    The edge's start and direction come from its endpoints in a canonical (lexicographic) order and the sign is
    folded into the direction afterwards, so the two triangles sharing an edge evaluate bit-identical values of
    opposite sign there: a pixel centre on the edge is covered by one of them, never by neither.
    """
    xy, depth = tri[..., :2], tri[..., 2]
    a, b = xy.roll(-1, dims=1), xy.roll(-2, dims=1)  # corner k's opposite edge runs from k+1 to k+2
    swap = (a[..., 0] > b[..., 0]) | ((a[..., 0] == b[..., 0]) & (a[..., 1] > b[..., 1]))
    start = torch.where(swap[..., None], b, a)
    direction = torch.where(swap[..., None], a - b, b - a)
    sign = torch.where(swap, -1.0, 1.0).to(xy.dtype)
    p0, p1, p2 = xy[:, 0], xy[:, 1], xy[:, 2]
    area = (p1[:, 0] - p0[:, 0]) * (p2[:, 1] - p0[:, 1]) - (p1[:, 1] - p0[:, 1]) * (p2[:, 0] - p0[:, 0])
    # Image y points down, so a counter-clockwise (in the image) triangle has negative ``area`` here; the edge
    # function d x (p - a) has the sign of ``area`` inside, whatever the winding: flip by it.
    sign = sign * torch.where(area < 0, -1.0, 1.0).to(xy.dtype)[:, None]
    ok = (depth >= near).all(dim=1) & (area.abs() > MIN_AREA) & torch.isfinite(xy).all(dim=(1, 2))
    table = torch.cat([start, direction * sign[..., None], (1.0 / depth.clamp_min(near))[..., None]], dim=-1)
    return table, ok


def _pixel_boxes(tri: torch.Tensor, height: int, width: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Per triangle the first column, first row and column count of the pixel centres in its bounding box
    (clipped to the image), and the number of candidate pixels (0 when none)."""
    xy = tri[..., :2]
    lo = xy.amin(dim=1).nan_to_num(0.0)
    hi = xy.amax(dim=1).nan_to_num(0.0)
    limit = torch.tensor([width, height], dtype=xy.dtype, device=xy.device)
    # Centre u + 0.5 >= lo and <= hi  =>  u in [ceil(lo - 0.5), floor(hi - 0.5)].
    first = torch.ceil(torch.minimum(lo.clamp_min(-1.0), limit) - 0.5).clamp_min(0).to(torch.int64)
    last = torch.floor(torch.maximum(hi, torch.zeros_like(hi)).clamp_max(limit + 1) - 0.5).to(torch.int64)
    last = torch.minimum(last, limit.to(torch.int64) - 1)
    n = (last - first + 1).clamp_min(0)
    return torch.stack([first[:, 0], first[:, 1], n[:, 0]], dim=1), n[:, 0] * n[:, 1]


def _chunks(counts: torch.Tensor, max_candidates: int) -> list[slice]:
    """Consecutive runs of triangles with at most ``max_candidates`` candidates each (a lone big triangle gets a
    run of its own)."""
    ends = torch.cumsum(counts, 0)
    total = int(ends[-1])
    if total <= max_candidates:
        return [slice(0, counts.numel())]
    cuts = torch.searchsorted(ends, torch.arange(max_candidates, total, max_candidates, device=counts.device),
                              right=True)
    bounds = sorted({0, *cuts.tolist(), counts.numel()})
    return [slice(lo, hi) for lo, hi in zip(bounds[:-1], bounds[1:])]


def _scan(edges: torch.Tensor, table: torch.Tensor, counts: torch.Tensor, width: int, key: torch.Tensor) -> None:
    """Test every candidate pixel of a run of triangles and scatter-min (depth, face) keys into ``key``.

    ``table`` rows are (first column, first row, column count, flat offset of the batch item, face index).
    ``index_select`` rather than advanced indexing: it is several times faster on the CPU.
    """
    total = int(counts.sum())
    if total == 0:
        return
    tri = torch.repeat_interleave(torch.arange(counts.numel(), device=counts.device), counts, output_size=total)
    start = torch.cumsum(counts, 0) - counts
    row = table.index_select(0, tri)
    local = torch.arange(total, device=counts.device) - start.index_select(0, tri)
    down = torch.div(local, row[:, 2], rounding_mode="floor")
    col = row[:, 0] + (local - down * row[:, 2])
    line = row[:, 1] + down
    e = edges.index_select(0, tri)  # [P, 3, 5]
    px = (col.to(edges.dtype) + 0.5)[:, None]
    py = (line.to(edges.dtype) + 0.5)[:, None]
    w = e[..., 2] * (py - e[..., 1]) - e[..., 3] * (px - e[..., 0])
    inside = torch.nonzero((w >= 0).all(dim=1)).squeeze(1)
    if inside.numel() == 0:
        return
    w, inv_depth = w.index_select(0, inside), e[..., 4].index_select(0, inside)
    depth = w.sum(dim=1) / (w * inv_depth).sum(dim=1)
    bits = depth.to(torch.float32).view(torch.int32).to(torch.int64)
    row = row.index_select(0, inside)
    packed = (bits << 32) | row[:, 4]
    pixel = row[:, 3] + line.index_select(0, inside) * width + col.index_select(0, inside)
    key.scatter_reduce_(0, pixel, packed, reduce="amin")


# --- pass 2: differentiable barycentrics -------------------------------------------------------------------------


def _vertex_index(faces: torch.Tensor, item: torch.Tensor, face: torch.Tensor) -> torch.Tensor:
    return (faces[face] if faces.dim() == 2 else faces[item, face]).to(torch.int64)


def _barycentrics(projected: torch.Tensor, faces: torch.Tensor, pixel: torch.Tensor, face: torch.Tensor,
                  width: int, height: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Perspective-correct barycentrics [N, 3] and view depth [N] of each covered pixel, from the differentiable
    projected corners of its winning triangle."""
    item, within = torch.div(pixel, height * width, rounding_mode="floor"), pixel % (height * width)
    corners = projected[item[:, None], _vertex_index(faces, item, face)]  # [N, 3, 3]
    px = (within % width).to(projected.dtype) + 0.5
    py = torch.div(within, width, rounding_mode="floor").to(projected.dtype) + 0.5
    x, y, z = corners[..., 0], corners[..., 1], corners[..., 2]
    a, b = (1, 2, 0), (2, 0, 1)  # corner k's opposite edge runs from corner a[k] to corner b[k]
    w = (x[:, b] - x[:, a]) * (py[:, None] - y[:, a]) - (y[:, b] - y[:, a]) * (px[:, None] - x[:, a])
    screen = w / w.sum(dim=1, keepdim=True)
    q = screen / z
    depth = 1.0 / q.sum(dim=1)
    return q * depth[:, None], depth


# --- input checks ------------------------------------------------------------------------------------------------


def _check_inputs(vertices: torch.Tensor, faces: torch.Tensor, intrinsics: torch.Tensor, image_size: Sequence[int],
                  world_to_camera: torch.Tensor | None, near: float, max_candidates: int) -> tuple[int, int]:
    if not isinstance(vertices, torch.Tensor) or vertices.dim() != 3 or vertices.shape[-1] != 3:
        raise InputError("vertices", f"must be a [B, V, 3] tensor, got {_describe(vertices)} (add a batch axis "
                                     "with vertices[None] for one mesh)")
    if not vertices.is_floating_point():
        raise InputError("vertices", f"must be floating point, got {vertices.dtype} (use .float())")
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

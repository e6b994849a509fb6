"""Ray casting core: camera rays and first-hit queries against a set of triangle meshes.

Built directly on embreex (``EmbreeScene`` + ``TriangleMesh``, one embree geometry per input mesh so that the
returned ``geomID`` names the mesh). trimesh's own embree wrapper is about 5x slower on full-image queries
because it post-processes every hit in Python, and the scene renderer casts a full 640x480 image per scene plus one
solo image per object.

Camera convention (:class:`po3d_ppl.world.scene.Camera`): Blender/OpenGL camera-to-world matrix (the camera looks
along its -z axis, +y is up); pixel coordinates start at the top-left *corner* of the image with y pointing down,
so the centre of pixel (column u, row v) is (u + 0.5, v + 0.5). :func:`camera_rays` and ``Camera.project`` are
exact inverses of each other.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import trimesh

from po3d_ppl.errors import InputError
from po3d_ppl.world.scene import Camera

#: ``Hits.geometry`` value of a ray that hits nothing.
MISS = -1


def pixel_rays(camera: Camera, xs: np.ndarray, ys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rays through arbitrary image points (pixel units, origin at the top-left corner, y down).

    Returns float32 ``origins`` and unit ``directions`` of shape ``(N, 3)`` in world coordinates.
    """
    xs = np.asarray(xs, dtype=np.float64).reshape(-1)
    ys = np.asarray(ys, dtype=np.float64).reshape(-1)
    if xs.shape != ys.shape:
        raise InputError("pixels", f"xs and ys must have the same length, got {xs.size} and {ys.size}")
    K = camera.K
    # Camera frame (OpenGL): x right, y up, looking along -z. Inverse of Camera.project.
    local = np.stack(
        [(xs - K[0, 2]) / K[0, 0], -(ys - K[1, 2]) / K[1, 1], -np.ones_like(xs)],
        axis=-1,
    )
    world = camera.matrix_world
    directions = local @ world[:3, :3].T
    directions /= np.linalg.norm(directions, axis=-1, keepdims=True)
    origins = np.broadcast_to(world[:3, 3], directions.shape)
    return np.ascontiguousarray(origins, dtype=np.float32), np.ascontiguousarray(directions, dtype=np.float32)


def camera_rays(camera: Camera) -> tuple[np.ndarray, np.ndarray]:
    """One ray per pixel centre, row-major (row 0 at the top): float32 origins and unit directions ``(H*W, 3)``."""
    v, u = np.mgrid[0 : camera.height, 0 : camera.width]
    return pixel_rays(camera, u.reshape(-1) + 0.5, v.reshape(-1) + 0.5)


def look_at_camera(
    eye: Sequence[float],
    target: Sequence[float] = (0.0, 0.0, 0.0),
    *,
    width: int = 640,
    height: int = 480,
    focal_px: float | None = None,
    up: Sequence[float] = (0.0, 0.0, 1.0),
) -> Camera:
    """A :class:`Camera` at ``eye`` looking at ``target`` with world ``up`` kept vertical in the image.

    ``focal_px`` defaults to Blender's default camera (35 mm lens on a 32 mm sensor) at this width, the camera of
    the CLEVR family of datasets.
    """
    eye_v = np.asarray(eye, dtype=np.float64)
    forward = np.asarray(target, dtype=np.float64) - eye_v
    if np.linalg.norm(forward) == 0:
        raise InputError("eye", "the camera position must differ from the target it looks at")
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, np.asarray(up, dtype=np.float64))
    if np.linalg.norm(right) < 1e-9:
        raise InputError("up", "the up vector must not be parallel to the viewing direction")
    right /= np.linalg.norm(right)
    cam_up = np.cross(right, forward)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = right, cam_up, -forward, eye_v
    f = focal_px if focal_px is not None else width * 35.0 / 32.0
    K = ((f, 0.0, width / 2.0), (0.0, f, height / 2.0), (0.0, 0.0, 1.0))
    return Camera(width, height, K, tuple(tuple(float(x) for x in row) for row in m))


@dataclass(frozen=True)
class Hits:
    """First hit per ray. ``geometry`` is the index of the mesh hit (``MISS`` = -1 for none), ``face`` the triangle
    index in that mesh (-1 on a miss), ``distance`` the distance along the unit ray (``inf`` on a miss) and
    ``normal`` the unit face normal of the triangle as stored in the mesh (outward for a consistently wound closed
    mesh; zeros on a miss)."""

    geometry: np.ndarray
    face: np.ndarray
    distance: np.ndarray
    normal: np.ndarray

    def __len__(self) -> int:
        return int(self.geometry.shape[0])

    @property
    def hit(self) -> np.ndarray:
        return self.geometry != MISS

    def points(self, origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """World positions of the hits (NaN on misses)."""
        d = np.where(self.hit, self.distance, np.nan).astype(np.float64)
        return np.asarray(origins, np.float64) + np.asarray(directions, np.float64) * d[:, None]


class RayCaster:
    """An embree scene over a fixed list of meshes. Build it once, cast any number of ray batches.

    ``ids`` optionally renames the meshes: hits report ``ids[k]`` for the k-th mesh (default: ``k``). This lets a
    caller cast against a subset of its objects and still get its own object indices back (see :meth:`subset`).
    """

    def __init__(self, meshes: Sequence[trimesh.Trimesh], ids: Sequence[int] | None = None):
        from embreex import mesh_construction, rtcore_scene

        self._meshes = list(meshes)
        if ids is None:
            ids = range(len(self._meshes))
        self._ids = np.asarray(list(ids), dtype=np.int32)
        if self._ids.shape[0] != len(self._meshes):
            raise InputError("ids", f"got {self._ids.shape[0]} ids for {len(self._meshes)} meshes")
        self._scene = rtcore_scene.EmbreeScene()
        normals: list[np.ndarray] = []
        self._embree_index = np.full(len(self._meshes), -1, dtype=np.int32)
        for k, mesh in enumerate(self._meshes):
            if not isinstance(mesh, trimesh.Trimesh):
                raise InputError("meshes", f"item {k} is a {type(mesh).__name__}, expected trimesh.Trimesh")
            if len(mesh.faces) == 0:
                continue
            normals.append(np.asarray(mesh.face_normals, dtype=np.float32))
            # embree numbers geometries in creation order; remember which input each number stands for.
            mesh_construction.TriangleMesh(
                self._scene,
                np.ascontiguousarray(mesh.vertices, dtype=np.float32),
                np.ascontiguousarray(mesh.faces, dtype=np.int32),
            )
            self._embree_index[k] = int(np.count_nonzero(self._embree_index >= 0))
        embree_to_input = np.flatnonzero(self._embree_index >= 0)
        self._embree_to_id = self._ids[embree_to_input]
        # all face normals in one table: row = first row of the hit geometry + primitive id
        self._normal_table = np.concatenate(normals) if normals else np.zeros((0, 3), np.float32)
        self._normal_offset = np.cumsum([0] + [len(n) for n in normals])[:-1].astype(np.int64)

    def subset(self, indices: Sequence[int]) -> RayCaster:
        """A caster over some of this caster's meshes (positions in its list) that reports the same ids."""
        indices = [int(i) for i in indices]
        for i in indices:
            if not 0 <= i < len(self._meshes):
                raise InputError("indices", f"mesh index {i} is out of range for {len(self._meshes)} meshes")
        return RayCaster([self._meshes[i] for i in indices], [int(self._ids[i]) for i in indices])

    def cast(self, origins: np.ndarray, directions: np.ndarray) -> Hits:
        """First hit of each ray. ``origins``/``directions``: ``(R, 3)``; directions should be unit vectors for
        ``distance`` to be a Euclidean distance."""
        o = np.ascontiguousarray(origins, dtype=np.float32)
        d = np.ascontiguousarray(directions, dtype=np.float32)
        if o.ndim != 2 or o.shape[1] != 3 or d.shape != o.shape:
            raise InputError(
                "rays", f"origins and directions must both have shape (R, 3), got {o.shape} and {d.shape}"
            )
        n = o.shape[0]
        geometry = np.full(n, MISS, dtype=np.int32)
        face = np.full(n, -1, dtype=np.int32)
        distance = np.full(n, np.inf, dtype=np.float32)
        normal = np.zeros((n, 3), dtype=np.float32)
        if n == 0 or self._embree_to_id.size == 0:
            return Hits(geometry, face, distance, normal)
        out = self._scene.run(o, d, output=1)
        geom = np.asarray(out["geomID"], dtype=np.int32)
        rows = np.flatnonzero(geom >= 0)
        g, prim = geom[rows], np.asarray(out["primID"], dtype=np.int32)[rows]
        geometry[rows] = self._embree_to_id[g]
        face[rows] = prim
        distance[rows] = np.asarray(out["tfar"], dtype=np.float32)[rows]
        normal[rows] = self._normal_table[self._normal_offset[g] + prim]
        return Hits(geometry, face, distance, normal)

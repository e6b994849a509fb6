"""Ray-cast geometry of a layout: exact object/part/depth maps and each object's solo footprint.

Blender is far too heavy for our CPU budget, so every pixel is a ray cast through
:class:`po3d_ppl.world.raycast.RayCaster` (Embree). The image itself is formed in :mod:`po3d_ppl.world.shading`.

**Objects alone first, then the scene.** Every object is a similarity transform (scale, yaw, translation) of its
subtype's canonical mesh. So each object is cast *alone*, in its own frame, against a BVH of the canonical mesh
that is built once per subtype and cached, and only for the pixels of its projected box; the scene is the
per-pixel nearest of those hits (a z-buffer over objects). This gives each object's solo footprint (what it
looks like rendered alone at the same camera, needed for occlusion) for free, never re-renders a whole image
per object, and builds no acceleration structure per scene (a 35k-triangle scene BVH costs more than all the
rays of a 640x480 image). A ray ``o + t d`` maps to ``A^-1 (o - T) + t A^-1 d`` in the object frame
(``A`` = scale * rotation), so hit distances ``t`` compare directly across objects.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache, lru_cache

import numpy as np

from po3d_ppl.world.sampler import ObjectSpec, canonical_bounds
from po3d_ppl.world.scene import Camera

#: Part id in solo maps for pixels the object does not cover (``-1`` is its body, as in ``part_ids``).
ABSENT = -2


@dataclass(frozen=True)
class PlacedMesh:
    """One object of a layout: its canonical mesh's labels and its placement, with world-space geometry kept as
    plain arrays (trimesh's cached properties re-hash the mesh on every access)."""

    subtype: str
    #: 4x4 object-to-world transform and the canonical mesh's bounds ``[[min xyz], [max xyz]]``.
    transform: np.ndarray
    bounds: np.ndarray
    #: [V, 3] world vertices, [F, 3, 3] float32 world triangles and [F, 3] unit world face normals.
    vertices: np.ndarray
    triangles: np.ndarray
    face_normals: np.ndarray
    #: [F, 3, 3] world shading normal at each triangle corner (smooth within creases).
    corner_normals: np.ndarray
    #: Per-face part id (-1 = body) and surface finish (index into ``meshes.FINISHES``).
    face_parts: np.ndarray
    face_finish: np.ndarray

    @property
    def box_centre(self) -> np.ndarray:
        """World position of the centre of the object's oriented bounding box (the ``3d_coords``)."""
        centre = 0.5 * (self.bounds[0] + self.bounds[1])
        return self.transform[:3, :3] @ centre + self.transform[:3, 3]

    def to_local(self, points: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World rays -> rays in the canonical mesh's frame, with the same parameter ``t`` along them."""
        inv = np.linalg.inv(self.transform[:3, :3])
        origins = (np.asarray(points, np.float64) - self.transform[:3, 3]) @ inv.T
        return origins.astype(np.float32), (np.asarray(directions, np.float64) @ inv.T).astype(np.float32)


def place_meshes(specs: list[ObjectSpec]) -> list[PlacedMesh]:
    """Scale, rotate and move each subtype's canonical mesh into the world."""
    from po3d_ppl.world.meshes import vehicle_mesh

    placed = []
    for spec in specs:
        vm = vehicle_mesh(spec.subtype)
        bounds = canonical_bounds(spec.subtype)
        M = spec.transform(bounds)
        faces = np.asarray(vm.mesh.faces)
        vertices = np.asarray(vm.mesh.vertices, dtype=np.float64) @ M[:3, :3].T + M[:3, 3]
        rotation = (M[:3, :3] / spec.scale).astype(np.float32)
        placed.append(PlacedMesh(
            spec.subtype, M, bounds, vertices, vertices.astype(np.float32)[faces],
            np.asarray(vm.mesh.face_normals, dtype=np.float32) @ rotation.T,
            corner_normals(spec.subtype) @ rotation.T,
            np.asarray(vm.face_parts, dtype=np.int16), np.asarray(vm.face_finish, dtype=np.int8)))
    return placed


@cache
def local_caster(subtype: str):
    """A :class:`RayCaster` over the subtype's canonical mesh, built once per process."""
    from po3d_ppl.world.meshes import vehicle_mesh
    from po3d_ppl.world.raycast import RayCaster

    return RayCaster([vehicle_mesh(subtype).mesh])


@cache
def corner_normals(subtype: str, crease_degrees: float = 35.0) -> np.ndarray:
    """[F, 3, 3] unit shading normals at the corners of the subtype's canonical mesh: the area-weighted mean of
    the normals of faces that share the corner's position and bend less than ``crease_degrees`` from the face.

    trimesh's ``smooth_shade`` does the same but renumbers faces, and the face index is what links a ray hit to
    its part label, so the averaging is done here on the mesh as built.
    """
    from po3d_ppl.world.meshes import vehicle_mesh

    mesh = vehicle_mesh(subtype).mesh
    fn, area = np.asarray(mesh.face_normals), np.asarray(mesh.area_faces)
    _, position = np.unique(np.round(np.asarray(mesh.vertices), 6), axis=0, return_inverse=True)
    corner_group = position.reshape(-1)[np.asarray(mesh.faces)].ravel()
    corner_face = np.repeat(np.arange(len(mesh.faces)), 3)
    order = np.argsort(corner_group, kind="stable")
    groups, faces = corner_group[order], corner_face[order]
    starts = np.flatnonzero(np.r_[True, groups[1:] != groups[:-1]])
    sizes = np.diff(np.r_[starts, len(groups)])
    # Every (corner, other corner at the same position) pair, group by group.
    per = np.repeat(sizes, sizes)
    a = np.repeat(np.arange(len(groups)), per)
    b = np.repeat(np.repeat(starts, sizes), per) + (np.arange(len(a)) - np.repeat(np.cumsum(per) - per, per))
    fa, fb = faces[a], faces[b]
    keep = (fn[fa] * fn[fb]).sum(axis=1) >= np.cos(np.radians(crease_degrees))
    acc = np.zeros((len(groups), 3))
    np.add.at(acc, a[keep], fn[fb[keep]] * area[fb[keep], None])
    acc /= np.maximum(np.linalg.norm(acc, axis=1, keepdims=True), 1e-12)
    out = np.empty_like(acc)
    out[order] = acc
    return out.reshape(-1, 3, 3).astype(np.float32)


@lru_cache(maxsize=4)
def _directions(camera: Camera) -> np.ndarray:
    from po3d_ppl.world.raycast import camera_rays

    dirs = camera_rays(camera)[1]
    dirs.setflags(write=False)
    return dirs


def pixel_directions(camera: Camera) -> np.ndarray:
    """Unit ray direction per pixel centre, [H*W, 3] row-major (``raycast.camera_rays``), cached: directions
    depend only on the camera's rotation and intrinsics, which the CLEVR camera keeps while jitter moves it."""
    M = camera.camera_to_world
    at_origin = Camera(camera.width, camera.height, camera.intrinsics,
                       tuple(tuple(row[:3]) + (0.0,) for row in M[:3]) + ((0.0, 0.0, 0.0, 1.0),))
    return _directions(at_origin)


def projected_box(mesh: PlacedMesh, camera: Camera) -> tuple[int, int, int, int]:
    """Pixel box ``(x0, y0, x1, y1)`` (exclusive ends, clipped to the image) holding every pixel whose centre
    can see the mesh."""
    uvz = camera.project(mesh.vertices)
    if (uvz[:, 2] <= 0).any():  # part of the object behind the camera: the whole image is conservative
        return 0, 0, camera.width, camera.height
    x0 = int(np.clip(np.floor(uvz[:, 0].min()), 0, camera.width))
    x1 = int(np.clip(np.ceil(uvz[:, 0].max()) + 1, 0, camera.width))
    y0 = int(np.clip(np.floor(uvz[:, 1].min()), 0, camera.height))
    y1 = int(np.clip(np.ceil(uvz[:, 1].max()) + 1, 0, camera.height))
    return x0, y0, x1, y1


@dataclass(frozen=True)
class SoloView:
    """One object rendered alone, cropped to its projected box ``[y0:y0+h, x0:x0+w]``: hit distance (inf where
    the object is absent), face index (-1 absent) and part id (:data:`ABSENT`, -1 body, or a part id)."""

    x0: int
    y0: int
    distance: np.ndarray
    face: np.ndarray
    parts: np.ndarray

    @property
    def present(self) -> np.ndarray:
        return self.face >= 0


def cast_alone(mesh: PlacedMesh, camera: Camera) -> SoloView:
    """Cast the pixels of the object's projected box against the object alone (in its canonical frame)."""
    x0, y0, x1, y1 = projected_box(mesh, camera)
    h, w = y1 - y0, x1 - x0
    rows = np.arange(y0, y1)[:, None] * camera.width + np.arange(x0, x1)[None, :]
    origin, dirs = mesh.to_local(camera.location[None, :], pixel_directions(camera)[rows.ravel()])
    hits = local_caster(mesh.subtype).cast(np.broadcast_to(origin, dirs.shape), dirs)
    face = np.asarray(hits.face, dtype=np.int32).reshape(h, w)
    parts = np.where(face >= 0, mesh.face_parts[np.maximum(face, 0)], np.int16(ABSENT)).astype(np.int16)
    return SoloView(x0, y0, np.asarray(hits.distance, dtype=np.float32).reshape(h, w), face, parts)


@dataclass
class GBuffer:
    """The scene's first hits, one entry per pixel, row-major (flat arrays of length H*W)."""

    width: int
    height: int
    eye: np.ndarray
    dirs: np.ndarray
    #: Object hit first (-1 none), its face, the ray distance (inf if none), its unit world face normal and part.
    geometry: np.ndarray
    face: np.ndarray
    distance: np.ndarray
    normal: np.ndarray
    part: np.ndarray

    @property
    def object_ids(self) -> np.ndarray:
        return self.geometry.reshape(self.height, self.width).astype(np.int16)

    @property
    def part_ids(self) -> np.ndarray:
        return self.part.reshape(self.height, self.width)

    def pixel_counts(self, n_objects: int) -> np.ndarray:
        return np.bincount(self.geometry[self.geometry >= 0], minlength=n_objects)[:n_objects]


def composite(views: list[SoloView], meshes: list[PlacedMesh], camera: Camera) -> GBuffer:
    """The scene as the per-pixel nearest of the objects' solo hits."""
    H, W = camera.height, camera.width
    distance = np.full((H, W), np.inf, dtype=np.float32)
    geometry = np.full((H, W), -1, dtype=np.int32)
    face = np.full((H, W), -1, dtype=np.int32)
    for i, v in enumerate(views):
        h, w = v.face.shape
        win = (slice(v.y0, v.y0 + h), slice(v.x0, v.x0 + w))
        nearer = v.distance < distance[win]
        distance[win][nearer] = v.distance[nearer]
        geometry[win][nearer] = i
        face[win][nearer] = v.face[nearer]
    geometry, face, distance = geometry.ravel(), face.ravel(), distance.ravel()
    part = np.full(H * W, -1, dtype=np.int16)
    normal = np.zeros((H * W, 3), dtype=np.float32)
    for i, m in enumerate(meshes):
        sel = np.flatnonzero(geometry == i)
        part[sel] = m.face_parts[face[sel]]
        normal[sel] = m.face_normals[face[sel]]
    return GBuffer(W, H, camera.location.astype(np.float32), pixel_directions(camera), geometry, face, distance,
                   normal, part)


def render_geometry(meshes: list[PlacedMesh], camera: Camera) -> tuple[GBuffer, list[SoloView]]:
    """Solo views of every object and the composited scene."""
    views = [cast_alone(m, camera) for m in meshes]
    return composite(views, meshes, camera), views


def depth_map(gbuffer: GBuffer, camera: Camera) -> np.ndarray:
    """Float32 [H, W] depth along the camera's viewing axis of the first surface (objects or ground); inf where a
    ray hits nothing."""
    d = gbuffer.dirs
    t = gbuffer.distance.copy()
    ground = (gbuffer.geometry < 0) & (d[:, 2] < 0)
    t[ground] = -gbuffer.eye[2] / d[ground, 2]
    forward = (-camera.matrix_world[:3, 2]).astype(np.float32)
    return (t * (d @ forward)).reshape(gbuffer.height, gbuffer.width)

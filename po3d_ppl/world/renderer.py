"""Ray-cast rendering of a layout: the image, exact id/part/depth maps and each object's solo footprint.

Blender is far too heavy for our CPU budget, so the renderer casts one ray per pixel through
:class:`po3d_ppl.world.raycast.RayCaster` (Embree) and shades hits with a small analytic model written here
(no maintained library shades Embree hits with a Lambert/Blinn-Phong model on numpy arrays):

- a ground plane at z = 0 (intersected analytically, it can never hide an object) lit by a key and a fill light;
- rubber: Lambertian diffuse with a faint sheen; metal: darker diffuse, a strong white Blinn-Phong highlight and
  a colour-tinted reflection of a sky/ground environment, so the two materials are told apart by eye;
- hard shadows of the key light, cast only where a shadow is possible (object pixels, and ground pixels inside
  the projected shadow hulls of the objects).

**Solo footprints.** Occlusion needs what each object looks like rendered alone at the same camera. Instead of
re-rendering the image per object, only the pixels of the object's projected box whose first hit is *another*
object are cast again, against that object alone: any other pixel already shows the object or shows nothing
that could hide it (a ray that misses every object misses this one too).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache, lru_cache

import cv2
import numpy as np
import trimesh

from po3d_ppl.world import ontology
from po3d_ppl.world.sampler import ObjectSpec, canonical_bounds
from po3d_ppl.world.scene import Camera

#: Direction towards the key light (from the camera's front-left, high up) and the fill light (front-right).
KEY_LIGHT = np.array([-0.2, -0.85, 0.75]) / np.linalg.norm([-0.2, -0.85, 0.75])
FILL_LIGHT = np.array([0.76, 0.38, 0.6]) / np.linalg.norm([0.76, 0.38, 0.6])
GROUND_ALBEDO = 0.32
#: Offset (world units) that moves shadow-ray origins off the surface they start on.
SHADOW_EPS = 2e-3

#: Part id used in solo maps for pixels where the object is absent (``-1`` is the body, as in ``part_ids``).
ABSENT = -2


@dataclass(frozen=True)
class PlacedMesh:
    """One object's mesh in world coordinates with its per-face part ids (-1 = body)."""

    mesh: trimesh.Trimesh
    face_parts: np.ndarray
    #: Per-face surface kind (index into ``meshes.FINISHES``), used to shade unlabelled glass, tyres, chrome.
    face_finish: np.ndarray
    #: 4x4 object-to-world transform and the canonical mesh's bounds ``[[min xyz], [max xyz]]``.
    transform: np.ndarray
    bounds: np.ndarray
    #: [F, 3, 3] world-space shading normal at each triangle corner (smooth within creases).
    corner_normals: np.ndarray

    @property
    def box_centre(self) -> np.ndarray:
        """World position of the centre of the object's oriented bounding box (the ``3d_coords``)."""
        centre = 0.5 * (self.bounds[0] + self.bounds[1])
        return self.transform[:3, :3] @ centre + self.transform[:3, 3]


def place_meshes(specs: list[ObjectSpec]) -> list[PlacedMesh]:
    """Scale, rotate and move each subtype's canonical mesh into the world."""
    from po3d_ppl.world.meshes import vehicle_mesh

    placed = []
    for spec in specs:
        vm = vehicle_mesh(spec.subtype)
        bounds = canonical_bounds(spec.subtype)
        M = spec.transform(bounds)
        vertices = np.asarray(vm.mesh.vertices, dtype=np.float64) @ M[:3, :3].T + M[:3, 3]
        mesh = trimesh.Trimesh(vertices, np.asarray(vm.mesh.faces), process=False)
        rotation = (M[:3, :3] / spec.scale).astype(np.float32)
        normals = corner_normals(spec.subtype) @ rotation.T
        placed.append(PlacedMesh(mesh, np.asarray(vm.face_parts, dtype=np.int16),
                                 np.asarray(vm.face_finish, dtype=np.int8), M, bounds, normals))
    return placed


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


def shading_normals(meshes: list[PlacedMesh], geometry: np.ndarray, face: np.ndarray, points: np.ndarray,
                    facing: np.ndarray, view: np.ndarray) -> np.ndarray:
    """Smooth normals at hit ``points`` (barycentric interpolation of corner normals), turned to the viewer like
    the geometric ``facing`` normals; where interpolation would face away from the viewer, the geometric normal."""
    out = facing.copy()
    for i, m in enumerate(meshes):
        sel = np.flatnonzero(geometry == i)
        if sel.size == 0:
            continue
        tri = np.asarray(m.mesh.triangles, dtype=np.float32)[face[sel]]
        v0, v1, v2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0], points[sel] - tri[:, 0]
        d00, d01, d11 = (v0 * v0).sum(1), (v0 * v1).sum(1), (v1 * v1).sum(1)
        d20, d21 = (v2 * v0).sum(1), (v2 * v1).sum(1)
        denom = np.maximum(d00 * d11 - d01 * d01, 1e-20)
        v = np.clip((d11 * d20 - d01 * d21) / denom, 0, 1)
        w = np.clip((d00 * d21 - d01 * d20) / denom, 0, 1)
        u = np.clip(1 - v - w, 0, 1)
        cn = m.corner_normals[face[sel]]
        n = u[:, None] * cn[:, 0] + v[:, None] * cn[:, 1] + w[:, None] * cn[:, 2]
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
        # Corner normals follow the mesh's winding; match the side the geometric normal was turned to.
        geometric = np.asarray(m.mesh.face_normals, dtype=np.float32)[face[sel]]
        n *= np.sign((geometric * facing[sel]).sum(1, keepdims=True) + 1e-12)
        ok = (n * view[sel]).sum(1) > 0.05
        out[sel[ok]] = n[ok]
    return out


@dataclass
class GBuffer:
    """Primary-ray results. Flat arrays have one entry per pixel, row-major."""

    width: int
    height: int
    origins: np.ndarray
    dirs: np.ndarray
    #: Object hit first (-1 none), its face, the ray distance (inf if none) and the hit's geometric normal.
    geometry: np.ndarray
    face: np.ndarray
    distance: np.ndarray
    normal: np.ndarray
    part: np.ndarray
    #: The caster over all objects, reused for shadow rays and (as subsets) for solo footprints.
    caster: object = None

    @property
    def object_ids(self) -> np.ndarray:
        return self.geometry.reshape(self.height, self.width).astype(np.int16)

    @property
    def part_ids(self) -> np.ndarray:
        return self.part.reshape(self.height, self.width)

    def pixel_counts(self, n_objects: int) -> np.ndarray:
        return np.bincount(self.geometry[self.geometry >= 0], minlength=n_objects)[:n_objects]


@lru_cache(maxsize=4)
def _directions(camera: Camera) -> np.ndarray:
    from po3d_ppl.world.raycast import camera_rays

    dirs = camera_rays(camera)[1]
    dirs.setflags(write=False)
    return dirs


def pixel_rays(camera: Camera) -> tuple[np.ndarray, np.ndarray]:
    """``raycast.camera_rays``, with the directions cached: they depend only on the camera's rotation and
    intrinsics, which the CLEVR camera keeps fixed while jitter moves it."""
    M = camera.camera_to_world
    at_origin = Camera(camera.width, camera.height, camera.intrinsics,
                       tuple(tuple(row[:3]) + (0.0,) for row in M[:3]) + ((0.0, 0.0, 0.0, 1.0),))
    dirs = _directions(at_origin)
    origins = np.empty_like(dirs)
    origins[:] = np.asarray([M[0][3], M[1][3], M[2][3]], dtype=np.float32)
    return origins, dirs


def cast_primary(meshes: list[PlacedMesh], camera: Camera) -> GBuffer:
    """Cast one ray per pixel centre against all objects."""
    from po3d_ppl.world.raycast import RayCaster

    origins, dirs = pixel_rays(camera)
    caster = RayCaster([m.mesh for m in meshes])
    hits = caster.cast(origins, dirs)
    geometry = np.asarray(hits.geometry, dtype=np.int32)
    face = np.asarray(hits.face, dtype=np.int32)
    part = np.full(geometry.shape, -1, dtype=np.int16)
    for i, m in enumerate(meshes):
        sel = geometry == i
        part[sel] = m.face_parts[face[sel]]
    return GBuffer(camera.width, camera.height, origins, dirs, geometry, face,
                   np.asarray(hits.distance, dtype=np.float32), np.asarray(hits.normal, dtype=np.float32), part, caster)


@dataclass(frozen=True)
class SoloView:
    """The object rendered alone, cropped to its projected box ``[y0:y0+h, x0:x0+w]``: part id per pixel,
    :data:`ABSENT` where the object does not cover the pixel, -1 on its body."""

    x0: int
    y0: int
    parts: np.ndarray

    @property
    def present(self) -> np.ndarray:
        return self.parts != ABSENT


def projected_box(mesh: trimesh.Trimesh, camera: Camera) -> tuple[int, int, int, int]:
    """Pixel box ``(x0, y0, x1, y1)`` (exclusive ends, clipped to the image) that holds every pixel whose centre
    can hit the mesh."""
    uvz = camera.project(np.asarray(mesh.vertices))
    if (uvz[:, 2] <= 0).any():  # part of the object behind the camera: the whole image is conservative
        return 0, 0, camera.width, camera.height
    x0 = int(np.clip(np.floor(uvz[:, 0].min()), 0, camera.width))
    x1 = int(np.clip(np.ceil(uvz[:, 0].max()) + 1, 0, camera.width))
    y0 = int(np.clip(np.floor(uvz[:, 1].min()), 0, camera.height))
    y1 = int(np.clip(np.ceil(uvz[:, 1].max()) + 1, 0, camera.height))
    return x0, y0, x1, y1


def solo_views(gbuffer: GBuffer, meshes: list[PlacedMesh], camera: Camera) -> list[SoloView]:
    """Each object's solo part map, re-casting only its box pixels that show another object."""
    W = gbuffer.width
    geometry = gbuffer.geometry.reshape(gbuffer.height, W)
    part = gbuffer.part_ids
    views = []
    for i, m in enumerate(meshes):
        x0, y0, x1, y1 = projected_box(m.mesh, camera)
        geo = geometry[y0:y1, x0:x1]
        parts = np.where(geo == i, part[y0:y1, x0:x1], np.int16(ABSENT)).astype(np.int16)
        hidden = (geo >= 0) & (geo != i)
        if hidden.any():
            rows, cols = np.nonzero(hidden)
            flat = (rows + y0) * W + (cols + x0)
            hits = gbuffer.caster.subset([i]).cast(gbuffer.origins[flat], gbuffer.dirs[flat])
            hit = np.asarray(hits.geometry) >= 0
            parts[rows[hit], cols[hit]] = m.face_parts[np.asarray(hits.face)[hit]]
        views.append(SoloView(x0, y0, parts))
    return views


#: Shading models of a surface row.
RUBBER, METAL, GLASS, LAMP = 0, 1, 2, 3


@dataclass(frozen=True)
class ObjectLook:
    """Appearance table of one object. Row ``k`` < ``n_finishes`` is unlabelled geometry of finish ``k`` (paint,
    glass, rubber, chrome, lamp); row ``n_finishes + p`` is part ``p``. Each row has a linear RGB albedo and a
    shading model (RUBBER, METAL, GLASS, LAMP)."""

    albedo: np.ndarray
    model: np.ndarray
    n_finishes: int


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    c = np.asarray(c, dtype=np.float32) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


_SRGB_STEPS = 4096
_SRGB_LUT = np.round(255.0 * np.where(
    np.linspace(0, 1, _SRGB_STEPS) <= 0.0031308, 12.92 * np.linspace(0, 1, _SRGB_STEPS),
    1.055 * np.power(np.linspace(0, 1, _SRGB_STEPS), 1 / 2.4) - 0.055)).astype(np.uint8)


def linear_to_srgb8(c: np.ndarray) -> np.ndarray:
    """Linear [0, 1] -> sRGB uint8 through a 4096-entry table (within one 8-bit level of the exact curve)."""
    idx = (np.clip(c, 0.0, 1.0) * (_SRGB_STEPS - 1) + 0.5).astype(np.int32)
    return _SRGB_LUT[idx]


#: Unlabelled non-paint finishes (fixed looks, so windows, tyres and lamps read as such whatever the colour).
_FINISH_LOOKS = {
    "glass": ((0.015, 0.02, 0.03), GLASS),
    "rubber": ((0.02, 0.02, 0.02), RUBBER),
    "chrome": ((0.55, 0.55, 0.57), METAL),
    "lamp": ((0.85, 0.8, 0.55), LAMP),
}


def object_look(spec: ObjectSpec, parts: dict[str, tuple[str, str]]) -> ObjectLook:
    """Appearance of an object whose recoloured ``parts`` map raw name -> (colour, material). Painted body and
    every part take the object's colour and material unless recoloured, as in Super-CLEVR."""
    from po3d_ppl.world.meshes import FINISHES

    names = ontology.PARTS[spec.subtype]
    own = (srgb_to_linear(ontology.COLOR_RGB[spec.color]), METAL if spec.material == "metal" else RUBBER)
    rows = [_FINISH_LOOKS.get(f, own) for f in FINISHES] + [own] * len(names)
    for raw, (color, material) in parts.items():
        rows[len(FINISHES) + names.index(raw)] = (srgb_to_linear(ontology.COLOR_RGB[color]),
                                                  METAL if material == "metal" else RUBBER)
    albedo = np.array([np.asarray(a, dtype=np.float32) for a, _ in rows], dtype=np.float32)
    return ObjectLook(albedo, np.array([m for _, m in rows], dtype=np.int8), len(FINISHES))


def shadow_candidates(meshes: list[PlacedMesh], camera: Camera) -> np.ndarray:
    """Boolean [H, W] mask of ground pixels that may lie in a key-light shadow (union of projected hulls of
    each object's footprint and its shadow on the ground)."""
    mask = np.zeros((camera.height, camera.width), dtype=np.uint8)
    for m in meshes:
        lo, hi = m.mesh.bounds
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        ground = corners - KEY_LIGHT[None, :] * (corners[:, 2:3] / KEY_LIGHT[2])
        pts = np.concatenate([ground[:, :2], corners[:, :2]])
        hull = cv2.convexHull(pts.astype(np.float32)).reshape(-1, 2)
        uvz = camera.project(np.column_stack([hull, np.zeros(len(hull))]))
        if (uvz[:, 2] <= 0).any():
            return np.ones_like(mask, dtype=bool)
        poly = np.round(uvz[:, :2] * 16).astype(np.int32)  # 4 fractional bits for sub-pixel accuracy
        cv2.fillConvexPoly(mask, poly, 1, lineType=cv2.LINE_8, shift=4)
    # Dilate by a pixel so pixel-centre rounding never drops a shadowed pixel.
    return cv2.dilate(mask, np.ones((3, 3), np.uint8)).astype(bool)


def _shadowed(caster, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    if len(points) == 0:
        return np.zeros(0, dtype=bool)
    origins = (points + SHADOW_EPS * (normals + KEY_LIGHT)).astype(np.float32)
    dirs = np.broadcast_to(KEY_LIGHT.astype(np.float32), origins.shape)
    hits = caster.cast(origins, np.ascontiguousarray(dirs))
    return np.asarray(hits.geometry) >= 0


#: A large soft light behind the scene (as seen from CLEVR's camera), about 30 degrees up. Metal reflects it on
#: upward-facing surfaces; the dark ground is what side panels reflect.
SOFTBOX = np.array([-0.66, 0.62, 0.55]) / np.linalg.norm([-0.66, 0.62, 0.55])


def _environment(r: np.ndarray) -> np.ndarray:
    """Radiance seen along reflected directions ``r``: a grey sky with a bright softbox above the horizon, the
    dark ground below it. The contrast is what makes metal read as metal."""
    up = r[:, 2]
    softbox = np.clip(r @ SOFTBOX.astype(np.float32), 0, 1) ** 6
    return np.where(up > 0, 0.45 + 2.2 * softbox, 0.05).astype(np.float32)


def shade(gbuffer: GBuffer, meshes: list[PlacedMesh], looks: list[ObjectLook], camera: Camera,
          shadows: bool = True) -> np.ndarray:
    """The RGB uint8 image."""
    H, W = gbuffer.height, gbuffer.width
    d, o = gbuffer.dirs, gbuffer.origins
    key = KEY_LIGHT.astype(np.float32)
    # Rays that miss everything (above the horizon) see a flat sky.
    radiance = np.full((H * W, 3), 0.35, dtype=np.float32)

    obj_idx = np.flatnonzero(gbuffer.geometry >= 0)
    g = np.flatnonzero((gbuffer.geometry < 0) & (d[:, 2] < 0))
    gpos = o[g] + d[g] * (-o[g, 2] / d[g, 2])[:, None]
    n = gbuffer.normal[obj_idx]
    n = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    n *= np.where((n * d[obj_idx]).sum(axis=1, keepdims=True) > 0, -1.0, 1.0).astype(np.float32)
    p = o[obj_idx] + d[obj_idx] * gbuffer.distance[obj_idx, None]
    lit_ground = np.ones(len(g), dtype=np.float32)
    lit_obj = np.ones(len(obj_idx), dtype=np.float32)
    if shadows and meshes:
        cand = np.flatnonzero(shadow_candidates(meshes, camera).ravel()[g])
        up = np.broadcast_to(np.array([0, 0, 1], np.float32), (len(cand), 3))
        lit_ground[cand] = np.where(_shadowed(gbuffer.caster, gpos[cand], up), 0.0, 1.0)
        lit_obj = np.where(_shadowed(gbuffer.caster, p, n), 0.0, 1.0).astype(np.float32)

    # Ground plane, with a soft fall-off towards the horizon like CLEVR's curved backdrop.
    fade = np.exp(-np.hypot(gpos[:, 0], gpos[:, 1]) / 40.0)
    radiance[g] = (GROUND_ALBEDO * (0.45 + 0.75 * key[2] * lit_ground) * (0.75 + 0.25 * fade))[:, None]

    if len(obj_idx):
        ns = shading_normals(meshes, gbuffer.geometry[obj_idx], gbuffer.face[obj_idx], p, n, -d[obj_idx])
        radiance[obj_idx] = _shade_objects(gbuffer, meshes, looks, obj_idx, ns, d[obj_idx], lit_obj)
    return linear_to_srgb8(radiance.reshape(H, W, 3))


def _shade_objects(gbuffer: GBuffer, meshes: list[PlacedMesh], looks: list[ObjectLook], obj_idx: np.ndarray,
                   n: np.ndarray, d: np.ndarray, lit: np.ndarray) -> np.ndarray:
    """Radiance of object pixels: look up each pixel's appearance row, then apply its shading model."""
    geo, part, face = gbuffer.geometry[obj_idx], gbuffer.part[obj_idx].astype(np.int64), gbuffer.face[obj_idx]
    finish = np.zeros(len(obj_idx), dtype=np.int64)
    for i, m in enumerate(meshes):
        sel = geo == i
        finish[sel] = m.face_finish[face[sel]]
    offsets = np.cumsum([0] + [len(lk.albedo) for lk in looks[:-1]])
    n_finishes = np.array([lk.n_finishes for lk in looks])[geo]
    row = offsets[geo] + np.where(part >= 0, n_finishes + part, finish)
    albedo = np.concatenate([lk.albedo for lk in looks])[row]
    model = np.concatenate([lk.model for lk in looks])[row]

    key, fill = KEY_LIGHT.astype(np.float32), FILL_LIGHT.astype(np.float32)
    view = -d
    ndl = np.clip(n @ key, 0, 1) * lit
    ndf = np.clip(n @ fill, 0, 1)
    half = key[None, :] + view
    half /= np.linalg.norm(half, axis=1, keepdims=True)
    ndh = np.clip((n * half).sum(axis=1), 0, 1)
    ndv = np.clip((n * view).sum(axis=1), 0, 1)
    env = _environment(2 * ndv[:, None] * n - view)
    fresnel = 0.6 + 0.4 * (1 - ndv) ** 3
    highlight = (1.6 * ndh**120 + 0.35 * ndh**20) * lit

    out = albedo * (0.18 + 0.85 * ndl + 0.22 * ndf)[:, None] + (0.05 * ndh**12 * lit)[:, None]  # rubber
    metal = model == METAL
    out[metal] = (albedo[metal] * (0.04 + 0.22 * ndl[metal] + 0.05 * ndf[metal])[:, None]
                  + (albedo[metal] * 0.9 + 0.06) * (env[metal] * fresnel[metal])[:, None] + highlight[metal, None])
    glass = model == GLASS
    out[glass] = albedo[glass] + (0.08 * env[glass] * (0.3 + fresnel[glass]) + highlight[glass])[:, None]
    lamp = model == LAMP
    out[lamp] = albedo[lamp] * (0.7 + 0.3 * ndl[lamp])[:, None]
    return out


def depth_map(gbuffer: GBuffer, camera: Camera) -> np.ndarray:
    """Float32 [H, W] depth along the camera's viewing axis of the first surface (objects or ground); inf where a
    ray hits nothing."""
    d, o = gbuffer.dirs, gbuffer.origins
    t = gbuffer.distance.astype(np.float64).copy()
    ground = (gbuffer.geometry < 0) & (d[:, 2] < 0)
    t[ground] = -o[ground, 2] / d[ground, 2]
    t[(gbuffer.geometry < 0) & ~ground] = np.inf
    forward = -camera.matrix_world[:3, 2]
    return (t * (d @ forward)).astype(np.float32).reshape(gbuffer.height, gbuffer.width)


def false_colour_masks(object_ids: np.ndarray, part_ids: np.ndarray) -> np.ndarray:
    """RGB uint8 visualisation of the id maps: one hue per object, a lighter or darker shade per part, black part
    and object boundaries, dark grey background."""
    n = int(object_ids.max()) + 1 if object_ids.size else 0
    hues = (np.arange(max(n, 1)) * 0.618034) % 1.0
    hsv = np.zeros((max(n, 1), 1, 3), dtype=np.float32)
    hsv[:, 0, 0], hsv[:, 0, 1], hsv[:, 0, 2] = hues * 360.0, 0.75, 0.95
    base = cv2.cvtColor(hsv, cv2.COLOR_HSV2RGB)[:, 0, :]
    out = np.full(object_ids.shape + (3,), 40, dtype=np.uint8)
    obj = object_ids >= 0
    # Parts: shade factor cycles through 5 levels; the body (-1) keeps the base colour at reduced saturation.
    shade_levels = np.array([1.0, 0.55, 0.8, 0.4, 0.68], dtype=np.float32)
    factor = np.where(part_ids >= 0, shade_levels[np.maximum(part_ids, 0) % 5], 0.9)
    colour = base[np.maximum(object_ids, 0)] * factor[..., None]
    colour = np.where((part_ids < 0)[..., None] & obj[..., None], 0.5 * colour + 0.5 * 0.85, colour)
    out[obj] = np.round(np.clip(colour[obj], 0, 1) * 255).astype(np.uint8)
    key = (object_ids.astype(np.int32) + 1) * 64 + (part_ids.astype(np.int32) + 1)
    edge = np.zeros(object_ids.shape, dtype=bool)
    edge[:, 1:] |= key[:, 1:] != key[:, :-1]
    edge[1:, :] |= key[1:, :] != key[:-1, :]
    out[edge & (obj | np.roll(obj, 1, axis=1) | np.roll(obj, 1, axis=0))] = 0
    return out

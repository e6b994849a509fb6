"""Image formation: shading the renderer's first hits into an RGB image, and the false-colour id map.

No maintained library shades Embree hits on numpy arrays, so the model is written here, kept small:

- a ground plane at z = 0 (intersected analytically; it can never hide an object) lit by a key light, with a
  soft fall-off towards the horizon like CLEVR's curved backdrop;
- painted surfaces take the object's (or the recoloured part's) colour. Rubber: Lambert diffuse from a key and a
  fill light with a faint sheen. Metal: dark diffuse, a colour-tinted mirror reflection of an environment (a
  bright softbox above the horizon, the dark ground below) and a sharp white highlight, so the two materials are
  told apart by eye. Unlabelled glass, tyres, chrome and lamps have fixed looks so vehicles read as vehicles;
- smooth shading normals (corner normals interpolated at the hit) and hard key-light shadows, cast only where a
  shadow is possible: for each object, the pixels inside the image of its shadow volume, against that object
  alone in its canonical frame (no scene BVH, see :mod:`po3d_ppl.world.renderer`).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from po3d_ppl import ontology
from po3d_ppl.world.renderer import GBuffer, PlacedMesh, local_caster
from po3d_ppl.world.sampler import ObjectSpec
from po3d_ppl.world.scene import Camera

#: Direction towards the key light (the camera's front-left, high up) and the fill light (front-right).
KEY_LIGHT = np.array([-0.2, -0.85, 0.75]) / np.linalg.norm([-0.2, -0.85, 0.75])
FILL_LIGHT = np.array([0.76, 0.38, 0.6]) / np.linalg.norm([0.76, 0.38, 0.6])
#: A large soft light behind the scene (as seen from CLEVR's camera), about 30 degrees up. Metal reflects it on
#: upward-facing surfaces; the dark ground is what side panels reflect.
SOFTBOX = np.array([-0.66, 0.62, 0.55]) / np.linalg.norm([-0.66, 0.62, 0.55])
GROUND_ALBEDO = 0.32
SKY = 0.35
#: Offset (world units) that moves shadow-ray origins off the surface they start on.
SHADOW_EPS = 2e-3

#: Shading models of an appearance row.
RUBBER, METAL, GLASS, LAMP = 0, 1, 2, 3
#: Unlabelled non-paint finishes: fixed looks whatever the object's colour.
_FINISH_LOOKS = {
    "glass": ((0.015, 0.02, 0.03), GLASS),
    "rubber": ((0.02, 0.02, 0.02), RUBBER),
    "chrome": ((0.55, 0.55, 0.57), METAL),
    "lamp": ((0.85, 0.8, 0.55), LAMP),
}


@dataclass(frozen=True)
class ObjectLook:
    """Appearance table of one object. Row ``k`` < ``n_finishes`` is unlabelled geometry of finish ``k`` (paint,
    glass, rubber, chrome, lamp); row ``n_finishes + p`` is part ``p``. Each row: linear RGB albedo and a model."""

    albedo: np.ndarray
    model: np.ndarray
    n_finishes: int


def srgb_to_linear(c) -> np.ndarray:
    c = np.asarray(c, dtype=np.float32) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


_SRGB_STEPS = 4096
_LEVELS = np.linspace(0, 1, _SRGB_STEPS)
_SRGB_LUT = np.round(255.0 * np.where(_LEVELS <= 0.0031308, 12.92 * _LEVELS,
                                      1.055 * np.power(_LEVELS, 1 / 2.4) - 0.055)).astype(np.uint8)


def linear_to_srgb8(c: np.ndarray) -> np.ndarray:
    """Linear [0, 1] -> sRGB uint8 through a 4096-entry table (within one 8-bit level of the exact curve)."""
    return _SRGB_LUT[(np.clip(c, 0.0, 1.0) * (_SRGB_STEPS - 1) + 0.5).astype(np.int32)]


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


def _shadow_region(mesh: PlacedMesh, camera: Camera) -> tuple[int, int, np.ndarray] | None:
    """Pixels whose visible point may lie in the object's key-light shadow volume, as a mask cropped at
    ``(x0, y0)``: the image of the convex hull of the object's box and its shadow on the ground, dilated by a
    pixel against rasterisation rounding. ``None`` means the whole image (hull partly behind the camera)."""
    lo, hi = mesh.bounds
    local = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    corners = local @ mesh.transform[:3, :3].T + mesh.transform[:3, 3]
    on_ground = corners - KEY_LIGHT[None, :] * (corners[:, 2:3] / KEY_LIGHT[2])
    uvz = camera.project(np.concatenate([corners, on_ground]))
    if (uvz[:, 2] <= 0).any():
        return None
    hull = cv2.convexHull(uvz[:, :2].astype(np.float32)).reshape(-1, 2)
    x0, y0 = (np.floor(hull.min(axis=0)).astype(int) - 2).clip(0, [camera.width, camera.height])
    x1, y1 = (np.ceil(hull.max(axis=0)).astype(int) + 3).clip(0, [camera.width, camera.height])
    if x1 <= x0 or y1 <= y0:
        return x0, y0, np.zeros((0, 0), dtype=bool)
    crop = np.zeros((y1 - y0, x1 - x0), dtype=np.uint8)
    poly = np.round((hull - [x0 + 0.5, y0 + 0.5]) * 16).astype(np.int32)  # pixel centres; 4 fractional bits
    cv2.fillConvexPoly(crop, poly, 1, lineType=cv2.LINE_8, shift=4)
    return x0, y0, cv2.dilate(crop, np.ones((3, 3), np.uint8)).astype(bool)


def shadow_regions(meshes: list[PlacedMesh], camera: Camera) -> tuple[list, np.ndarray]:
    """Each object's shadow region (see :func:`_shadow_region`) and their union as a boolean [H, W] mask."""
    regions = [_shadow_region(m, camera) for m in meshes]
    union = np.zeros((camera.height, camera.width), dtype=bool)
    for region in regions:
        if region is None:
            union[:] = True
            break
        x0, y0, mask = region
        union[y0:y0 + mask.shape[0], x0:x0 + mask.shape[1]] |= mask
    return regions, union


def shadowed(meshes: list[PlacedMesh], regions: list, camera: Camera, pixels: np.ndarray, points: np.ndarray,
             normals: np.ndarray) -> np.ndarray:
    """Whether each surface point (seen at flat pixel index ``pixels``) is hidden from the key light: each
    object is tested, alone in its frame, for the points inside its shadow region."""
    W, H = camera.width, camera.height
    out = np.zeros(len(pixels), dtype=bool)
    index = np.full(H * W, -1, dtype=np.int64)
    index[pixels] = np.arange(len(pixels))
    index = index.reshape(H, W)
    origins = points + SHADOW_EPS * (normals + KEY_LIGHT.astype(np.float32))
    for m, region in zip(meshes, regions):
        if region is None:
            cand = np.arange(len(pixels))
        else:
            x0, y0, mask = region
            h, w = mask.shape
            cand = index[y0:y0 + h, x0:x0 + w][mask]
            cand = cand[cand >= 0]
        cand = cand[~out[cand]]
        if cand.size == 0:
            continue
        o, d = m.to_local(origins[cand], np.broadcast_to(KEY_LIGHT, (cand.size, 3)))
        out[cand[np.asarray(local_caster(m.subtype).cast(o, d).geometry) >= 0]] = True
    return out


def shading_normals(meshes: list[PlacedMesh], geometry: np.ndarray, face: np.ndarray, points: np.ndarray,
                    facing: np.ndarray, view: np.ndarray) -> np.ndarray:
    """Smooth normals at hit ``points`` (barycentric interpolation of corner normals), turned to the viewer like
    the geometric ``facing`` normals; where interpolation would face away from the viewer, the geometric normal."""
    out = facing.copy()
    for i, m in enumerate(meshes):
        sel = np.flatnonzero(geometry == i)
        if sel.size == 0:
            continue
        tri = m.triangles[face[sel]]
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
        n *= np.sign((m.face_normals[face[sel]] * facing[sel]).sum(1, keepdims=True) + 1e-12)
        ok = (n * view[sel]).sum(1) > 0.05
        out[sel[ok]] = n[ok]
    return out


def _environment(r: np.ndarray) -> np.ndarray:
    """Radiance seen along reflected directions ``r``: a grey sky with a bright softbox above the horizon, the
    dark ground below it. The contrast is what makes metal read as metal."""
    softbox = np.clip(r @ SOFTBOX.astype(np.float32), 0, 1) ** 6
    return np.where(r[:, 2] > 0, 0.45 + 2.2 * softbox, 0.05).astype(np.float32)


def shade(gbuffer: GBuffer, meshes: list[PlacedMesh], looks: list[ObjectLook], camera: Camera,
          shadows: bool = True) -> np.ndarray:
    """The RGB uint8 image."""
    H, W = gbuffer.height, gbuffer.width
    d, eye = gbuffer.dirs, gbuffer.eye
    key = KEY_LIGHT.astype(np.float32)

    # Ground (whole-image arithmetic: it covers most pixels); rays that miss everything see a flat sky.
    ground = (gbuffer.geometry < 0) & (d[:, 2] < 0)
    t = np.where(ground, -eye[2] / np.where(ground, d[:, 2], -1.0), 0.0).astype(np.float32)
    gx, gy = eye[0] + d[:, 0] * t, eye[1] + d[:, 1] * t
    fade = 0.75 + 0.25 * np.exp(np.hypot(gx, gy) * np.float32(-1 / 40.0))
    value = np.where(ground, GROUND_ALBEDO * (0.45 + 0.75 * key[2]) * fade, np.float32(SKY))

    obj_idx = np.flatnonzero(gbuffer.geometry >= 0)
    n = gbuffer.normal[obj_idx]
    n *= np.where((n * d[obj_idx]).sum(axis=1, keepdims=True) > 0, -1.0, 1.0).astype(np.float32)
    p = eye + d[obj_idx] * gbuffer.distance[obj_idx, None]
    # Surfaces turned away from the key light are in their own shadow; the others may be shadowed.
    lit_obj = ((n @ key) > 0).astype(np.float32)
    if shadows and meshes:
        regions, union = shadow_regions(meshes, camera)
        g = np.flatnonzero(ground & union.ravel())
        facing = obj_idx[lit_obj > 0]
        pixels = np.concatenate([g, facing])
        points = np.concatenate([np.stack([gx[g], gy[g], np.zeros(len(g), np.float32)], axis=1),
                                 p[lit_obj > 0]])
        normals = np.concatenate([np.broadcast_to(np.array([0, 0, 1], np.float32), (len(g), 3)),
                                  n[lit_obj > 0]])
        dark = shadowed(meshes, regions, camera, pixels, points, normals)
        value[g[dark[:len(g)]]] *= 0.45 / (0.45 + 0.75 * key[2])
        lit_obj[np.flatnonzero(lit_obj)[dark[len(g):]]] = 0.0
    radiance = np.repeat(value[:, None], 3, axis=1)
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
    # Parts: the shade cycles through 5 levels; the body (-1) keeps the base colour, paler.
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

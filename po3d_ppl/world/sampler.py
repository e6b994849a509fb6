"""Random scene layouts, the way Super-CLEVR samples them, plus the CLEVR camera.

Per scene (all draws from one ``numpy.random.Generator``, in this order): camera jitter, object count, then per
object its size, subtype, position/yaw (re-drawn until it does not intersect earlier objects), elevation
(aeroplanes only, when enabled), colour and material. A layout that cannot be completed within
``max_placement_retries`` draws for some object is abandoned (``None``) and the caller starts a new attempt,
like Super-CLEVR's ``add_random_objects``.

Objects must not intersect: their oriented ground footprints (the mesh's x/y extent, enlarged by
``footprint_margin``) are tested with the separating-axis theorem; two objects whose height ranges are disjoint
(an elevated aeroplane above a car) may overlap on the ground.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from functools import cache
from numbers import Integral, Real

import numpy as np

from po3d_ppl import ontology
from po3d_ppl.errors import InputError
from po3d_ppl.world.scene import DECIMALS, MATRIX_DECIMALS, Camera, PartStyle

#: CLEVR's base camera (the Blender default camera of ``base_scene.blend``), looking at the origin.
BASE_CAMERA_LOCATION: tuple[float, float, float] = (7.3589, -6.9258, 4.9583)
#: 35 mm lens on a 32 mm sensor (Blender defaults): focal length in pixels = 35/32 * the larger image side.
LENS_MM, SENSOR_MM = 35.0, 32.0
#: Positions are drawn uniformly from [-POSITION_RANGE, POSITION_RANGE]^2 (Super-CLEVR).
POSITION_RANGE = 3.0


@dataclass(frozen=True)
class SceneConfig:
    """Everything that shapes a generated scene. Invalid values raise :class:`InputError` naming the field."""

    min_objects: int = 3
    max_objects: int = 10
    width: int = 640
    height: int = 480
    #: Uniform jitter (+-) added to each coordinate of the camera location.
    camera_jitter: float = 0.5
    max_recoloured_parts: int = 3
    #: Every object must show at least this many pixels, else the scene is re-sampled.
    min_object_pixels: int = 200
    #: A part can be recoloured only if at least this many of its pixels are visible in the full scene.
    min_part_pixels: int = 20
    #: Paper §6: aeroplanes fly at a random height in [0, max_elevation].
    elevated_aeroplanes: bool = False
    max_elevation: float = 2.0
    #: Footprints are enlarged by this fraction before the intersection test (Super-CLEVR uses 10%).
    footprint_margin: float = 0.1
    max_placement_retries: int = 50
    #: Attempts (fresh layouts) before generation gives up.
    max_attempts: int = 200
    shadows: bool = True

    def __post_init__(self) -> None:
        def need(ok: bool, name: str, msg: str) -> None:
            if not ok:
                raise InputError(f"SceneConfig.{name}", f"{msg}, got {getattr(self, name)!r}")

        for f in fields(self):
            value = getattr(self, f.name)
            if f.type == "int":
                need(isinstance(value, Integral) and not isinstance(value, bool), f.name, "must be an integer")
                object.__setattr__(self, f.name, int(value))
            elif f.type == "float":
                need(isinstance(value, Real) and not isinstance(value, bool) and math.isfinite(value),
                     f.name, "must be a finite number")
            elif f.type == "bool":
                need(isinstance(value, bool), f.name, "must be true or false")
        need(self.min_objects >= 1, "min_objects", "must be at least 1")
        need(self.max_objects >= self.min_objects, "max_objects", f"must be >= min_objects ({self.min_objects})")
        need(self.max_objects <= 30, "max_objects", "must be at most 30 (the placement area is 6x6 units)")
        need(16 <= self.width <= 4096, "width", "must be between 16 and 4096 pixels")
        need(16 <= self.height <= 4096, "height", "must be between 16 and 4096 pixels")
        need(0.0 <= self.camera_jitter <= 2.0, "camera_jitter", "must be between 0 and 2")
        need(self.max_recoloured_parts >= 0, "max_recoloured_parts", "must be >= 0")
        need(self.min_object_pixels >= 1, "min_object_pixels", "must be >= 1")
        need(self.min_part_pixels >= 1, "min_part_pixels", "must be >= 1")
        need(0.0 <= self.max_elevation <= 4.0, "max_elevation", "must be between 0 and 4")
        need(0.0 <= self.footprint_margin <= 1.0, "footprint_margin", "must be between 0 and 1")
        need(self.max_placement_retries >= 1, "max_placement_retries", "must be >= 1")
        need(self.max_attempts >= 1, "max_attempts", "must be >= 1")

    @classmethod
    def with_objects(cls, count: int, **kwargs) -> SceneConfig:
        """A config with exactly ``count`` objects."""
        return cls(min_objects=count, max_objects=count, **kwargs)


@dataclass(frozen=True)
class ObjectSpec:
    """One object to place: what it is and where. ``rotation`` is the yaw in degrees (front = +x rotated
    counter-clockwise), ``elevation`` the height of the mesh's base above the ground.

    ``parts`` lists recoloured parts; ``None`` lets the renderer pick them by the public rule.
    """

    subtype: str
    color: str
    material: str
    size: str
    rotation: float
    x: float
    y: float
    elevation: float = 0.0
    parts: Mapping[str, PartStyle] | None = field(default=None)

    def __post_init__(self) -> None:
        checks = (("subtype", ontology.SUBTYPES), ("color", ontology.COLORS),
                  ("material", ontology.MATERIALS), ("size", ontology.SIZES))
        for name, known in checks:
            if getattr(self, name) not in known:
                raise InputError(f"ObjectSpec.{name}", f"{getattr(self, name)!r} is not one of {', '.join(known)}")
        for name in ("rotation", "x", "y", "elevation"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or not math.isfinite(value):
                raise InputError(f"ObjectSpec.{name}", f"must be a finite number, got {value!r}")
        for raw, style in (self.parts or {}).items():
            if raw not in ontology.PARTS[self.subtype]:
                raise InputError("ObjectSpec.parts", f"{raw!r} is not a part of {self.subtype}")
            if style.color not in ontology.COLORS or style.material not in ontology.MATERIALS:
                raise InputError(f"ObjectSpec.parts[{raw!r}]", f"bad style {style!r}")

    @property
    def scale(self) -> float:
        return float(ontology.SIZE_SCALE[self.size])

    def transform(self, bounds: np.ndarray) -> np.ndarray:
        """4x4 object-to-world matrix: scale, yaw about z, then move so the mesh's base sits at ``elevation``
        and its x/y bounding-box centre at (x, y)."""
        s, th = self.scale, math.radians(self.rotation)
        c, si = math.cos(th), math.sin(th)
        centre = 0.5 * (bounds[0] + bounds[1]) * s
        R = np.array([[c, -si, 0.0], [si, c, 0.0], [0.0, 0.0, 1.0]])
        M = np.eye(4)
        M[:3, :3] = R * s
        offset = R @ np.array([centre[0], centre[1], 0.0])
        M[:3, 3] = [self.x - offset[0], self.y - offset[1], self.elevation - bounds[0][2] * s]
        return M


@cache
def canonical_bounds(subtype: str) -> np.ndarray:
    """``[[xmin, ymin, zmin], [xmax, ymax, zmax]]`` of the subtype's canonical (unscaled) mesh."""
    from po3d_ppl.world.meshes import vehicle_mesh

    return np.asarray(vehicle_mesh(subtype).mesh.bounds, dtype=np.float64)


def camera_matrix(location: np.ndarray, rotation: np.ndarray) -> tuple[tuple[float, ...], ...]:
    M = np.eye(4)
    M[:3, :3] = rotation
    M[:3, 3] = location
    return tuple(tuple(float(v) for v in row) for row in M)


def look_at_rotation(location: np.ndarray, target: np.ndarray = np.zeros(3)) -> np.ndarray:
    """Camera-to-world rotation (Blender convention: the camera looks along -z, +y up) with no roll."""
    forward = target - location
    forward = forward / np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    return np.stack([right, up, -forward], axis=1)


def clevr_intrinsics(width: int, height: int) -> tuple[tuple[float, ...], ...]:
    f = LENS_MM / SENSOR_MM * max(width, height)
    return ((f, 0.0, width / 2.0), (0.0, f, height / 2.0), (0.0, 0.0, 1.0))


def make_camera(width: int = 640, height: int = 480, offset: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> Camera:
    """CLEVR's camera moved by ``offset``. As in CLEVR, jitter moves the camera without turning it: the rotation
    is the one that looks from the base location at the origin."""
    base = np.asarray(BASE_CAMERA_LOCATION)
    rotation = look_at_rotation(base)
    location = np.round(base + np.asarray(offset, dtype=np.float64), DECIMALS)
    return Camera(width, height, clevr_intrinsics(width, height),
                  camera_matrix(location, np.round(rotation, MATRIX_DECIMALS)))


def sample_camera(rng: np.random.Generator, config: SceneConfig) -> Camera:
    offset = rng.uniform(-config.camera_jitter, config.camera_jitter, size=3)
    return make_camera(config.width, config.height, tuple(offset))


def _corners(x: float, y: float, rotation: float, half: np.ndarray) -> np.ndarray:
    th = math.radians(rotation)
    c, s = math.cos(th), math.sin(th)
    local = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=np.float64) * half
    return local @ np.array([[c, s], [-s, c]]) + np.array([x, y])


def footprint_corners(spec: ObjectSpec, bounds: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """The four ground corners (4, 2) of the object's oriented footprint, enlarged by ``margin`` (a fraction)."""
    half = 0.5 * (bounds[1][:2] - bounds[0][:2]) * spec.scale * (1.0 + margin)
    return _corners(spec.x, spec.y, spec.rotation, half)


def footprints_overlap(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Separating-axis test of rectangle ``a`` (4, 2) against rectangles ``b`` (n, 4, 2) -> bool (n,).

    Corners go round each rectangle, so edges 0 and 1 give its two axes."""
    b = np.asarray(b, dtype=np.float64).reshape(-1, 4, 2)
    a_axes = np.broadcast_to((a[1:3] - a[0:2])[None], (len(b), 2, 2))
    axes = np.concatenate([a_axes, b[:, 1:3] - b[:, 0:2]], axis=1)  # (n, 4, 2)
    pa = np.einsum("nkd,cd->nkc", axes, a)
    pb = np.einsum("nkd,ncd->nkc", axes, b)
    separated = (pa.max(axis=2) < pb.min(axis=2)) | (pb.max(axis=2) < pa.min(axis=2))
    return ~separated.any(axis=1)


def height_range(spec: ObjectSpec, bounds: np.ndarray) -> tuple[float, float]:
    return spec.elevation, spec.elevation + (bounds[1][2] - bounds[0][2]) * spec.scale


def intersects(a: ObjectSpec, b: ObjectSpec, margin: float,
               bounds_of: Callable[[str], np.ndarray] = canonical_bounds) -> bool:
    """Whether two placed objects intersect (footprints with margin, and overlapping height ranges)."""
    ba, bb = bounds_of(a.subtype), bounds_of(b.subtype)
    za, zb = height_range(a, ba), height_range(b, bb)
    if za[1] < zb[0] or zb[1] < za[0]:
        return False
    return bool(footprints_overlap(footprint_corners(a, ba, margin), footprint_corners(b, bb, margin)[None])[0])


def sample_objects(rng: np.random.Generator, config: SceneConfig,
                   bounds_of: Callable[[str], np.ndarray] = canonical_bounds) -> list[ObjectSpec] | None:
    """Draw a non-intersecting layout, or ``None`` when some object could not be placed."""
    count = int(rng.integers(config.min_objects, config.max_objects + 1))
    placed: list[ObjectSpec] = []
    corners = np.zeros((0, 4, 2))
    heights = np.zeros((0, 2))
    for _ in range(count):
        size = ontology.SIZES[int(rng.integers(len(ontology.SIZES)))]
        subtype = ontology.SUBTYPES[int(rng.integers(len(ontology.SUBTYPES)))]
        bounds = bounds_of(subtype)
        elevated = config.elevated_aeroplanes and ontology.CATEGORY_OF[subtype] == "aeroplane"
        scale = float(ontology.SIZE_SCALE[size])
        half = 0.5 * (bounds[1][:2] - bounds[0][:2]) * scale * (1.0 + config.footprint_margin)
        tall = (bounds[1][2] - bounds[0][2]) * scale
        for _try in range(config.max_placement_retries):
            x, y = (round(float(v), DECIMALS) for v in rng.uniform(-POSITION_RANGE, POSITION_RANGE, size=2))
            rotation = round(float(rng.uniform(0.0, 360.0)), DECIMALS)
            elevation = round(float(rng.uniform(0.0, config.max_elevation)), DECIMALS) if elevated else 0.0
            cand_corners = _corners(x, y, rotation, half)
            z0, z1 = elevation, elevation + tall
            near = (heights[:, 1] >= z0) & (heights[:, 0] <= z1)
            if not near.any() or not footprints_overlap(cand_corners, corners[near]).any():
                break
        else:
            return None
        color = ontology.COLORS[int(rng.integers(len(ontology.COLORS)))]
        material = ontology.MATERIALS[int(rng.integers(len(ontology.MATERIALS)))]
        placed.append(ObjectSpec(subtype, color, material, size, rotation, x, y, elevation))
        corners = np.concatenate([corners, cand_corners[None]])
        heights = np.concatenate([heights, [[z0, z1]]])
    return placed

"""The in-memory scene: the one record type that the world writes, the question engine reads and the reasoning
engine turns into evidence.

It holds what the public Super-CLEVR-3D scene files hold (spec §1) plus what they drop (every occluder with its
overlap, pixel counts). Records are frozen dataclasses so scenes can be compared for equality (round-trip tests)
and shared between processes without copies going stale.

Occlusion semantics used everywhere in po3d_ppl (documented in docs/semantics.md):
- ``Occlusion.level`` follows the public rule (spec §1.6);
- the world sets ``occluded_by`` to the objects whose overlap with the entity's hidden pixels is at least
  :data:`MIN_OCCLUDER_PIXELS`, provided the level is 1 or 2 (the public data keeps only the largest such object; we
  keep all, largest first), and ``occluded`` (what ``filter_occludee`` asks) to ``bool(occluded_by)``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from po3d_ppl import ontology

#: An entity counts as visible before occlusion with at least this many pixels when rendered alone (public rule).
MIN_VISIBLE_BEFORE_PIXELS = 20
#: An object counts as an occluder of an entity when it hides more than 15 of its pixels (the public level rule's
#: threshold, applied per occluder).
MIN_OCCLUDER_PIXELS = 16
#: CLEVR's spatial-relation margin: j is left of i iff dot(p_j - p_i, left) > RELATION_EPS.
RELATION_EPS = 0.2
#: Decimals kept for every float of a scene (positions, angles, depths, camera location): far below rendering
#: precision, and it keeps exported files byte-identical across platforms whose last-bit arithmetic differs.
DECIMALS = 6
#: Decimals kept for camera matrices (rotation, and the inverse and projection matrices derived on export).
MATRIX_DECIMALS = 9

Vec3 = tuple[float, float, float]
BBox = tuple[int, int, int, int]  # x, y, w, h (x2, y2 exclusive); all zero for an empty mask


def occlusion_levels(unoccluded_pixels, hidden_pixels) -> np.ndarray:
    """The public occlusion level (spec §1.6), elementwise over arrays of counts: 2 fully hidden, 1 occluded,
    0 not occluded, -1 ambiguous.

    ``unoccluded_pixels`` = |before| (rendered alone), ``hidden_pixels`` = |before minus after|.
    """
    b = np.asarray(unoccluded_pixels, dtype=np.int64)
    o = np.asarray(hidden_pixels, dtype=np.int64)
    return np.select([b - o < 1, (o > 15) & (b - o > 15), o < 1], [2, 1, 0], default=-1)


def occlusion_level(unoccluded_pixels: int, hidden_pixels: int) -> int:
    """:func:`occlusion_levels` of one entity."""
    return int(occlusion_levels(unoccluded_pixels, hidden_pixels))


def occluder_mask(unoccluded_pixels, hidden_pixels, overlaps) -> np.ndarray:
    """Elementwise :meth:`Occlusion.from_overlaps`: ``[..., J]`` whether object j occludes the entity, from its
    counts ``[...]`` and its hidden-pixel overlap with each object ``[..., J]`` (for perception's graded
    projections, which apply the rule to many renderings at once)."""
    level = occlusion_levels(unoccluded_pixels, hidden_pixels)
    can = ((level == 1) | (level == 2)) & (np.asarray(unoccluded_pixels) >= MIN_VISIBLE_BEFORE_PIXELS)
    return can[..., None] & (np.asarray(overlaps) >= MIN_OCCLUDER_PIXELS)


@dataclass(frozen=True)
class Occlusion:
    """Occlusion of one entity (object or part) in its scene."""

    level: int
    visible_before: bool
    #: Objects that occlude the entity in the question-answering sense, largest overlap first.
    occluded_by: tuple[int, ...] = ()
    #: Hidden-pixel overlap with every other object that covers the entity (object index -> pixels). Empty when
    #: unknown (scenes imported from public files carry only the largest occluder).
    overlaps: Mapping[int, int] = field(default_factory=dict)
    #: The entity's occlusion state as questions see it (``filter_occludee``). The world keeps it equal to
    #: ``bool(occluded_by)`` (the public "level > 0 and an occluder was found"); it is a field of its own because a
    #: probabilistic scene (or a perception result) may hold the state and the occluders as separate variables, as
    #: the reasoning engine does. ``None`` at construction means "derive it from ``occluded_by``".
    occluded: bool | None = None

    def __post_init__(self) -> None:
        if self.occluded is None:
            object.__setattr__(self, "occluded", bool(self.occluded_by))

    @classmethod
    def from_overlaps(cls, unoccluded_pixels: int, hidden_pixels: int, overlaps: Mapping[int, int]) -> Occlusion:
        """Apply the rules: the public level, and occluders = objects hiding >= MIN_OCCLUDER_PIXELS pixels."""
        level = occlusion_level(unoccluded_pixels, hidden_pixels)
        visible_before = unoccluded_pixels >= MIN_VISIBLE_BEFORE_PIXELS
        ranked = sorted(overlaps.items(), key=lambda kv: (-kv[1], kv[0]))
        keep = occluder_mask(unoccluded_pixels, hidden_pixels, [px for _, px in ranked]) if ranked else ()
        by = tuple(int(j) for (j, _), kept in zip(ranked, keep) if kept)
        return cls(level, visible_before, by, {int(j): int(px) for j, px in sorted(overlaps.items()) if px > 0})


NOT_OCCLUDED = Occlusion(level=0, visible_before=True)


@dataclass(frozen=True)
class EntityAnnotation:
    """Image-space annotation of one object or part."""

    visible_pixels: int
    unoccluded_pixels: int
    bbox: BBox
    occlusion: Occlusion
    #: Public RLE (alternating runs starting with zeros, row-major) of the visible mask; None if not stored.
    visible_mask: str | None = None
    #: Public RLE of the pixels visible alone but hidden in the scene; None if not stored.
    occlusion_mask: str | None = None

    @property
    def occlusion_ratio(self) -> float:
        if self.unoccluded_pixels == 0:
            return 0.0
        return 1.0 - self.visible_pixels / self.unoccluded_pixels


@dataclass(frozen=True)
class PartStyle:
    """Colour and material of a recoloured part (the public ``parts`` field)."""

    color: str
    material: str


@dataclass(frozen=True)
class SceneObject:
    subtype: str
    color: str
    material: str
    size: str
    #: Yaw in degrees (Blender ``rotation_euler[2]``): the object's front (+x) rotated counter-clockwise.
    rotation: float
    #: World position (``3d_coords``).
    position: Vec3
    #: Clockwise angle (seen from above) from the camera's viewing ray to the object's front; 0 = back visible.
    pose_degree: float
    #: Recoloured parts only (raw part name -> style); other parts have no attributes.
    parts: Mapping[str, PartStyle] = field(default_factory=dict)
    #: (x, y, depth) of the object's origin in the image, y from the top.
    pixel_coords: Vec3 | None = None
    annotation: EntityAnnotation | None = None
    #: Annotation of every part of the subtype (raw name -> annotation); empty when unknown.
    part_annotations: Mapping[str, EntityAnnotation] = field(default_factory=dict)

    @property
    def category(self) -> str:
        return ontology.CATEGORY_OF[self.subtype]

    @property
    def pose(self) -> str:
        """Pose label (``front_pose`` ... or ``'None'``)."""
        return ontology.pose_label(self.pose_degree)

    @property
    def occluded(self) -> bool:
        return bool(self.annotation and self.annotation.occlusion.occluded)

    @property
    def occluded_by(self) -> tuple[int, ...]:
        return self.annotation.occlusion.occluded_by if self.annotation else ()

    def part_occluded(self, raw: str) -> bool:
        ann = self.part_annotations.get(raw)
        return bool(ann and ann.occlusion.occluded)

    def part_occluded_by(self, raw: str) -> tuple[int, ...]:
        ann = self.part_annotations.get(raw)
        return ann.occlusion.occluded_by if ann else ()


@dataclass(frozen=True)
class Camera:
    """A pinhole camera. ``camera_to_world`` follows Blender/OpenGL: the camera looks along its -z axis, +y up."""

    width: int
    height: int
    #: 3x3 pixel intrinsics (origin at the top-left pixel corner, y down).
    intrinsics: tuple[tuple[float, ...], ...]
    #: 4x4 camera-to-world matrix (the public ``matrix_world``).
    camera_to_world: tuple[tuple[float, ...], ...]

    @property
    def K(self) -> np.ndarray:
        return np.asarray(self.intrinsics, dtype=np.float64)

    @property
    def matrix_world(self) -> np.ndarray:
        return np.asarray(self.camera_to_world, dtype=np.float64)

    @property
    def location(self) -> np.ndarray:
        return self.matrix_world[:3, 3].copy()

    def world_to_camera(self) -> np.ndarray:
        return np.linalg.inv(self.matrix_world)

    def project(self, points: np.ndarray) -> np.ndarray:
        """World points (..., 3) -> (..., 3) of (x pixel, y pixel from top, depth along the viewing axis)."""
        pts = np.asarray(points, dtype=np.float64)
        cam = pts @ self.world_to_camera()[:3, :3].T + self.world_to_camera()[:3, 3]
        depth = -cam[..., 2]
        K = self.K
        x = K[0, 0] * cam[..., 0] / depth + K[0, 2]
        y = -K[1, 1] * cam[..., 1] / depth + K[1, 2]
        return np.stack([x, y, depth], axis=-1)

    def ground_directions(self) -> dict[str, Vec3]:
        """CLEVR's ``directions``: camera axes projected on the ground plane (behind = away from the camera)."""
        R = self.matrix_world[:3, :3]

        def flat(v: np.ndarray) -> np.ndarray:
            v = v.copy()
            v[2] = 0.0
            return v / np.linalg.norm(v)

        behind = flat(R @ np.array([0.0, 0.0, -1.0]))
        left = flat(R @ np.array([-1.0, 0.0, 0.0]))
        up = np.array([0.0, 0.0, 1.0])
        dirs = {"behind": behind, "front": -behind, "left": left, "right": -left, "above": up, "below": -up}
        return {k: tuple(float(x) for x in v) for k, v in dirs.items()}


def compute_relationships(positions: np.ndarray, directions: Mapping[str, Vec3], eps: float = RELATION_EPS):
    """CLEVR's relationships: ``rel[r][i]`` lists j with ``dot(p_j - p_i, dir_r) > eps`` (above/below skipped)."""
    pos = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    out: dict[str, tuple[tuple[int, ...], ...]] = {}
    for name in ("behind", "front", "left", "right"):
        d = np.asarray(directions[name], dtype=np.float64)
        proj = pos @ d
        out[name] = tuple(
            tuple(int(j) for j in range(len(pos)) if j != i and proj[j] - proj[i] > eps) for i in range(len(pos))
        )
    return out


@dataclass(frozen=True)
class Scene:
    objects: tuple[SceneObject, ...]
    directions: Mapping[str, Vec3]
    relationships: Mapping[str, tuple[tuple[int, ...], ...]]
    camera: Camera | None = None
    image_index: int = 0
    image_filename: str = ""
    split: str = "new"

    def __len__(self) -> int:
        return len(self.objects)

    @property
    def has_occlusion(self) -> bool:
        return all(o.annotation is not None for o in self.objects)

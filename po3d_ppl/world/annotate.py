"""Exact annotations of a rendered layout: pixel counts, boxes, masks, occlusion, pose and the scene record.

All measurements come from the renderer's id maps and solo footprints, cropped to each object's projected box
so that a 10-object scene is annotated in a few milliseconds. Conventions (docs/world_scenes.md):

- ``pose_degree``: clockwise angle, seen from above, from the camera->object viewing ray (projected on the
  ground) to the object's front; 0 means the camera sees the object's back.
- ``position`` (``3d_coords``): the centre of the object's oriented bounding box, in world coordinates.
- masks: the public RLE over the full image (:mod:`po3d_ppl.world.rle`); boxes ``[x, y, w, h]``.
- occlusion: the public level rule; ``occluded_by`` keeps every object that hides at least
  :data:`~po3d_ppl.world.scene.MIN_OCCLUDER_PIXELS` pixels (:meth:`Occlusion.from_overlaps`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from po3d_ppl import ontology
from po3d_ppl.world import rle
from po3d_ppl.world.renderer import GBuffer, PlacedMesh, SoloView
from po3d_ppl.world.sampler import ObjectSpec
from po3d_ppl.world.scene import (
    DECIMALS,
    Camera,
    EntityAnnotation,
    Occlusion,
    PartStyle,
    Scene,
    SceneObject,
    compute_relationships,
)


@dataclass(frozen=True)
class ObjectMeasure:
    """Pixel-level annotation of one object: the object itself and every part of its subtype (by part id)."""

    obj: EntityAnnotation
    parts: tuple[EntityAnnotation, ...]


def _entity(visible: np.ndarray, present: np.ndarray, geo: np.ndarray, view: SoloView, width: int,
            total: int) -> EntityAnnotation:
    """Annotation of the entity that is ``visible`` in the scene and ``present`` when its object is alone (crop
    masks); ``geo`` holds the scene's object ids in the crop."""
    n_present = int(np.count_nonzero(present))
    if n_present == 0:  # most parts of an object face away from the camera: nothing to encode
        empty = str(total)
        return EntityAnnotation(0, 0, (0, 0, 0, 0), Occlusion.from_overlaps(0, 0, {}), empty, empty)
    hidden = present & ~visible
    n_visible, n_hidden = int(np.count_nonzero(visible)), int(np.count_nonzero(hidden))
    counts = np.bincount(geo[hidden].astype(np.int64)) if n_hidden else np.zeros(0, np.int64)
    overlaps = {int(j): int(c) for j, c in enumerate(counts) if c > 0}

    def to_flat(mask: np.ndarray) -> np.ndarray:
        rows, cols = np.nonzero(mask)
        return (rows + view.y0) * width + (cols + view.x0)

    bbox = rle.bbox_of(visible)
    if n_visible:
        bbox = (bbox[0] + view.x0, bbox[1] + view.y0, bbox[2], bbox[3])
    return EntityAnnotation(
        visible_pixels=n_visible,
        unoccluded_pixels=n_present,
        bbox=bbox,
        occlusion=Occlusion.from_overlaps(n_present, n_hidden, overlaps),
        visible_mask=rle.encode_indices(to_flat(visible), total),
        occlusion_mask=rle.encode_indices(to_flat(hidden), total),
    )


def measure(gbuffer: GBuffer, views: Sequence[SoloView], specs: Sequence[ObjectSpec]) -> list[ObjectMeasure]:
    """Counts, boxes, masks and occlusion of every object and every part."""
    W, total = gbuffer.width, gbuffer.width * gbuffer.height
    geometry = gbuffer.geometry.reshape(gbuffer.height, W)
    part_ids = gbuffer.part_ids
    out = []
    for i, (view, spec) in enumerate(zip(views, specs)):
        h, w = view.parts.shape
        geo = geometry[view.y0:view.y0 + h, view.x0:view.x0 + w]
        seen = part_ids[view.y0:view.y0 + h, view.x0:view.x0 + w]
        visible = geo == i
        obj = _entity(visible, view.present, geo, view, W, total)
        parts = tuple(
            _entity(visible & (seen == p), view.parts == p, geo, view, W, total)
            for p in range(len(ontology.PARTS[spec.subtype]))
        )
        out.append(ObjectMeasure(obj, parts))
    return out


def choose_recoloured_parts(spec: ObjectSpec, m: ObjectMeasure, rng: np.random.Generator, max_parts: int,
                            min_part_pixels: int) -> dict[str, PartStyle]:
    """The public rule (spec §1.4): up to ``max_parts`` parts with at least ``min_part_pixels`` visible pixels,
    each with a colour different from the object's and a random material. Keyed by raw name, in part-id order."""
    if spec.parts is not None:
        return dict(spec.parts)
    candidates = [p for p, a in enumerate(m.parts) if a.visible_pixels >= min_part_pixels]
    k = min(max_parts, len(candidates))
    if k == 0:
        return {}
    chosen = rng.choice(np.array(candidates), size=k, replace=False)
    other_colors = [c for c in ontology.COLORS if c != spec.color]
    styles = {}
    for p in chosen.tolist():
        color = other_colors[int(rng.integers(len(other_colors)))]
        material = ontology.MATERIALS[int(rng.integers(len(ontology.MATERIALS)))]
        styles[int(p)] = PartStyle(color, material)
    names = ontology.PARTS[spec.subtype]
    return {names[p]: styles[p] for p in sorted(styles)}


def pose_degree(position: np.ndarray, rotation: float, camera: Camera) -> float:
    """Clockwise angle (seen from above) from the viewing ray to the object's front, in [0, 360)."""
    ray = np.asarray(position[:2]) - camera.location[:2]
    view_azimuth = math.degrees(math.atan2(ray[1], ray[0]))
    return round((view_azimuth - rotation) % 360.0, DECIMALS) % 360.0


def _r(values) -> tuple[float, ...]:
    return tuple(round(float(v), DECIMALS) + 0.0 for v in values)  # + 0.0 turns -0.0 into 0.0


def build_scene(specs: Sequence[ObjectSpec], meshes: Sequence[PlacedMesh], measures: Sequence[ObjectMeasure],
                styles: Sequence[dict[str, PartStyle]], camera: Camera, image_index: int = 0,
                image_filename: str | None = None) -> Scene:
    """Assemble the :class:`Scene` record (positions, pose, pixel coordinates, directions, relationships)."""
    objects = []
    for spec, mesh, m, parts in zip(specs, meshes, measures, styles):
        position = _r(mesh.box_centre)
        u, v, depth = camera.project(np.asarray(position))
        names = ontology.PARTS[spec.subtype]
        rotation = round(spec.rotation % 360.0, DECIMALS) % 360.0
        objects.append(SceneObject(
            subtype=spec.subtype,
            color=spec.color,
            material=spec.material,
            size=spec.size,
            rotation=rotation,
            position=position,
            pose_degree=pose_degree(np.asarray(position), rotation, camera),
            parts=dict(parts),
            pixel_coords=(float(round(u)), float(round(v)), round(float(depth), DECIMALS)),
            annotation=m.obj,
            part_annotations={names[p]: a for p, a in enumerate(m.parts)},
        ))
    directions = {k: _r(v) for k, v in camera.ground_directions().items()}
    relationships = compute_relationships(np.array([o.position for o in objects]).reshape(-1, 3), directions)
    if image_filename is None:
        image_filename = f"superCLEVR_new_{image_index:06d}.png"
    return Scene(tuple(objects), directions, relationships, camera, image_index, image_filename)

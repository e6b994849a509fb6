"""Hand-built scenes and random evidence for the reasoning tests."""

from __future__ import annotations

import numpy as np

from po3d_ppl.world import ontology
from po3d_ppl.world.scene import (
    EntityAnnotation,
    Occlusion,
    PartStyle,
    Scene,
    SceneObject,
    compute_relationships,
)

DIRECTIONS = {
    "behind": (-0.7, 0.7, 0.0), "front": (0.7, -0.7, 0.0), "left": (-0.7, -0.7, 0.0), "right": (0.7, 0.7, 0.0),
    "above": (0.0, 0.0, 1.0), "below": (0.0, 0.0, -1.0),
}


def _ann(occluded_by=(), occluded=None, visible=500):
    occ = Occlusion(level=1 if occluded_by else 0, visible_before=True, occluded_by=tuple(occluded_by),
                    occluded=occluded)
    return EntityAnnotation(visible_pixels=visible, unoccluded_pixels=visible + 20 * bool(occluded_by),
                            bbox=(0, 0, 10, 10), occlusion=occ)


def make_object(subtype="suv", color="red", material="metal", size="large", pose_degree=10.0,
                position=(0.0, 0.0, 0.5), parts=None, occluded_by=(), part_occlusion=None, depth=None):
    """An object; ``parts`` maps raw names to (colour, material); ``part_occlusion`` raw name -> occluders."""
    parts = {k: PartStyle(*v) for k, v in (parts or {}).items()}
    part_occlusion = part_occlusion or {}
    part_ann = {raw: _ann(part_occlusion.get(raw, ()), visible=30) for raw in ontology.PARTS[subtype]}
    if depth is None:
        depth = 10.0 + position[0] - position[1]
    return SceneObject(subtype=subtype, color=color, material=material, size=size, rotation=0.0,
                       position=tuple(float(x) for x in position), pose_degree=float(pose_degree), parts=parts,
                       pixel_coords=(100.0, 100.0, float(depth)), annotation=_ann(occluded_by),
                       part_annotations=part_ann)


def make_scene(*objects: SceneObject) -> Scene:
    positions = np.array([o.position for o in objects]).reshape(-1, 3)
    return Scene(objects=tuple(objects), directions=DIRECTIONS,
                 relationships=compute_relationships(positions, DIRECTIONS))

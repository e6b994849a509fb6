"""Hand-built scenes with chosen attributes, parts, poses and occlusions, without rendering.

Tests of the executor, the generator and the reasoning engine need scenes whose ground truth is set by hand
(a part occluded by two objects, a pose in a dead zone ...), and benchmarks of the question generator need many
scenes without paying for rendering. The camera convention is fixed: it looks along +y, so ``behind`` is +y,
``left`` is -x, and an object's camera depth grows with its y coordinate.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from po3d_ppl import ontology
from po3d_ppl.world.scene import EntityAnnotation, Occlusion, PartStyle, Scene, SceneObject, compute_relationships

#: Ground directions of the toy camera (looking along +y).
TOY_DIRECTIONS: dict[str, tuple[float, float, float]] = {
    "behind": (0.0, 1.0, 0.0), "front": (0.0, -1.0, 0.0), "left": (-1.0, 0.0, 0.0), "right": (1.0, 0.0, 0.0),
    "above": (0.0, 0.0, 1.0), "below": (0.0, 0.0, -1.0),
}
#: Distance from the toy camera to the plane y = 0.
TOY_CAMERA_DISTANCE = 10.0


def _annotation(occluded_by: Sequence[int]) -> EntityAnnotation:
    occ = Occlusion(level=1 if occluded_by else 0, visible_before=True, occluded_by=tuple(occluded_by),
                    overlaps={int(j): 20 + k for k, j in enumerate(reversed(list(occluded_by)))})
    return EntityAnnotation(visible_pixels=400, unoccluded_pixels=450 if occluded_by else 400, bbox=(0, 0, 10, 10),
                            occlusion=occ)


def toy_object(subtype: str = "suv", color: str = "gray", material: str = "rubber", size: str = "large", *,
               position: tuple[float, float, float] = (0.0, 0.0, 0.0), pose_degree: float = 0.0,
               parts: Mapping[str, tuple[str, str]] | None = None, occluded_by: Sequence[int] = (),
               part_occluded_by: Mapping[str, Sequence[int]] | None = None) -> SceneObject:
    """One object; ``parts`` maps raw part names to (colour, material) of recoloured parts, ``occluded_by`` and
    ``part_occluded_by`` name the occluding objects (largest first)."""
    part_anns = {raw: _annotation(by) for raw, by in (part_occluded_by or {}).items()}
    x, y, z = (float(v) for v in position)
    return SceneObject(
        subtype=subtype, color=color, material=material, size=size,
        # our meshes face +x; the toy camera looks along +y, so a yaw of 90 degrees shows the object's back
        rotation=(90.0 - pose_degree) % 360.0, position=(x, y, z), pose_degree=float(pose_degree) % 360.0,
        parts={raw: PartStyle(c, m) for raw, (c, m) in (parts or {}).items()},
        pixel_coords=(320.0 + 40.0 * x, 240.0 - 10.0 * z, TOY_CAMERA_DISTANCE + y),
        annotation=_annotation(occluded_by), part_annotations=part_anns,
    )


def toy_scene(objects: Sequence[SceneObject], image_index: int = 0) -> Scene:
    """A scene of the given objects with CLEVR relationships computed for the toy camera."""
    positions = np.array([o.position for o in objects], dtype=np.float64).reshape(-1, 3)
    return Scene(objects=tuple(objects), directions=dict(TOY_DIRECTIONS),
                 relationships=compute_relationships(positions, TOY_DIRECTIONS), image_index=image_index,
                 image_filename=f"toy_{image_index:06d}.png")


def random_toy_scene(seed: int, num_objects: tuple[int, int] = (3, 10), occlusion_rate: float = 0.35,
                     elevate_aeroplanes: bool = False) -> Scene:
    """A random scene with recoloured parts and plausible occlusions (nearer objects occlude farther ones)."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(num_objects[0], num_objects[1] + 1))
    specs = []
    for _ in range(n):
        subtype = str(rng.choice(ontology.SUBTYPES))
        color = str(rng.choice(ontology.COLORS))
        names = ontology.PARTS[subtype]
        chosen = rng.choice(len(names), size=min(3, len(names)), replace=False)
        parts = {names[p]: (str(rng.choice([c for c in ontology.COLORS if c != color])),
                            str(rng.choice(ontology.MATERIALS))) for p in chosen}
        z = float(rng.uniform(0.5, 3.0)) if elevate_aeroplanes and ontology.CATEGORY_OF[subtype] == "aeroplane" else 0
        specs.append(dict(subtype=subtype, color=color, material=str(rng.choice(ontology.MATERIALS)),
                          size=str(rng.choice(ontology.SIZES)), parts=parts,
                          position=(float(rng.uniform(-3, 3)), float(rng.uniform(-3, 3)), z),
                          pose_degree=float(rng.uniform(0, 360))))
    occluded_by: list[list[int]] = [[] for _ in range(n)]
    part_occ: list[dict[str, list[int]]] = [{} for _ in range(n)]
    for i in range(n):
        for j in range(n):
            # j (nearer the camera, smaller y) may hide object i or some of its parts
            if i == j or specs[j]["position"][1] >= specs[i]["position"][1] or rng.random() > occlusion_rate:
                continue
            occluded_by[i].append(j)
            names = ontology.PARTS[specs[i]["subtype"]]
            for p in rng.choice(len(names), size=int(rng.integers(1, 4)), replace=False):
                part_occ[i].setdefault(names[p], []).append(j)
    objects = [toy_object(**spec, occluded_by=occluded_by[i], part_occluded_by=part_occ[i])
               for i, spec in enumerate(specs)]
    return toy_scene(objects, image_index=seed)

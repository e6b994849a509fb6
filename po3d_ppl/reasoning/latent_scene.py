"""Concrete assignments of the scene model's latents, and the ``Scene`` record each one describes.

An assignment maps latent *elements* to value indices: ``("exists", i)``, ``("subtype", i)``, ``("color", i)``,
``("material", i)``, ``("size", i)``, ``("pose", i)`` (an index into the proposal's azimuth grid),
``("occluded", i)``, ``("occludes", i, j)`` (i occluded by j), ``("part_state", i, s, p)``,
``("part_occluded", i, s, p)`` and ``("part_occludes", i, s, p, j)`` for subtype hypothesis s. Turning one into a
``Scene`` lets the question engine's reference executor run on it: the thresholded baseline does so with the most
probable assignment, and the tests do so with every assignment to check the exact engine.
"""

from __future__ import annotations

import numpy as np

from po3d_ppl import ontology
from po3d_ppl.evidence import SceneEvidence
from po3d_ppl.reasoning.posterior import SitePosteriors
from po3d_ppl.reasoning.scene_model import OBJECT_SITES
from po3d_ppl.world.scene import EntityAnnotation, Occlusion, PartStyle, Scene, SceneObject, compute_relationships


def argmax_assignment(post: SitePosteriors) -> dict[tuple, int]:
    """The most probable value of every latent element (ties: the lowest index)."""
    out: dict[tuple, int] = {}
    n = post.probs["exists"].shape[0]
    for name in OBJECT_SITES:
        best = post.probs[name].argmax(-1)
        out.update({(name, i): int(best[i]) for i in range(n)})
    occ = post.probs["occludes"].argmax(-1)
    out.update({("occludes", i, j): int(occ[i, j]) for i in range(n) for j in range(n) if i != j})
    for i in range(n):
        s = out[("subtype", i)]
        for name in ("part_state", "part_occluded"):
            best = post.probs[name][i, s].argmax(-1)
            out.update({(name, i, s, p): int(best[p]) for p in range(len(ontology.PARTS[ontology.SUBTYPES[s]]))})
        best = post.probs["part_occludes"][i, s].argmax(-1)  # [P, N_j]
        out.update({("part_occludes", i, s, p, j): int(best[p, j])
                    for p in range(len(ontology.PARTS[ontology.SUBTYPES[s]])) for j in range(n) if j != i})
    return out


def scene_from_assignment(assign: dict[tuple, int], evidence: SceneEvidence) -> Scene:
    """The scene an assignment describes: non-existing proposals are dropped (and the rest re-indexed)."""
    n = evidence.num_objects
    alive = [i for i in range(n) if assign[("exists", i)] == 1]
    new_index = {i: k for k, i in enumerate(alive)}
    objects = []
    for i in alive:
        s = assign[("subtype", i)]
        sub = ontology.SUBTYPES[s]
        parts, part_ann = {}, {}
        for p, raw in enumerate(ontology.PARTS[sub]):
            state = assign[("part_state", i, s, p)]
            if state >= 2:
                style = state - 2
                parts[raw] = PartStyle(ontology.COLORS[style // len(ontology.MATERIALS)],
                                       ontology.MATERIALS[style % len(ontology.MATERIALS)])
            by = tuple(new_index[j] for j in alive if j != i and assign[("part_occludes", i, s, p, j)] == 1)
            occ = Occlusion(level=1 if by else 0, visible_before=True, occluded_by=by,
                            occluded=bool(assign[("part_occluded", i, s, p)]))
            visible = 20 if state >= 1 else 0
            part_ann[raw] = EntityAnnotation(visible, visible, (0, 0, 0, 0), occ)
        by = tuple(new_index[j] for j in alive if j != i and assign[("occludes", i, j)] == 1)
        occ = Occlusion(level=1 if by else 0, visible_before=True, occluded_by=by,
                        occluded=bool(assign[("occluded", i)]))
        objects.append(SceneObject(
            subtype=sub, color=ontology.COLORS[assign[("color", i)]],
            material=ontology.MATERIALS[assign[("material", i)]], size=ontology.SIZES[assign[("size", i)]],
            rotation=0.0, position=tuple(float(x) for x in evidence.positions[i]),
            pose_degree=float(evidence.pose_support[i, assign[("pose", i)]]), parts=parts,
            pixel_coords=(0.0, 0.0, float(evidence.depths[i])),
            annotation=EntityAnnotation(200, 200, (0, 0, 0, 0), occ), part_annotations=part_ann))
    directions = {k: tuple(float(x) for x in v) for k, v in evidence.directions.items()}
    positions = np.array([o.position for o in objects], dtype=float).reshape(-1, 3)
    return Scene(objects=tuple(objects), directions=directions,
                 relationships=compute_relationships(positions, directions))

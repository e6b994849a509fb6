"""An independent oracle for the reasoning engine: enumerate every joint assignment of the latent scene, build a
concrete ``Scene`` for each, and run the *reference executor* (the question engine's ground-truth semantics).

Nothing here uses the reasoning engine's inference code: posteriors are computed per latent directly from the
evidence and the priors, and answers come from ``po3d_ppl.questions.executor`` (only the mapping from an
assignment to a ``Scene`` record is shared with the thresholded baseline). Feasible only for evidence whose latents have
small supports, which :func:`sparse_random_evidence` produces.
"""

from __future__ import annotations

import itertools
import math
from collections import defaultdict
from dataclasses import dataclass

import numpy as np
import torch

from po3d_ppl import ontology
from po3d_ppl.evidence import CERTAIN, SceneEvidence, ScenePriors
from po3d_ppl.perception import simulated_evidence
from po3d_ppl.questions.executor import execute
from po3d_ppl.world.scene import EntityAnnotation, Occlusion, PartStyle, Scene, SceneObject, compute_relationships

S = len(ontology.SUBTYPES)


def sparse_random_evidence(scene: Scene, rng: np.random.Generator, num_uncertain: int) -> SceneEvidence:
    """Certain evidence for ``scene`` with ``num_uncertain`` randomly chosen latents made uncertain between their
    true value and one random alternative (random log-likelihoods). Part slots of every subtype hypothesis are
    certain (visible, plain, not occluded) unless chosen."""
    ev = simulated_evidence(scene)
    n = ev.num_objects
    fields = {name: getattr(ev, name).clone() for name in (
        "exist_logodds", "subtype_loglik", "color_loglik", "material_loglik", "size_loglik", "pose_loglik",
        "occluded_logodds", "occludes_logodds", "part_visible_logodds", "part_style_loglik",
        "part_occluded_logodds", "part_occludes_logodds")}
    true_sub = [ontology.SUBTYPES.index(o.subtype) for o in scene.objects]
    for i in range(n):
        for s in range(S):
            if s != true_sub[i]:
                fields["part_visible_logodds"][i, s] = CERTAIN
                fields["part_style_loglik"][i, s] = -CERTAIN
                fields["part_style_loglik"][i, s, :, 0] = 0.0
                fields["part_occluded_logodds"][i, s] = -CERTAIN
                fields["part_occludes_logodds"][i, s] = -CERTAIN

    def two_way(tensor: torch.Tensor, index: tuple) -> None:
        row = tensor[index]
        true = int(row.argmax())
        other = int(rng.choice([k for k in range(row.shape[-1]) if k != true]))
        row[:] = -CERTAIN
        row[true], row[other] = rng.normal(), rng.normal()

    def flip(tensor: torch.Tensor, index: tuple) -> None:
        tensor[index] = rng.normal(0.0, 2.0)

    objects, others = [], []  # half of the uncertainty goes to object latents, half to pairs and parts
    for i in range(n):
        objects += [("exist_logodds", (i,)), ("subtype_loglik", (i,)), ("color_loglik", (i,)),
                    ("material_loglik", (i,)), ("size_loglik", (i,)), ("occluded_logodds", (i,))]
        # the pose read by each category's mesh: made uncertain per category, so it depends on the subtype
        objects += [("pose_loglik", (i, c)) for c in range(len(ontology.CATEGORIES))]
        others += [("occludes_logodds", (i, j)) for j in range(n) if j != i]
        s = true_sub[i]
        for p in range(len(ontology.PARTS[ontology.SUBTYPES[s]])):
            others += [("part_style_loglik", (i, s, p)), ("part_occluded_logodds", (i, s, p))]
            others += [("part_occludes_logodds", (i, s, p, j)) for j in range(n) if j != i]
    half = num_uncertain // 2
    picked = [objects[k] for k in rng.choice(len(objects), size=min(num_uncertain - half, len(objects)), replace=False)]
    picked += [others[k] for k in rng.choice(len(others), size=min(half, len(others)), replace=False)]
    for name, index in picked:
        (two_way if name.endswith("loglik") else flip)(fields[name], index)
    return SceneEvidence(**fields, pose_support=ev.pose_support, positions=ev.positions, depths=ev.depths,
                         directions=ev.directions)


@dataclass
class _Latent:
    key: tuple
    values: list
    probs: list


def _categorical(prior: np.ndarray, loglik: np.ndarray) -> tuple[list, list]:
    logits = np.log(prior) + loglik
    p = np.exp(logits - logits.max())
    p /= p.sum()
    keep = [k for k in range(len(p)) if p[k] > 0]
    return keep, [float(p[k]) for k in keep]


def _binary(prior: float, logodds: float) -> tuple[list, list]:
    return _categorical(np.array([1 - prior, prior]), np.array([0.0, float(logodds)]))


def _latents(ev: SceneEvidence, priors: ScenePriors) -> list[_Latent]:
    n = ev.num_objects
    out = []
    uniform = lambda k: np.full(k, 1.0 / k)  # noqa: E731
    for i in range(n):
        out.append(_Latent(("exists", i), *_binary(priors.exists, ev.exist_logodds[i])))
        for name, ll in (("subtype", ev.subtype_loglik), ("color", ev.color_loglik),
                         ("material", ev.material_loglik), ("size", ev.size_loglik)):
            out.append(_Latent((name, i), *_categorical(uniform(ll.shape[-1]), ll[i].numpy())))
        subtypes = next(lat for lat in out if lat.key == ("subtype", i)).values
        for s in subtypes:  # the pose of each subtype hypothesis, scored by its category's mesh
            ll = ev.pose_loglik[i, ontology.CATEGORIES.index(ontology.CATEGORY_OF[ontology.SUBTYPES[s]])].numpy()
            out.append(_Latent(("pose", i, s), *_categorical(uniform(ll.shape[-1]), ll)))
        out.append(_Latent(("occluded", i), *_binary(priors.occluded, ev.occluded_logodds[i])))
        for j in range(n):
            if j != i:
                out.append(_Latent(("occludes", i, j), *_binary(priors.occludes, ev.occludes_logodds[i, j])))
    state_prior = priors.part_state_probs().numpy()
    for i in range(n):
        subtypes = next(lat for lat in out if lat.key == ("subtype", i)).values
        for s in subtypes:
            for p in range(len(ontology.PARTS[ontology.SUBTYPES[s]])):
                style = ev.part_style_loglik[i, s, p].numpy()  # hidden is scored as plain (style 0)
                ll = np.concatenate([style[:1], ev.part_visible_logodds[i, s, p].item() + style])
                out.append(_Latent(("part_state", i, s, p), *_categorical(state_prior, ll)))
                out.append(_Latent(("part_occluded", i, s, p),
                                   *_binary(priors.part_occluded, ev.part_occluded_logodds[i, s, p])))
                for j in range(n):
                    if j != i:
                        out.append(_Latent(("part_occludes", i, s, p, j),
                                           *_binary(priors.part_occludes, ev.part_occludes_logodds[i, s, p, j])))
    return out


def brute_force(program_json: list[dict], ev: SceneEvidence, priors: ScenePriors = ScenePriors(),
                max_assignments: int = 200_000) -> tuple[dict, float]:
    """Answer distribution (raw answers -> probability) and invalid mass, by enumerating every assignment."""
    latents = _latents(ev, priors)
    fixed = {lat.key: lat.values[0] for lat in latents if len(lat.values) == 1}
    free = [lat for lat in latents if len(lat.values) > 1]
    total = math.prod(len(lat.values) for lat in free)
    if total > max_assignments:
        raise ValueError(f"{total} assignments: too many for brute force")
    dist: dict = defaultdict(float)
    invalid = 0.0
    for combo in itertools.product(*(range(len(lat.values)) for lat in free)):
        assign = dict(fixed)
        weight = 1.0
        for lat, k in zip(free, combo):
            assign[lat.key] = lat.values[k]
            weight *= lat.probs[k]
        if weight == 0.0:
            continue
        result = execute(scene_from_assignment(assign, ev), program_json)
        if result.valid:
            dist[result.answer] += weight
        else:
            invalid += weight
    return dict(dist), invalid


def scene_from_assignment(assign: dict[tuple, int], evidence: SceneEvidence) -> Scene:
    """The scene an assignment describes: non-existing proposals are dropped (and the rest re-indexed).

    Assignments map latent elements to value indices: ``("exists", i)``, ``("pose", i, s)`` (an index into the
    proposal's azimuth grid, for subtype hypothesis s), ``("occludes", i, j)`` (i occluded by j), ``("part_state", i, s, p)``,
    ``("part_occludes", i, s, p, j)`` for subtype hypothesis s, ... Running the reference executor on the scene
    checks the latent-world semantics against the ground-truth ones, assignment by assignment."""
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
            pose_degree=float(evidence.pose_support[i, assign[("pose", i, s)]]), parts=parts,
            pixel_coords=(0.0, 0.0, float(evidence.depths[i])),
            annotation=EntityAnnotation(200, 200, (0, 0, 0, 0), occ), part_annotations=part_ann))
    directions = {k: tuple(float(x) for x in v) for k, v in evidence.directions.items()}
    positions = np.array([o.position for o in objects], dtype=float).reshape(-1, 3)
    return Scene(objects=tuple(objects), directions=directions,
                 relationships=compute_relationships(positions, directions))

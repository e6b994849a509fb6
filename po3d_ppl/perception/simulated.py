"""The simulated sensor: evidence made from a ground-truth scene, certain or through a calibrated noise model.

A perception back-end like the render-and-compare parser, behind the same interface
(:class:`~po3d_ppl.perception.EvidenceSource`), but it reads a :class:`~po3d_ppl.world.Scene` instead of pixels.
It is the stand-in for perception in reasoning tests, in the oracle column of evaluation and in calibration
studies of the reasoning alone: with ``noise = t`` every categorical observation is wrong with probability ``t``
(uniformly), every binary one flipped with probability ``t``, and the azimuth observed with a Gaussian error of
``60 t`` degrees. The log-likelihoods are those of that sensor model, so posteriors are calibrated wherever the
priors match the world (docs/reasoning.md lists where they do not yet).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Integral, Real

import numpy as np
import torch

from po3d_ppl import ontology
from po3d_ppl.errors import InputError
from po3d_ppl.evidence import CERTAIN, DEFAULT_POSE_BINS, DTYPE, NUM_STYLES, P, S, SceneEvidence, style_index
from po3d_ppl.world.sampler import SceneConfig
from po3d_ppl.world.scene import Scene, SceneObject

#: A part counts as visible at this many pixels: the rule the world's recolouring uses.
VISIBLE_PART_PIXELS = SceneConfig().min_part_pixels


@dataclass(frozen=True)
class SimulatedSensor:
    """Evidence from ground truth: ``SimulatedSensor(noise=0.1, seed=3).evidence(scene)``."""

    noise: float = 0.0
    seed: int = 0
    pose_bins: int = DEFAULT_POSE_BINS
    name = "simulated"

    def __post_init__(self) -> None:
        if isinstance(self.noise, bool) or not isinstance(self.noise, Real) or not 0.0 <= float(self.noise) < 1.0:
            raise InputError("noise", f"must be a number in [0, 1), got {self.noise!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, Integral) or self.seed < 0:
            raise InputError("seed", f"must be a non-negative integer, got {self.seed!r}")
        if isinstance(self.pose_bins, bool) or not isinstance(self.pose_bins, Integral) or self.pose_bins < 1:
            raise InputError("pose_bins", f"must be an integer >= 1, got {self.pose_bins!r}")

    def evidence(self, scene: Scene) -> SceneEvidence:
        if not isinstance(scene, Scene):
            raise InputError("scene", f"the simulated sensor reads a po3d_ppl.world.Scene, got {type(scene).__name__}")
        return _EvidenceBuilder(scene, float(self.noise), np.random.default_rng(int(self.seed)), int(self.pose_bins)).build()


def simulated_evidence(scene: Scene, noise: float = 0.0, seed: int = 0,
                       pose_bins: int = DEFAULT_POSE_BINS) -> SceneEvidence:
    """Evidence from a ground-truth scene: certain when ``noise == 0``, else the noisy-sensor model above."""
    return SimulatedSensor(noise, seed, pose_bins).evidence(scene)


class _EvidenceBuilder:
    """Turns a ground-truth scene into (noisy) evidence with a symmetric-channel sensor model."""

    def __init__(self, scene: Scene, noise: float, rng: np.random.Generator, pose_bins: int):
        self.scene, self.noise, self.rng, self.k = scene, noise, rng, pose_bins

    def categorical(self, true_index: int, size: int) -> np.ndarray:
        if self.noise == 0.0:
            out = np.full(size, -CERTAIN)
            out[true_index] = 0.0
            return out
        observed = true_index
        if size > 1 and self.rng.random() < self.noise:
            observed = int(self.rng.choice([i for i in range(size) if i != true_index]))
        wrong = self.noise / max(size - 1, 1)  # underflows to 0 for subnormal noise: then as good as certain
        out = np.full(size, math.log(wrong) if wrong > 0.0 else -CERTAIN)
        out[observed] = math.log(1.0 - self.noise)
        return out

    def binary(self, truth: bool) -> float:
        if self.noise == 0.0:
            return CERTAIN if truth else -CERTAIN
        observed = truth != (self.rng.random() < self.noise)
        strength = min(math.log((1.0 - self.noise) / self.noise), CERTAIN)  # the ratio overflows for subnormal noise
        return strength if observed else -strength

    def pose(self, degree: float) -> tuple[np.ndarray, np.ndarray]:
        grid = np.arange(self.k) * (360.0 / self.k)
        certain = np.full(self.k, -CERTAIN)
        certain[0] = 0.0
        if self.noise == 0.0:
            return (degree + grid) % 360.0, certain
        sigma = math.radians(60.0 * self.noise)
        observed = (degree + math.degrees(self.rng.normal(0.0, sigma))) % 360.0
        if sigma**2 < 1.0 / CERTAIN:  # so sharp that every other bin is impossible (and 1 / sigma^2 may overflow)
            return (observed + grid) % 360.0, certain
        kappa = 1.0 / sigma**2
        return (observed + grid) % 360.0, kappa * (np.cos(np.radians(grid)) - 1.0)

    def build(self) -> SceneEvidence:
        objs = self.scene.objects
        n = len(objs)
        ev = {
            "exist_logodds": np.array([self.binary(True) for _ in objs]),
            "subtype_loglik": np.stack([self.categorical(ontology.SUBTYPES.index(o.subtype), S) for o in objs])
            if n else np.zeros((0, S)),
            "color_loglik": np.stack([self.categorical(ontology.COLORS.index(o.color), len(ontology.COLORS))
                                      for o in objs]) if n else np.zeros((0, len(ontology.COLORS))),
            "material_loglik": np.stack([self.categorical(ontology.MATERIALS.index(o.material), 2) for o in objs])
            if n else np.zeros((0, 2)),
            "size_loglik": np.stack([self.categorical(ontology.SIZES.index(o.size), 2) for o in objs])
            if n else np.zeros((0, 2)),
            "occluded_logodds": np.array([self.binary(o.occluded) for o in objs]),
        }
        poses = [self.pose(o.pose_degree) for o in objs]
        ev["pose_support"] = np.stack([p[0] for p in poses]) if n else np.zeros((0, self.k))
        # the simulated sensor reads the azimuth the same way whatever the category (a real parser fits each
        # category's mesh on its own, and its likelihoods differ)
        categories = len(ontology.CATEGORIES)
        ev["pose_loglik"] = (np.repeat(np.stack([p[1] for p in poses])[:, None, :], categories, axis=1) if n
                             else np.zeros((0, categories, self.k)))
        ev["occludes_logodds"] = np.array(
            [[0.0 if i == j else self.binary(j in objs[i].occluded_by) for j in range(n)] for i in range(n)]
        ).reshape(n, n)
        vis = np.zeros((n, S, P))
        style = np.zeros((n, S, P, NUM_STYLES))
        occ = np.zeros((n, S, P))
        pocc = np.zeros((n, S, P, n))
        for i, obj in enumerate(objs):
            s = ontology.SUBTYPES.index(obj.subtype)
            for p, raw in enumerate(ontology.PARTS[obj.subtype]):
                vis[i, s, p] = self.binary(part_visible(obj, raw))
                part_style = obj.parts.get(raw)
                truth = style_index(part_style.color, part_style.material) if part_style else 0
                style[i, s, p] = self.categorical(truth, NUM_STYLES)
                occ[i, s, p] = self.binary(obj.part_occluded(raw))
                by = obj.part_occluded_by(raw)
                pocc[i, s, p] = [0.0 if j == i else self.binary(j in by) for j in range(n)]
        ev.update(part_visible_logodds=vis, part_style_loglik=style, part_occluded_logodds=occ,
                  part_occludes_logodds=pocc)
        ev["positions"] = np.array([o.position for o in objs], dtype=float).reshape(n, 3)
        ev["depths"] = np.array([_depth(self.scene, o) for o in objs], dtype=float)
        tensors = {k: torch.as_tensor(v, dtype=DTYPE) for k, v in ev.items()}
        directions = {k: torch.as_tensor(v, dtype=DTYPE) for k, v in self.scene.directions.items()}
        boxes = torch.tensor([o.annotation.bbox if o.annotation else (0, 0, 0, 0) for o in objs],
                             dtype=DTYPE).reshape(n, 4)
        return SceneEvidence(**tensors, directions=directions, boxes=boxes, camera=self.scene.camera)


def part_visible(obj: SceneObject, raw: str) -> bool:
    """Recoloured parts are visible by construction; otherwise use the annotation (the world's
    ``SceneConfig.min_part_pixels`` visible pixels)."""
    if raw in obj.parts:
        return True
    ann = obj.part_annotations.get(raw)
    return bool(ann and ann.visible_pixels >= VISIBLE_PART_PIXELS)


def _depth(scene: Scene, obj: SceneObject) -> float:
    if obj.pixel_coords is not None:
        return float(obj.pixel_coords[2])
    if scene.camera is not None:
        return float(scene.camera.project(np.asarray(obj.position))[2])
    raise InputError("scene", "objects need pixel_coords or the scene a camera to compute depths")

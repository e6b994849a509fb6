"""``SceneEvidence``: the contract between perception and reasoning.

Perception (render-and-compare scene parsing) or a ground-truth scene produces, for every object proposal, scores
that the reasoning engine's Pyro model uses as likelihood factors. Everything is a log-likelihood (or log-odds,
for binary variables), never a probability: a proposal's scores say how well each hypothesis explains the image,
and the model's priors are separate (:class:`ScenePriors`).

Part scores are given *per subtype hypothesis* (``[N, 21, P, ...]``): perception projects each candidate subtype's
mesh to find its parts, so a part slot only means something under one subtype. The paper's occlusion matrix S
appears as ``occludes_logodds`` (object by object) and ``part_occludes_logodds`` (part slot by object).

Part states (``part_state`` latent, :data:`NUM_PART_STATES` of them): 0 = hidden, 1 = visible with the object's own look,
``2 + 2 * colour + material`` = visible and recoloured (the public ``parts`` field). A part's attribute reading
(``part_style_loglik``) is scored under every state: a hidden part shows no recolouring, so "hidden" takes the
plain style's column, never a free likelihood of 1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
import torch

from po3d_ppl.errors import InputError, Po3dError
from po3d_ppl import ontology
from po3d_ppl.world.scene import Scene, SceneObject

#: Log-likelihood gap used for "certain" evidence: exp(-CERTAIN) underflows to exactly 0 in float64.
CERTAIN = 1.0e4
#: Azimuth grid size of ground-truth evidence (15-degree steps, anchored at the estimated azimuth).
DEFAULT_POSE_BINS = 24
NUM_STYLES = 1 + len(ontology.COLORS) * len(ontology.MATERIALS)  # plain + recoloured (colour, material)
NUM_PART_STATES = 1 + NUM_STYLES  # hidden + styles
P = ontology.MAX_PARTS
S = len(ontology.SUBTYPES)
DTYPE = torch.float64


def style_index(color: str, material: str) -> int:
    """Index of a recoloured style in the style axis (0 = plain)."""
    return 1 + ontology.COLORS.index(color) * len(ontology.MATERIALS) + ontology.MATERIALS.index(material)


def _state_tables() -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    color = [-1, -1]
    material = [-1, -1]
    for c in range(len(ontology.COLORS)):
        for m in range(len(ontology.MATERIALS)):
            color.append(c)
            material.append(m)
    visible = [0] + [1] * NUM_STYLES
    return torch.tensor(color), torch.tensor(material), torch.tensor(visible, dtype=torch.bool)


#: Per part state: colour id (-1 none), material id (-1 none), visible.
STATE_COLOR, STATE_MATERIAL, STATE_VISIBLE = _state_tables()


class EvidenceError(Po3dError, ValueError):
    """Evidence tensors with wrong shapes or values. The message names the field and the expected shape."""


@dataclass(frozen=True)
class ScenePriors:
    """Prior probabilities of the scene model (categorical latents have uniform priors)."""

    exists: float = 0.5
    occluded: float = 0.3
    occludes: float = 0.1
    part_visible: float = 0.5
    #: Probability that a visible part is recoloured (spread uniformly over the 16 styles).
    part_recoloured: float = 0.15
    part_occluded: float = 0.2
    part_occludes: float = 0.05

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if not 0.0 < v < 1.0:
                raise InputError(f"priors.{f.name}", f"must be a probability in (0, 1), got {v}")

    def part_state_probs(self) -> torch.Tensor:
        """Prior over the 18 part states."""
        vis = self.part_visible
        recol = vis * self.part_recoloured / (NUM_STYLES - 1)
        return torch.tensor([1.0 - vis, vis * (1.0 - self.part_recoloured)] + [recol] * (NUM_STYLES - 1), dtype=DTYPE)


@dataclass
class SceneEvidence:
    """Scores for N object proposals. Shapes: N proposals, K azimuth bins, 21 subtypes, P = MAX_PARTS slots."""

    exist_logodds: torch.Tensor  # [N]
    subtype_loglik: torch.Tensor  # [N, 21]
    color_loglik: torch.Tensor  # [N, 8]
    material_loglik: torch.Tensor  # [N, 2]
    size_loglik: torch.Tensor  # [N, 2]
    pose_support: torch.Tensor  # [N, K] azimuths in degrees (a grid per proposal)
    pose_loglik: torch.Tensor  # [N, K]
    occluded_logodds: torch.Tensor  # [N]
    occludes_logodds: torch.Tensor  # [N, N]: [i, j] object i is occluded by object j (diagonal ignored)
    part_visible_logodds: torch.Tensor  # [N, 21, P]
    part_style_loglik: torch.Tensor  # [N, 21, P, 17]: 0 plain, 1 + 2 * colour + material recoloured
    part_occluded_logodds: torch.Tensor  # [N, 21, P]
    part_occludes_logodds: torch.Tensor  # [N, 21, P, N]: part slot occluded by object j
    positions: torch.Tensor  # [N, 3] world coordinates (observed)
    depths: torch.Tensor  # [N] distance along the camera's viewing axis (observed)
    directions: dict[str, torch.Tensor]  # CLEVR's six ground directions

    def __post_init__(self) -> None:
        self.validate()

    @property
    def num_objects(self) -> int:
        return int(self.exist_logodds.shape[0])

    @property
    def num_pose_bins(self) -> int:
        return int(self.pose_support.shape[-1])

    def validate(self) -> None:
        n = self.exist_logodds.shape[0] if self.exist_logodds.dim() == 1 else -1
        if n < 0:
            raise EvidenceError(f"exist_logodds: expected shape [N], got {tuple(self.exist_logodds.shape)}")
        k = self.pose_support.shape[-1] if self.pose_support.dim() == 2 else 0
        expected = {
            "exist_logodds": (n,),
            "subtype_loglik": (n, S),
            "color_loglik": (n, len(ontology.COLORS)),
            "material_loglik": (n, len(ontology.MATERIALS)),
            "size_loglik": (n, len(ontology.SIZES)),
            "pose_support": (n, k),
            "pose_loglik": (n, k),
            "occluded_logodds": (n,),
            "occludes_logodds": (n, n),
            "part_visible_logodds": (n, S, P),
            "part_style_loglik": (n, S, P, NUM_STYLES),
            "part_occluded_logodds": (n, S, P),
            "part_occludes_logodds": (n, S, P, n),
            "positions": (n, 3),
            "depths": (n,),
        }
        if k < 1:
            raise EvidenceError(f"pose_support: expected shape [N, K] with K >= 1, got {tuple(self.pose_support.shape)}")
        for name, shape in expected.items():
            value = getattr(self, name)
            if not isinstance(value, torch.Tensor):
                raise EvidenceError(f"{name}: expected a torch tensor of shape {list(shape)}, got {type(value).__name__}")
            if tuple(value.shape) != shape:
                raise EvidenceError(f"{name}: expected shape {list(shape)}, got {list(value.shape)} (N={n}, K={k})")
            if torch.isnan(value).any():
                raise EvidenceError(f"{name}: contains NaN")
            if name in ("positions", "depths", "pose_support") and not torch.isfinite(value).all():
                raise EvidenceError(f"{name}: must be finite")
        missing = {"behind", "front", "left", "right", "above", "below"} - set(self.directions)
        if missing:
            raise EvidenceError(f"directions: missing {sorted(missing)}")

    def to(self, device: torch.device | str) -> SceneEvidence:
        moved = {f.name: getattr(self, f.name) for f in fields(self)}
        for name, value in moved.items():
            if isinstance(value, torch.Tensor):
                moved[name] = value.to(device)
        moved["directions"] = {k: v.to(device) for k, v in self.directions.items()}
        return SceneEvidence(**moved)

    @classmethod
    def from_scene(cls, scene: Scene, noise: float = 0.0, seed: int = 0,
                   pose_bins: int = DEFAULT_POSE_BINS) -> SceneEvidence:
        """Evidence from a ground-truth scene: certain when ``noise == 0``, else a noisy-sensor study.

        With ``noise = t`` every categorical observation is wrong with probability ``t`` (uniformly), every binary
        one flipped with probability ``t``, and the azimuth observed with a Gaussian error of ``60 t`` degrees. The
        log-likelihoods are those of that sensor model, so posteriors are calibrated wherever the priors match the
        world (docs/reasoning.md lists where they do not yet): the setting for calibration studies of the reasoning.
        """
        if not 0.0 <= noise < 1.0:
            raise InputError("noise", f"must be in [0, 1), got {noise}")
        if pose_bins < 1:
            raise InputError("pose_bins", f"must be >= 1, got {pose_bins}")
        return _EvidenceBuilder(scene, noise, np.random.default_rng(seed), pose_bins).build()


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
        out = np.full(size, math.log(self.noise / max(size - 1, 1)))
        out[observed] = math.log(1.0 - self.noise)
        return out

    def binary(self, truth: bool) -> float:
        if self.noise == 0.0:
            return CERTAIN if truth else -CERTAIN
        observed = truth != (self.rng.random() < self.noise)
        strength = math.log((1.0 - self.noise) / self.noise)
        return strength if observed else -strength

    def pose(self, degree: float) -> tuple[np.ndarray, np.ndarray]:
        grid = np.arange(self.k) * (360.0 / self.k)
        if self.noise == 0.0:
            loglik = np.full(self.k, -CERTAIN)
            loglik[0] = 0.0
            return (degree + grid) % 360.0, loglik
        sigma = math.radians(60.0 * self.noise)
        observed = (degree + math.degrees(self.rng.normal(0.0, sigma))) % 360.0
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
        ev["pose_loglik"] = np.stack([p[1] for p in poses]) if n else np.zeros((0, self.k))
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
                vis[i, s, p] = self.binary(_part_visible(obj, raw))
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
        return SceneEvidence(**tensors, directions=directions)


def _part_visible(obj: SceneObject, raw: str) -> bool:
    """Recoloured parts are visible by construction; otherwise use the annotation (>= 20 visible pixels)."""
    if raw in obj.parts:
        return True
    ann = obj.part_annotations.get(raw)
    return bool(ann and ann.visible_pixels >= 20)


def _depth(scene: Scene, obj: SceneObject) -> float:
    if obj.pixel_coords is not None:
        return float(obj.pixel_coords[2])
    if scene.camera is not None:
        return float(scene.camera.project(np.asarray(obj.position))[2])
    raise InputError("scene", "objects need pixel_coords or the scene a camera to compute depths")

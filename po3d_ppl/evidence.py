"""``SceneEvidence``: the contract between perception and reasoning, in a module of its own.

Both stages import it and neither imports the other: a perception back-end (the render-and-compare parser, or the
simulated sensor of :mod:`po3d_ppl.perception.simulated`) produces, for every object proposal, scores that the
reasoning engine's Pyro model uses as likelihood factors. Everything is a log-likelihood (or log-odds,
for binary variables), never a probability: a proposal's scores say how well each hypothesis explains the image,
and the model's priors are separate (:class:`ScenePriors`).

Part scores are given *per subtype hypothesis* (``[N, 21, P, ...]``): perception projects each candidate subtype's
mesh to find its parts, so a part slot only means something under one subtype. The paper's occlusion matrix S
appears as ``occludes_logodds`` (object by object) and ``part_occludes_logodds`` (part slot by object).

Part states (``part_state`` latent, :data:`NUM_PART_STATES` of them): 0 = hidden, 1 = visible with the object's own look,
``2 + 2 * colour + material`` = visible and recoloured (the public ``parts`` field). A part's attribute reading
(``part_style_loglik``) is scored under every state: a hidden part shows no recolouring, so "hidden" takes the
plain style's column, never a free likelihood of 1.

Proposals are distinct objects: a back-end must not return two proposals for one object (the real parser
guarantees it with 3D non-maximum suppression on ground footprints; ``docs/architecture.md`` says why this, rather
than a mutual-exclusion latent, and how it is measured with :func:`duplicate_pairs`). ``boxes``, ``masks`` and
``camera`` are carried for overlays and evaluation; reasoning never reads them.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import torch

from po3d_ppl import ontology
from po3d_ppl.errors import InputError, Po3dError
from po3d_ppl.world.scene import Camera

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
    #: The world's recolouring rule (:mod:`po3d_ppl.reasoning.part_counts`): every object has exactly
    #: ``min(max_recoloured_parts, its visible parts)`` recoloured parts. None: each visible part is recoloured
    #: independently at ``part_recoloured``.
    max_recoloured_parts: int | None = None
    #: Under the rule, a recoloured part's colour is never the object's own.
    recoloured_unlike_body: bool = False

    def __post_init__(self) -> None:
        for name in RATE_FIELDS:
            v = getattr(self, name)
            if not 0.0 < v < 1.0:
                raise InputError(f"priors.{name}", f"must be a probability in (0, 1), got {v}")
        cap = self.max_recoloured_parts
        if cap is not None and not (isinstance(cap, int) and not isinstance(cap, bool) and cap >= 1):
            raise InputError("priors.max_recoloured_parts", f"must be an integer >= 1 or None, got {cap!r}")
        if not isinstance(self.recoloured_unlike_body, bool):
            raise InputError("priors.recoloured_unlike_body", f"must be true or false, got "
                                                               f"{self.recoloured_unlike_body!r}")
        if self.recoloured_unlike_body and cap is None:
            raise InputError("priors.recoloured_unlike_body", "is part of the recolouring rule: set "
                                                               "max_recoloured_parts too")

    def part_state_probs(self) -> torch.Tensor:
        """Prior over the 18 part states."""
        vis = self.part_visible
        recol = vis * self.part_recoloured / (NUM_STYLES - 1)
        return torch.tensor([1.0 - vis, vis * (1.0 - self.part_recoloured)] + [recol] * (NUM_STYLES - 1), dtype=DTYPE)


#: The ``ScenePriors`` fields that are probabilities (the rest describe the recolouring rule).
RATE_FIELDS = tuple(f.name for f in fields(ScenePriors) if f.type == "float")


@dataclass
class SceneEvidence:
    """Scores for N object proposals. Shapes: N proposals, K azimuth bins, 21 subtypes, P = MAX_PARTS slots."""

    exist_logodds: torch.Tensor  # [N]
    subtype_loglik: torch.Tensor  # [N, 21]
    color_loglik: torch.Tensor  # [N, 8]
    material_loglik: torch.Tensor  # [N, 2]
    size_loglik: torch.Tensor  # [N, 2]
    pose_support: torch.Tensor  # [N, K] azimuths in degrees (a grid per proposal, shared by the categories)
    pose_loglik: torch.Tensor  # [N, 5, K]: per category hypothesis (each category's mesh is fitted on its own)
    occluded_logodds: torch.Tensor  # [N]
    occludes_logodds: torch.Tensor  # [N, N]: [i, j] object i is occluded by object j (diagonal ignored)
    part_visible_logodds: torch.Tensor  # [N, 21, P]
    part_style_loglik: torch.Tensor  # [N, 21, P, 17]: 0 plain, 1 + 2 * colour + material recoloured
    part_occluded_logodds: torch.Tensor  # [N, 21, P]
    part_occludes_logodds: torch.Tensor  # [N, 21, P, N]: part slot occluded by object j
    positions: torch.Tensor  # [N, 3] world coordinates (observed)
    depths: torch.Tensor  # [N] distance along the camera's viewing axis (observed)
    directions: dict[str, torch.Tensor]  # CLEVR's six ground directions
    #: For overlays and evaluation only: boxes ``[N, 4]`` (x, y, w, h pixels, the public bbox layout), visible
    #: masks ``[N, H, W]`` bool, and the camera the image was taken with (estimated or known).
    boxes: torch.Tensor | None = None
    masks: torch.Tensor | None = None
    camera: Camera | None = None

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
            "pose_loglik": (n, len(ontology.CATEGORIES), k),
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
            if value.dtype != DTYPE:
                raise EvidenceError(f"{name}: expected dtype {DTYPE}, got {value.dtype} (convert with "
                                    f".to(torch.float64): exact inference needs double precision)")
            if value.device != self.exist_logodds.device:
                raise EvidenceError(f"{name}: on {value.device}, but exist_logodds is on {self.exist_logodds.device} "
                                    "(every table must be on one device; use evidence.to(device))")
            if torch.isnan(value).any():
                raise EvidenceError(f"{name}: contains NaN")
            if name in ("positions", "depths", "pose_support") and not torch.isfinite(value).all():
                raise EvidenceError(f"{name}: must be finite")
        missing = {"behind", "front", "left", "right", "above", "below"} - set(self.directions)
        if missing:
            raise EvidenceError(f"directions: missing {sorted(missing)}")
        self._validate_overlays(n)

    def _validate_overlays(self, n: int) -> None:
        if self.boxes is not None and (not isinstance(self.boxes, torch.Tensor) or tuple(self.boxes.shape) != (n, 4)):
            raise EvidenceError(f"boxes: expected a tensor of shape [{n}, 4] (x, y, w, h) or None")
        if self.masks is not None:
            if not isinstance(self.masks, torch.Tensor) or self.masks.dim() != 3 or self.masks.shape[0] != n \
                    or self.masks.dtype != torch.bool:
                raise EvidenceError(f"masks: expected a bool tensor of shape [{n}, H, W] or None")
            if self.camera is not None and tuple(self.masks.shape[1:]) != (self.camera.height, self.camera.width):
                raise EvidenceError(f"masks: {list(self.masks.shape[1:])} pixels, but the camera's image is "
                                    f"[{self.camera.height}, {self.camera.width}]")
        if self.camera is not None and not isinstance(self.camera, Camera):
            raise EvidenceError(f"camera: expected a po3d_ppl.world.Camera or None, got {type(self.camera).__name__}")

    def to(self, device: torch.device | str) -> SceneEvidence:
        moved = {f.name: getattr(self, f.name) for f in fields(self)}
        for name, value in moved.items():
            if isinstance(value, torch.Tensor):
                moved[name] = value.to(device)
        moved["directions"] = {k: v.to(device) for k, v in self.directions.items()}
        return SceneEvidence(**moved)


def duplicate_pairs(evidence: SceneEvidence, min_iou: float = 0.5) -> list[tuple[int, int]]:
    """Proposal pairs whose boxes overlap by at least ``min_iou``: candidates for one object counted twice.

    The contract promises there are none among proposals that are likely to exist; evaluation measures it with
    this (it needs ``boxes``).
    """
    if evidence.boxes is None:
        raise EvidenceError("boxes: duplicate_pairs needs the proposals' boxes; this evidence carries none")
    x, y, w, h = evidence.boxes.to(DTYPE).unbind(-1)
    x1, y1 = torch.maximum(x[:, None], x[None]), torch.maximum(y[:, None], y[None])
    x2, y2 = torch.minimum((x + w)[:, None], (x + w)[None]), torch.minimum((y + h)[:, None], (y + h)[None])
    inter = (x2 - x1).clamp(min=0) * (y2 - y1).clamp(min=0)
    union = (w * h)[:, None] + (w * h)[None] - inter
    iou = torch.where(union > 0, inter / union.clamp(min=1e-12), torch.zeros_like(inter))
    n = evidence.num_objects
    return [(i, j) for i in range(n) for j in range(i + 1, n) if float(iou[i, j]) >= min_iou]

"""The scene model's latent layout, declared once: every site's name, plates, support and program-facing reading.

The scene model (:mod:`po3d_ppl.reasoning.scene_model`) samples exactly these sites; the posterior tables, the
compiled model, every inference method and the baselines derive their layouts from this table, so adding a
latent means one row here, its ``pyro.sample`` in the model, and the operations that read it.

Plates, outermost first: ``occluders`` (j), ``models`` (subtype hypothesis s), ``objects`` (i), ``parts`` (p).
Each plate signature is one *kind* of site with a fixed table layout (:data:`TABLE_AXES`). Sites on the ``models``
plate are switches: object i's value is the one of hypothesis ``subtype[i]`` (its parts, and its pose, whose
likelihood perception computes per category mesh).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from po3d_ppl import ontology
from po3d_ppl.evidence import NUM_PART_STATES

#: Pyro plate dims of the scene model, and the first dimension free for enumeration (left of every plate).
PLATE_DIMS = {"parts": -1, "objects": -2, "models": -3, "occluders": -4}
FIRST_ENUM_DIM = -5

#: Site kinds by plate signature, and the axis order of their posterior tables (values always last).
KINDS = {
    ("objects",): "object",
    ("models", "objects"): "object_by_model",
    ("occluders", "objects"): "pair",
    ("models", "objects", "parts"): "part",
    ("occluders", "models", "objects", "parts"): "part_pair",
}
TABLE_AXES = {"object": "[N, K]", "object_by_model": "[N, 21, K]", "pair": "[N_i, N_j, K]",
              "part": "[N, 21, P, K]", "part_pair": "[N_i, 21, P, N_j, K]"}
#: Where the subtype-hypothesis axis sits in an element layout (tables without the values axis), for the kinds
#: indexed by subtype hypothesis: an object's value is the one at its own subtype (a switch).
MODELS_AXIS = {"object_by_model": -1, "part": -2, "part_pair": -3}


@dataclass(frozen=True)
class LatentSite:
    """A latent site of the scene model."""

    name: str
    plates: tuple[str, ...]
    #: Number of values; None when the evidence gives each proposal its own support (``support_field``).
    size: int | None
    #: Evidence field holding per-proposal values of the support (pose azimuths), if any.
    support_field: str | None = None
    #: The name programs read it by, when that is not the site's (the pose site is read as ``pose_degree``).
    reads_as: str | None = None
    #: A yes/no latent (a Bernoulli site), read as bool; the others are ids (or azimuths).
    boolean: bool = False

    @property
    def kind(self) -> str:
        return KINDS[self.plates]

    @property
    def value_name(self) -> str:
        return self.reads_as or self.name


#: The latent sites, in model order.
SITES: tuple[LatentSite, ...] = (
    LatentSite("exists", ("objects",), 2, boolean=True),
    LatentSite("subtype", ("objects",), len(ontology.SUBTYPES)),
    LatentSite("color", ("objects",), len(ontology.COLORS)),
    LatentSite("material", ("objects",), len(ontology.MATERIALS)),
    LatentSite("size", ("objects",), len(ontology.SIZES)),
    LatentSite("pose", ("models", "objects"), None, support_field="pose_support", reads_as="pose_degree"),
    LatentSite("occluded", ("objects",), 2, boolean=True),
    LatentSite("occludes", ("occluders", "objects"), 2, boolean=True),
    LatentSite("part_state", ("models", "objects", "parts"), NUM_PART_STATES),
    LatentSite("part_occluded", ("models", "objects", "parts"), 2, boolean=True),
    LatentSite("part_occludes", ("occluders", "models", "objects", "parts"), 2, boolean=True),
)
SITE = {site.name: site for site in SITES}
#: Sites by the name programs read them by (``pose_degree`` -> the pose site).
BY_VALUE_NAME = {site.value_name: site for site in SITES}


#: The object-level sites (one value per proposal, at its own subtype hypothesis for a switch), in model order.
OBJECT_SITES = tuple(site.name for site in SITES if site.kind in ("object", "object_by_model"))


def element_layout(value: torch.Tensor, plates: tuple[str, ...]) -> torch.Tensor:
    """A site's value in the scene model's plate layout (``[*B, occluders, models, objects, parts]``, singletons
    where a plate is absent, at least one batch dimension assumed) in its kind's :data:`TABLE_AXES` without the
    values axis, batch first: ``[*B, N]``, ``[*B, N, 21]``, ``[*B, N_i, N_j]``, ``[*B, N, 21, P]`` or
    ``[*B, N_i, 21, P, N_j]``."""
    if value.dim() < 5:
        value = value.reshape([1] * (5 - value.dim()) + list(value.shape))
    kind = KINDS[plates]
    if kind == "object":
        return value[..., 0, 0, :, 0]
    if kind == "object_by_model":
        return value[..., 0, :, :, 0].transpose(-1, -2)
    if kind == "pair":
        return value[..., :, 0, :, 0].transpose(-1, -2)
    if kind == "part":
        return value[..., 0, :, :, :].transpose(-3, -2)
    return value.movedim(-4, -1).transpose(-4, -3)

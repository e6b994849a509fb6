"""Posterior tables of the scene model's latent sites, read from the model itself with Pyro's handlers.

The scene model is traced once under ``poutine.enum`` (every site enumerated in a dimension of its own). Each
site's prior log-probability and its evidence factor then live on that site's enumeration dimension, and because
no factor touches two sites, the posterior of each site is its local softmax. We check that structure rather than
assume it: a researcher who adds a factor coupling two latents gets :class:`CoupledModelError` and must use the
sampling or generic methods, which make no such assumption.
"""

from __future__ import annotations

from dataclasses import dataclass

import pyro.poutine as poutine
import torch
from pyro.infer import config_enumerate

from po3d_ppl.errors import Po3dError
from po3d_ppl.reasoning.evidence import DTYPE, ScenePriors, SceneEvidence
from po3d_ppl.reasoning.scene_model import FIRST_ENUM_DIM, SITES, scene_model

#: Axis orders of the tables returned, per site plate signature (values always last).
_LAYOUT = {
    ("objects",): "[N, K]",
    ("occluders", "objects"): "[N_i, N_j, K]",
    ("models", "objects", "parts"): "[N, 21, P, K]",
    ("occluders", "models", "objects", "parts"): "[N_i, 21, P, N_j, K]",
}


class CoupledModelError(Po3dError):
    """The scene model has a factor over two or more latent sites; exact per-site posteriors do not exist."""


@dataclass(frozen=True)
class SitePosteriors:
    """Posterior probabilities per site (see ``_LAYOUT`` for axis orders) and the support of each site."""

    probs: dict[str, torch.Tensor]
    #: Values of each site's support: ``[K]`` ids, or ``[N, K]`` for per-proposal supports (pose azimuths).
    support: dict[str, torch.Tensor]

    def __getitem__(self, name: str) -> torch.Tensor:
        return self.probs[name]


def _enum_dim(shape: torch.Size) -> list[int]:
    """Negative positions of enumeration dims (left of the plates) with size > 1."""
    return [d - len(shape) for d in range(len(shape)) if d - len(shape) < FIRST_ENUM_DIM + 1 and shape[d] > 1]


def site_posteriors(evidence: SceneEvidence, priors: ScenePriors = ScenePriors()) -> SitePosteriors:
    """Per-site posterior tables of ``scene_model(evidence, priors)``."""
    model = poutine.enum(config_enumerate(scene_model, default="parallel"), first_available_dim=FIRST_ENUM_DIM)
    trace = poutine.trace(model).get_trace(evidence, priors)
    trace.compute_log_prob()
    site_dim: dict[int, str] = {}
    for spec in SITES:
        dims = _enum_dim(trace.nodes[spec.name]["value"].shape)
        if len(dims) == 1:
            site_dim[dims[0]] = spec.name
    logp: dict[str, torch.Tensor] = {}
    for name, node in trace.nodes.items():
        if node["type"] != "sample":
            continue
        lp = node["log_prob"]
        dims = _enum_dim(lp.shape)
        if len(dims) > 1:
            raise CoupledModelError(
                f"scene-model site {name!r} couples latents {[site_dim.get(d, d) for d in dims]}; exact per-site "
                "posteriors do not apply - use method='sampling' or 'generic'"
            )
        owner = site_dim.get(dims[0]) if dims else None
        if owner is None:
            continue  # constant factors do not change any posterior
        logp[owner] = lp if owner not in logp else logp[owner] + lp
    probs, support = {}, {}
    n = evidence.num_objects
    for spec in SITES:
        lp = logp[spec.name]
        (dim,) = _enum_dim(lp.shape)
        table = torch.softmax(lp.to(DTYPE), dim=dim)
        table = table.movedim(dim, -1)  # values last; remaining: enum singletons + plates (-4..-1 -> -5..-2)
        table = table.reshape(table.shape[-5:])  # [occluders, models, objects, parts, K]
        probs[spec.name] = _arrange(table, spec.plates, n)
        k = probs[spec.name].shape[-1]
        support[spec.name] = evidence.pose_support if spec.name == "pose" else torch.arange(k)
    return SitePosteriors(probs, support)


def _arrange(table: torch.Tensor, plates: tuple[str, ...], n: int) -> torch.Tensor:
    """[occluders, models, objects, parts, K] (singletons where a plate is absent) -> the site's ``_LAYOUT``."""
    j, s, i, p, k = range(5)
    shape = table.shape
    full = table.expand(max(shape[j], 1), shape[s], max(shape[i], 1), shape[p], shape[k])
    if plates == ("objects",):
        return full[0, 0, :, 0, :]
    if plates == ("occluders", "objects"):
        return full[:, 0, :, 0, :].transpose(0, 1).contiguous()
    if plates == ("models", "objects", "parts"):
        return full[0].permute(1, 0, 2, 3).contiguous()
    if plates == ("occluders", "models", "objects", "parts"):
        return full.permute(2, 1, 3, 0, 4).contiguous()
    raise AssertionError(f"unexpected plates {plates}")

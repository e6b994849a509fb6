"""Posterior tables of the scene model's latent sites, read from the model itself with Pyro's handlers.

The scene model is traced once under ``poutine.enum`` (every site enumerated in a dimension of its own). Each
site's prior log-probability and its evidence factor then live on that site's enumeration dimension, and because
no factor touches two sites, the posterior of each site is its local softmax. We check that structure rather than
assume it: a researcher who adds a factor coupling two latents gets :class:`CoupledModelError` and must use the
sampling or generic methods, which make no such assumption.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import pyro.poutine as poutine
import torch
from pyro.infer import config_enumerate
from pyro.poutine.util import site_is_subsample

from po3d_ppl.errors import Po3dError
from po3d_ppl.evidence import DTYPE, SceneEvidence, ScenePriors
from po3d_ppl.reasoning.latents import FIRST_ENUM_DIM, SITES, element_layout
from po3d_ppl.reasoning.scene_model import check_not_empty, scene_model


class LayoutError(Po3dError):
    """The scene model's sampled sites differ from the declaration in ``latents.SITES``."""


class CoupledModelError(Po3dError):
    """The scene model has a factor over two or more latent sites; exact per-site posteriors do not exist."""


@dataclass(frozen=True)
class SitePosteriors:
    """Posterior probabilities per site (axis orders: ``latents.TABLE_AXES`` of the site's kind) and the support
    of each site."""

    probs: dict[str, torch.Tensor]
    #: Values of each site's support: ``[K]`` ids, or ``[N, K]`` for per-proposal supports (pose azimuths).
    support: dict[str, torch.Tensor]
    #: For ``object_by_model`` sites whose posterior is the same under every subtype hypothesis (the evidence does
    #: not tell the categories apart there, as with the simulated sensor's poses): the table without that axis,
    #: ``[N, K]``. The site is then independent of the subtype, and engines may treat it as an object site.
    shared: dict[str, torch.Tensor] = field(default_factory=dict)

    def __getitem__(self, name: str) -> torch.Tensor:
        return self.probs[name]


def _enum_dim(shape: torch.Size) -> list[int]:
    """Negative positions of enumeration dims (left of the plates) with size > 1."""
    return [d - len(shape) for d in range(len(shape)) if d - len(shape) < FIRST_ENUM_DIM + 1 and shape[d] > 1]


def site_posteriors(evidence: SceneEvidence, priors: ScenePriors = ScenePriors()) -> SitePosteriors:
    """Per-site posterior tables of ``scene_model(evidence, priors)``."""
    check_not_empty(evidence)  # before tracing: pyro appends its trace-shape dump to errors raised in a model
    model = poutine.enum(config_enumerate(scene_model, default="parallel"), first_available_dim=FIRST_ENUM_DIM)
    trace = poutine.trace(model).get_trace(evidence, priors)
    trace.compute_log_prob()
    sampled = [name for name, node in trace.nodes.items()
               if node["type"] == "sample" and not node["is_observed"] and not site_is_subsample(node)]
    if sampled != [spec.name for spec in SITES]:
        raise LayoutError(f"the scene model samples {sampled}, but latents.SITES declares "
                             f"{[spec.name for spec in SITES]}: declare every latent once, in model order")
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
    for spec in SITES:
        lp = logp[spec.name]
        (dim,) = _enum_dim(lp.shape)
        table = torch.softmax(lp.to(DTYPE), dim=dim)
        table = table.movedim(dim, -1)  # values last; remaining: enum singletons + plates (-4..-1 -> -5..-2)
        table = table.reshape(table.shape[-5:])  # [occluders, models, objects, parts, K]
        # the values axis leads as a batch axis while the plates are rearranged; tables whose plates were permuted
        # are copied contiguous for the gathers that read them
        table = element_layout(table.movedim(-1, 0), spec.plates).movedim(0, -1)
        probs[spec.name] = table.contiguous() if len(spec.plates) > 1 else table
        k = probs[spec.name].shape[-1]
        support[spec.name] = getattr(evidence, spec.support_field) if spec.support_field else torch.arange(k)
    shared = {}
    for spec in SITES:
        if spec.kind == "object_by_model":
            table = probs[spec.name]
            if torch.equal(table, table[:, :1].expand_as(table)):
                shared[spec.name] = table[:, 0]
    return SitePosteriors(probs, support, shared)

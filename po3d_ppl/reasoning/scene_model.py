"""The latent scene as one Pyro program.

Read it top to bottom: every object proposal has latent existence, subtype, colour, material, size, azimuth (per
subtype hypothesis, scored by its category's mesh) and occlusion state; every part slot of every subtype hypothesis has a latent state (hidden, plain or recoloured with a
colour and material) and occlusion state; every (entity, object) pair has a latent "is occluded by". Each latent is
drawn from its prior and conditioned on the evidence with ``pyro.factor``.

Part latents are indexed by subtype *hypothesis* (a ``models`` plate): the parts of object i are the slots of
hypothesis ``subtype[i]``. This "switch" keeps every latent independent a posteriori (each factor touches one
site), which the exact engine checks and relies on; the subtype's posterior comes from the subtype evidence, which
perception computes from the same projected meshes.

Every inference method derives from this function through one Pyro handler: it is traced once under
``poutine.enum`` (:mod:`po3d_ppl.reasoning.posterior`) and each site's posterior table read off the trace. The exact
engine contracts those tables with the program's constraints, sampling draws from them site by site (exact
ancestral sampling, since the sites are independent a posteriori), and the generic reference path rebuilds the
same factor graph as a Pyro model for ``TraceEnum_ELBO``.

The sites, their plates and supports are declared in :mod:`po3d_ppl.reasoning.latents` (the posterior tables
check that the trace samples exactly those); plate dims: parts -1, objects -2, subtype hypotheses -3, occluders -4.
"""

from __future__ import annotations

import pyro
import pyro.distributions as dist
import torch
from pyro.ops.indexing import Vindex

from po3d_ppl import ontology
from po3d_ppl.errors import Po3dError
from po3d_ppl.evidence import DTYPE, SceneEvidence, ScenePriors
from po3d_ppl.reasoning import values
from po3d_ppl.reasoning.part_counts import part_state_loglik
from po3d_ppl.reasoning.latents import PLATE_DIMS


def _bernoulli(name: str, prior: float, logodds: torch.Tensor) -> torch.Tensor:
    value = pyro.sample(name, dist.Bernoulli(torch.tensor(prior, dtype=DTYPE)))
    pyro.factor(f"{name}_evidence", value * logodds)
    return value


def _categorical(name: str, probs: torch.Tensor, loglik: torch.Tensor) -> torch.Tensor:
    """``loglik`` has the site's batch shape plus a trailing axis of values."""
    value = pyro.sample(name, dist.Categorical(probs))
    pyro.factor(f"{name}_evidence", Vindex(loglik)[..., value])
    return value


class EmptyEvidenceError(Po3dError, ValueError):
    """The scene model of evidence with no object proposals: a Pyro plate cannot have size 0. Answering programs
    over such evidence works (``SceneReasoner`` answers them without the model, ``inference/empty.py``); only the
    model and its posterior tables refuse."""


def check_not_empty(evidence: SceneEvidence) -> None:
    if evidence.num_objects == 0:
        raise EmptyEvidenceError("the evidence has no object proposals, so the scene model has no plates to sample "
                                 "(answer programs with SceneReasoner, which handles an empty scene)")


def scene_model(evidence: SceneEvidence, priors: ScenePriors = ScenePriors()) -> dict[str, torch.Tensor]:
    """Sample a latent scene conditioned on ``evidence``. Returns the latent values by site name."""
    check_not_empty(evidence)
    n = evidence.num_objects
    uniform = lambda size: torch.full((size,), 1.0 / size, dtype=DTYPE)  # noqa: E731
    latents: dict[str, torch.Tensor] = {}
    occluders = pyro.plate("occluders", n, dim=PLATE_DIMS["occluders"])
    models = pyro.plate("models", len(ontology.SUBTYPES), dim=PLATE_DIMS["models"])
    objects = pyro.plate("objects", n, dim=PLATE_DIMS["objects"])
    parts = pyro.plate("parts", ontology.MAX_PARTS, dim=PLATE_DIMS["parts"])

    with objects:
        col = lambda t: t.unsqueeze(-1)  # noqa: E731  [N] -> [N, 1] (objects plate, parts broadcast)
        latents["exists"] = _bernoulli("exists", priors.exists, col(evidence.exist_logodds))
        for name, loglik in (("subtype", evidence.subtype_loglik), ("color", evidence.color_loglik),
                             ("material", evidence.material_loglik), ("size", evidence.size_loglik)):
            latents[name] = _categorical(name, uniform(loglik.shape[-1]), loglik.unsqueeze(-2))
        with models:
            # the pose of hypothesis s is scored by the mesh of s's category: [N, 5, K] -> [21, N, 1, K]
            by_subtype = evidence.pose_loglik[:, values.subtype_category()].transpose(0, 1).unsqueeze(-2)
            latents["pose"] = _categorical("pose", uniform(by_subtype.shape[-1]), by_subtype)
        latents["occluded"] = _bernoulli("occluded", priors.occluded, col(evidence.occluded_logodds))
        with occluders:
            # occludes[j, 0, i, 0]: object i is occluded by object j.
            pair = evidence.occludes_logodds.T.reshape(n, 1, n, 1)
            latents["occludes"] = _bernoulli("occludes", priors.occludes, pair)

    with models, objects, parts:
        by_model = lambda t: t.transpose(0, 1)  # noqa: E731  [N, 21, P, ...] -> [21, N, P, ...]
        # hidden, plain or one of 16 looks; with the world's recolouring rule when the priors hold it
        state_loglik = part_state_loglik(evidence, priors)
        latents["part_state"] = _categorical("part_state", priors.part_state_probs(), by_model(state_loglik))
        latents["part_occluded"] = _bernoulli("part_occluded", priors.part_occluded,
                                              by_model(evidence.part_occluded_logodds))
        with occluders:
            pocc = evidence.part_occludes_logodds.permute(3, 1, 0, 2)  # [j, s, i, p]
            latents["part_occludes"] = _bernoulli("part_occludes", priors.part_occludes, pocc)
    return latents

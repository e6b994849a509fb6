"""Dense exact answers for small scenes: every joint assignment of the latents a program reads, as one batch.

The program runs once on the most probable scene to learn which latent sites it reads; then every element of
those sites (one per object, object pair or part slot) is enumerated jointly over its non-zero posterior support,
the whole product becomes the batch of a ``ConcreteWorld``, and each assignment is weighted by its posterior
probability. Exponential in the number of uncertain elements, so it serves small scenes and cross-checks of the
polynomial exact engine, which must agree with it to rounding error.
"""

from __future__ import annotations

import math

import torch

from po3d_ppl import ontology
from po3d_ppl.evidence import DTYPE, SceneEvidence
from po3d_ppl.reasoning.execution import run_program
from po3d_ppl.reasoning.inference.concrete_world import (
    ConcreteWorld,
    evidence_supports,
    most_probable_world,
    object_centric,
)
from po3d_ppl.reasoning.inference.enum_world import ExactUnsupported
from po3d_ppl.reasoning.latents import SITE
from po3d_ppl.reasoning.posterior import SitePosteriors
from po3d_ppl.reasoning.values import INVALID

#: Largest number of joint assignments the dense path enumerates.
MAX_ASSIGNMENTS = 1 << 18

class DenseTooLarge(ExactUnsupported):
    """The joint support of the latents the program reads is too large to enumerate."""


class _Tables:
    """Per-site posterior tables arranged by element, with the program-facing (object-centric) views."""

    def __init__(self, post: SitePosteriors, evidence: SceneEvidence):
        self.post, self.evidence = post, evidence
        self.n = evidence.num_objects
        self.argmax = {name: post.probs[name].argmax(-1) for name in post.probs}

    def elements(self, site: str, subtypes: list[list[int]]):
        """(element index tuple into the site's table, its probability vector) for every element of ``site``."""
        probs = self.post.probs[site]
        n = self.n
        kind = SITE[site].kind
        if site in self.post.shared:  # one value per object whatever its subtype: its row is set for every s
            return [((i,), self.post.shared[site][i]) for i in range(n)]
        if kind == "object":
            return [((i,), probs[i]) for i in range(n)]
        if kind == "object_by_model":
            return [((i, s), probs[i, s]) for i in range(n) for s in subtypes[i]]
        if kind == "pair":
            return [((i, j), probs[i, j]) for i in range(n) for j in range(n) if i != j]
        out = []
        for i in range(n):
            for s in subtypes[i]:
                for p in range(len(ontology.PARTS[ontology.SUBTYPES[s]])):
                    if kind == "part_pair":
                        out += [((i, s, p, j), probs[i, s, p, j]) for j in range(n) if j != i]
                    else:
                        out.append(((i, s, p), probs[i, s, p]))
        return out


def dense_distribution(typed, post: SitePosteriors, evidence: SceneEvidence, num_values: int,
                       max_assignments: int = MAX_ASSIGNMENTS, semantics: str = "intended"
                       ) -> tuple[torch.Tensor, float, int]:
    """Answer probabilities per id, invalid mass, and the number of joint assignments enumerated."""
    tables = _Tables(post, evidence)
    n = evidence.num_objects

    # 1. which sites does the program read? (run it on the most probable scene)
    read: set[str] = set()
    run_program(typed, most_probable_world(post, evidence, on_read=read.add), semantics)

    # 2. enumerate the joint support of their elements
    subtypes = [[int(s) for s in torch.nonzero(post.probs["subtype"][i] > 0).flatten()] for i in range(n)]
    free = []  # (site, element index, support indices, probabilities)
    for site in sorted(read):
        for index, probs in tables.elements(site, subtypes):
            support = torch.nonzero(probs > 0).flatten()
            if len(support) > 1:
                free.append((site, index, support, probs[support]))
    log_count = sum(math.log10(len(f[2])) for f in free)
    if log_count > math.log10(max_assignments):
        raise DenseTooLarge(f"the program's latents have about 10^{log_count:.1f} joint assignments (dense limit "
                            f"{max_assignments}); use method='exact' or 'sampling'")
    count = math.prod(len(f[2]) for f in free)
    grids = torch.cartesian_prod(*[torch.arange(len(f[2])) for f in free]) if free else torch.zeros(1, 0)
    grids = grids.reshape(count, len(free)).long()
    weights = torch.ones(count, dtype=DTYPE)
    batch = {site: tables.argmax[site].unsqueeze(0).repeat(count, *([1] * tables.argmax[site].dim()))
             for site in read}  # the sites the program does not read never reach it
    for column, (site, index, support, probs) in enumerate(free):
        choice = grids[:, column]
        batch[site][(slice(None), *index)] = support[choice]
        weights = weights * probs[choice]

    # 3. run the program on every assignment at once
    supports = evidence_supports(evidence)
    world = ConcreteWorld(lambda name: object_centric(name, batch.__getitem__, supports), (count,), n,
                          evidence.positions, evidence.depths, evidence.directions)
    value = run_program(typed, world, semantics).expand(count, 1, 1).reshape(count)
    valid = world.valid & (value != INVALID)
    probs = torch.zeros(num_values, dtype=DTYPE).scatter_add_(0, value[valid], weights[valid])
    return probs, float(max(0.0, 1.0 - probs.sum())), count

"""Monte Carlo answer marginals: vectorised posterior samples, the program run on batched tensors.

Samples are drawn site by site from the posterior tables of the scene model (``posterior.site_posteriors``, read
from the model's enumerated trace), which is exact ancestral sampling because the model's latents are independent
a posteriori. Sites on the subtype-hypothesis plate (parts, pose) are drawn only for each sample's subtype: the
switch model's other hypotheses never reach a program, so drawing them would not change any answer. Sites are drawn lazily, when the program first reads them.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from po3d_ppl.evidence import SceneEvidence
from po3d_ppl.reasoning.execution import run_program
from po3d_ppl.reasoning.inference.concrete_world import ConcreteWorld, pose_degrees
from po3d_ppl.reasoning.latents import BY_VALUE_NAME
from po3d_ppl.reasoning.posterior import SitePosteriors
from po3d_ppl.reasoning.values import INVALID


def _inverse_cdf(probs: torch.Tensor, uniform: torch.Tensor) -> torch.Tensor:
    """Index k with cdf[k-1] <= u < cdf[k] (vectorised categorical draws; ``probs`` broadcast against ``u``)."""
    cdf = probs.cumsum(-1)
    index = (uniform.unsqueeze(-1) >= cdf).sum(-1)
    return index.clamp(max=probs.shape[-1] - 1)  # guard against rounding at the top of the cdf


def _uniform(shape: tuple[int, ...], generator: torch.Generator, like: torch.Tensor) -> torch.Tensor:
    """Uniforms drawn on the CPU (the seeded generator's device) and moved to ``like``'s device, so a seed gives the
    same samples on every device."""
    return torch.rand(shape, generator=generator, dtype=like.dtype, device="cpu").to(like.device)


def _draw(probs: torch.Tensor, num_samples: int, generator: torch.Generator) -> torch.Tensor:
    """Indices ``[S, *batch]`` drawn from ``probs [*batch, K]`` (one draw per batch element and sample)."""
    uniform = _uniform((num_samples, *probs.shape[:-1]), generator, probs)
    return _inverse_cdf(probs, uniform)


class PosteriorSampleSource:
    """Lazily draws object-centric latent values (``ConcreteWorld``'s source protocol)."""

    def __init__(self, posteriors: SitePosteriors, num_samples: int, generator: torch.Generator):
        self.post, self.s, self.gen = posteriors, num_samples, generator
        self.cache: dict[str, torch.Tensor] = {}

    def __call__(self, name: str) -> torch.Tensor:
        if name not in self.cache:
            self.cache[name] = self._sample(name)
        return self.cache[name]

    def _sample(self, name: str) -> torch.Tensor:
        post, spec = self.post, BY_VALUE_NAME[name]
        if spec.name in post.shared:  # the same posterior under every subtype: drawn as an object site
            index = _draw(post.shared[spec.name], self.s, self.gen)
        elif spec.kind in ("object", "pair"):
            index = _draw(post.probs[spec.name], self.s, self.gen)
        else:
            index = self._at_own_subtype(post.probs[spec.name])
        return index if spec.support_field is None else pose_degrees(post.support[spec.name], index)

    def _at_own_subtype(self, table: torch.Tensor) -> torch.Tensor:
        """Draws ``[S, N, ...]`` from ``table [N, 21, ..., K]`` at each sample's subtype: one uniform per element,
        compared with the cdf's k-th column gathered by subtype one column at a time (never materialising
        ``[S, N, ..., K]``)."""
        subtype = self("subtype")  # [S, N]
        cdf = table.cumsum(-1)
        objects = torch.arange(table.shape[0])
        uniform = _uniform((self.s, *table.shape[:1], *table.shape[2:-1]), self.gen, table)
        index = torch.zeros(uniform.shape, dtype=torch.long)
        for k in range(table.shape[-1] - 1):
            index += uniform >= cdf[..., k][objects, subtype]
        return index


@dataclass(frozen=True)
class SampledResult:
    probs: torch.Tensor  # per answer id
    invalid: float
    stderr: torch.Tensor  # per answer id
    num_samples: int


def sample_distribution(typed, posteriors: SitePosteriors, evidence: SceneEvidence, num_values: int,
                        num_samples: int = 4096, seed: int = 0, semantics: str = "intended") -> SampledResult:
    generator = torch.Generator(device="cpu").manual_seed(seed)
    source = PosteriorSampleSource(posteriors, num_samples, generator)
    world = ConcreteWorld(source, (num_samples,), evidence.num_objects, evidence.positions, evidence.depths,
                          evidence.directions)
    value = run_program(typed, world, semantics).reshape(-1).expand(num_samples)
    valid = world.valid & (value != INVALID)
    counts = torch.bincount(value[valid], minlength=num_values).to(torch.float64)
    probs = counts / num_samples
    stderr = (probs * (1 - probs) / num_samples).sqrt()
    return SampledResult(probs, float(1.0 - probs.sum()), stderr, num_samples)

"""Inference methods over a compiled program and scene evidence.

``SceneReasoner`` holds one scene's evidence and its posterior tables (computed once from the scene model's
enumerated trace) and answers any number of programs:

- ``exact``: lifted enumeration with pivots and running-state chains (``exact.py``), polynomial in the number of
  objects;
- ``sampling``: vectorised posterior samples (``sampling.py``) with standard errors;
- ``auto``: ``exact`` unless its tensors would exceed ``AUTO_EXACT_ELEMENTS`` (beyond which sampling is faster) or
  the program needs a structure it does not support, then ``sampling`` (the reason is recorded in ``info``);
- ``thresholded`` and ``soft``: the NS-VQA and P-NSVQA baselines (``baselines.py``).

The reference implementations ``dense`` and ``generic`` (``reference/``) are reached through
:meth:`SceneReasoner.reference`, for tests and benchmarks.
"""

from __future__ import annotations

from functools import cached_property

import torch

from po3d_ppl.errors import UnknownNameError
from po3d_ppl.evidence import SceneEvidence, ScenePriors
from po3d_ppl.reasoning import values
from po3d_ppl.reasoning.answer import AnswerDistribution
from po3d_ppl.reasoning.compiler import CompiledProgram, compile_program
from po3d_ppl.reasoning.inference.reference import REFERENCE_METHODS
from po3d_ppl.reasoning.posterior import SitePosteriors, site_posteriors

METHODS = ("auto", "exact", "sampling", "thresholded", "soft")
#: ``auto`` answers exactly while the exact engine's largest tensor stays under this many elements (measured: past
#: a few million elements exact takes longer than 4,096 samples on one core).
AUTO_EXACT_ELEMENTS = 2e6


class SceneReasoner:
    """Answers programs about one scene; computes the scene model's posterior tables (and the baselines' views of
    them) once."""

    def __init__(self, evidence: SceneEvidence, priors: ScenePriors = ScenePriors()):
        self.evidence, self.priors = evidence, priors

    @cached_property
    def posteriors(self) -> SitePosteriors:
        with self._device():
            return site_posteriors(self.evidence, self.priors)

    @cached_property
    def _soft_rules(self):
        from po3d_ppl.reasoning.inference.baselines import soft_rules

        with self._device():
            return soft_rules(self.posteriors, self.evidence)

    def _device(self) -> torch.device:
        """Inference runs on the evidence's device: every tensor the engines create lands there (``torch.device``
        as a context manager sets the default device of factory functions)."""
        return torch.device(self.evidence.exist_logodds.device)

    def infer(self, program, method: str = "auto", *, num_samples: int = 4096, seed: int = 0) -> AnswerDistribution:
        if method not in METHODS:
            raise UnknownNameError("inference method", method, METHODS)
        compiled = program if isinstance(program, CompiledProgram) else compile_program(program)
        run = getattr(self, f"_{method}")
        with self._device():
            return run(compiled, num_samples=num_samples, seed=seed)

    def reference(self, program, method: str) -> AnswerDistribution:
        """The answer by a reference implementation (``dense`` or ``generic``), to cross-check the exact engine."""
        if method not in REFERENCE_METHODS:
            raise UnknownNameError("reference method", method, REFERENCE_METHODS)
        compiled = program if isinstance(program, CompiledProgram) else compile_program(program)
        with self._device():
            return getattr(self, f"_{method}")(compiled)

    # ---- methods -------------------------------------------------------------------------------------------------
    def _support(self, compiled: CompiledProgram) -> list:
        return values.support(compiled.answer_type, self.evidence.num_objects)

    def _distribution(self, compiled, probs, invalid, method, **extra) -> AnswerDistribution:
        support = self._support(compiled)
        stderr = extra.pop("stderr", None)
        ranked = sorted((k for k, p in enumerate(probs.tolist()) if p > 0), key=lambda k: -float(probs[k]))
        answers = {support[k]: float(probs[k]) for k in ranked}
        errs = {support[k]: float(stderr[k]) for k in ranked} if stderr is not None else {}
        error = extra.pop("error", 0.0)
        return AnswerDistribution(answers, float(invalid), method, compiled.answer_type, error=error, stderr=errs,
                                  info=extra)

    def _exact(self, compiled, max_elements: float | None = None, **_):
        from po3d_ppl.reasoning.inference.exact import exact_distribution

        result = exact_distribution(compiled.typed, self.posteriors, self.evidence, len(self._support(compiled)),
                                    max_elements=max_elements)
        return self._distribution(compiled, result.probs, result.invalid, "exact", peak_elements=result.peak_elements)

    def _dense(self, compiled, **_):
        from po3d_ppl.reasoning.inference.reference.dense import dense_distribution

        probs, invalid, count = dense_distribution(compiled.typed, self.posteriors, self.evidence,
                                                   len(self._support(compiled)))
        return self._distribution(compiled, probs, invalid, "dense", assignments=count)

    def _sampling(self, compiled, num_samples: int = 4096, seed: int = 0, **_):
        from po3d_ppl.reasoning.inference.sampling import sample_distribution

        result = sample_distribution(compiled.typed, self.posteriors, self.evidence, len(self._support(compiled)),
                                     num_samples=num_samples, seed=seed)
        # three standard errors per outcome; at least the "rule of three" bound 3/S when samples all agree
        error = float(3 * result.stderr.sum()) + 3 * (result.invalid * (1 - result.invalid) / num_samples) ** 0.5
        error = min(max(error, 3.0 / num_samples), 1.0)
        return self._distribution(compiled, result.probs, result.invalid, "sampling", stderr=result.stderr,
                                  error=error, samples=num_samples)

    def _auto(self, compiled, num_samples: int = 4096, seed: int = 0, **_):
        from po3d_ppl.reasoning.inference import exact as exact_module
        from po3d_ppl.reasoning.inference.enum_world import ExactUnsupported

        try:
            return self._exact(compiled, max_elements=min(AUTO_EXACT_ELEMENTS, exact_module.MAX_ELEMENTS))
        except ExactUnsupported as reason:
            dist = self._sampling(compiled, num_samples=num_samples, seed=seed)
            dist.info["fallback"] = str(reason)
            return dist

    def _generic(self, compiled, **_):
        from po3d_ppl.reasoning.inference.reference.generic import generic_distribution

        probs, invalid = generic_distribution(compiled.typed, self.posteriors, self.evidence,
                                              len(self._support(compiled)))
        return self._distribution(compiled, probs, invalid, "generic")

    def _thresholded(self, compiled, **_):
        from po3d_ppl.reasoning.inference.baselines import thresholded_answer

        answer = thresholded_answer(compiled.typed, self.posteriors, self.evidence)
        probs = torch.zeros(len(self._support(compiled)), dtype=torch.float64)
        if answer != values.INVALID:
            probs[answer] = 1.0
        return self._distribution(compiled, probs, 0.0 if answer != values.INVALID else 1.0, "thresholded")

    def _soft(self, compiled, **_):
        from po3d_ppl.reasoning.inference.baselines import soft_distribution

        probs, invalid = soft_distribution(compiled.typed, self._soft_rules, len(self._support(compiled)))
        return self._distribution(compiled, probs, invalid, "soft")


def infer(program, evidence: SceneEvidence, method: str = "auto", *, priors: ScenePriors = ScenePriors(),
          num_samples: int = 4096, seed: int = 0) -> AnswerDistribution:
    """The answer distribution of ``program`` (text, AST, JSON node list or compiled) given ``evidence``."""
    return SceneReasoner(evidence, priors).infer(program, method, num_samples=num_samples, seed=seed)

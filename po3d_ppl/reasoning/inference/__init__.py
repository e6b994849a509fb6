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

import time
from functools import cached_property

import torch

from po3d_ppl.catalogue.semantics import DEFAULT_SEMANTICS, check_semantics
from po3d_ppl.errors import InputError, UnknownNameError
from po3d_ppl.evidence import SceneEvidence, ScenePriors
from po3d_ppl.reasoning import values
from po3d_ppl.reasoning.answer import AnswerDistribution
from po3d_ppl.reasoning.budget import Budget, BudgetExceeded, enforce
from po3d_ppl.reasoning.compiler import CompiledProgram, compile_program
from po3d_ppl.reasoning.inference.reference import REFERENCE_METHODS
from po3d_ppl.reasoning.posterior import SitePosteriors, site_posteriors

METHODS = ("auto", "exact", "sampling", "thresholded", "soft")
#: ``auto`` answers exactly while the exact engine's largest tensor stays under this many elements (measured: past
#: a few million elements exact takes longer than 4,096 samples on one core).
AUTO_EXACT_ELEMENTS = 2e6
#: Share of the call's time budget ``auto`` gives exact inference before it falls back to sampling.
AUTO_EXACT_TIME_SHARE = 0.5


class SceneReasoner:
    """Answers programs about one scene; computes the scene model's posterior tables (and the baselines' views of
    them) once."""

    def __init__(self, evidence: SceneEvidence, priors: ScenePriors = ScenePriors(),
                 semantics: str = DEFAULT_SEMANTICS):
        self.evidence, self.priors = evidence, priors
        #: "intended" or "public" (docs/semantics.md): every method runs programs under it. Under "public" the
        #: evidence should read the public annotation (``po3d_ppl.questions.public.public_reading``).
        self.semantics = check_semantics(semantics)

    @cached_property
    def posteriors(self) -> SitePosteriors:
        with self._device():
            return site_posteriors(self.evidence, self.priors)

    @cached_property
    def _soft_rules(self):
        from po3d_ppl.reasoning.inference.baselines import soft_rules

        with self._device():
            return soft_rules(self.posteriors, self.evidence, self.semantics)

    def _device(self) -> torch.device:
        """Inference runs on the evidence's device: every tensor the engines create lands there (``torch.device``
        as a context manager sets the default device of factory functions)."""
        return torch.device(self.evidence.exist_logodds.device)

    def infer(self, program, method: str = "auto", *, num_samples: int = 4096, seed: int = 0,
              budget: Budget | None = None) -> AnswerDistribution:
        """The answer distribution of ``program``. ``budget`` (default :class:`Budget`: 2 GiB, 10 s) bounds the
        call's largest tensor and its time; past it, ``auto`` falls back to sampling and the other methods raise
        :class:`BudgetExceeded`."""
        if method not in METHODS:
            raise UnknownNameError("inference method", method, METHODS)
        if not isinstance(num_samples, int) or isinstance(num_samples, bool) or num_samples < 1:
            raise InputError("num_samples", f"must be a positive integer, got {num_samples!r}")
        compiled = program if isinstance(program, CompiledProgram) else compile_program(program)
        if self.evidence.num_objects == 0:
            return self._empty(compiled, method)
        run = getattr(self, f"_{method}")
        with self._device():
            return run(compiled, num_samples=num_samples, seed=seed, budget=budget or Budget())

    def reference(self, program, method: str, *, budget: Budget | None = None) -> AnswerDistribution:
        """The answer by a reference implementation (``dense`` or ``generic``), to cross-check the exact engine."""
        if method not in REFERENCE_METHODS:
            raise UnknownNameError("reference method", method, REFERENCE_METHODS)
        compiled = program if isinstance(program, CompiledProgram) else compile_program(program)
        if self.evidence.num_objects == 0:
            return self._empty(compiled, method)
        with self._device():
            return getattr(self, f"_{method}")(compiled, budget=budget or Budget())

    # ---- methods -------------------------------------------------------------------------------------------------
    def _support(self, compiled: CompiledProgram) -> list:
        return compiled.support(self.evidence.num_objects, self.semantics)

    def _distribution(self, compiled, probs, invalid, method, **extra) -> AnswerDistribution:
        support = self._support(compiled)
        stderr = extra.pop("stderr", None)
        ranked = sorted((k for k, p in enumerate(probs.tolist()) if p > 0), key=lambda k: -float(probs[k]))
        answers = {support[k]: float(probs[k]) for k in ranked}
        errs = {support[k]: float(stderr[k]) for k in ranked} if stderr is not None else {}
        error = extra.pop("error", 0.0)
        return AnswerDistribution(answers, float(invalid), method, compiled.answer_type, error=error, stderr=errs,
                                  info=extra)

    def _empty(self, compiled, method: str) -> AnswerDistribution:
        """No proposals: no latents, one certain answer for every method (``inference/empty.py``)."""
        from po3d_ppl.reasoning.inference.empty import empty_distribution

        with self._device():
            probs, invalid = empty_distribution(compiled.typed, self.evidence, len(self._support(compiled)),
                                                self.semantics)
        return self._distribution(compiled, probs, invalid, method, empty_scene=True)

    def _exact(self, compiled, budget: Budget, max_elements: float | None = None, **_):
        from po3d_ppl.reasoning.inference import exact as exact_module
        from po3d_ppl.reasoning.inference.exact import exact_distribution

        if max_elements is None and budget.max_bytes > Budget().max_bytes:
            # the static cap suits the default budget; a caller who grants more memory raises it in proportion
            max_elements = exact_module.MAX_ELEMENTS * budget.max_bytes / Budget().max_bytes
        result = exact_distribution(compiled.typed, self.posteriors, self.evidence, len(self._support(compiled)),
                                    max_elements=max_elements, budget=budget, semantics=self.semantics)
        return self._distribution(compiled, result.probs, result.invalid, "exact", peak_elements=result.peak_elements)

    def _dense(self, compiled, budget: Budget, **_):
        from po3d_ppl.reasoning.inference.reference.dense import dense_distribution

        with enforce(budget, "dense enumeration"):
            probs, invalid, count = dense_distribution(compiled.typed, self.posteriors, self.evidence,
                                                       len(self._support(compiled)), semantics=self.semantics)
        return self._distribution(compiled, probs, invalid, "dense", assignments=count)

    def _sampling(self, compiled, budget: Budget, num_samples: int = 4096, seed: int = 0, **_):
        from po3d_ppl.reasoning.inference.sampling import sample_distribution

        with enforce(budget, "sampling"):
            result = sample_distribution(compiled.typed, self.posteriors, self.evidence, len(self._support(compiled)),
                                         num_samples=num_samples, seed=seed, semantics=self.semantics)
        # three standard errors per outcome; at least the "rule of three" bound 3/S when samples all agree
        error = float(3 * result.stderr.sum()) + 3 * (result.invalid * (1 - result.invalid) / num_samples) ** 0.5
        error = min(max(error, 3.0 / num_samples), 1.0)
        return self._distribution(compiled, result.probs, result.invalid, "sampling", stderr=result.stderr,
                                  error=error, samples=num_samples)

    def _auto(self, compiled, budget: Budget, num_samples: int = 4096, seed: int = 0, **_):
        from po3d_ppl.reasoning.inference import exact as exact_module
        from po3d_ppl.reasoning.inference.enum_world import ExactUnsupported

        start = time.monotonic()
        exact_budget = Budget(budget.max_bytes, None if budget.max_seconds is None
                              else budget.max_seconds * AUTO_EXACT_TIME_SHARE)
        try:
            return self._exact(compiled, exact_budget,
                               max_elements=min(AUTO_EXACT_ELEMENTS, exact_module.MAX_ELEMENTS))
        except (ExactUnsupported, BudgetExceeded) as reason:
            left = None if budget.max_seconds is None else max(budget.max_seconds - (time.monotonic() - start), 1e-3)
            dist = self._sampling(compiled, Budget(budget.max_bytes, left), num_samples=num_samples, seed=seed)
            dist.info["fallback"] = str(reason)
            return dist

    def _generic(self, compiled, budget: Budget, **_):
        from po3d_ppl.reasoning.inference.reference.generic import generic_distribution

        with enforce(budget, "generic inference"):
            probs, invalid = generic_distribution(compiled.typed, self.posteriors, self.evidence,
                                                  len(self._support(compiled)), semantics=self.semantics)
        return self._distribution(compiled, probs, invalid, "generic")

    def _thresholded(self, compiled, **_):
        from po3d_ppl.reasoning.inference.baselines import thresholded_answer

        answer = thresholded_answer(compiled.typed, self.posteriors, self.evidence, self.semantics)
        probs = torch.zeros(len(self._support(compiled)), dtype=torch.float64)
        if answer != values.INVALID:
            probs[answer] = 1.0
        return self._distribution(compiled, probs, 0.0 if answer != values.INVALID else 1.0, "thresholded")

    def _soft(self, compiled, **_):
        from po3d_ppl.reasoning.inference.baselines import soft_distribution

        probs, invalid = soft_distribution(compiled.typed, self._soft_rules, len(self._support(compiled)))
        return self._distribution(compiled, probs, invalid, "soft")


def infer(program, evidence: SceneEvidence, method: str = "auto", *, priors: ScenePriors = ScenePriors(),
          num_samples: int = 4096, seed: int = 0, budget: Budget | None = None,
          semantics: str = DEFAULT_SEMANTICS) -> AnswerDistribution:
    """The answer distribution of ``program`` (text, AST, JSON node list or compiled) given ``evidence``."""
    return SceneReasoner(evidence, priors, semantics).infer(program, method, num_samples=num_samples, seed=seed, budget=budget)

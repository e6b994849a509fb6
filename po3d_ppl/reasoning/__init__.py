"""Reasoning: programs compile to Pyro models over a latent scene; answers are posterior marginals.

Public surface (imported lazily: importing the package loads no torch):

- :func:`register_operation` / :data:`REGISTRY` - add operations (re-exported from ``po3d_ppl.catalogue``);
- :class:`SceneEvidence`, :class:`ScenePriors` - the perception -> reasoning contract (``po3d_ppl.evidence``);
- :func:`scene_model` - the latent scene as a Pyro program (``scene_model``);
- :func:`compile_program` -> :class:`CompiledProgram` - a program as a Pyro model with an ``answer`` site;
- :func:`infer`, :class:`SceneReasoner` -> :class:`AnswerDistribution` - answers by ``exact``, ``sampling``,
  ``auto`` or the ``thresholded``/``soft`` baselines within a :class:`Budget` (``inference``); the ``dense`` and
  ``generic`` references through ``SceneReasoner.reference``.
"""

from po3d_ppl.catalogue import REGISTRY, register_operation, register_reference, register_world

_LAZY = {
    "SceneEvidence": "po3d_ppl.evidence",
    "ScenePriors": "po3d_ppl.evidence",
    "scene_model": "po3d_ppl.reasoning.scene_model",
    "compile_program": "po3d_ppl.reasoning.compiler",
    "CompiledProgram": "po3d_ppl.reasoning.compiler",
    "infer": "po3d_ppl.reasoning.inference",
    "SceneReasoner": "po3d_ppl.reasoning.inference",
    "METHODS": "po3d_ppl.reasoning.inference",
    "AnswerDistribution": "po3d_ppl.reasoning.answer",
    "PresuppositionWarning": "po3d_ppl.reasoning.answer",
    "Budget": "po3d_ppl.reasoning.budget",
    "BudgetExceeded": "po3d_ppl.reasoning.budget",
}

__all__ = ["REGISTRY", "register_operation", "register_reference", "register_world", *_LAZY]


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

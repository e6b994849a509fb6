"""Programs become Pyro models.

``compile_program`` type-checks a program (text, AST, public JSON or an already checked program) and returns a
:class:`CompiledProgram` whose :meth:`~CompiledProgram.model` is a Pyro model: the scene model's latents, the
program's operations run on them (vectorised over any enclosing ``pyro.plate``), and a deterministic ``answer``
site holding the program's output (``values.INVALID`` when the execution is invalid). Every inference method
answers questions about this model; the exact and sampling engines do so without re-tracing it per sample (they
read the scene model's posterior tables once and run the program on their own latent worlds), and the tests check
that the model itself answers like them.
"""

from __future__ import annotations

from dataclasses import dataclass

import pyro
import torch

from po3d_ppl import ontology
from po3d_ppl.catalogue.semantics import DEFAULT_SEMANTICS
from po3d_ppl.errors import InputError
from po3d_ppl.evidence import SceneEvidence, ScenePriors
from po3d_ppl.reasoning import values
from po3d_ppl.reasoning.execution import run_program
from po3d_ppl.reasoning.inference.concrete_world import ConcreteWorld, evidence_supports, object_centric
from po3d_ppl.reasoning.latents import SITE, element_layout
from po3d_ppl.reasoning.scene_model import scene_model
from po3d_ppl.reasoning.semantics import answer_support

#: Output types a program may end in (an answer), with their value vocabularies in ``values``.
ANSWER_TYPES = ("Bool", "Integer", *values.ANSWER_VOCABULARY)


def _object_centric(latents: dict[str, torch.Tensor], evidence: SceneEvidence):
    """A ``ConcreteWorld`` source reading the scene model's latents (plate layout) object by object."""
    site = lambda name: element_layout(latents[name], SITE[name].plates)  # noqa: E731
    return lambda name: object_centric(name, site, evidence_supports(evidence))


@dataclass(frozen=True)
class CompiledProgram:
    typed: object  # po3d_ppl.language.TypedProgram

    @property
    def answer_type(self) -> str:
        return self.typed.type

    def support(self, num_objects: int, semantics: str = DEFAULT_SEMANTICS) -> list:
        """Every answer the program can give over ``num_objects`` proposals (a count of parts can reach every
        slot of every proposal) under ``semantics`` (a public ``query_pose`` may answer ``'None'``)."""
        counts_parts = any(node.operation.name == "count" and node.operation.inputs == ("PartSet",)
                           for node in self.typed.nodes)
        return answer_support(self.answer_type, num_objects * ontology.MAX_PARTS if counts_parts else num_objects,
                              semantics)

    def model(self, evidence: SceneEvidence, priors: ScenePriors = ScenePriors(),
              semantics: str = DEFAULT_SEMANTICS) -> torch.Tensor:
        """The program as a Pyro model over the latent scene; its ``answer`` site is the program's output."""
        latents = scene_model(evidence, priors)
        batch = tuple(latents["exists"].shape[:-4]) or (1,)  # the enclosing plates (one element without any)
        world = ConcreteWorld(_object_centric(latents, evidence), batch, evidence.num_objects,
                              evidence.positions, evidence.depths, evidence.directions)
        value = run_program(self.typed, world, semantics).expand(*batch, 1, 1).reshape(batch)
        return pyro.deterministic("answer", torch.where(world.valid, value, values.INVALID))


def compile_program(program) -> CompiledProgram:
    """Type-check ``program`` and compile it (see the module docstring)."""
    from po3d_ppl.language import as_typed_program

    typed = as_typed_program(program)
    if typed.type not in ANSWER_TYPES:
        raise InputError(
            "program", f"its result has type {typed.type}; a question must end in a query, count, exist or "
            "comparison (answer types: " + ", ".join(ANSWER_TYPES) + ")")
    return CompiledProgram(typed)

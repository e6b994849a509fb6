"""Answers over evidence with no object proposals (an image with no vehicle).

With no proposals there is no latent variable: the scene is certainly empty, so every method has one answer,
that of the program run on the empty world (``count`` = 0, ``exist`` = false, ``unique`` invalid, so any query
through it is invalid). The scene model itself cannot express it (a Pyro plate cannot have size 0), so the
reasoner routes empty evidence here instead of building posterior tables.
"""

from __future__ import annotations

import torch

from po3d_ppl import ontology
from po3d_ppl.evidence import DTYPE, SceneEvidence
from po3d_ppl.reasoning import values
from po3d_ppl.reasoning.execution import run_program
from po3d_ppl.reasoning.inference.concrete_world import ConcreteWorld
from po3d_ppl.reasoning.latents import BY_VALUE_NAME

#: The empty value of each site kind, object-centric with a batch of one (``concrete_world`` source layout).
_EMPTY_SHAPES = {"object": (1, 0), "object_by_model": (1, 0), "pair": (1, 0, 0), "part": (1, 0, ontology.MAX_PARTS),
                 "part_pair": (1, 0, ontology.MAX_PARTS, 0)}


def _empty_source(name: str) -> torch.Tensor:
    spec = BY_VALUE_NAME[name]
    dtype = DTYPE if spec.support_field else torch.long
    return torch.zeros(_EMPTY_SHAPES[spec.kind], dtype=dtype)


class _EmptyWorld(ConcreteWorld):
    """The world without objects: every set is empty, so a pivot never exists and reading one gives no value."""

    def pivot_attribute(self, obj, name):
        if name == "position":
            return torch.zeros((1, 1, 1, 3), dtype=DTYPE)
        if name in ("depth", "pose_degree"):
            return torch.zeros((1, 1, 1), dtype=DTYPE)
        return torch.full((1, 1, 1), values.INVALID, dtype=torch.long)

    def pivot_part_attribute(self, part, name):
        return torch.full((1, 1, 1), values.INVALID, dtype=torch.long)

    def _no_objects(self, *_) -> torch.Tensor:
        return torch.zeros((1, 0, 1), dtype=torch.bool)

    def _no_parts(self, *_) -> torch.Tensor:
        return torch.zeros((1, 0, ontology.MAX_PARTS), dtype=torch.bool)

    occluders_of = occludees_of = occluders_of_part = occluding_anything = _no_objects
    parts_occluded_by = _no_parts


def empty_distribution(typed, evidence: SceneEvidence, num_values: int,
                       semantics: str = "intended") -> tuple[torch.Tensor, float]:
    """Answer probabilities per id and the invalid mass (0 or 1) of ``typed`` over an empty scene."""
    if evidence.num_objects != 0:
        raise ValueError(f"empty_distribution needs evidence without proposals, got {evidence.num_objects}")
    world = _EmptyWorld(_empty_source, (1,), 0, evidence.positions, evidence.depths, evidence.directions)
    value = int(run_program(typed, world, semantics).reshape(-1)[0])
    probs = torch.zeros(num_values, dtype=DTYPE)
    if bool(world.valid.reshape(-1)[0]) and value != values.INVALID:
        probs[value] = 1.0
        return probs, 0.0
    return probs, 1.0

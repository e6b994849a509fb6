"""Integer codes of program values inside tensors.

Inside the latent world every attribute is a ``long`` tensor of ids into an ontology tuple; ``INVALID`` (-1) marks
"no value" (an unrecoloured part's colour, a pose in a dead zone) and makes a query or comparison invalid. This
module holds the answer vocabularies (id -> answer) and the id tables that operations index with.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache, wraps

import torch

from po3d_ppl import ontology
from po3d_ppl.evidence import STATE_COLOR, STATE_MATERIAL

INVALID = -1

#: Answer vocabulary of each output type that is decoded through a table.
ANSWER_VOCABULARY: dict[str, tuple[str, ...]] = {
    "Color": ontology.COLORS,
    "Material": ontology.MATERIALS,
    "Size": ontology.SIZES,
    "Shape": ontology.SUBTYPES,
    "Partname": ontology.RAW_PART_NAMES,
    "Direction": ontology.POSES,
}


def has_support(value_type: str) -> bool:
    """Whether :func:`support` knows the answers of ``value_type`` (not so for ``"mixed"`` distributions, which pool
    parses of several types)."""
    return value_type in ("Bool", "Integer") or value_type in ANSWER_VOCABULARY


def support(value_type: str, max_count: int) -> list:
    """All possible answers of an output type (``max_count`` bounds Integer answers)."""
    if value_type == "Bool":
        return [False, True]
    if value_type == "Integer":
        return list(range(max_count + 1))
    return list(ANSWER_VOCABULARY[value_type])


def on_default_device(build: Callable[[], torch.Tensor]) -> Callable[[], torch.Tensor]:
    """A constant table, built once and kept once per device: the one ``torch.get_default_device()`` names when
    it is asked for (inference runs under ``with torch.device(evidence.device)``)."""
    built = cache(build)

    @cache
    def on(device: torch.device) -> torch.Tensor:
        return built().to(device)

    @wraps(build)
    def table() -> torch.Tensor:
        return on(torch.get_default_device())

    return table


@on_default_device
def shape_match_table() -> torch.Tensor:
    """[len(SHAPE_VALUES), 21] bool: does filter value v select subtype s (itself or its category)."""
    return torch.tensor(
        [[ontology.shape_matches(s, v) for s in ontology.SUBTYPES] for v in ontology.SHAPE_VALUES], dtype=torch.bool,
        device="cpu")


@on_default_device
def partname_match_table() -> torch.Tensor:
    """[len(PARTNAME_VALUES), 85 + 1] bool over raw part ids; the last column (id -1) never matches."""
    rows = [[ontology.partname_matches(r, v) for r in ontology.RAW_PART_NAMES] + [False]
            for v in ontology.PARTNAME_VALUES]
    return torch.tensor(rows, dtype=torch.bool, device="cpu")


@on_default_device
def subtype_part_names() -> torch.Tensor:
    """[21, MAX_PARTS] long: global raw-part id of part slot p of subtype s, INVALID past the part list."""
    table = torch.full((len(ontology.SUBTYPES), ontology.MAX_PARTS), INVALID, dtype=torch.long, device="cpu")
    for s, sub in enumerate(ontology.SUBTYPES):
        for p, raw in enumerate(ontology.PARTS[sub]):
            table[s, p] = ontology.RAW_PART_NAMES.index(raw)
    return table


@on_default_device
def subtype_category() -> torch.Tensor:
    """[21] long: category id of each subtype."""
    return torch.tensor([ontology.CATEGORIES.index(ontology.CATEGORY_OF[s]) for s in ontology.SUBTYPES], device="cpu")

@on_default_device
def state_color() -> torch.Tensor:
    """Per part state: colour id (INVALID for hidden and plain), as ``evidence.STATE_COLOR``."""
    return STATE_COLOR


@on_default_device
def state_material() -> torch.Tensor:
    """Per part state: material id (INVALID for hidden and plain), as ``evidence.STATE_MATERIAL``."""
    return STATE_MATERIAL

"""Integer codes of program values inside tensors.

Inside the latent world every attribute is a ``long`` tensor of ids into an ontology tuple; ``INVALID`` (-1) marks
"no value" (an unrecoloured part's colour, a pose in a dead zone) and makes a query or comparison invalid. These
functions translate between literals (as they appear in programs and answers) and ids.
"""

from __future__ import annotations

from functools import cache

import torch

from po3d_ppl.errors import UnknownNameError
from po3d_ppl.world import ontology

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


def encode(value_type: str, value: str) -> int:
    """Id of an answer-type literal (``Color`` 'red' -> 1)."""
    vocab = ANSWER_VOCABULARY[value_type]
    try:
        return vocab.index(value)
    except ValueError:
        raise UnknownNameError(f"{value_type} value", value, vocab) from None


def decode(value_type: str, code: int):
    """Python answer for an id: a string for attribute types, bool for Bool, int for Integer."""
    if code == INVALID:
        return None
    if value_type == "Bool":
        return bool(code)
    if value_type == "Integer":
        return int(code)
    return ANSWER_VOCABULARY[value_type][code]


def support(value_type: str, max_count: int) -> list:
    """All possible answers of an output type (``max_count`` bounds Integer answers)."""
    if value_type == "Bool":
        return [False, True]
    if value_type == "Integer":
        return list(range(max_count + 1))
    return list(ANSWER_VOCABULARY[value_type])


@cache
def shape_match_table() -> torch.Tensor:
    """[len(SHAPE_VALUES), 21] bool: does filter value v select subtype s (itself or its category)."""
    return torch.tensor(
        [[ontology.shape_matches(s, v) for s in ontology.SUBTYPES] for v in ontology.SHAPE_VALUES], dtype=torch.bool
    )


@cache
def partname_match_table() -> torch.Tensor:
    """[len(PARTNAME_VALUES), 85 + 1] bool over raw part ids; the last column (id -1) never matches."""
    rows = [[ontology.partname_matches(r, v) for r in ontology.RAW_PART_NAMES] + [False]
            for v in ontology.PARTNAME_VALUES]
    return torch.tensor(rows, dtype=torch.bool)


@cache
def subtype_part_names() -> torch.Tensor:
    """[21, MAX_PARTS] long: global raw-part id of part slot p of subtype s, INVALID past the part list."""
    table = torch.full((len(ontology.SUBTYPES), ontology.MAX_PARTS), INVALID, dtype=torch.long)
    for s, sub in enumerate(ontology.SUBTYPES):
        for p, raw in enumerate(ontology.PARTS[sub]):
            table[s, p] = ontology.RAW_PART_NAMES.index(raw)
    return table


@cache
def subtype_category() -> torch.Tensor:
    """[21] long: category id of each subtype."""
    return torch.tensor([ontology.CATEGORIES.index(ontology.CATEGORY_OF[s]) for s in ontology.SUBTYPES])

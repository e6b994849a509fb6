"""Small tensor helpers shared by the built-in operations."""

from __future__ import annotations

import torch

from po3d_ppl.reasoning.values import INVALID


def compare(a: torch.Tensor, b: torch.Tensor, relation) -> torch.Tensor:
    """Bool value of ``relation(a, b)``; INVALID when either side is invalid."""
    valid = (a != INVALID) & (b != INVALID)
    return torch.where(valid, relation(a, b).long(), INVALID)


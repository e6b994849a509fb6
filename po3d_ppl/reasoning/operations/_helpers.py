"""Small tensor helpers shared by the built-in operations."""

from __future__ import annotations

import torch

from po3d_ppl.reasoning.values import INVALID


def check(flag: torch.Tensor) -> torch.Tensor:
    """A Bool program value (long 0/1) from a bool tensor."""
    return flag.long()


def compare(a: torch.Tensor, b: torch.Tensor, relation) -> torch.Tensor:
    """Bool value of ``relation(a, b)``; INVALID when either side is invalid."""
    valid = (a != INVALID) & (b != INVALID)
    return torch.where(valid, relation(a, b).long(), INVALID)


def valid_or_invalid(value: torch.Tensor, ok: torch.Tensor) -> torch.Tensor:
    """``value`` where ``ok``, INVALID elsewhere."""
    return torch.where(ok, value, INVALID)

"""Lazy sums of products of tensors: how the exact engine keeps sets and factors small.

In the exact engine every latent variable is enumerated along a dimension of its own, so a set built by five
filters depends on five enumeration dimensions plus the object axis. Materialising it would cost the product of
those sizes; keeping it as a product of five small tensors costs their sum, and contraction (einsum) never forms
the product either. Negation and union (``1 - a``, ``a + b - ab``) make sums of such products, hence the name.

A :class:`Sop` behaves like a boolean tensor under ``&``, ``|`` and ``~`` (also with plain tensors on either side,
through ``__torch_function__``), which is all that set-valued operations need. Small results are materialised
eagerly so term counts stay low.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import torch

#: Results up to this many elements are materialised into a single dense tensor.
DENSE_LIMIT = 1 << 14

Term = tuple[float, tuple[torch.Tensor, ...]]


def broadcast_shape(tensors: Iterable[torch.Tensor]) -> torch.Size:
    return torch.broadcast_shapes(*(t.shape for t in tensors)) if tensors else torch.Size()


class Sop:
    """``sum_t coef_t * prod_i factor_{t,i}`` over broadcastable tensors (bool or float)."""

    __slots__ = ("terms",)

    def __init__(self, terms: Iterable[Term]):
        self.terms: tuple[Term, ...] = tuple((float(c), tuple(fs)) for c, fs in terms if c != 0.0)

    # ---- construction ----------------------------------------------------------------------------------------
    @staticmethod
    def lift(value) -> Sop:
        if isinstance(value, Sop):
            return value
        if isinstance(value, torch.Tensor):
            return Sop([(1.0, (value,))])
        if isinstance(value, (bool, int, float)):
            return Sop([(float(value), ())])
        raise TypeError(f"cannot use {type(value).__name__} as a set in exact inference")

    @property
    def shape(self) -> torch.Size:
        return broadcast_shape([f for _, fs in self.terms for f in fs])

    def dense(self, dtype: torch.dtype = torch.float64) -> torch.Tensor:
        """The materialised tensor (broadcast shape of all factors)."""
        shape = self.shape
        out = torch.zeros(shape, dtype=dtype)
        for coef, factors in self.terms:
            prod = torch.full((), coef, dtype=dtype)
            for f in factors:
                prod = prod * f.to(dtype)
            out = out + prod
        return out

    def _compact(self) -> Sop:
        if len(self.terms) == 1 and len(self.terms[0][1]) <= 1:
            return self
        if math.prod(self.shape) <= DENSE_LIMIT:
            return Sop([(1.0, (self.dense(),))])
        return self

    # ---- boolean algebra -------------------------------------------------------------------------------------
    def __and__(self, other) -> Sop:
        other = Sop.lift(other)
        return Sop([(c1 * c2, f1 + f2) for c1, f1 in self.terms for c2, f2 in other.terms])._compact()

    __rand__ = __and__

    def __or__(self, other) -> Sop:
        other = Sop.lift(other)
        both = self & other
        return Sop(self.terms + other.terms + tuple((-c, f) for c, f in both.terms))._compact()

    __ror__ = __or__

    def __invert__(self) -> Sop:
        return Sop(((1.0, ()),) + tuple((-c, f) for c, f in self.terms))._compact()

    def __repr__(self) -> str:
        return f"Sop({len(self.terms)} terms, shape={tuple(self.shape)})"

    # ---- interplay with torch ------------------------------------------------------------------------------------
    _BINARY = {"__and__": "__and__", "__rand__": "__rand__", "__or__": "__or__", "__ror__": "__ror__",
               "logical_and": "__and__", "logical_or": "__or__", "bitwise_and": "__and__", "bitwise_or": "__or__",
               "__iand__": "__and__", "__ior__": "__or__"}
    _UNARY = {"__invert__", "logical_not", "bitwise_not"}

    @classmethod
    def __torch_function__(cls, func, types, args=(), kwargs=None):
        name = getattr(func, "__name__", str(func))
        if name in cls._UNARY and len(args) == 1:
            return ~Sop.lift(args[0])
        if name in cls._BINARY and len(args) == 2:
            left, right = args
            if isinstance(left, Sop):
                return getattr(left, cls._BINARY[name])(right)
            return Sop.lift(left) & right if "and" in name else Sop.lift(left) | right
        raise TypeError(
            f"exact inference represents sets lazily and supports only &, | and ~ on them, not {name}; "
            "write set operations with those, or run with method='sampling'"
        )

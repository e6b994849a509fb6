"""Exact answer marginals: contract the enumerated world (see ``enum_world``) down to the answer.

Per object: sum its local latents, with part slots inside a product over slots; then take the product over
objects (or, when the program counts, run the running-state chain over objects that tracks each count); finally
sum the global dimensions (pivots, copies) and collect mass per answer value. Sums use ``torch.einsum`` on the
small factor tensors (never on their product), with opt_einsum choosing the contraction order.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import torch

from po3d_ppl.evidence import DTYPE, SceneEvidence
from po3d_ppl.reasoning.budget import Budget, LazyGuard
from po3d_ppl.reasoning.execution import run_program
from po3d_ppl.reasoning.inference.enum_world import Dim, EnumWorld, ExactUnsupported
from po3d_ppl.reasoning.inference.sop import Sop
from po3d_ppl.reasoning.posterior import SitePosteriors

#: Largest intermediate tensor (elements) the exact engine will build before giving up (``auto`` then samples).
MAX_ELEMENTS = 2.5e7
#: Plate products over at most this many elements are vectorised; larger ones loop over the plate's elements.
_VECTOR_LIMIT = 1 << 20


class ExactTooCostly(ExactUnsupported):
    """The exact contraction would build tensors larger than ``MAX_ELEMENTS``."""


@dataclass(frozen=True)
class ExactResult:
    #: probability of each answer id (index = value id; for Integer answers, the count)
    probs: torch.Tensor
    invalid: float
    #: largest tensor built (elements), for cost reports
    peak_elements: int


def _present(t: torch.Tensor) -> list[int]:
    return [p for p in range(-t.dim(), 0) if t.shape[p] > 1]


def _rank(t: torch.Tensor, rank: int) -> torch.Tensor:
    return t.reshape([1] * (rank - t.dim()) + list(t.shape)) if t.dim() < rank else t


class _Contractor:
    def __init__(self, world: EnumWorld, max_elements: float = MAX_ELEMENTS, tick=lambda: None):
        self.world = world
        #: called at every contraction: the time budget's clock
        self.tick = tick
        self.max_elements = max_elements
        self.kind = {d.pos: d.kind for d in world.dims}
        self.kind[-1] = "plate"
        self.kind[-2] = "plate"
        self.peak = 0
        self._floats: dict[int, tuple[torch.Tensor, torch.Tensor]] = {}

    def _size(self, pos: int) -> int:
        if pos == -1:
            return self.world.num_parts
        if pos == -2:
            return self.world.num_objects
        return self.world.dims[-3 - pos].size

    def _float(self, t: torch.Tensor) -> torch.Tensor:
        """``t`` as float64, converted once per contraction (factor tensors recur in many terms)."""
        if t.dtype == DTYPE:
            return t
        key = id(t)
        if key not in self._floats:
            self._floats[key] = (t, t.to(DTYPE))
        return self._floats[key][1]

    def einsum(self, tensors: list[torch.Tensor], keep) -> torch.Tensor:
        """Sum every dimension not kept (``keep(pos)``) of the product of ``tensors``; result in the layout."""
        # tensors over the same dimensions are multiplied first: fewer operands, cheaper contraction paths
        grouped: dict[tuple[int, ...], torch.Tensor] = {}
        seen: set[int] = set()
        for t in tensors:
            if id(t) in seen:  # a {0,1} factor repeated in a product is the factor itself
                continue
            seen.add(id(t))
            pos = tuple(_present(t))
            squeezed = self._float(t).reshape([t.shape[p] for p in pos])
            grouped[pos] = grouped[pos] * squeezed if pos in grouped else squeezed
        operands: list = []
        present: set[int] = set()
        for pos, t in grouped.items():
            present.update(pos)
            operands += [t, [-p for p in pos]]
        out = sorted(p for p in present if keep(p))
        self.tick()
        size = math.prod(self._size(p) for p in out)
        self.peak = max(self.peak, size)
        if size > self.max_elements:
            raise ExactTooCostly(f"exact inference needs a {size:.2e}-element tensor (limit {self.max_elements:.2g})")
        if not operands:
            return torch.ones((), dtype=DTYPE)
        with torch.backends.opt_einsum.flags(enabled=True, strategy="greedy"):  # path search dominates otherwise
            result = torch.einsum(*operands, [-p for p in out])
        rank = max([-p for p in out], default=0)
        shape = [1] * rank
        for p in out:
            shape[rank + p] = self._size(p)
        return result.reshape(shape)

    def with_posteriors(self, tensors: list[torch.Tensor], q: dict[int, torch.Tensor],
                        kinds: tuple[str, ...]) -> list[torch.Tensor]:
        """Add the posterior table of every enumerated dimension of the given kinds that the tensors use."""
        out, seen = list(tensors), set()
        frontier = [p for t in tensors for p in _present(t)]
        while frontier:
            p = frontier.pop()
            if p in seen or self.kind.get(p) not in kinds or p not in q:
                continue
            seen.add(p)
            out.append(q[p])
            frontier += _present(q[p])
        return out

    def sum_of_products(self, factors: list[Sop], q, kinds: tuple[str, ...], keep) -> torch.Tensor:
        total = torch.zeros((), dtype=DTYPE)
        for combo in itertools.product(*(f.terms for f in factors)):
            coef = math.prod(c for c, _ in combo)
            tensors = [t for _, fs in combo for t in fs]
            total = total + coef * self.einsum(self.with_posteriors(tensors, q, kinds), keep)
        return total

    def inner(self, factors: list[Sop], q) -> torch.Tensor:
        """Per part slot: the part latents summed out of the product of part-level factors, ``[.., N, P]``."""
        return _rank(self.sum_of_products(factors, q, ("part",), lambda p: self.kind.get(p) != "part"), 2)

    def masses(self, factors: list[Sop], q: dict[int, torch.Tensor],
               slotted: list[tuple[Dim, Sop | None, Sop | None]] = (),
               part_aggregates: list[tuple[Dim, Sop]] = ()) -> torch.Tensor:
        """Per-object mass of the factors (local latents summed, part slots inside a product): ``[.., N, 1]``.

        ``slotted`` holds part-pivot factors ``(slot dim, at the slot, at the other slots)`` of the one object being
        evaluated; part pivots are handled like object pivots one level down (see :func:`_pivoted_product`).
        ``part_aggregates`` are flags R = "some slot is in T": by inclusion-exclusion,
        ``[R=0] prod_p(1-T_p) + [R=1] (prod_p 1 - prod_p(1-T_p))``, each product taken together with the other
        part-level factors.
        """
        part_level = [f for f in factors if self.world.is_part_level(f)]
        object_level = [f for f in factors if not self.world.is_part_level(f)]

        def part_product(extra: list[Sop]) -> torch.Tensor | None:
            if slotted:
                slots = list(dict.fromkeys(d for d, _, _ in slotted))
                off = self.inner(part_level + extra + [other for _, _, other in slotted if other is not None], q)

                def at_block(block: tuple[Dim, ...]) -> torch.Tensor:
                    chosen = [at if d in block else other for d, at, other in slotted]
                    values = self.inner(part_level + extra + [f for f in chosen if f is not None], q)
                    return _substitute(values, self.world, block[0], block[1:], axis=-1)

                return _pivoted_product(self.world, off, slots, at_block, axis=-1)
            if part_level or extra:
                return _product_along(self.inner(part_level + extra, q), -1, self.world.num_parts)
            return None

        if part_aggregates:
            flags = torch.zeros((), dtype=DTYPE)
            for subset in itertools.product((False, True), repeat=len(part_aggregates)):
                product = part_product([~members for (_, members), used in zip(part_aggregates, subset) if used])
                weight = torch.ones((), dtype=DTYPE)
                for (flag, _), used in zip(part_aggregates, subset):
                    r = self.world.ar(flag)
                    weight = weight * (((r == 0).to(DTYPE) - (r == 1).to(DTYPE)) if used else (r == 1).to(DTYPE))
                flags = flags + weight * (product if product is not None else 1.0)
            object_level.append(Sop.lift(flags))
        else:
            product = part_product([])
            if product is not None:
                object_level.append(Sop.lift(product))
        mass = self.sum_of_products(object_level, q, ("local",),
                                    lambda p: p == -2 or self.kind.get(p) in ("global", "aggregate"))
        return _rank(mass, 2)


def _substitute(t: torch.Tensor, world: EnumWorld, rep: Dim, merged: tuple[Dim, ...], axis: int = -2) -> torch.Tensor:
    """Evaluate ``t`` at the element pivot ``rep`` denotes: the plate ``axis`` (objects -2, part slots -1) and the
    axes of pivots known to equal ``rep`` are indexed by ``rep``'s value."""
    index = world.ar(rep)
    for ax in (axis, *(d.pos for d in merged)):
        if t.dim() >= -ax and t.shape[ax] > 1:
            rank = max(t.dim(), index.dim())
            t = torch.take_along_dim(_rank(t, rank), _rank(index, rank), dim=ax)
    return t


def _substitute_sop(sop: Sop, world: EnumWorld, rep: Dim, merged: tuple[Dim, ...]) -> Sop:
    return Sop([(c, tuple(_substitute(f, world, rep, merged) for f in fs)) for c, fs in sop.terms])


def _product_along(values: torch.Tensor, axis: int, size: int) -> torch.Tensor:
    """Product over a plate axis (a size-1 axis means the same value for every element)."""
    values = _rank(values, -axis)
    shape = list(values.shape)
    shape[axis] = size
    return values.expand(shape).prod(axis, keepdim=True)


def _pivoted_product(world: EnumWorld, off: torch.Tensor, pivots: list[Dim], at_block, axis: int) -> torch.Tensor:
    """``prod_e value(e)`` over the plate ``axis`` where pivots select elements: ``at_block(block)`` at the element
    a group of coinciding pivots denotes, ``off`` at every other element; summed over how pivots may coincide."""
    rest = _product_except(world, _rank(off, -axis), pivots, axis)
    total = torch.zeros((), dtype=DTYPE)
    for partition in _partitions(pivots):
        term = _indicator(world, partition) * rest
        for block in partition:
            term = term * at_block(tuple(block))
        total = total + term
    return total


def _product_except(world: EnumWorld, off: torch.Tensor, pivots: list[Dim], axis: int) -> torch.Tensor:
    """``prod_e off(e)`` over the plate ``axis``, skipping the elements the pivots denote (a tensor over the pivot
    dimensions). Built one element at a time, so the plate axis and the pivot axes never meet in memory."""
    size = world.num_objects if axis == -2 else world.num_parts
    element = world.index if axis == -2 else world.slot
    skip = torch.zeros((), dtype=torch.bool)
    for dim in pivots:
        skip = skip | (element == world.ar(dim))
    if math.prod(torch.broadcast_shapes(skip.shape, off.shape)) <= _VECTOR_LIMIT:  # small: all at once
        return _product_along(torch.where(skip, torch.ones((), dtype=DTYPE), off), axis, size)
    out = torch.ones((), dtype=DTYPE)
    for e in range(size):
        value = off.narrow(axis, e if off.shape[axis] > 1 else 0, 1)
        skip = torch.zeros((), dtype=torch.bool)
        for dim in pivots:
            skip = skip | (world.ar(dim) == e)
        out = out * torch.where(skip, torch.ones((), dtype=DTYPE), value)
    return out


def _partitions(items: list) -> list[list[list]]:
    """All set partitions of ``items`` (pivots that may denote the same object)."""
    if not items:
        return [[]]
    first, rest = items[0], items[1:]
    out = []
    for partition in _partitions(rest):
        out.append([[first], *partition])
        for i in range(len(partition)):
            out.append(partition[:i] + [[first, *partition[i]]] + partition[i + 1:])
    return out


class _Masses:
    """Per-object masses off the pivots and at each group of coinciding pivots, for one set of extra factors."""

    def __init__(self, contractor: _Contractor, extra: list[Sop]):
        world = contractor.world
        self.world, self.contractor = world, contractor
        q = {d.pos: t for d, t in world.q.items()}
        self.off = contractor.masses([f.off for f in world.factors if f.off is not None] + extra, q,
                                     part_aggregates=[(a.dim, a.members) for a in world.part_aggregates])
        self.on: dict[tuple[Dim, ...], torch.Tensor] = {}
        for size in range(1, len(world.pivot_dims) + 1):
            for block in itertools.combinations(world.pivot_dims, size):
                self.on[block] = self._at(block, extra, q)

    def _at(self, block: tuple[Dim, ...], extra: list[Sop], q) -> torch.Tensor:
        """Mass of the object that the coinciding pivots ``block`` denote."""
        world, rep, merged = self.world, block[0], block[1:]
        plain, slotted = list(extra), []
        for f in world.factors:
            if f.owner in block and f.slot is not None:
                slotted.append((f.slot, f.at_slot, f.on))
            elif f.owner in block:
                plain.append(f.on)
            elif f.off is not None:
                plain.append(f.off)
        sub = lambda sop: None if sop is None else _substitute_sop(sop, world, rep, merged)  # noqa: E731
        plain = [sub(f) for f in plain if f is not None]
        slotted = [(d, sub(at), sub(other)) for d, at, other in slotted]
        q_at = {p: _substitute(t, world, rep, merged) for p, t in q.items()}
        aggregates = [(a.dim, sub(a.members)) for a in world.part_aggregates]
        return self.contractor.masses(plain, q_at, slotted, aggregates)


def _indicator(world: EnumWorld, partition: list[list[Dim]]) -> torch.Tensor:
    """1 where the pivots' values coincide exactly as the partition says."""
    out = torch.ones((), dtype=DTYPE)
    for block in partition:
        for dim in block[1:]:
            out = out * (world.ar(dim) == world.ar(block[0]))
    for a, b in itertools.combinations([blk[0] for blk in partition], 2):
        out = out * (world.ar(a) != world.ar(b))
    return out


def _shift(state: torch.Tensor, dim: Dim, cap: int) -> torch.Tensor:
    """Count one more member on aggregate ``dim`` (values saturate at ``cap``)."""
    state = _rank(state, -dim.pos)
    shape = list(state.shape)
    shape[dim.pos] = dim.size
    s = state.expand(shape)
    shifted = torch.cat([torch.zeros_like(s.narrow(dim.pos, 0, 1)), s.narrow(dim.pos, 0, dim.size - 1)], dim.pos)
    overflow = torch.zeros_like(shifted)
    overflow.narrow(dim.pos, cap, 1).copy_(s.narrow(dim.pos, cap, 1))
    return shifted + overflow


def joint_mass(world: EnumWorld, contractor: _Contractor) -> torch.Tensor:
    """Mass of every joint value of the global and aggregate dimensions (valid executions only)."""
    aggregates = world.aggregates
    patterns = list(itertools.product((False, True), repeat=len(aggregates)))
    masses = {pattern: _Masses(contractor, [agg.members if bit else ~agg.members
                                            for agg, bit in zip(aggregates, pattern)])
              for pattern in patterns}
    if not aggregates:
        m = masses[()]
        return _pivoted_product(world, m.off, list(world.pivot_dims), m.on.__getitem__, axis=-2)
    at_pivots = torch.zeros((), dtype=torch.bool)
    for dim in world.pivot_dims:
        at_pivots = at_pivots | (world.index == world.ar(dim))
    total = torch.zeros((), dtype=DTYPE)
    for partition in _partitions(list(world.pivot_dims)):
        blocks = [tuple(b) for b in partition]
        weights = {}
        for pattern, m in masses.items():
            # per-object weight: the pivot group's mass at its object, the off-pivot mass elsewhere
            w = torch.where(at_pivots, torch.zeros((), dtype=DTYPE), m.off)
            for block in blocks:
                w = w + (world.index == world.ar(block[0])) * m.on[block]
            weights[pattern] = w
        total = total + _indicator(world, partition) * _count_chain(world, aggregates, weights, contractor.tick)
    return total


def _count_chain(world: EnumWorld, aggregates, weights: dict, tick) -> torch.Tensor:
    """Running-state chain over objects: the joint distribution of every count/exist of the program."""
    state = torch.ones((), dtype=DTYPE)
    for agg in aggregates:
        state = state * (world.ar(agg.dim) == 0).to(DTYPE)
    for k in range(world.num_objects):
        tick()
        new_state = torch.zeros((), dtype=DTYPE)
        for pattern, w in weights.items():
            w = _rank(w, 2)
            wk = w.narrow(-2, k, 1) if w.shape[-2] > 1 else w
            shifted = state
            for agg, bit in zip(aggregates, pattern):
                if bit:
                    shifted = _shift(shifted, agg.dim, agg.cap)
            new_state = new_state + wk * shifted
        state = new_state
    return state


def exact_distribution(typed, posteriors: SitePosteriors, evidence: SceneEvidence, num_values: int,
                       max_elements: float | None = None, budget: Budget | None = None,
                       semantics: str = "intended") -> ExactResult:
    """Exact answer distribution of ``typed`` over answer ids ``0..num_values-1`` plus the invalid mass.

    Within ``budget`` (:mod:`po3d_ppl.reasoning.budget`): past it, :class:`BudgetExceeded` before the allocation."""
    guard = LazyGuard(budget or Budget(), "exact inference")
    try:
        return _exact_distribution(typed, posteriors, evidence, num_values, max_elements, guard, semantics)
    finally:
        guard.close()


def _exact_distribution(typed, posteriors, evidence, num_values, max_elements, guard: LazyGuard,
                        semantics: str = "intended") -> ExactResult:
    world = EnumWorld(posteriors, evidence, on_grow=guard.grow)
    value = run_program(typed, world, semantics)
    if not isinstance(value, torch.Tensor):
        raise ExactUnsupported("the program's result is not an answer value")
    if isinstance(value, torch.Tensor) and bool((value < 0).all()):  # every execution is invalid: nothing to weigh
        return ExactResult(torch.zeros(num_values, dtype=DTYPE), 1.0, 0)
    contractor = _Contractor(world, MAX_ELEMENTS if max_elements is None else max_elements, tick=guard.tick)
    mass = joint_mass(world, contractor)
    if any(contractor.kind.get(p) in ("local", "part") for p in _present(value)):
        raise ExactUnsupported("the answer depends on a latent that is not a pivot attribute")
    shape = torch.broadcast_shapes(mass.shape, value.shape)
    mass = mass.expand(shape).reshape(-1)
    value = value.expand(shape).reshape(-1).long()
    valid = value >= 0
    probs = torch.zeros(num_values, dtype=DTYPE).scatter_add_(0, value[valid], mass[valid])
    invalid = float(1.0 - probs.sum())
    return ExactResult(probs, max(invalid, 0.0), contractor.peak)

"""The exact engine's world: every latent enumerated on a dimension of its own, objects on a plate.

This is Pyro's parallel enumeration under a plate, made lifted: a *generic object* k carries one enumeration
dimension per latent site the program reads (its support compacted per object, so certain evidence costs nothing),
and all objects share those dimensions because, given the pivots, objects are independent. Structural operations
add *global* dimensions:

- ``unique`` guesses its result (a pivot: an object index, or an object and a part slot) and adds a factor
  "the pivot is in the set, every other object or part is not";
- reading an attribute of a pivot adds a *copy* dimension tied to the pivot object's own latent;
- ``count``/``exist`` add an aggregate dimension whose distribution a running-state chain over objects computes
  (:mod:`po3d_ppl.reasoning.inference.exact`);
- ``part2object`` of a part set (and ``exist`` of one) adds a per-object flag R = "some part of the object is in
  the set", constrained by inclusion-exclusion over products over part slots (``exact._Contractor.masses``).

The answer is then a contraction: per object, sum its local dimensions (parts inside a product over slots); take
the product over objects; sum the global dimensions. Every factor is a posterior table read from the scene model
or a {0,1} constraint, so the result is the exact marginal of the compiled model.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import torch

from po3d_ppl import ontology
from po3d_ppl.errors import Po3dError
from po3d_ppl.evidence import SceneEvidence
from po3d_ppl.reasoning import values
from po3d_ppl.reasoning.inference.sop import Sop
from po3d_ppl.reasoning.latents import BY_VALUE_NAME, OBJECT_SITES, SITE
from po3d_ppl.reasoning.posterior import SitePosteriors
from po3d_ppl.reasoning.world import LatentWorld


class ExactUnsupported(Po3dError):
    """The program needs a dependency structure the exact engine does not handle; sampling does."""


@dataclass(frozen=True, eq=False)
class Dim:
    name: str
    size: int
    #: 'local' (a generic object's latent), 'part' (a generic part slot's latent), 'global' (pivot, copy),
    #: 'aggregate' (the value of a count or exist)
    kind: str
    pos: int

    def __repr__(self) -> str:
        return f"Dim({self.name}, {self.size}, {self.kind}, {self.pos})"


@dataclass(frozen=True, eq=False)
class ObjectPivot:
    dim: Dim


@dataclass(frozen=True, eq=False)
class PartPivot:
    owner: Dim
    slot: Dim


@dataclass(frozen=True, eq=False)
class Factor:
    """A constraint on every generic object, split by where it applies.

    At the object that pivot ``owner`` denotes the factor is ``on`` (and, if ``slot`` names a part pivot, ``at_slot``
    on that part and ``on`` on the object's other parts); elsewhere it is ``off``. ``None`` means no constraint.
    Keeping the cases apart is what keeps exact inference cheap: the dimensions private to a pivot (its part slot,
    the copies of its latents) only ever meet the one object (and the one part) that is the pivot.
    """

    on: Sop | None
    off: Sop | None
    owner: Dim | None = None
    slot: Dim | None = None
    at_slot: Sop | None = None

    @staticmethod
    def everywhere(value) -> Factor:
        sop = Sop.lift(value)
        return Factor(sop, sop)


@dataclass(frozen=True, eq=False)
class PartAggregate:
    """A per-object flag ``dim`` that is 1 exactly when some part slot of the object is in ``members``."""

    dim: Dim
    members: Sop


@dataclass(frozen=True, eq=False)
class Aggregate:
    dim: Dim
    members: Sop
    cap: int


def _compact(probs: torch.Tensor, vals: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Keep, along the last axis, only values with non-zero probability (per leading index), padded with zeros."""
    keep = probs > 0
    width = max(int(keep.sum(-1).max()) if keep.numel() else 1, 1)
    order = torch.argsort((~keep).to(torch.int8), dim=-1, stable=True)[..., :width]
    vals = vals.expand(probs.shape)
    return probs.gather(-1, order), vals.gather(-1, order)


class EnumWorld(LatentWorld):
    def __init__(self, posteriors: SitePosteriors, evidence: SceneEvidence,
                 on_grow: Callable[[int], None] | None = None):
        self.post = posteriors
        #: hears the bound on any tensor's size (objects x parts x every dimension) each time it grows
        self._on_grow = on_grow
        self._bound = evidence.num_objects * ontology.MAX_PARTS
        self.num_objects = n = evidence.num_objects
        self.num_parts = ontology.MAX_PARTS
        self.positions = evidence.positions.reshape(n, 1, 3)
        self.depths = evidence.depths.reshape(n, 1)
        self.directions = evidence.directions
        self.dims: list[Dim] = []
        #: posterior table of each allocated local/part dimension, placed in the layout
        self.q: dict[Dim, torch.Tensor] = {}
        #: compacted per-object supports of object sites: name -> (dim, values [N, E])
        self._object_sites: dict[str, tuple[Dim, torch.Tensor]] = {}
        self._part_sites: dict[str, tuple[Dim, torch.Tensor]] = {}
        self._placed: dict[str, torch.Tensor] = {}
        self._copies: dict[tuple, tuple[Dim, torch.Tensor]] = {}
        self._pair_reads: dict[tuple, torch.Tensor] = {}
        self.factors: list[Factor] = []
        self.aggregates: list[Aggregate] = []
        self.part_aggregates: list[PartAggregate] = []
        self.pivot_dims: list[Dim] = []
        #: part pivots that stand for a one-part set (``last_part``), which a later ``unique`` reuses
        self._part_pivots: list[PartPivot] = []
        self._ar_n = torch.arange(n).view(n, 1)
        self._ar_p = torch.arange(self.num_parts).view(1, self.num_parts)

    # ---- dimensions ----------------------------------------------------------------------------------------
    def alloc(self, name: str, size: int, kind: str) -> Dim:
        dim = Dim(name, size, kind, -3 - len(self.dims))
        self.dims.append(dim)
        self._bound *= max(size, 1)
        if self._on_grow is not None:
            self._on_grow(self._bound)
        return dim

    @staticmethod
    def ar(dim: Dim) -> torch.Tensor:
        """``arange(dim.size)`` placed on the dimension (for advanced indexing and comparisons)."""
        return torch.arange(dim.size).view(dim.size, *([1] * (-dim.pos - 1)))

    @staticmethod
    def _single(dim: Dim) -> torch.Tensor:
        """Index 0 placed on the dimension with size 1: a value that does not vary along ``dim`` broadcasts."""
        return torch.zeros((1,) * -dim.pos, dtype=torch.long)

    # ---- latent sites ----------------------------------------------------------------------------------------
    def _by_model(self, name: str) -> bool:
        """Whether object site ``name`` depends on the subtype hypothesis (a switch the evidence tells apart)."""
        return SITE[name].kind == "object_by_model" and name not in self.post.shared

    def _object_site(self, name: str) -> tuple[Dim, torch.Tensor]:
        """The generic object's dimension for site ``name`` and its compacted values ``[N, E]`` (``[N, E_s, E]``
        for a site that depends on the subtype hypothesis: its table then follows the subtype's dimension;
        ``[N, 1, E]`` when only the probabilities do, as the pose bins' degrees)."""
        if name not in self._object_sites:
            support = self.post.support[name]
            support = support.unsqueeze(0) if support.dim() == 1 else support
            if self._by_model(name):
                sub_dim, sub_vals = self._object_site("subtype")
                by_support = self.post.probs[name][self._ar_n, sub_vals]  # [N, E_s, K]
                probs_c, vals_c = _compact(by_support, support.unsqueeze(-2).expand(by_support.shape))
                dim = self.alloc(name, probs_c.shape[-1], "local")
                at = (self._ar_n, self.ar(sub_dim), self.ar(dim))
                values_at = at
                if bool((vals_c == vals_c[:, :1]).all()):
                    # the same values under every subtype (the pose bins' degrees): only their probabilities
                    # follow the subtype, so the values are placed off its dimension and what compares them
                    # (a pose relation: pivot x object x both poses) is not 21 x 21 times larger than it needs
                    vals_c = vals_c[:, :1]
                    values_at = (self._ar_n, self._single(sub_dim), self.ar(dim))
            else:
                probs = self.post.shared.get(name, self.post.probs[name])
                probs_c, vals_c = _compact(probs, support)
                dim = self.alloc(name, probs_c.shape[-1], "local")
                at = values_at = (self._ar_n, self.ar(dim))
            self.q[dim] = probs_c[at]
            self._object_sites[name] = (dim, vals_c)
            self._placed[name] = vals_c[values_at]
        return self._object_sites[name]

    def _object_values(self, name: str) -> torch.Tensor:
        """The site's values for the generic object, placed on its dimension (computed once)."""
        self._object_site(name)
        return self._placed[name]

    def _part_site(self, name: str) -> tuple[Dim, torch.Tensor]:
        if name not in self._part_sites:
            sub_dim, sub_vals = self._object_site("subtype")
            table = self.post.probs[name]  # [N, 21, P, K]
            n_idx = torch.arange(self.num_objects).view(-1, 1, 1)
            p_idx = torch.arange(self.num_parts).view(1, 1, -1)
            by_support = table[n_idx, sub_vals.unsqueeze(-1), p_idx]  # [N, E_s, P, K]
            support = torch.arange(table.shape[-1]).expand(by_support.shape)
            probs_c, vals_c = _compact(by_support, support)
            dim = self.alloc(name, probs_c.shape[-1], "part")
            self.q[dim] = probs_c[self._ar_n, self.ar(sub_dim), self._ar_p, self.ar(dim)]
            self._part_sites[name] = (dim, vals_c)
            self._placed[name] = vals_c[self._ar_n, self.ar(sub_dim), self._ar_p, self.ar(dim)]
        return self._part_sites[name]

    def _part_values(self, name: str) -> torch.Tensor:
        self._part_site(name)
        return self._placed[name]

    def object_latent(self, site: str):
        value = self._object_values(site)
        return Sop.lift(value.bool()) if SITE[site].boolean else value

    @property
    def part_color(self):
        return values.state_color()[self._part_values("part_state")]

    @property
    def part_material(self):
        return values.state_material()[self._part_values("part_state")]

    @property
    def part_occluded(self):
        return Sop.lift(self._part_values("part_occluded").bool())

    # ---- pair latents read through a pivot ---------------------------------------------------------------------
    def _pair_site(self, key: tuple, probs: torch.Tensor, kind: str) -> torch.Tensor:
        """A pair latent read from one side (``probs`` placed, values {0,1} last): its dim and bool values."""
        if key in self._pair_reads:
            return self._pair_reads[key]
        site, side = key[0], key[1]
        clash = [k for k in self._pair_reads if k[0] == site and k[1] != side]
        if clash:
            raise ExactUnsupported(
                f"the program reads the occlusion relation {site!r} both from the occluded and from the occluding "
                "side; the same latent then belongs to two objects at once. Use method='sampling'."
            )
        probs_c, vals_c = _compact(probs, torch.arange(2))
        dim = self.alloc(f"{site}:{side}", probs_c.shape[-1], kind)
        self.q[dim] = _to_dim(probs_c, dim)
        value = _to_dim(vals_c, dim).bool()
        for other_key, other_value in self._pair_reads.items():
            if other_key[:2] == key[:2]:  # same relation, same side, another pivot: tie when the pivots coincide
                same_pivot = key[2].same_entity_as(other_key[2])
                self.factors.append(Factor.everywhere(~same_pivot | (value == other_value)))
        self._pair_reads[key] = value
        return value

    def occluders_of(self, obj: ObjectPivot):
        j = self.ar(obj.dim)
        probs = self.post.probs["occludes"][j, self._ar_n]  # [..J.., N, 1, 2]
        value = self._pair_site(("occludes", "row", _PivotKey(self, obj.dim)), probs, "local")
        return Sop.lift(value) & (self.index != j)

    def occludees_of(self, obj: ObjectPivot):
        j = self.ar(obj.dim)
        probs = self.post.probs["occludes"][self._ar_n, j]
        value = self._pair_site(("occludes", "col", _PivotKey(self, obj.dim)), probs, "local")
        return Sop.lift(value) & (self.index != j)

    def parts_occluded_by(self, obj: ObjectPivot):
        sub_dim, sub_vals = self._object_site("subtype")
        j = self.ar(obj.dim)
        subtype = sub_vals[self._ar_n, self.ar(sub_dim)]
        probs = self.post.probs["part_occludes"][self._ar_n, subtype, self._ar_p, j]
        value = self._pair_site(("part_occludes", "col", _PivotKey(self, obj.dim)), probs, "part")
        return Sop.lift(value) & (self.index != j)

    def occluders_of_part(self, part: PartPivot):
        j, slot = self.ar(part.owner), self.ar(part.slot)
        owner_subtype = self.pivot_attribute(ObjectPivot(part.owner), "subtype")
        probs = self.post.probs["part_occludes"][j, owner_subtype, slot, self._ar_n]
        value = self._pair_site(("part_occludes", "row", _PivotKey(self, part.owner, part.slot)), probs, "local")
        return Sop.lift(value) & (self.index != j)

    def occluding_anything(self):
        raise ExactUnsupported(
            "filter_occluder asks whether an object occludes *any* object or part: the answer depends on the other "
            "objects' latents, which the exact engine keeps independent; use method='sampling'")

    # ---- pivots ---------------------------------------------------------------------------------------------------
    def _copy(self, owner: Dim, site: str) -> tuple[Dim, torch.Tensor]:
        """A global copy of object ``owner``'s latent ``site``, tied to it: its dim and its values."""
        key = (owner, site)
        if key not in self._copies:
            dim, vals = self._object_site(site)
            copy = self.alloc(f"{site}@{owner.name}", dim.size, "global")
            j = self.ar(owner)
            self.factors.append(Factor(Sop.lift(self.ar(copy) == self.ar(dim)), None, owner=owner))
            if self._by_model(site):  # the copy's values follow the pivot's own subtype (its copy)
                sub_copy, _ = self._copy(owner, "subtype")
                along = self.ar(sub_copy) if vals.shape[1] > 1 else self._single(sub_copy)
                self._copies[key] = (copy, vals[j, along, self.ar(copy)])
            else:
                self._copies[key] = (copy, vals[j, self.ar(copy)])
        return self._copies[key]

    def _part_copy(self, part: PartPivot, site: str) -> tuple[Dim, torch.Tensor]:
        key = (part.owner, part.slot, site)
        if key not in self._copies:
            dim, vals = self._part_site(site)
            sub_copy, _ = self._copy(part.owner, "subtype")
            copy = self.alloc(f"{site}@{part.owner.name}.{part.slot.name}", dim.size, "global")
            j, slot = self.ar(part.owner), self.ar(part.slot)
            tie = Sop.lift(self.ar(copy) == self.ar(dim))
            self.factors.append(Factor(None, None, owner=part.owner, slot=part.slot, at_slot=tie))
            self._copies[key] = (copy, vals[j, self.ar(sub_copy), slot, self.ar(copy)])
        return self._copies[key]

    def pivot_attribute(self, obj: ObjectPivot, name: str):
        j = self.ar(obj.dim)
        if name == "index":
            return j
        if name == "position":
            return self.positions.squeeze(-2)[j]
        if name == "depth":
            return self.depths.squeeze(-1)[j]
        spec = BY_VALUE_NAME.get(name)
        if spec is None or spec.name not in OBJECT_SITES:
            raise AttributeError(name)
        value = self._copy(obj.dim, spec.name)[1]
        return value.bool() if spec.boolean else value

    def pivot_part_attribute(self, part: PartPivot, name: str):
        if name == "owner":
            return self.ar(part.owner)
        if name == "slot":
            return self.ar(part.slot)
        if name == "name":
            subtype = self._copy(part.owner, "subtype")[1]
            return values.subtype_part_names()[subtype, self.ar(part.slot)]
        if name == "occluded":
            return self._part_copy(part, "part_occluded")[1]
        state = self._part_copy(part, "part_state")[1]
        if name == "color":
            return values.state_color()[state]
        if name == "material":
            return values.state_material()[state]
        if name == "size":
            named = self.pivot_part_attribute(part, "name") != values.INVALID
            ok = named & (values.state_color()[state] != values.INVALID)
            return torch.where(ok, self.pivot_attribute(ObjectPivot(part.owner), "size"), values.INVALID)
        raise AttributeError(name)

    # ---- structural operations -----------------------------------------------------------------------------------
    def is_part_level(self, value) -> bool:
        """Whether a set or factor varies over part slots (along the slot axis or a part latent's dimension)."""
        return _varies_along(Sop.lift(value), -1) or any(d.kind == "part" for d in self.dims_of(value))

    def _new_pivot(self) -> Dim:
        """A guess of an object index (the result of ``unique``)."""
        pivot = self.alloc(f"J{len(self.pivot_dims)}", self.num_objects, "global")
        self.pivot_dims.append(pivot)
        return pivot

    def _owner_candidate(self, members: Sop) -> Dim | None:
        """An existing pivot dimension J such that the set only has members with object index == J."""
        for dim in self.pivot_dims:
            if _support_within(members, self.index == self.ar(dim), self):
                return dim
        return None

    def unique_object(self, objects):
        members = Sop.lift(objects)
        if self.is_part_level(members):
            raise ExactUnsupported("unique got a set that depends on part slots")
        pivot = self._owner_candidate(members)
        if pivot is not None:  # the set can only hold that pivot's object: no new guess needed
            self.factors.append(Factor(members, None, owner=pivot))
            return ObjectPivot(pivot)
        pivot = self._new_pivot()
        self.factors.append(Factor(members, ~members, owner=pivot))
        return ObjectPivot(pivot)

    def unique_part(self, parts):
        members = Sop.lift(parts)
        for pivot in self._part_pivots:  # the set can only hold that pivot's part (a last_part result)
            at = (self.index == self.ar(pivot.owner)) & (self.slot == self.ar(pivot.slot))
            if _support_within(members, at, self):
                self.factors.append(Factor(None, None, owner=pivot.owner, slot=pivot.slot, at_slot=members))
                return pivot
        owner = self._owner_candidate(members)
        off = None
        if owner is None:
            owner = self._new_pivot()
            off = ~members
        slot = self.alloc(f"PP{len(self.dims)}", self.num_parts, "global")
        self.factors.append(Factor(~members, off, owner=owner, slot=slot, at_slot=members))
        return PartPivot(owner, slot)

    def any_part(self, parts):
        """Objects owning a member part: a per-object latent R = "some part is a member", constrained through
        inclusion-exclusion over part products (see ``exact._Contractor.masses``)."""
        members = Sop.lift(parts)
        flag = self.alloc(f"R{len(self.part_aggregates)}", 2, "local")
        self.part_aggregates.append(PartAggregate(flag, members))
        return Sop.lift(self.ar(flag) == 1)

    def last_part(self, parts):
        """The member last in the public order, guessed like ``unique``'s pivot: a flag F (1: the set has a member)
        and a part pivot (owner J, slot L). With F = 1 the pivot is a member and no later part is; with F = 0 no
        part is a member and the pivot is fixed at (0, 0), so each outcome is counted once."""
        members = Sop.lift(parts)
        found = self.alloc(f"F{len(self.dims)}", 2, "global")
        owner = self._new_pivot()
        slot = self.alloc(f"L{len(self.dims)}", self.num_parts, "global")
        some = self.ar(found) == 1
        none = ~some & (self.ar(owner) == 0) & (self.ar(slot) == 0)
        view = self.at_part(PartPivot(owner, slot))
        pivot_recoloured = (view.name != values.INVALID) & (view.color != values.INVALID)
        recoloured = Sop.lift(self.part_recoloured)
        same_kind = (recoloured & pivot_recoloured) | (~recoloured & ~pivot_recoloured)
        later = (~recoloured & pivot_recoloured) | (same_kind & (self.slot > self.ar(slot)))
        self.factors.append(Factor(
            on=(Sop.lift(some) & (~members | ~later)) | (Sop.lift(none) & ~members),
            off=(Sop.lift(some) & (~members | (self.index < self.ar(owner)))) | (Sop.lift(~some) & ~members),
            owner=owner, slot=slot,
            at_slot=(Sop.lift(some) & members) | (Sop.lift(none) & ~members)))
        self._part_pivots.append(PartPivot(owner, slot))
        return some & (self.index == self.ar(owner)) & (self.slot == self.ar(slot))

    def _aggregate(self, members, cap: int, name: str) -> torch.Tensor:
        members = Sop.lift(members)
        if self.is_part_level(members):
            if name == "exist":
                members = Sop.lift(self.any_part(members))
            else:
                raise ExactUnsupported("counting parts is not supported by the exact engine; use sampling")
        dim = self.alloc(f"{name}{len(self.aggregates)}", cap + 1, "aggregate")
        self.aggregates.append(Aggregate(dim, members, cap))
        return self.ar(dim)

    def count(self, members):
        return self._aggregate(members, self.num_objects, "count")

    def exist(self, members):
        return self._aggregate(members, 1, "exist")

    # ---- helpers ----------------------------------------------------------------------------------------------------
    def dims_of(self, value) -> list[Dim]:
        tensors = [f for _, fs in Sop.lift(value).terms for f in fs] if not isinstance(value, torch.Tensor) else [value]
        return [d for d in self.dims if any(t.dim() >= -d.pos and t.shape[d.pos] > 1 for t in tensors)]


@dataclass(frozen=True, eq=False)
class _PivotKey:
    """Identifies a pivot in a pair-latent read; two keys may denote the same entity (same object, same slot)."""

    world: EnumWorld
    owner: Dim
    slot: Dim | None = None

    def __hash__(self) -> int:
        return hash((id(self.owner), id(self.slot)))

    def __eq__(self, other) -> bool:
        return isinstance(other, _PivotKey) and self.owner is other.owner and self.slot is other.slot

    def same_entity_as(self, other: _PivotKey) -> torch.Tensor:
        same = self.world.ar(self.owner) == self.world.ar(other.owner)
        if self.slot is not None and other.slot is not None:
            same = same & (self.world.ar(self.slot) == self.world.ar(other.slot))
        return same


def _to_dim(table: torch.Tensor, dim: Dim) -> torch.Tensor:
    """A placed table whose last axis holds the values of the newest dimension ``dim``: move that axis there."""
    body = table.shape[:-1]
    rank = -dim.pos
    if len(body) >= rank:
        raise AssertionError(f"{dim} is not left of the table's axes {tuple(body)}")
    return table.movedim(-1, 0).reshape(table.shape[-1], *([1] * (rank - 1 - len(body))), *body)


def _varies_along(value: Sop, pos: int) -> bool:
    return any(f.dim() >= -pos and f.shape[pos] > 1 for _, fs in value.terms for f in fs)


def _support_within(members: Sop, mask: torch.Tensor, world: EnumWorld) -> bool:
    """Whether every term of ``members`` is zero wherever ``mask`` (over pivot and object axes) is False.

    Each term's non-zero pattern is reduced with "any" onto the mask's axes; the union over terms over-approximates
    the set's support, so a True answer is always right.
    """
    for _, fs in members.terms:
        nonzero = torch.ones((), dtype=torch.bool)
        for f in fs:
            nz = f != 0
            axes = [a for a in range(-nz.dim(), 0)
                    if nz.shape[a] > 1 and a != -2 and (mask.dim() < -a or mask.shape[a] == 1)]
            nonzero = nonzero & (nz.any(dim=axes, keepdim=True) if axes else nz)
        if (nonzero & ~mask).any():
            return False
    return True

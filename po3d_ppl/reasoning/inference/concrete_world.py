"""A batch of concrete latent scenes, as operations see them (sampling, dense enumeration, the Pyro model).

Latent values come from a *source*: a callable ``source(name) -> tensor`` giving object-centric values, by each
site's ``value_name`` (:mod:`po3d_ppl.reasoning.latents`), with a leading batch shape ``B``: object sites
``[*B, N]`` (the pose as ``pose_degree`` azimuths), pair sites ``[*B, N_i, N_j]`` (i occluded by j), part sites
``[*B, N, P]`` for the slots of each object's own subtype, part-pair sites ``[*B, N, P, N_j]``. Sources are asked
lazily, so a program only pays for the latents it reads.

Pivots are index tensors of shape ``[*B]`` (-1 once the execution became invalid); scalar program values have shape
``[*B, 1, 1]``. ``valid`` tracks, per batch element, whether every ``unique`` so far found exactly one member.

:func:`object_centric` builds a source from values laid out like the posterior tables (per subtype hypothesis),
which is what the compiled model's latents and the dense enumeration hold.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import torch

from po3d_ppl.reasoning import values
from po3d_ppl.reasoning.latents import BY_VALUE_NAME, MODELS_AXIS, SITE
from po3d_ppl.reasoning.world import LatentWorld


def pose_degrees(support: torch.Tensor, index: torch.Tensor) -> torch.Tensor:
    """Azimuths ``[*B, N]`` that pose-grid indices ``[*B, N]`` pick from the per-proposal grids ``support [N, K]``."""
    index = index.long()
    return support.expand(*index.shape[:-1], *support.shape).gather(-1, index.unsqueeze(-1)).squeeze(-1)


def object_centric(name: str, site: Callable[[str], torch.Tensor], supports: Callable[[str], torch.Tensor]
                   ) -> torch.Tensor:
    """Source value ``name`` (a site's ``value_name``) from ``site(site_name)``: a site's values in the posterior
    tables' layout without the values axis, batch first (``latents.TABLE_AXES``). Sites on the subtype-hypothesis
    plate are read at each object's own subtype; a site with per-proposal supports through ``supports(site)``."""
    spec = BY_VALUE_NAME[name]
    value = site(spec.name)
    if spec.kind in MODELS_AXIS:
        models = MODELS_AXIS[spec.kind]
        subtype = site("subtype").long()
        index = subtype.reshape(*subtype.shape, *([1] * -models))  # [*B, N, 1(, 1, 1)]
        rank = max(index.dim(), value.dim())  # batch ranks may differ (broadcast)
        index, value = (t.reshape([1] * (rank - t.dim()) + list(t.shape)) for t in (index, value))
        value = torch.take_along_dim(value, index, dim=models).squeeze(models)
    if spec.support_field is not None:
        value = pose_degrees(supports(spec.name), value)
    return value


def evidence_supports(evidence) -> Callable[[str], torch.Tensor]:
    """``supports(site)`` for :func:`object_centric`: the evidence field with the site's per-proposal values."""
    return lambda name: getattr(evidence, SITE[name].support_field)


def most_probable_world(post, evidence, on_read: Callable[[str], None] | None = None) -> ConcreteWorld:
    """One concrete scene with every latent at its most probable value (ties: the lowest index), as the
    thresholded baseline and the dense engine's first pass see it; ``on_read(site)`` hears each site read."""

    def argmax_site(site: str) -> torch.Tensor:
        if on_read is not None:
            on_read(site)
        return post.probs[site].argmax(-1).unsqueeze(0)

    return ConcreteWorld(lambda name: object_centric(name, argmax_site, evidence_supports(evidence)), (1,),
                         evidence.num_objects, evidence.positions, evidence.depths, evidence.directions)


@dataclass(frozen=True)
class PartHandle:
    owner: torch.Tensor  # [*B]
    slot: torch.Tensor  # [*B]


class ConcreteWorld(LatentWorld):
    def __init__(self, source: Callable[[str], torch.Tensor], batch_shape: tuple[int, ...], num_objects: int,
                 positions: torch.Tensor, depths: torch.Tensor, directions: dict[str, torch.Tensor]):
        self._source = source
        self._cache: dict[str, torch.Tensor] = {}
        self.batch_shape = tuple(batch_shape)
        self.num_objects = num_objects
        self.positions = positions.reshape(num_objects, 1, 3)
        self.depths = depths.reshape(num_objects, 1)
        self.directions = directions
        self.valid = torch.ones(self.batch_shape, dtype=torch.bool)

    def latent(self, name: str) -> torch.Tensor:
        if name not in self._cache:
            self._cache[name] = self._source(name)
        return self._cache[name]

    # ---- latent attributes -----------------------------------------------------------------------------------
    def object_latent(self, site: str) -> torch.Tensor:
        spec = SITE[site]
        value = self.latent(spec.value_name).unsqueeze(-1)
        if spec.boolean:
            return value.bool()
        return value if spec.support_field else value.long()

    @cached_property
    def part_color(self):
        return values.state_color()[self.latent("part_state").long()]

    @cached_property
    def part_material(self):
        return values.state_material()[self.latent("part_state").long()]

    @property
    def part_occluded(self):
        return self.latent("part_occluded").bool()

    # ---- relations ---------------------------------------------------------------------------------------------
    def _not_self(self, obj: torch.Tensor) -> torch.Tensor:
        return self.index != obj[..., None, None]

    def occluders_of(self, obj):
        row = _take(self.latent("occludes").bool(), obj, dim=-2)  # [*B, N_j]
        return row.unsqueeze(-1) & self._not_self(obj)

    def occludees_of(self, obj):
        col = _take(self.latent("occludes").bool(), obj, dim=-1)  # [*B, N_i]
        return col.unsqueeze(-1) & self._not_self(obj)

    def parts_occluded_by(self, obj):
        occ = _take(self.latent("part_occludes").bool(), obj, dim=-1)  # [*B, N, P]
        return occ & self._not_self(obj)

    def occluders_of_part(self, part: PartHandle):
        occ = self.latent("part_occludes").bool()  # [*B, N, P, N_j]
        row = _take(_take(occ, part.owner, dim=-3), part.slot, dim=-2)  # [*B, N_j]
        return row.unsqueeze(-1) & self._not_self(part.owner)

    def occluding_anything(self):
        other = self.index != self.index.T  # [N_i, N_j]: an object never occludes itself or its own parts
        objects = self.latent("occludes").bool() & self.exists & other  # [*B, N_i, N_j]
        parts = self.latent("part_occludes").bool() & self.part_valid.unsqueeze(-1) & other.unsqueeze(-2)
        return (objects.any(-2) | parts.flatten(-3, -2).any(-2)).unsqueeze(-1)  # parts: [*B, N, P, N_j]

    # ---- pivots ---------------------------------------------------------------------------------------------------
    def pivot_attribute(self, obj, name):
        if name == "index":
            return obj[..., None, None]
        if name == "position":
            return self.positions.squeeze(-2)[obj.clamp(min=0)][..., None, None, :]
        if name == "depth":
            return self.depths.squeeze(-1)[obj.clamp(min=0)][..., None, None]
        value = _take(getattr(self, name).squeeze(-1), obj, dim=-1)
        return value[..., None, None]

    def pivot_part_attribute(self, part: PartHandle, name):
        if name == "owner":
            return part.owner[..., None, None]
        if name == "slot":
            return part.slot[..., None, None]
        attribute = {"name": self.part_name, "color": self.part_color, "material": self.part_material,
                     "size": self.part_size, "occluded": self.part_occluded.long()}[name]
        attribute = attribute.expand(*self.batch_shape, self.num_objects, attribute.shape[-1])
        return _take(_take(attribute, part.owner, dim=-2), part.slot, dim=-1)[..., None, None]

    # ---- aggregations ------------------------------------------------------------------------------------------
    def _members(self, members: torch.Tensor) -> torch.Tensor:
        return members.expand(*self.batch_shape, *members.shape[-2:])

    def unique_object(self, objects):
        members = self._members(objects).squeeze(-1)
        found = members.sum(-1) == 1
        self.valid = self.valid & found
        if members.shape[-1] == 0:  # no objects at all (empty evidence): never exactly one
            return torch.full(found.shape, values.INVALID, dtype=torch.long)
        return torch.where(found, members.long().argmax(-1), values.INVALID)

    def unique_part(self, parts):
        members = self._members(parts)
        flat = members.flatten(-2)
        found = flat.sum(-1) == 1
        self.valid = self.valid & found
        if flat.shape[-1] == 0:
            none = torch.full(found.shape, values.INVALID, dtype=torch.long)
            return PartHandle(none, none)
        index = flat.long().argmax(-1)
        width = members.shape[-1]
        return PartHandle(torch.where(found, index // width, values.INVALID),
                          torch.where(found, index % width, values.INVALID))

    def count(self, members):
        return self._members(members).sum((-2, -1))[..., None, None]

    def exist(self, members):
        return self._members(members).flatten(-2).any(-1).long()[..., None, None]

    def any_part(self, parts):
        return parts.any(-1, keepdim=True)

    def last_part(self, parts):
        members = self._members(parts)
        rank = torch.where(members, self.part_order(), -1)
        last = rank.flatten(-2).max(-1).values[..., None, None]
        return members & (rank == last)


def _take(tensor: torch.Tensor, index: torch.Tensor, dim: int) -> torch.Tensor:
    """``tensor`` indexed along ``dim`` by a per-batch index ``[*B]`` (the batch dims lead both tensors)."""
    dim = dim % tensor.dim()
    batch = index.shape
    expanded = tensor.expand(*batch, *tensor.shape[len(batch):]) if tensor.dim() > len(batch) else tensor
    idx = index.clamp(min=0).reshape(*batch, *([1] * (expanded.dim() - len(batch))))
    idx = idx.expand(*batch, *[1 if d == dim else s for d, s in enumerate(expanded.shape)][len(batch):])
    return expanded.gather(dim, idx).squeeze(dim)

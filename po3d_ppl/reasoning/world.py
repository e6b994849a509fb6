"""The latent world as operations see it.

Operations (``po3d_ppl.reasoning.operations``) are written once, as tensor code over a :class:`LatentWorld`.
Each inference method supplies its own world:

- ``ConcreteWorld`` (sampling, dense enumeration, thresholding): every latent is a concrete value per batch
  element; tensors have a leading batch shape.
- ``EnumWorld`` (exact): every latent is its enumerated support along a dimension of its own, as under Pyro's
  parallel enumeration; pivots (the result of ``unique``) are extra dimensions.

Layout contract, shared by every world: object-level tensors are ``[..., N, 1]`` and part-level tensors
``[..., N, P]`` (objects on dim -2, part slots on dim -1, ``P = ontology.MAX_PARTS``). Sets are ``bool`` tensors
of those shapes; attribute values are ``long`` ids (``values.INVALID`` = -1 for "none"). Pivot views
(:meth:`LatentWorld.at`) return tensors shaped ``[..., 1, 1]`` that broadcast against the object axis.

Because operations only combine these tensors elementwise, the same function is a vectorised Pyro computation
under a plate in every world: no loops over objects, no engine-specific code.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from functools import cached_property

import torch

from po3d_ppl import ontology
from po3d_ppl.reasoning import values
from po3d_ppl.reasoning.latents import OBJECT_SITES, SITE
from po3d_ppl.world.scene import RELATION_EPS


class ObjectView:
    """Attributes of one pivot object (an ``Object`` program value), shaped ``[..., 1, 1]``.

    Attributes are fetched lazily from the world, because an exact world creates a dimension per attribute read.
    ``category`` and ``pose_label`` are derived here from the subtype and the azimuth, as for every object.
    """

    _ATTRS = ("index", *(SITE[name].value_name for name in OBJECT_SITES), "category", "pose_label", "position",
              "depth")

    def __init__(self, world: LatentWorld, handle):
        self._world, self._handle = world, handle

    def __getattr__(self, name: str) -> torch.Tensor:
        if name not in ObjectView._ATTRS:
            raise AttributeError(f"objects have no attribute {name!r} (known: {', '.join(ObjectView._ATTRS)})")
        if name == "category":
            value = values.subtype_category()[self.subtype]
        elif name == "pose_label":
            value = pose_label_ids(self.pose_degree)
        else:
            value = self._world.pivot_attribute(self._handle, name)
        setattr(self, name, value)
        return value


class PartView:
    """Attributes of one pivot part (a ``Part`` program value), shaped ``[..., 1, 1]``."""

    _ATTRS = ("owner", "slot", "name", "color", "material", "size", "occluded")

    def __init__(self, world: LatentWorld, handle):
        self._world, self._handle = world, handle

    def __getattr__(self, name: str) -> torch.Tensor:
        if name not in PartView._ATTRS:
            raise AttributeError(f"parts have no attribute {name!r} (known: {', '.join(PartView._ATTRS)})")
        value = self._world.pivot_part_attribute(self._handle, name)
        setattr(self, name, value)
        return value


class LatentWorld(ABC):
    """A (batched or enumerated) assignment of the scene's latent variables, viewed by operations."""

    num_objects: int
    #: Observed geometry: world positions ``[N, 1, 3]`` and camera depth ``[N, 1]``, and CLEVR's ground directions.
    positions: torch.Tensor
    depths: torch.Tensor
    directions: dict[str, torch.Tensor]

    # ---- latent object attributes, [..., N, 1] -------------------------------------------------------------
    # One attribute per object-level site of the latent layout, by the name programs read it by (``exists``,
    # ``subtype``, ``color``, ``material``, ``size``, ``pose_degree`` (azimuth, float), ``occluded``): see
    # :class:`_ObjectLatent` below the class. Binary sites read as bool, the pose as its azimuth, the rest as ids.
    @abstractmethod
    def object_latent(self, site: str) -> torch.Tensor:
        """Object-level latent ``site`` (a ``latents.OBJECT_SITES`` name) of every object, ``[..., N, 1]``."""

    # ---- latent part attributes, [..., N, P] ---------------------------------------------------------------
    @property
    @abstractmethod
    def part_color(self) -> torch.Tensor:
        """Colour id of a recoloured part, INVALID for a part that keeps the object's look."""

    @property
    @abstractmethod
    def part_material(self) -> torch.Tensor: ...

    @property
    @abstractmethod
    def part_occluded(self) -> torch.Tensor: ...

    # ---- latent occlusion relations --------------------------------------------------------------------------
    @abstractmethod
    def occluders_of(self, obj) -> torch.Tensor:
        """bool [..., N, 1]: objects that occlude the pivot object ``obj``."""

    @abstractmethod
    def occludees_of(self, obj) -> torch.Tensor:
        """bool [..., N, 1]: objects occluded by the pivot object ``obj``."""

    @abstractmethod
    def parts_occluded_by(self, obj) -> torch.Tensor:
        """bool [..., N, P]: parts occluded by the pivot object ``obj``."""

    @abstractmethod
    def occluders_of_part(self, part) -> torch.Tensor:
        """bool [..., N, 1]: objects that occlude the pivot part ``part``."""

    @abstractmethod
    def occluding_anything(self) -> torch.Tensor:
        """bool [..., N, 1]: objects that occlude some (existing) object or part."""

    # ---- pivots ------------------------------------------------------------------------------------------------
    @abstractmethod
    def pivot_attribute(self, obj, name: str) -> torch.Tensor:
        """Attribute ``name`` of pivot object ``obj``, shaped [..., 1, 1] (any of ``ObjectView``'s but the derived
        ``category`` and ``pose_label``)."""

    @abstractmethod
    def pivot_part_attribute(self, part, name: str) -> torch.Tensor:
        """Attribute ``name`` of pivot part ``part``, shaped [..., 1, 1]."""

    # ---- aggregations: each engine implements them its own way ------------------------------------------------
    @abstractmethod
    def unique_object(self, objects: torch.Tensor):
        """The single object of a set (a pivot handle); the execution is invalid unless there is exactly one."""

    @abstractmethod
    def unique_part(self, parts: torch.Tensor):
        """The single part of a part set (a pivot handle)."""

    @abstractmethod
    def count(self, members: torch.Tensor) -> torch.Tensor:
        """Integer: number of members of an object set ``[..., N, 1]`` or part set ``[..., N, P]``."""

    @abstractmethod
    def exist(self, members: torch.Tensor) -> torch.Tensor:
        """Bool (long 0/1): whether a set has a member."""

    @abstractmethod
    def any_part(self, parts: torch.Tensor) -> torch.Tensor:
        """Object set ``[..., N, 1]``: objects owning at least one member of the part set."""

    @abstractmethod
    def last_part(self, parts: torch.Tensor) -> torch.Tensor:
        """Part set ``[..., N, P]`` holding only the member of ``parts`` that comes last in the public code's
        order (objects by index; in an object its recoloured parts before its other parts, each by slot; see
        :meth:`part_order`), or nothing if ``parts`` is empty. Public semantics' ``relate_occluding_part``."""

    def at(self, obj) -> ObjectView:
        return ObjectView(self, obj)

    def at_part(self, part) -> PartView:
        return PartView(self, part)

    # ---- derived attributes, shared by every world --------------------------------------------------------------
    @cached_property
    def index(self) -> torch.Tensor:
        """Object index, [N, 1]."""
        return torch.arange(self.num_objects).unsqueeze(-1)

    @cached_property
    def slot(self) -> torch.Tensor:
        """Part-slot index, [1, P]."""
        return torch.arange(ontology.MAX_PARTS).unsqueeze(0)

    @property
    def category(self) -> torch.Tensor:
        return values.subtype_category()[self.subtype]

    @property
    def pose_label(self) -> torch.Tensor:
        return pose_label_ids(self.pose_degree)

    @property
    def part_name(self) -> torch.Tensor:
        """Global raw-part id of each part slot (INVALID past the subtype's part list), [..., N, P]."""
        return values.subtype_part_names()[self.subtype.squeeze(-1)]

    @property
    def part_valid(self) -> torch.Tensor:
        """bool [..., N, P]: the slot is a part of the object's subtype and the object exists."""
        return (self.part_name != values.INVALID) & self.exists

    @property
    def part_recoloured(self) -> torch.Tensor:
        return self.part_valid & (self.part_color != values.INVALID)

    def part_order(self) -> torch.Tensor:
        """Rank of every part slot in the public order of :meth:`last_part` (larger = later), ``[..., N, P]``."""
        plain = (~self.part_recoloured).long()
        return (self.index * 2 + plain) * ontology.MAX_PARTS + self.slot

    @property
    def part_size(self) -> torch.Tensor:
        """A recoloured part carries its object's size (the public data copies it); others have none."""
        recoloured = (self.part_name != values.INVALID) & (self.part_color != values.INVALID)
        return torch.where(recoloured, self.size, values.INVALID)

    def related(self, obj, relation: str) -> torch.Tensor:
        """bool [..., N, 1]: objects in spatial ``relation`` to pivot ``obj``.

        CLEVR's rule for left/right/behind/front/above/below: ``dot(p_j - p_obj, direction) > RELATION_EPS``;
        closer/farther compare camera depths with the same margin.
        """
        pivot = self.at(obj)
        if relation in ("closer", "farther"):
            sign = 1.0 if relation == "farther" else -1.0
            offset = sign * (self.depths - pivot.depth)
        else:
            direction = self.directions[relation]
            offset = self.positions @ direction - pivot.position @ direction
        return self.exists & (offset > RELATION_EPS) & (self.index != pivot.index)


class _ObjectLatent:
    """``world.<value name>``: the object-level latent that a site of the layout declares, read through the
    world's own :meth:`LatentWorld.object_latent`."""

    def __init__(self, site: str):
        self.site = site

    def __get__(self, world, owner=None):
        return self if world is None else world.object_latent(self.site)


for _site in OBJECT_SITES:
    setattr(LatentWorld, SITE[_site].value_name, _ObjectLatent(_site))


def pose_label_ids(degree: torch.Tensor) -> torch.Tensor:
    """Vectorised :func:`ontology.pose_label`: ids into ``ontology.POSES``, INVALID in the dead zones."""
    d = torch.remainder(degree, 360.0)
    out = torch.full(d.shape, values.INVALID, dtype=torch.long)
    out = torch.where((d < 30.0) | (d > 330.0), ontology.POSES.index("back"), out)
    out = torch.where((d > 60.0) & (d <= 120.0), ontology.POSES.index("right"), out)
    out = torch.where((d > 150.0) & (d <= 210.0), ontology.POSES.index("front"), out)
    out = torch.where((d > 240.0) & (d <= 300.0), ontology.POSES.index("left"), out)
    return out


def pose_relation_ids(reference: torch.Tensor, other: torch.Tensor) -> torch.Tensor:
    """0 same (< 45 degrees apart), 1 vertical, 2 opposite (> 135): the rule of spec §2.3."""
    diff = torch.remainder(reference - other, 360.0)
    diff = torch.minimum(diff, 360.0 - diff)
    return torch.where(diff < 45.0, 0, torch.where(diff > 135.0, 2, 1))

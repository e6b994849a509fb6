"""Latent-world code of the operations whose meaning differs under public semantics (docs/semantics.md).

Every inference method runs a program through :func:`po3d_ppl.reasoning.execution.run_program`, which takes each
operation's implementation from here under ``semantics="public"`` and from the catalogue otherwise, so one table
changes exact, sampling, auto, thresholded and the dense and generic references alike (the soft baseline has its
own rules, :func:`po3d_ppl.reasoning.inference.baselines.soft_rules`).

The public *facts* (one occluder per entity, which parts are annotated, the public pose formula) are not here:
they are what the evidence of a public-semantics run reads (the simulated sensor on
``po3d_ppl.questions.public.public_reading(scene)``), so the latent world's occlusion sites hold the public
relation. What is here are the public *rules*:

- filters match by substring (``value in atr``), shapes then by hypernym (rows 1, 27);
- ``filter_occluder`` ignores its input (row 2);
- ``relate_occluding_part`` keeps only the last part the public loop meets (row 4): ``world.last_part``;
- pose labels lose the back sector ``[0, 30]`` (row 7), and ``query_pose`` of a dead-zone object answers
  ``'None'`` (row 10, the id :data:`NO_POSE_ID`); a pose relation needs a labelled reference (row 9);
- ``relate`` has no height or depth relations (row 25): a :class:`~po3d_ppl.catalogue.semantics.SemanticsError`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import torch

from po3d_ppl import ontology
from po3d_ppl.catalogue import REGISTRY
from po3d_ppl.catalogue.semantics import PUBLIC, SemanticsError, check_semantics
from po3d_ppl.reasoning import values
from po3d_ppl.reasoning.world import pose_label_ids, pose_relation_ids

#: ``query_pose``'s answer id for a dead-zone object under public semantics (after the four directions).
NO_POSE_ID = len(ontology.POSES)
PUBLIC_RELATIONS = ontology.RELATIONS

#: (operation, input types) -> latent-world implementation under public semantics.
PUBLIC_WORLD: dict[tuple[str, tuple[str, ...]], Callable] = {}


def public_world(name: str, inputs: Sequence[str] | None = None):
    """Attach public-semantics latent-world code to overload(s) of ``name``."""
    def decorate(fn: Callable) -> Callable:
        for op in REGISTRY.overloads(name):
            if inputs is None or tuple(inputs) == op.inputs:
                PUBLIC_WORLD[(op.name, op.inputs)] = fn
        return fn
    return decorate


def world_implementation(op, semantics: str) -> Callable | None:
    """``op``'s latent-world code under ``semantics``."""
    if check_semantics(semantics) == PUBLIC:
        return PUBLIC_WORLD.get((op.name, op.inputs), op.world_fn)
    return op.world_fn


def answer_support(answer_type: str, max_count: int, semantics: str) -> list:
    """Every answer of an output type; under public semantics a direction may also be ``'None'``."""
    out = values.support(answer_type, max_count)
    if answer_type == "Direction" and check_semantics(semantics) == PUBLIC:
        out = out + [ontology.NO_POSE]
    return out


# ---- the public rules as tables --------------------------------------------------------------------------------
def public_match(attribute: str, value: str) -> bool:
    """The public filter test (``value == atr or value in atr``)."""
    return value == attribute or value in attribute


@values.on_default_device
def _color_table() -> torch.Tensor:
    return torch.tensor([[public_match(a, v) for a in ontology.COLORS] for v in ontology.COLORS], device="cpu")


@values.on_default_device
def _material_table() -> torch.Tensor:
    return torch.tensor([[public_match(a, v) for a in ontology.MATERIALS] for v in ontology.MATERIALS],
                        device="cpu")


@values.on_default_device
def _size_table() -> torch.Tensor:
    return torch.tensor([[public_match(a, v) for a in ontology.SIZES] for v in ontology.SIZES], device="cpu")


@values.on_default_device
def public_shape_table() -> torch.Tensor:
    """[len(SHAPE_VALUES), 21] bool: substring on the subtype, then the hypernym."""
    return torch.tensor([[public_match(s, v) or ontology.CATEGORY_OF[s] == v for s in ontology.SUBTYPES]
                         for v in ontology.SHAPE_VALUES], device="cpu")


@values.on_default_device
def public_partname_table() -> torch.Tensor:
    """[len(PARTNAME_VALUES), 85 + 1] bool over raw part ids (substring); the last column (id -1) never matches."""
    return torch.tensor([[public_match(r, v) for r in ontology.RAW_PART_NAMES] + [False]
                         for v in ontology.PARTNAME_VALUES], device="cpu")


def _lookup(table: torch.Tensor, ids: torch.Tensor) -> torch.Tensor:
    """``table[ids]`` with INVALID ids (no value) never matching."""
    return (ids != values.INVALID) & table[ids.clamp(min=0)]


def public_pose_labels(degree: torch.Tensor) -> torch.Tensor:
    """Vectorised public labels: :func:`~po3d_ppl.reasoning.world.pose_label_ids` without the ``[0, 30]`` part of
    the back sector (``merge_scene.py``'s broken copy)."""
    label = pose_label_ids(degree)
    return torch.where(torch.remainder(degree, 360.0) <= 30.0, values.INVALID, label)


# ---- operations ------------------------------------------------------------------------------------------------
def _attribute_filter(table: Callable[[], torch.Tensor], attribute: str, vocabulary: tuple[str, ...]):
    def run(world, objects, value):
        return objects & table()[vocabulary.index(value)][getattr(world, attribute)]
    return run


for _attr, _table, _vocab in (("color", _color_table, ontology.COLORS), ("material", _material_table,
                                                                         ontology.MATERIALS),
                              ("size", _size_table, ontology.SIZES)):
    public_world(f"filter_{_attr}")(_attribute_filter(_table, _attr, _vocab))


@public_world("filter_shape")
def _filter_shape(world, objects, value):
    return objects & public_shape_table()[ontology.SHAPE_VALUES.index(value)][world.subtype]


@public_world("partfilter_partname")
def _partfilter_partname(world, parts, value):
    return parts & public_partname_table()[ontology.PARTNAME_VALUES.index(value)][world.part_name]


@public_world("partfilter_color")
def _partfilter_color(world, parts, value):
    return parts & _lookup(_color_table()[ontology.COLORS.index(value)], world.part_color)


@public_world("partfilter_material")
def _partfilter_material(world, parts, value):
    return parts & _lookup(_material_table()[ontology.MATERIALS.index(value)], world.part_material)


@public_world("partfilter_size")
def _partfilter_size(world, parts, value):
    return parts & _lookup(_size_table()[ontology.SIZES.index(value)], world.part_size)


@public_world("relate")
def _relate(world, obj, value):
    if value not in PUBLIC_RELATIONS:
        raise SemanticsError(f"relate[{value}] has no public meaning: the public scene files hold only the "
                             f"{', '.join(PUBLIC_RELATIONS)} relationships")
    return world.related(obj, value)


@public_world("filter_pose")
def _filter_pose(world, objects, value):
    return objects & (public_pose_labels(world.pose_degree) == ontology.POSES.index(value.removesuffix("_pose")))


@public_world("query_pose")
def _query_pose(world, obj):
    label = public_pose_labels(world.at(obj).pose_degree)
    return torch.where(label == values.INVALID, NO_POSE_ID, label)


def _pose_relation(code: int):
    def relation(world, obj):
        pivot = world.at(obj)
        related = pose_relation_ids(pivot.pose_degree, world.pose_degree) == code
        labelled = public_pose_labels(pivot.pose_degree) != values.INVALID
        return world.exists & related & (world.index != pivot.index) & labelled
    return relation


for _code, _name in enumerate(("same_pose", "vertical_pose", "opposite_pose")):  # pose_relation_ids' codes
    public_world(_name)(_pose_relation(_code))


@public_world("filter_occluder")
def _filter_occluder(world, objects):
    """Ignores its input: every object that occludes some object or part."""
    return world.exists & world.occluding_anything()


@public_world("relate_occluding_part")
def _relate_occluding_part(world, obj):
    """Only the last part the public loop meets (``part_occluding[occluder] = [part]`` overwrites)."""
    return world.last_part(world.part_valid & world.parts_occluded_by(obj))

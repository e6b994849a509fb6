"""Ground-truth semantics of every program operation over a :class:`SceneContext` (docs/semantics.md).

Each function is attached to its registry overload with :func:`register_reference`, so the registry is the one
place that says which operations have a reference semantics. The latent-world implementations in
``po3d_ppl.reasoning.operations`` compute exactly these sets; the reasoning engine's tests compare against them.

Value conventions: ObjectSet = ``frozenset[int]``, PartSet = ``frozenset[(object, part_id)]``, Object = ``int``,
Part = ``(object, part_id)``, Bool = ``bool``, Integer = ``int``, attribute values are raw strings (subtype
names, raw part names, ``front``/``back``/``left``/``right`` for ``query_pose``). An operation that has no valid
result (``unique`` of a set without exactly one member, a query of a missing value) raises :class:`InvalidStep`.
"""

from __future__ import annotations

import operator

from po3d_ppl import ontology
from po3d_ppl.catalogue import REGISTRY, register_reference
from po3d_ppl.questions.context import Part, SceneContext


class InvalidStep(Exception):
    """The step has no valid result (the public ``'__INVALID__'``); the message says why."""


# ---- core ------------------------------------------------------------------------------------------------------
@register_reference("scene", inputs=())
def scene(ctx: SceneContext) -> frozenset[int]:
    return ctx.all_objects


def _attribute_filter(attribute: str):
    def run(ctx: SceneContext, objects: frozenset[int], value: str) -> frozenset[int]:
        return frozenset(i for i in objects if getattr(ctx.objects[i], attribute) == value)

    return run


for _attr in ("color", "material", "size"):
    register_reference(f"filter_{_attr}", inputs=("ObjectSet",))(_attribute_filter(_attr))


@register_reference("filter_shape", inputs=("ObjectSet",))
def filter_shape(ctx: SceneContext, objects: frozenset[int], value: str) -> frozenset[int]:
    return frozenset(i for i in objects if ontology.shape_matches(ctx.objects[i].subtype, value))


@register_reference("unique", inputs=("ObjectSet",))
@register_reference("unique", inputs=("PartSet",))
def unique(ctx: SceneContext, members: frozenset):
    if len(members) != 1:
        raise InvalidStep(f"unique of a set with {len(members)} members")
    return next(iter(members))


@register_reference("relate", inputs=("Object",))
def relate(ctx: SceneContext, obj: int, relation: str) -> frozenset[int]:
    return ctx.related(obj, relation)


@register_reference("union", inputs=("ObjectSet", "ObjectSet"))
@register_reference("union", inputs=("PartSet", "PartSet"))
def union(ctx: SceneContext, a: frozenset, b: frozenset) -> frozenset:
    return a | b


@register_reference("intersect", inputs=("ObjectSet", "ObjectSet"))
@register_reference("intersect", inputs=("PartSet", "PartSet"))
def intersect(ctx: SceneContext, a: frozenset, b: frozenset) -> frozenset:
    return a & b


@register_reference("count", inputs=("ObjectSet",))
@register_reference("count", inputs=("PartSet",))
def count(ctx: SceneContext, members: frozenset) -> int:
    return len(members)


@register_reference("exist", inputs=("ObjectSet",))
@register_reference("exist", inputs=("PartSet",))
def exist(ctx: SceneContext, members: frozenset) -> bool:
    return len(members) > 0


def _query(attribute: str):
    def run(ctx: SceneContext, obj: int) -> str:
        return getattr(ctx.objects[obj], attribute)

    return run


for _name, _attr in (("query_color", "color"), ("query_material", "material"), ("query_size", "size"),
                     ("query_shape", "subtype")):
    register_reference(_name, inputs=("Object",))(_query(_attr))


def _compare(relation):
    def run(ctx: SceneContext, a, b) -> bool:
        return bool(relation(a, b))

    return run


for _name in ("equal_color", "equal_material", "equal_size", "equal_shape", "equal_integer"):
    register_reference(_name)(_compare(operator.eq))
register_reference("less_than")(_compare(operator.lt))
register_reference("greater_than")(_compare(operator.gt))


def _same(attribute: str):
    def run(ctx: SceneContext, obj: int) -> frozenset[int]:
        value = getattr(ctx.objects[obj], attribute)
        return frozenset(j for j, o in enumerate(ctx.objects) if j != obj and getattr(o, attribute) == value)

    return run


for _name, _attr in (("same_color", "color"), ("same_material", "material"), ("same_size", "size"),
                     ("same_shape", "subtype")):
    register_reference(_name, inputs=("Object",))(_same(_attr))


# ---- parts -------------------------------------------------------------------------------------------------------
@register_reference("object2part", inputs=("ObjectSet",))
def object2part(ctx: SceneContext, objects: frozenset[int]) -> frozenset[Part]:
    return frozenset().union(*(ctx.recoloured_of[i] for i in objects))


@register_reference("object2part", inputs=("Object",))
def object2part_single(ctx: SceneContext, obj: int) -> frozenset[Part]:
    return ctx.recoloured_of[obj]


@register_reference("object2part_all", inputs=("ObjectSet",))
def object2part_all(ctx: SceneContext, objects: frozenset[int]) -> frozenset[Part]:
    return frozenset().union(*(ctx.parts_all_of[i] for i in objects))


@register_reference("object2part_all", inputs=("Object",))
def object2part_all_single(ctx: SceneContext, obj: int) -> frozenset[Part]:
    return ctx.parts_all_of[obj]


@register_reference("part2object", inputs=("PartSet",))
def part2object(ctx: SceneContext, parts: frozenset[Part]) -> frozenset[int]:
    return frozenset(k for k, _ in parts)


@register_reference("part2object", inputs=("Part",))
def part2object_single(ctx: SceneContext, part: Part) -> frozenset[int]:
    return frozenset((part[0],))


def _part_style_filter(attribute: str):
    def run(ctx: SceneContext, parts: frozenset[Part], value: str) -> frozenset[Part]:
        out = []
        for p in parts:
            style = ctx.part_style(p)
            if style is not None and getattr(style, attribute) == value:
                out.append(p)
        return frozenset(out)

    return run


register_reference("partfilter_color", inputs=("PartSet",))(_part_style_filter("color"))
register_reference("partfilter_material", inputs=("PartSet",))(_part_style_filter("material"))


@register_reference("partfilter_size", inputs=("PartSet",))
def partfilter_size(ctx: SceneContext, parts: frozenset[Part], value: str) -> frozenset[Part]:
    return frozenset(p for p in parts if ctx.owner_size(p) == value)


@register_reference("partfilter_partname", inputs=("PartSet",))
def partfilter_partname(ctx: SceneContext, parts: frozenset[Part], value: str) -> frozenset[Part]:
    return frozenset(p for p in parts if ontology.partname_matches(ctx.part_names[p], value))


def _part_query(attribute: str):
    def run(ctx: SceneContext, part: Part) -> str:
        style = ctx.part_style(part)
        if style is None:
            raise InvalidStep(f"part {ctx.part_names[part]} of object {part[0]} has no {attribute}")
        return getattr(style, attribute)

    return run


register_reference("partquery_color", inputs=("Part",))(_part_query("color"))
register_reference("partquery_material", inputs=("Part",))(_part_query("material"))


@register_reference("partquery_size", inputs=("Part",))
def partquery_size(ctx: SceneContext, part: Part) -> str:
    size = ctx.owner_size(part)
    if size is None:
        raise InvalidStep(f"part {ctx.part_names[part]} of object {part[0]} has no size")
    return size


@register_reference("partquery_partname", inputs=("Part",))
def partquery_partname(ctx: SceneContext, part: Part) -> str:
    return ctx.part_names[part]


# ---- pose --------------------------------------------------------------------------------------------------------
@register_reference("filter_pose", inputs=("ObjectSet",))
def filter_pose(ctx: SceneContext, objects: frozenset[int], value: str) -> frozenset[int]:
    return frozenset(i for i in objects if ctx.objects[i].pose == value)


@register_reference("query_pose", inputs=("Object",))
def query_pose(ctx: SceneContext, obj: int) -> str:
    label = ctx.objects[obj].pose
    if label == ontology.NO_POSE:
        raise InvalidStep(f"object {obj} faces a dead-zone direction (pose 'None')")
    return label.removesuffix("_pose")


def _pose_relation(kind: str):
    def run(ctx: SceneContext, obj: int) -> frozenset[int]:
        ref = ctx.objects[obj]
        label = ref.pose
        return frozenset(
            j for j, o in enumerate(ctx.objects)
            if j != obj and ontology.pose_relation(ref.pose_degree, label, o.pose_degree) == kind
        )

    return run


for _name, _kind in (("same_pose", "same"), ("opposite_pose", "opposite"), ("vertical_pose", "vertical")):
    register_reference(_name, inputs=("Object",))(_pose_relation(_kind))


# ---- occlusion ---------------------------------------------------------------------------------------------------
@register_reference("filter_occludee", inputs=("ObjectSet",))
def filter_occludee(ctx: SceneContext, objects: frozenset[int]) -> frozenset[int]:
    return frozenset(i for i in objects if ctx.objects[i].occluded)


@register_reference("partfilter_occludee", inputs=("PartSet",))
def partfilter_occludee(ctx: SceneContext, parts: frozenset[Part]) -> frozenset[Part]:
    return frozenset(p for p in parts if p in ctx.occluded_parts)


@register_reference("partquery_occlusion", inputs=("Part",))
def partquery_occlusion(ctx: SceneContext, part: Part) -> bool:
    return part in ctx.occluded_parts


@register_reference("relate_occluded", inputs=("Object",))
def relate_occluded(ctx: SceneContext, obj: int) -> frozenset[int]:
    return frozenset(ctx.objects[obj].occluded_by)


@register_reference("relate_occluding", inputs=("Object",))
def relate_occluding(ctx: SceneContext, obj: int) -> frozenset[int]:
    return ctx.occludees_of[obj]


@register_reference("relate_occluding_part", inputs=("Object",))
def relate_occluding_part(ctx: SceneContext, obj: int) -> frozenset[Part]:
    return ctx.parts_occluded_by[obj]


@register_reference("relate_part_occluded", inputs=("Part",))
def relate_part_occluded(ctx: SceneContext, part: Part) -> frozenset[int]:
    return frozenset(ctx.part_occluders.get(part, ()))


@register_reference("filter_occluder", inputs=("ObjectSet",))
def filter_occluder(ctx: SceneContext, objects: frozenset[int]) -> frozenset[int]:
    """Objects of the set that occlude some object or part (the public code ignores its input)."""
    return frozenset(j for j in objects if ctx.occludees_of[j] or ctx.parts_occluded_by[j])


def missing_references() -> list[str]:
    """Overloads without a reference implementation (empty for the built-ins; a test keeps it so)."""
    return [f"{op.name}{op.signature}" for op in REGISTRY if op.reference_fn is None]

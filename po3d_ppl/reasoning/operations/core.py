"""The CLEVR core: scene, filters, unique, relate, set operations, count/exist, queries and comparisons."""

from __future__ import annotations

import operator

from po3d_ppl import ontology
from po3d_ppl.catalogue import register_world
from po3d_ppl.reasoning import values
from po3d_ppl.reasoning.operations._helpers import compare


@register_world("scene")
def scene(world):
    return world.exists


@register_world("filter_color")
def filter_color(world, objects, value):
    return objects & (world.color == ontology.COLORS.index(value))


@register_world("filter_material")
def filter_material(world, objects, value):
    return objects & (world.material == ontology.MATERIALS.index(value))


@register_world("filter_size")
def filter_size(world, objects, value):
    return objects & (world.size == ontology.SIZES.index(value))


@register_world("filter_shape")
def filter_shape(world, objects, value):
    table = values.shape_match_table()[ontology.SHAPE_VALUES.index(value)]
    return objects & table[world.subtype]


@register_world("unique", inputs=["ObjectSet"])
def unique_object(world, objects):
    return world.unique_object(objects)


@register_world("unique", inputs=["PartSet"])
def unique_part(world, parts):
    return world.unique_part(parts)


@register_world("relate")
def relate(world, obj, value):
    return world.related(obj, value)


@register_world("union", inputs=["ObjectSet", "ObjectSet"])
def union(world, a, b):
    return a | b


@register_world("intersect", inputs=["ObjectSet", "ObjectSet"])
def intersect(world, a, b):
    return a & b


@register_world("union", inputs=["PartSet", "PartSet"])
def union_parts(world, a, b):
    return a | b


@register_world("intersect", inputs=["PartSet", "PartSet"])
def intersect_parts(world, a, b):
    return a & b


@register_world("count", inputs=["ObjectSet"])
def count_objects(world, objects):
    return world.count(objects)


@register_world("count", inputs=["PartSet"])
def count_parts(world, parts):
    return world.count(parts)


@register_world("exist", inputs=["ObjectSet"])
def exist_objects(world, objects):
    return world.exist(objects)


@register_world("exist", inputs=["PartSet"])
def exist_parts(world, parts):
    return world.exist(parts)


@register_world("query_color")
def query_color(world, obj):
    return world.at(obj).color


@register_world("query_material")
def query_material(world, obj):
    return world.at(obj).material


@register_world("query_size")
def query_size(world, obj):
    return world.at(obj).size


@register_world("query_shape")
def query_shape(world, obj):
    return world.at(obj).subtype


def _same(attribute: str):
    def same(world, obj):
        pivot = world.at(obj)
        return world.exists & (getattr(world, attribute) == getattr(pivot, attribute)) & (world.index != pivot.index)

    return same


for _attribute, _name in (("color", "same_color"), ("material", "same_material"), ("size", "same_size"),
                          ("subtype", "same_shape")):
    register_world(_name)(_same(_attribute))


@register_world("equal_color")
@register_world("equal_material")
@register_world("equal_size")
@register_world("equal_shape")
@register_world("equal_integer")
def equal(world, a, b):
    return compare(a, b, operator.eq)


@register_world("less_than")
def less_than(world, a, b):
    return compare(a, b, operator.lt)


@register_world("greater_than")
def greater_than(world, a, b):
    return compare(a, b, operator.gt)


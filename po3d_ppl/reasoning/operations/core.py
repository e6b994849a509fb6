"""The CLEVR core: scene, filters, unique, relate, set operations, count/exist, queries and comparisons."""

from __future__ import annotations

import operator

from po3d_ppl.reasoning import values
from po3d_ppl.reasoning.operations._helpers import compare
from po3d_ppl.reasoning.registry import register_operation
from po3d_ppl.world import ontology


@register_operation("scene", inputs=[], output="ObjectSet")
def scene(world):
    """All objects in the scene."""
    return world.exists


@register_operation("filter_color", inputs=["ObjectSet"], value="Color", output="ObjectSet")
def filter_color(world, objects, value):
    """Objects of the given colour."""
    return objects & (world.color == ontology.COLORS.index(value))


@register_operation("filter_material", inputs=["ObjectSet"], value="Material", output="ObjectSet")
def filter_material(world, objects, value):
    """Objects of the given material."""
    return objects & (world.material == ontology.MATERIALS.index(value))


@register_operation("filter_size", inputs=["ObjectSet"], value="Size", output="ObjectSet")
def filter_size(world, objects, value):
    """Objects of the given size."""
    return objects & (world.size == ontology.SIZES.index(value))


@register_operation("filter_shape", inputs=["ObjectSet"], value="Shape", output="ObjectSet")
def filter_shape(world, objects, value):
    """Objects of the given subtype, or of any subtype of the given category (``car`` matches ``suv``)."""
    table = values.shape_match_table()[ontology.SHAPE_VALUES.index(value)]
    return objects & table[world.subtype]


@register_operation("unique", inputs=["ObjectSet"], output="Object", structural=True)
def unique_object(world, objects):
    """The single object of the set; invalid unless the set has exactly one member."""
    return world.unique_object(objects)


@register_operation("unique", inputs=["PartSet"], output="Part", structural=True)
def unique_part(world, parts):
    """The single part of the set; invalid unless the set has exactly one member."""
    return world.unique_part(parts)


@register_operation("relate", inputs=["Object"], value="Relation", output="ObjectSet")
def relate(world, obj, value):
    """Objects in the given spatial relation (left, right, behind, front) to the object."""
    return world.related(obj, value)


@register_operation("union", inputs=["ObjectSet", "ObjectSet"], output="ObjectSet")
def union(world, a, b):
    """Objects in either set."""
    return a | b


@register_operation("intersect", inputs=["ObjectSet", "ObjectSet"], output="ObjectSet")
def intersect(world, a, b):
    """Objects in both sets."""
    return a & b


@register_operation("union", inputs=["PartSet", "PartSet"], output="PartSet")
def union_parts(world, a, b):
    """Parts in either set."""
    return a | b


@register_operation("intersect", inputs=["PartSet", "PartSet"], output="PartSet")
def intersect_parts(world, a, b):
    """Parts in both sets."""
    return a & b


@register_operation("count", inputs=["ObjectSet"], output="Integer", structural=True)
def count_objects(world, objects):
    """Number of objects in the set."""
    return world.count(objects)


@register_operation("count", inputs=["PartSet"], output="Integer", structural=True)
def count_parts(world, parts):
    """Number of parts in the set."""
    return world.count(parts)


@register_operation("exist", inputs=["ObjectSet"], output="Bool", structural=True)
def exist_objects(world, objects):
    """Whether the set is non-empty."""
    return world.exist(objects)


@register_operation("exist", inputs=["PartSet"], output="Bool", structural=True)
def exist_parts(world, parts):
    """Whether the part set is non-empty."""
    return world.exist(parts)


@register_operation("query_color", inputs=["Object"], output="Color")
def query_color(world, obj):
    """Colour of the object."""
    return world.at(obj).color


@register_operation("query_material", inputs=["Object"], output="Material")
def query_material(world, obj):
    """Material of the object."""
    return world.at(obj).material


@register_operation("query_size", inputs=["Object"], output="Size")
def query_size(world, obj):
    """Size of the object."""
    return world.at(obj).size


@register_operation("query_shape", inputs=["Object"], output="Shape")
def query_shape(world, obj):
    """Subtype of the object (e.g. ``suv``)."""
    return world.at(obj).subtype


def _same(attribute: str):
    def same(world, obj):
        pivot = world.at(obj)
        return world.exists & (getattr(world, attribute) == getattr(pivot, attribute)) & (world.index != pivot.index)

    same.__doc__ = f"Other objects with the same {attribute} as the object (exact match, no hypernyms)."
    return same


for _attribute, _name in (("color", "same_color"), ("material", "same_material"), ("size", "same_size"),
                          ("subtype", "same_shape")):
    register_operation(_name, inputs=["Object"], output="ObjectSet")(_same(_attribute))


def _equal(value_type: str):
    def equal(world, a, b):
        return compare(a, b, operator.eq)

    equal.__doc__ = f"Whether two {value_type} values are equal."
    return equal


for _type in ("Color", "Material", "Size", "Shape"):
    register_operation(f"equal_{_type.lower()}", inputs=[_type, _type], output="Bool")(_equal(_type))


@register_operation("equal_integer", inputs=["Integer", "Integer"], output="Bool")
def equal_integer(world, a, b):
    """Whether two counts are equal."""
    return compare(a, b, operator.eq)


@register_operation("less_than", inputs=["Integer", "Integer"], output="Bool")
def less_than(world, a, b):
    """Whether the first count is smaller."""
    return compare(a, b, operator.lt)


@register_operation("greater_than", inputs=["Integer", "Integer"], output="Bool")
def greater_than(world, a, b):
    """Whether the first count is larger."""
    return compare(a, b, operator.gt)


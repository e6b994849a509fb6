"""Part operations: from objects to their parts and back, part filters and part queries."""

from __future__ import annotations

from po3d_ppl.reasoning import values
from po3d_ppl.reasoning.registry import register_operation
from po3d_ppl.world import ontology


@register_operation("object2part", inputs=["ObjectSet"], output="PartSet")
def object2part(world, objects):
    """The recoloured parts (the parts that have attributes) of the objects."""
    return objects & world.part_recoloured


@register_operation("object2part", inputs=["Object"], output="PartSet")
def object2part_single(world, obj):
    """The recoloured parts of the object."""
    return (world.index == world.at(obj).index) & world.part_recoloured


def _attributed_or_occluded(world):
    return world.part_recoloured | (world.part_valid & world.part_occluded)


@register_operation("object2part_all", inputs=["ObjectSet"], output="PartSet")
def object2part_all(world, objects):
    """The recoloured parts and the occluded parts of the objects."""
    return objects & _attributed_or_occluded(world)


@register_operation("object2part_all", inputs=["Object"], output="PartSet")
def object2part_all_single(world, obj):
    """The recoloured parts and the occluded parts of the object."""
    return (world.index == world.at(obj).index) & _attributed_or_occluded(world)


@register_operation("part2object", inputs=["Part"], output="ObjectSet")
def part2object_single(world, part):
    """The object the part belongs to."""
    return world.exists & (world.index == world.at_part(part).owner)


@register_operation("part2object", inputs=["PartSet"], output="ObjectSet", structural=True)
def part2object(world, parts):
    """The objects owning at least one of the parts."""
    return world.any_part(parts)


@register_operation("partfilter_color", inputs=["PartSet"], value="Color", output="PartSet")
def partfilter_color(world, parts, value):
    """Parts of the given colour."""
    return parts & (world.part_color == ontology.COLORS.index(value))


@register_operation("partfilter_material", inputs=["PartSet"], value="Material", output="PartSet")
def partfilter_material(world, parts, value):
    """Parts of the given material."""
    return parts & (world.part_material == ontology.MATERIALS.index(value))


@register_operation("partfilter_size", inputs=["PartSet"], value="Size", output="PartSet")
def partfilter_size(world, parts, value):
    """Parts of the given size (a recoloured part carries its object's size)."""
    return parts & (world.part_size == ontology.SIZES.index(value))


@register_operation("partfilter_partname", inputs=["PartSet"], value="Partname", output="PartSet")
def partfilter_partname(world, parts, value):
    """Parts named by the value's words (``back_left_wheel`` matches ``wheel_back_left`` too), or whose coarse name
    it is (``wheel`` matches every wheel)."""
    table = values.partname_match_table()[ontology.PARTNAME_VALUES.index(value)]
    return parts & table[world.part_name]


@register_operation("partquery_color", inputs=["Part"], output="Color")
def partquery_color(world, part):
    """Colour of the part (invalid for a part without attributes)."""
    return world.at_part(part).color


@register_operation("partquery_material", inputs=["Part"], output="Material")
def partquery_material(world, part):
    """Material of the part (invalid for a part without attributes)."""
    return world.at_part(part).material


@register_operation("partquery_size", inputs=["Part"], output="Size")
def partquery_size(world, part):
    """Size of the part (its object's size; invalid for a part without attributes)."""
    return world.at_part(part).size


@register_operation("partquery_partname", inputs=["Part"], output="Partname")
def partquery_partname(world, part):
    """Raw name of the part (e.g. ``wheel_back_left``)."""
    return world.at_part(part).name

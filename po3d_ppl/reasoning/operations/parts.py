"""Part operations: from objects to their parts and back, part filters and part queries."""

from __future__ import annotations

from po3d_ppl import ontology
from po3d_ppl.catalogue import register_world
from po3d_ppl.reasoning import values


@register_world("object2part", inputs=["ObjectSet"])
def object2part(world, objects):
    return objects & world.part_recoloured


@register_world("object2part", inputs=["Object"])
def object2part_single(world, obj):
    return (world.index == world.at(obj).index) & world.part_recoloured


def _attributed_or_occluded(world):
    return world.part_recoloured | (world.part_valid & world.part_occluded)


@register_world("object2part_all", inputs=["ObjectSet"])
def object2part_all(world, objects):
    return objects & _attributed_or_occluded(world)


@register_world("object2part_all", inputs=["Object"])
def object2part_all_single(world, obj):
    return (world.index == world.at(obj).index) & _attributed_or_occluded(world)


@register_world("part2object", inputs=["Part"])
def part2object_single(world, part):
    return world.exists & (world.index == world.at_part(part).owner)


@register_world("part2object", inputs=["PartSet"])
def part2object(world, parts):
    return world.any_part(parts)


@register_world("partfilter_color")
def partfilter_color(world, parts, value):
    return parts & (world.part_color == ontology.COLORS.index(value))


@register_world("partfilter_material")
def partfilter_material(world, parts, value):
    return parts & (world.part_material == ontology.MATERIALS.index(value))


@register_world("partfilter_size")
def partfilter_size(world, parts, value):
    return parts & (world.part_size == ontology.SIZES.index(value))


@register_world("partfilter_partname")
def partfilter_partname(world, parts, value):
    table = values.partname_match_table()[ontology.PARTNAME_VALUES.index(value)]
    return parts & table[world.part_name]


@register_world("partquery_color")
def partquery_color(world, part):
    return world.at_part(part).color


@register_world("partquery_material")
def partquery_material(world, part):
    return world.at_part(part).material


@register_world("partquery_size")
def partquery_size(world, part):
    return world.at_part(part).size


@register_world("partquery_partname")
def partquery_partname(world, part):
    return world.at_part(part).name

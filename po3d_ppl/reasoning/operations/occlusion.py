"""Occlusion operations over the latent occlusion state and the pairwise occlusion relation (paper's S matrix)."""

from __future__ import annotations

from po3d_ppl.catalogue import register_world


@register_world("filter_occludee")
def filter_occludee(world, objects):
    return objects & world.occluded


@register_world("partfilter_occludee")
def partfilter_occludee(world, parts):
    return parts & world.part_occluded


@register_world("partquery_occlusion")
def partquery_occlusion(world, part):
    return world.at_part(part).occluded


@register_world("filter_occluder")
def filter_occluder(world, objects):
    return objects & world.occluding_anything()


@register_world("relate_occluded")
def relate_occluded(world, obj):
    return world.exists & world.occluders_of(obj)


@register_world("relate_occluding")
def relate_occluding(world, obj):
    return world.exists & world.occludees_of(obj)


@register_world("relate_occluding_part")
def relate_occluding_part(world, obj):
    return world.part_valid & world.parts_occluded_by(obj)


@register_world("relate_part_occluded")
def relate_part_occluded(world, part):
    return world.exists & world.occluders_of_part(part)

"""Occlusion operations over the latent occlusion state and the pairwise occlusion relation (paper's S matrix)."""

from __future__ import annotations

from po3d_ppl.reasoning.registry import register_operation


@register_operation("filter_occludee", inputs=["ObjectSet"], output="ObjectSet")
def filter_occludee(world, objects):
    """Objects that are occluded."""
    return objects & world.occluded


@register_operation("partfilter_occludee", inputs=["PartSet"], output="PartSet")
def partfilter_occludee(world, parts):
    """Parts that are occluded."""
    return parts & world.part_occluded


@register_operation("partquery_occlusion", inputs=["Part"], output="Bool")
def partquery_occlusion(world, part):
    """Whether the part is occluded."""
    return world.at_part(part).occluded


@register_operation("filter_occluder", inputs=["ObjectSet"], output="ObjectSet")
def filter_occluder(world, objects):
    """Objects that occlude some object or part (no template emits it; the exact engine defers to sampling)."""
    return objects & world.occluding_anything()


@register_operation("relate_occluded", inputs=["Object"], output="ObjectSet")
def relate_occluded(world, obj):
    """The objects that occlude the object."""
    return world.exists & world.occluders_of(obj)


@register_operation("relate_occluding", inputs=["Object"], output="ObjectSet")
def relate_occluding(world, obj):
    """The objects that the object occludes."""
    return world.exists & world.occludees_of(obj)


@register_operation("relate_occluding_part", inputs=["Object"], output="PartSet")
def relate_occluding_part(world, obj):
    """The parts (of other objects) that the object occludes."""
    return world.part_valid & world.parts_occluded_by(obj)


@register_operation("relate_part_occluded", inputs=["Part"], output="ObjectSet")
def relate_part_occluded(world, part):
    """The objects that occlude the part."""
    return world.exists & world.occluders_of_part(part)

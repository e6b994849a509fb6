"""Pose operations: filter and query the facing direction, and pairwise pose relations (spec §1.7, §2.3)."""

from __future__ import annotations

from po3d_ppl import ontology
from po3d_ppl.catalogue import register_world
from po3d_ppl.reasoning import values
from po3d_ppl.reasoning.world import pose_relation_ids


@register_world("filter_pose")
def filter_pose(world, objects, value):
    return objects & (world.pose_label == ontology.POSES.index(value.removesuffix("_pose")))


@register_world("query_pose")
def query_pose(world, obj):
    return world.at(obj).pose_label


def _pose_relation(code: int):
    def relation(world, obj):
        pivot = world.at(obj)
        related = pose_relation_ids(pivot.pose_degree, world.pose_degree) == code
        return world.exists & related & (world.index != pivot.index) & (pivot.pose_label != values.INVALID)
    return relation


for _code, _name in enumerate(("same_pose", "vertical_pose", "opposite_pose")):  # pose_relation_ids' codes
    register_world(_name)(_pose_relation(_code))

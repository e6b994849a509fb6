"""Pose operations: filter and query the facing direction, and pairwise pose relations (spec §1.7, §2.3)."""

from __future__ import annotations

from po3d_ppl.reasoning import values
from po3d_ppl.reasoning.registry import register_operation
from po3d_ppl.reasoning.world import pose_relation_ids
from po3d_ppl.world import ontology


@register_operation("filter_pose", inputs=["ObjectSet"], value="Pose", output="ObjectSet")
def filter_pose(world, objects, value):
    """Objects facing the given direction (``front_pose`` ...); objects in a dead zone match none."""
    return objects & (world.pose_label == ontology.POSES.index(value.removesuffix("_pose")))


@register_operation("query_pose", inputs=["Object"], output="Direction")
def query_pose(world, obj):
    """Direction the object faces (front, back, left, right); invalid in a dead zone."""
    return world.at(obj).pose_label


def _pose_relation(code: int, words: str):
    def relation(world, obj):
        pivot = world.at(obj)
        related = pose_relation_ids(pivot.pose_degree, world.pose_degree) == code
        return world.exists & related & (world.index != pivot.index) & (pivot.pose_label != values.INVALID)

    relation.__doc__ = (
        f"Other objects facing {words} the object (azimuths compared with the 45/135 degree rule); none when the "
        "object itself faces a dead-zone direction."
    )
    return relation


for _name, _code, _words in (("same_pose", 0, "the same direction as"), ("vertical_pose", 1, "perpendicular to"),
                             ("opposite_pose", 2, "opposite to")):
    register_operation(_name, inputs=["Object"], output="ObjectSet")(_pose_relation(_code, _words))

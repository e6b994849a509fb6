"""Public semantics (docs/semantics.md, the public column): what the public Super-CLEVR-3D code computes.

Two halves, kept apart because perception and reasoning need them apart:

- :func:`public_reading` is the scene *as the public annotation records it*: the public file's occlusion entries
  (spec §1.6: one occluder per entity, the largest overlap > 0; a part is annotated as occluded only if its entry
  is kept, with an occluder; an occluded object without an occluder loses all its part entries) and the public
  pose formula (spec §1.7: ``pose_degree = (-rotation + 50) % 360``, 140 for bicycles, the camera ignored). The
  occlusion entries are read from :func:`po3d_ppl.world.scene_io.scene_to_public`, the file we write, so the
  public reading is by construction what a public tool reads. The simulated sensor reads this scene to give the
  evidence of a public-semantics run.
- :data:`PUBLIC_REFERENCE` holds the operations whose *rules* differ (substring filters, ``filter_occluder``
  ignoring its input, ``relate_occluding_part`` keeping only the last part, the broken back sector of the pose
  labels, ``query_pose`` answering ``'None'``, no height/depth relations). Every other operation keeps its
  reference semantics, applied to the public reading.

Row 5 (the part occlusion relation depends on template order) cannot be reproduced as a function of the scene;
we fix the state the public code reaches once an ``object2part`` node has run on the scene: the relation covers
every annotated part (recoloured or occluded), recoloured parts first within an object.
"""

from __future__ import annotations

import dataclasses
from collections import Counter
from collections.abc import Callable, Sequence

from po3d_ppl import ontology
from po3d_ppl.catalogue import REGISTRY
from po3d_ppl.catalogue.semantics import SemanticsError
from po3d_ppl.questions.context import Part, SceneContext
from po3d_ppl.world import scene_io
from po3d_ppl.world.scene import EntityAnnotation, Occlusion, Scene, SceneObject

#: Relations the public scene files hold (spec §1.3: above/below are skipped, closer/farther do not exist).
PUBLIC_RELATIONS = ontology.RELATIONS
#: Steps after which the public ``extra_filter`` skips keys whose scene-wide denotation has at most one member
#: (spec §2.3, with its typo: ``oppo_pose`` is listed, so ``opposite_pose`` is not covered).
PUBLIC_RELATIONAL = frozenset({"same_pose", "vertical_pose", "partfilter_occludee", "filter_occludee",
                               "filter_occluder", "relate_occluding", "relate_occluded"})


# ---- the public reading of a scene ------------------------------------------------------------------------------
def public_pose_degree(obj: SceneObject) -> float:
    """The public ``pose_degree``: the fixed world offset of the public formula on the file's rotation."""
    return scene_io.public_pose_degree(obj.subtype, scene_io.public_rotation(obj.subtype, obj.rotation))


def public_pose_label(degree: float) -> str:
    """The label of the public files (``merge_scene.py``'s broken copy: ``[0, 30]`` is ``'None'``, only
    ``(330, 360)`` is ``back_pose``)."""
    label = ontology.pose_label(degree)
    return ontology.NO_POSE if label == "back_pose" and degree % 360.0 <= 30.0 else label


def _entry_occlusion(entry: list | None, before: Occlusion) -> Occlusion:
    """Occlusion of one entity as its public entry states it (``[level, mask, visible_before, (occluder)]``)."""
    if entry is None:
        return Occlusion(0, before.visible_before, (), {}, False)
    level = int(entry[0])
    if level > 0 and len(entry) == 4:
        return Occlusion(level, before.visible_before, (int(entry[3]),), {}, True)
    return Occlusion(level, before.visible_before, (), {}, False)


def _with(ann: EntityAnnotation | None, entry: list | None) -> EntityAnnotation | None:
    return None if ann is None else dataclasses.replace(ann, occlusion=_entry_occlusion(entry, ann.occlusion))


def public_reading(scene: Scene) -> Scene:
    """The scene as the public annotation records it (see the module docstring)."""
    if not isinstance(scene, Scene):
        raise TypeError(f"public_reading reads a po3d_ppl Scene, got {type(scene).__name__}")
    occlusion = scene_io.scene_to_public(scene).get("occlusion") if scene.has_occlusion else None
    objects = []
    for i, obj in enumerate(scene.objects):
        entries = occlusion.get(str(i), {}) if occlusion else {}
        annotation = _with(obj.annotation, entries.get("obj")) if occlusion else obj.annotation
        parts = ({name: _with(a, entries.get(name)) for name, a in obj.part_annotations.items()} if occlusion
                 else dict(obj.part_annotations))
        objects.append(dataclasses.replace(obj, pose_degree=public_pose_degree(obj), annotation=annotation,
                                           part_annotations=parts))
    return dataclasses.replace(scene, objects=tuple(objects))


# ---- the public rules ---------------------------------------------------------------------------------------------
def public_match(attribute: str | None, value: str) -> bool:
    """The public filter test: ``atr is not None and (value == atr or value in atr)`` (a substring)."""
    return attribute is not None and (value == attribute or value in attribute)


def public_shape_match(subtype: str, value: str) -> bool:
    """Substring on the subtype, then the hypernym (``_shape_hier[atr] == value``)."""
    return public_match(subtype, value) or ontology.category_of(subtype) == value


def public_part_order(ctx: SceneContext, part: Part) -> tuple[int, int, int]:
    """Where the public code meets a part when it builds the part occlusion relation: objects by index, in an
    object its recoloured parts (``complete_parts``) before the occluded ones ``compute_occlusion`` adds, each by
    part id."""
    return part[0], 0 if part in ctx.recoloured else 1, part[1]


#: (operation, input types) -> public reference implementation.
PUBLIC_REFERENCE: dict[tuple[str, tuple[str, ...]], Callable] = {}


def public_reference(name: str, inputs: Sequence[str] | None = None):
    """Attach a public-semantics reference implementation to overload(s) of ``name``."""
    def decorate(fn: Callable) -> Callable:
        for op in REGISTRY.overloads(name):
            if inputs is None or tuple(inputs) == op.inputs:
                PUBLIC_REFERENCE[(op.name, op.inputs)] = fn
        return fn
    return decorate


def public_implementation(op) -> Callable:
    """The reference implementation of ``op`` under public semantics."""
    return PUBLIC_REFERENCE.get((op.name, op.inputs), op.reference_fn)


def _object_filter(attribute: str):
    def run(ctx: SceneContext, objects: frozenset[int], value: str) -> frozenset[int]:
        return frozenset(i for i in objects if public_match(getattr(ctx.objects[i], attribute), value))
    return run


for _attr in ("color", "material", "size"):
    public_reference(f"filter_{_attr}")(_object_filter(_attr))


@public_reference("filter_shape")
def _filter_shape(ctx: SceneContext, objects: frozenset[int], value: str) -> frozenset[int]:
    return frozenset(i for i in objects if public_shape_match(ctx.objects[i].subtype, value))


def _part_attribute(ctx: SceneContext, part: Part, attribute: str) -> str | None:
    if attribute == "partname":
        return ctx.part_names[part]
    if attribute == "size":
        return ctx.owner_size(part)
    style = ctx.part_style(part)
    return None if style is None else getattr(style, attribute)


def _part_filter(attribute: str):
    def run(ctx: SceneContext, parts: frozenset[Part], value: str) -> frozenset[Part]:
        return frozenset(p for p in parts if public_match(_part_attribute(ctx, p, attribute), value))
    return run


for _attr in ("color", "material", "size", "partname"):
    public_reference(f"partfilter_{_attr}")(_part_filter(_attr))


@public_reference("relate")
def _relate(ctx: SceneContext, obj: int, relation: str) -> frozenset[int]:
    if relation not in PUBLIC_RELATIONS:
        raise SemanticsError(f"relate[{relation}] has no public meaning: the public scene files hold only the "
                             f"{', '.join(PUBLIC_RELATIONS)} relationships")
    return ctx.related(obj, relation)


@public_reference("filter_pose")
def _filter_pose(ctx: SceneContext, objects: frozenset[int], value: str) -> frozenset[int]:
    return frozenset(i for i in objects if public_pose_label(ctx.objects[i].pose_degree) == value)


@public_reference("query_pose")
def _query_pose(ctx: SceneContext, obj: int) -> str:
    """``obj['pose'].split('_pose')[0]``: a dead-zone object answers ``'None'``."""
    return public_pose_label(ctx.objects[obj].pose_degree).split("_pose")[0]


def _pose_relation(kind: str):
    def run(ctx: SceneContext, obj: int) -> frozenset[int]:
        ref = ctx.objects[obj]
        label = public_pose_label(ref.pose_degree)
        return frozenset(j for j, o in enumerate(ctx.objects)
                         if j != obj and ontology.pose_relation(ref.pose_degree, label, o.pose_degree) == kind)
    return run


for _name, _kind in (("same_pose", "same"), ("opposite_pose", "opposite"), ("vertical_pose", "vertical")):
    public_reference(_name)(_pose_relation(_kind))


@public_reference("filter_occluder")
def _filter_occluder(ctx: SceneContext, objects: frozenset[int]) -> frozenset[int]:
    """Ignores its input: every object that occludes some object or part."""
    return frozenset(j for j in range(ctx.num_objects) if ctx.occludees_of[j] or ctx.parts_occluded_by[j])


@public_reference("relate_occluding_part")
def _relate_occluding_part(ctx: SceneContext, obj: int) -> frozenset[Part]:
    """``part_occluding[occluder] = [part]`` overwrites: only the last part met is kept."""
    parts = ctx.parts_occluded_by[obj]
    return frozenset((max(parts, key=lambda p: public_part_order(ctx, p)),)) if parts else frozenset()


# ---- the public generator's answer rejection (spec §3.3) ----------------------------------------------------------
def public_rejects(counts: Counter, answer: str) -> bool:
    """Skip an answer whose count exceeds 1.1 x the runner-up or 5 x max(median, 5) (the public rule, only for
    templates with a raw ``relate`` node)."""
    if not counts:
        return False
    ranked = sorted(counts.values(), reverse=True)
    mine = counts.get(answer, 0)
    runner_up = ranked[1] if len(ranked) > 1 else 0
    median = sorted(counts.values())[len(ranked) // 2]
    return mine > 1.1 * runner_up or mine > 5 * max(median, 5)

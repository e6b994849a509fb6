"""Per-scene facts the reference semantics need, validated and indexed once per scene.

The executor and the question generator run many programs on the same scene; building the part ids, the
inverse occlusion maps and the validity checks here keeps each operation a one-line set comprehension and makes a
malformed scene fail once, with the field that is wrong.

Occlusion is read the way the scene record defines it: the *state* (``Occlusion.occluded``, what
``filter_occludee`` asks) and the *occluders* (``occluded_by``, what the relations ask) are separate fields. The
world keeps ``occluded == bool(occluded_by)``; reading each field for its own purpose keeps the reference
semantics identical to the reasoning engine's, which holds them as separate latents.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from po3d_ppl import ontology
from po3d_ppl.catalogue.semantics import DEFAULT_SEMANTICS, PUBLIC, check_semantics
from po3d_ppl.errors import SceneFormatError
from po3d_ppl.world.scene import RELATION_EPS, Scene, SceneObject

Part = tuple[int, int]


class SceneContext:
    """A ground-truth scene plus the indices the reference operations read.

    Under ``semantics="public"`` the indices are those of the scene's public reading
    (:func:`po3d_ppl.questions.public.public_reading`: one occluder per entity, the public part annotations, the
    public pose formula); ``scene`` is then that reading.
    """

    def __init__(self, scene: Scene, semantics: str = DEFAULT_SEMANTICS):
        if not isinstance(scene, Scene):
            raise SceneFormatError(f"expected a po3d_ppl Scene, got {type(scene).__name__}")
        self.semantics = check_semantics(semantics)
        if semantics == PUBLIC:
            from po3d_ppl.questions.public import public_reading  # the public module builds on this one

            for i, obj in enumerate(scene.objects):  # before the public reading, which needs known subtypes
                if obj.subtype not in ontology.PARTS:
                    raise SceneFormatError(f"objects[{i}].shape: unknown subtype {obj.subtype!r} (known: "
                                           f"{', '.join(ontology.SUBTYPES)})")

            scene = public_reading(scene)
        self.scene = scene
        self.objects: tuple[SceneObject, ...] = scene.objects
        self.num_objects = n = len(scene.objects)
        self.all_objects: frozenset[int] = frozenset(range(n))
        recoloured: dict[Part, str] = {}
        occluded_parts: set[Part] = set()
        part_occluders: dict[Part, tuple[int, ...]] = {}
        self.part_names: dict[Part, str] = {}
        for i, obj in enumerate(self.objects):
            where = f"objects[{i}]"
            if obj.subtype not in ontology.PARTS:
                raise SceneFormatError(
                    f"{where}.shape: unknown subtype {obj.subtype!r} (known: {', '.join(ontology.SUBTYPES)})"
                )
            for field, value, vocab in (("color", obj.color, ontology.COLORS), ("material", obj.material,
                                        ontology.MATERIALS), ("size", obj.size, ontology.SIZES)):
                if value not in vocab:
                    raise SceneFormatError(f"{where}.{field}: unknown value {value!r} (known: {', '.join(vocab)})")
            names = ontology.PARTS[obj.subtype]
            for raw, style in obj.parts.items():
                if raw not in names:
                    raise SceneFormatError(f"{where}.parts: {raw!r} is not a part of {obj.subtype}")
                if style.color not in ontology.COLORS or style.material not in ontology.MATERIALS:
                    raise SceneFormatError(f"{where}.parts.{raw}: bad colour/material {style!r}")
                recoloured[(i, names.index(raw))] = raw
            self._check_occluders(f"{where}.occlusion", obj.occluded_by, i)
            for raw, ann in obj.part_annotations.items():
                if raw not in names:
                    raise SceneFormatError(f"{where}.part_annotations: {raw!r} is not a part of {obj.subtype}")
                by = ann.occlusion.occluded_by
                self._check_occluders(f"{where}.part_annotations.{raw}", by, i)
                if by:
                    part_occluders[(i, names.index(raw))] = tuple(by)
                if ann.occlusion.occluded:
                    occluded_parts.add((i, names.index(raw)))
            for p, raw in enumerate(names):
                self.part_names[(i, p)] = raw
        for rel in ontology.RELATIONS:
            rows = scene.relationships.get(rel)
            if rows is None or len(rows) != n:
                raise SceneFormatError(f"relationships.{rel}: expected one list per object ({n}), got "
                                       f"{'none' if rows is None else len(rows)}")
            for i, row in enumerate(rows):
                if any(not 0 <= j < n or j == i for j in row):
                    raise SceneFormatError(f"relationships.{rel}[{i}]: indices must name other objects, got {row}")
        #: recoloured part -> raw name
        self.recoloured = recoloured
        #: parts whose occlusion state is "occluded" (what partfilter_occludee asks)
        self.occluded_parts = frozenset(occluded_parts)
        #: part -> objects occluding it (non-empty entries only)
        self.part_occluders = part_occluders
        occludees: dict[int, set[int]] = {j: set() for j in range(n)}
        for i, obj in enumerate(self.objects):
            for j in obj.occluded_by:
                occludees[j].add(i)
        #: object j -> objects that j occludes
        self.occludees_of = {j: frozenset(s) for j, s in occludees.items()}
        parts_by: dict[int, set[Part]] = {j: set() for j in range(n)}
        for part, by in part_occluders.items():
            for j in by:
                parts_by[j].add(part)
        #: object j -> parts that j occludes
        self.parts_occluded_by = {j: frozenset(s) for j, s in parts_by.items()}
        self.recoloured_of = {i: frozenset(p for p in recoloured if p[0] == i) for i in range(n)}
        self.parts_all_of = {
            i: self.recoloured_of[i] | frozenset(p for p in occluded_parts if p[0] == i) for i in range(n)
        }
        #: every part some operation can return (object2part_all of all objects, and occluded parts)
        self.reachable_parts = frozenset(recoloured) | self.occluded_parts | frozenset(part_occluders)

    def _check_occluders(self, where: str, by: tuple[int, ...], owner: int) -> None:
        for j in by:
            if not isinstance(j, (int, np.integer)) or not 0 <= j < self.num_objects or j == owner:
                raise SceneFormatError(f"{where}.occluded_by: {j!r} does not name another object of the scene")

    @cached_property
    def heights(self) -> np.ndarray:
        return np.array([o.position[2] for o in self.objects], dtype=np.float64)

    @cached_property
    def depths(self) -> np.ndarray:
        """Camera depth of each object (``pixel_coords[2]``), projected from the camera when not stored."""
        out = np.empty(self.num_objects, dtype=np.float64)
        for i, obj in enumerate(self.objects):
            if obj.pixel_coords is not None:
                out[i] = obj.pixel_coords[2]
            elif self.scene.camera is not None:
                out[i] = self.scene.camera.project(np.asarray(obj.position))[2]
            else:
                raise SceneFormatError(
                    f"objects[{i}].pixel_coords: needed for closer/farther relations but missing (and no camera)"
                )
        return out

    def related(self, i: int, relation: str) -> frozenset[int]:
        """Objects in spatial ``relation`` to object i (never i itself)."""
        if relation in ontology.RELATIONS:
            return frozenset(self.scene.relationships[relation][i])
        if relation in ("above", "below"):
            offset = self.heights - self.heights[i]
            if relation == "below":
                offset = -offset
        else:  # closer / farther
            offset = self.depths - self.depths[i]
            if relation == "closer":
                offset = -offset
        return frozenset(int(j) for j in np.flatnonzero(offset > RELATION_EPS) if j != i)

    def owner_size(self, part: Part) -> str | None:
        """A recoloured part carries its owner's size; other parts have none."""
        return self.objects[part[0]].size if part in self.recoloured else None

    def part_style(self, part: Part):
        raw = self.recoloured.get(part)
        return None if raw is None else self.objects[part[0]].parts[raw]

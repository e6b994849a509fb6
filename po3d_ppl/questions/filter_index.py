"""Denotations of every filter key of one scene, as bitmasks (spec §3.3's "filter options").

Like the public generator we precompute, per scene, which objects (or parts) each attribute value selects, so that
the generator's depth-first search tries hundreds of filter keys with a few integer ANDs instead of re-running
filter programs. Objects are bits of a Python int by index; parts are bits in :attr:`FilterIndex.parts` order (the
parts any program can reach: recoloured or occluded ones). Keys are tuples of values (``None`` = no filter on that
slot) aligned with a tuple of slot types such as ``("Size", "Color", "Material", "Shape")``.

Part names are indexed under every canonical value that selects them (``ontology.canonical_names_selecting``:
``wheel_back_left`` on a bus is filed under ``back_left_wheel``, the name that reads the same, and ``wheel``; a bus's
``head_light_left`` also under ``headlight_left`` and ``headlight``, since spaced and joined forms are one word), so
generated programs use one spelling per wording, the program is a function of the question text and the index
agrees with the executor on what is unique.

Under public semantics (``ctx.semantics == "public"``) denotations follow the public rules instead: values are
the scene's own values (raw part names as they are, and super-part names), a value selects every member whose
attribute contains it (the public substring test) and poses carry the public labels.
"""

from __future__ import annotations

from collections.abc import Iterable

from po3d_ppl import ontology
from po3d_ppl.catalogue.semantics import PUBLIC
from po3d_ppl.questions.context import Part, SceneContext

Key = tuple[str | None, ...]


class FilterIndex:
    def __init__(self, ctx: SceneContext):
        self.all_objects = (1 << ctx.num_objects) - 1
        self.object_values: dict[str, dict[str, int]] = {t: {} for t in ("Pose", "Size", "Color", "Material",
                                                                          "Shape")}
        for i, o in enumerate(ctx.objects):
            bit = 1 << i
            for slot, value in (("Size", o.size), ("Color", o.color), ("Material", o.material),
                                ("Shape", o.subtype), ("Shape", o.category), ("Pose", o.pose)):
                if value != ontology.NO_POSE:
                    self.object_values[slot][value] = self.object_values[slot].get(value, 0) | bit
        self.parts: tuple[Part, ...] = tuple(sorted(ctx.reachable_parts))
        self.part_bit = {p: 1 << k for k, p in enumerate(self.parts)}
        self.all_parts = (1 << len(self.parts)) - 1
        self.part_values: dict[str, dict[str, int]] = {t: {} for t in ("Size", "Color", "Material", "Partname")}
        for p, bit in self.part_bit.items():
            raw = ctx.part_names[p]
            style = ctx.part_style(p)
            pairs = [("Partname", value) for value in ontology.canonical_names_selecting(raw)]
            if style is not None:
                pairs += [("Size", ctx.objects[p[0]].size), ("Color", style.color), ("Material", style.material)]
            for slot, value in pairs:
                self.part_values[slot][value] = self.part_values[slot].get(value, 0) | bit
        self._keys: dict[tuple, dict[Key, int]] = {}
        if ctx.semantics == PUBLIC:
            self._public_denotations(ctx)

    def _public_denotations(self, ctx: SceneContext) -> None:
        """Re-file every value by the public rules (substring tests, public pose labels, raw part names)."""
        from po3d_ppl.questions.public import public_match, public_pose_label, public_shape_match

        objects = list(enumerate(ctx.objects))
        tests = {"Size": lambda o, v: public_match(o.size, v), "Color": lambda o, v: public_match(o.color, v),
                 "Material": lambda o, v: public_match(o.material, v),
                 "Shape": lambda o, v: public_shape_match(o.subtype, v)}
        for slot, test in tests.items():
            self.object_values[slot] = {
                v: m for v in self.object_values[slot]
                if (m := sum(1 << i for i, o in objects if test(o, v)))}
        poses: dict[str, int] = {}
        for i, o in objects:
            label = public_pose_label(o.pose_degree)
            if label != ontology.NO_POSE:
                poses[label] = poses.get(label, 0) | 1 << i
        self.object_values["Pose"] = poses
        names = {v for p in self.parts for v in (ctx.part_names[p], ontology.super_part_name(ctx.part_names[p]))}
        self.part_values["Partname"] = {
            v: m for v in sorted(names)
            if (m := sum(bit for p, bit in self.part_bit.items() if public_match(ctx.part_names[p], v)))}
        for slot in ("Size", "Color", "Material"):
            attribute = slot.lower()
            values = self.part_values[slot]
            for v in list(values):
                values[v] = 0
                for p, bit in self.part_bit.items():
                    style = ctx.part_style(p)
                    own = None if style is None else (ctx.objects[p[0]].size if slot == "Size"
                                                      else getattr(style, attribute))
                    if public_match(own, v):
                        values[v] |= bit

    # ---- conversions -------------------------------------------------------------------------------------------
    def object_mask(self, objects: Iterable[int]) -> int:
        mask = 0
        for i in objects:
            mask |= 1 << i
        return mask

    def part_mask(self, parts: Iterable[Part]) -> int:
        mask = 0
        for p in parts:
            mask |= self.part_bit[p]
        return mask

    def objects_of(self, mask: int) -> frozenset[int]:
        out, i = [], 0
        while mask:
            if mask & 1:
                out.append(i)
            mask >>= 1
            i += 1
        return frozenset(out)

    def parts_of(self, mask: int) -> frozenset[Part]:
        out, k = [], 0
        while mask:
            if mask & 1:
                out.append(self.parts[k])
            mask >>= 1
            k += 1
        return frozenset(out)

    def values(self, part_level: bool, slot: str) -> dict[str, int]:
        return (self.part_values if part_level else self.object_values)[slot]

    # ---- keys --------------------------------------------------------------------------------------------------
    def keys(self, part_level: bool, slots: tuple[str, ...], forced_null: tuple[bool, ...],
             within: int | None = None) -> dict[Key, int]:
        """Every key (null slots where forced) with a non-empty denotation inside ``within`` (default: all)."""
        full = self.all_parts if part_level else self.all_objects
        within = full if within is None else within
        cache_key = (part_level, slots, forced_null, within)
        found = self._keys.get(cache_key)
        if found is not None:
            return found
        tables = [self.values(part_level, s) for s in slots]
        out: dict[Key, int] = {}
        key: list[str | None] = []

        def walk(k: int, mask: int) -> None:
            if k == len(slots):
                out[tuple(key)] = mask
                return
            key.append(None)
            walk(k + 1, mask)
            key.pop()
            if forced_null[k]:
                return
            for value, vmask in tables[k].items():
                m = mask & vmask
                if m:
                    key.append(value)
                    walk(k + 1, m)
                    key.pop()

        if within:
            walk(0, within)
        self._keys[cache_key] = out
        return out

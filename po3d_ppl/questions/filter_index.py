"""Denotations of every filter key of one scene, as bitmasks (spec §3.3's "filter options").

Like the public generator we precompute, per scene, which objects (or parts) each attribute value selects, so that
the generator's depth-first search tries hundreds of filter keys with a few integer ANDs instead of re-running
filter programs. Objects are bits of a Python int by index; parts are bits in :attr:`FilterIndex.parts` order (the
parts any program can reach: recoloured or occluded ones). Keys are tuples of values (``None`` = no filter on that
slot) aligned with a tuple of slot types such as ``("Size", "Color", "Material", "Shape")``.

Part names are indexed under their canonical spelling (``ontology.canonical_part_name``: ``wheel_back_left`` on a
bus is filed under ``back_left_wheel``, the name that reads the same) and their super-part name, so generated
programs use one spelling per wording and the program is a function of the question text.
"""

from __future__ import annotations

from collections.abc import Iterable

from po3d_ppl import ontology
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
            pairs = [("Partname", ontology.canonical_part_name(raw)), ("Partname", ontology.super_part_name(raw))]
            if style is not None:
                pairs += [("Size", ctx.objects[p[0]].size), ("Color", style.color), ("Material", style.material)]
            for slot, value in pairs:
                self.part_values[slot][value] = self.part_values[slot].get(value, 0) | bit
        self._keys: dict[tuple, dict[Key, int]] = {}

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

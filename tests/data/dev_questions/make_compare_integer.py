#!/usr/bin/env python
"""Extra DEV questions for CLEVR integer comparison (greater_than / less_than / equal_integer over two counts).

MODEL SELECTION ONLY (see README.md). Written without reading the question templates or the realiser: the phrase
lists below are this file's own, from how people and the public CLEVR dataset word integer comparisons. Each count
side is any filter chain: attributes, a relation to a unique object, occlusion, or a recoloured part.

    python tests/data/dev_questions/make_compare_integer.py      # compare_integer_extra.jsonl (deterministic)
"""

from __future__ import annotations

import random
import sys
from collections import Counter
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import make_set as ms

from po3d_ppl import ontology as ont

N = 180
SEED = 13

SIZE = {"large": ["large", "big"], "small": ["small", "tiny"]}
MAT = {"metal": ["metal", "metallic", "shiny"], "rubber": ["rubber", "matte"]}
SUB = {s: [ms.SUB_W[s][0][0]] for s in ont.SUBTYPES if s in ms.SUB_W}
SUB["dirtbike"] = ["dirt bike", "dirtbike"]
SUB["double"] = ["double bus", "double-decker bus"]
CAT = {"car": ["car"], "bus": ["bus"], "motorbike": ["motorbike", "motorcycle"], "aeroplane": ["aeroplane",
       "airplane", "plane"], "bicycle": ["bicycle", "bike"]}
THING = ["thing", "object", "vehicle"]
REL = {"left": ["left of", "to the left of", "on the left side of"],
       "right": ["right of", "to the right of", "on the right side of"],
       "behind": ["behind"], "front": ["in front of"]}
OCC = ["occluded", "partially occluded", "hidden"]

# {X} / {Y}: plural noun phrases. (op, template)
T = [
    ("greater_than", "Are there more {X} than {Y}?"),
    ("greater_than", "Are there more {X} than there are {Y}?"),
    ("greater_than", "Is the number of {X} greater than the number of {Y}?"),
    ("greater_than", "Is the number of {X} larger than the number of {Y}?"),
    ("greater_than", "Is the number of {X} bigger than the number of {Y}?"),
    ("greater_than", "Is the number of {X} more than the number of {Y}?"),
    ("greater_than", "Do the {X} outnumber the {Y}?"),
    ("greater_than", "Is the count of {X} greater than the count of {Y}?"),
    ("greater_than", "Is the count of {X} higher than that of {Y}?"),
    ("greater_than", "Are the {X} more numerous than the {Y}?"),
    ("greater_than", "Is there a greater number of {X} than {Y}?"),
    ("greater_than", "Are {X} more common than {Y}?"),
    ("greater_than", "Does the scene contain more {X} than {Y}?"),
    ("greater_than", "Are there more {X} in the picture than {Y}?"),
    ("greater_than", "Is the number of {X} greater than that of {Y}?"),
    ("less_than", "Are there fewer {X} than {Y}?"),
    ("less_than", "Are there less {X} than {Y}?"),
    ("less_than", "Are there fewer {X} than there are {Y}?"),
    ("less_than", "Is the number of {X} less than the number of {Y}?"),
    ("less_than", "Is the number of {X} smaller than the number of {Y}?"),
    ("less_than", "Is the number of {X} lower than the number of {Y}?"),
    ("less_than", "Is the number of {X} fewer than the number of {Y}?"),
    ("less_than", "Is the count of {X} smaller than the count of {Y}?"),
    ("less_than", "Is the count of {X} less than that of {Y}?"),
    ("less_than", "Do the {Y} outnumber the {X}?"),
    ("less_than", "Are the {X} outnumbered by the {Y}?"),
    ("less_than", "Is there a smaller number of {X} than {Y}?"),
    ("less_than", "Are there fewer {X} in the image than {Y}?"),
    ("less_than", "Are {X} less common than {Y}?"),
    ("equal_integer", "Are there the same number of {X} and {Y}?"),
    ("equal_integer", "Are there an equal number of {X} and {Y}?"),
    ("equal_integer", "Is the number of {X} equal to the number of {Y}?"),
    ("equal_integer", "Is the number of {X} the same as the number of {Y}?"),
    ("equal_integer", "Are there as many {X} as {Y}?"),
    ("equal_integer", "Are there as many {X} as there are {Y}?"),
    ("equal_integer", "Is the count of {X} equal to the count of {Y}?"),
    ("equal_integer", "Is there the same number of {X} as {Y}?"),
    ("equal_integer", "Is there an equal number of {X} and {Y}?"),
    ("equal_integer", "Do the {X} and the {Y} have the same count?"),
    ("equal_integer", "Are the numbers of {X} and {Y} equal?"),
    ("equal_integer", "Is the number of {X} the same as that of {Y}?"),
    ("equal_integer", "Are there exactly as many {X} as {Y}?"),
    ("equal_integer", "Does the number of {X} equal the number of {Y}?"),
]


def pl(word: str) -> str:
    return ms.plural(word, random.Random(0), False)[0]


class G:
    def __init__(self, rng, worlds):
        self.rng, self.worlds = rng, worlds

    def c(self, seq):
        return self.rng.choice(list(seq))

    def adjs(self, d):
        out = []
        if "size" in d:
            out.append(self.c(SIZE[d["size"]]))
        if "color" in d:
            out.append("grey" if d["color"] == "gray" and self.rng.random() < 0.3 else d["color"])
        if "material" in d:
            out.append(self.c(MAT[d["material"]]))
        return out

    def noun(self, d):
        if "shape" in d:
            s = d["shape"]
            return self.c(CAT[s]) if s in CAT else self.c(SUB[s])
        return self.c(THING)

    def plural_np(self, d, extra_adj=()):
        """Plural words for an attribute description (no article)."""
        adjs = list(extra_adj) + self.adjs(d)
        n = pl(self.noun(d))
        if "material" in d and self.rng.random() < 0.25 and "shape" in d:
            adjs = [a for a in adjs if a not in MAT[d["material"]]]
            return " ".join(adjs + [n]) + f" made of {d['material']}"
        return " ".join(adjs + [n])

    def rand_desc(self, w, cands, require_nonempty=False):
        """A random description true of a random object of cands (1-3 slots)."""
        i = self.c(sorted(cands))
        o = w.objs[i]
        slots = [s for s in ("size", "color", "material", "shape") if self.rng.random() < 0.45]
        if not slots:
            slots = [self.c(("color", "shape", "material", "size"))]
        d = {}
        for s in slots:
            if s == "shape":
                d[s] = self.c([o.subtype, o.cat, o.cat])
            else:
                d[s] = o.val(s)
        return ms.order(d)

    def unique_desc(self, w, i):
        """The shortest unique description of object i (attributes only)."""
        o = w.objs[i]
        best = None
        for d in ms.all_descs(o, ("size", "color", "material", "shape")):
            if not d:
                continue
            if ms.denote(w, d, w.all) == {i} and (
                    best is None or len(d) < len(best) or (len(d) == len(best) and self.rng.random() < 0.5)):
                best = d
        return ms.order(best) if best else None

    def side(self, w):
        """One count side: (text, program pipeline)."""
        kind = self.rng.choices(["attr", "rel", "occ", "part"], [0.55, 0.2, 0.12, 0.13])[0]
        if kind == "rel":
            i = self.c(sorted(w.all))
            du = self.unique_desc(w, i)
            if du is None:
                return self.side(w)
            r = self.c(ms.ont.RELATIONS)
            R = w.rel[r][i]
            d = self.rand_desc(w, R) if R and self.rng.random() < 0.8 else self.rand_desc(w, w.all)
            ref = " ".join(self.adjs(du) + [self.noun(du)])
            phr = self.c(REL[r])
            text = self.c([f"{self.plural_np(d)} {phr} the {ref}",
                           f"{self.plural_np(d)} that are {phr} the {ref}"])
            prog = f"scene(){ms.filters(du)} | unique | relate[{r}]{ms.filters(d)}"
            return text, prog
        if kind == "occ":
            occ = [o.i for o in w.objs if o.occluded]
            if not occ:
                return self.side(w)
            d = self.rand_desc(w, occ)
            a = self.c(OCC)
            if self.rng.random() < 0.6:
                text = self.plural_np(d, extra_adj=[a])
            else:
                text = f"{self.plural_np(d)} that are {a}"
            return text, f"scene() | filter_occludee{ms.filters(d)}"
        if kind == "part":
            owners = [o for o in w.objs if o.parts]
            if not owners:
                return self.side(w)
            o = self.c(owners)
            raw = self.c(sorted(o.parts))
            col, mat = o.parts[raw]
            sup = ont.super_part_name(raw)
            use_color = self.rng.random() < 0.7
            pw = sup.replace("_", " ")
            if use_color:
                pf, adj = f" | partfilter_color[{col}]", col
            else:
                pf, adj = f" | partfilter_material[{mat}]", self.c(MAT[mat])
            # the owners: any description true of o
            d = {}
            if self.rng.random() < 0.5:
                d = {"shape": o.cat}
            noun = pl(self.noun(d))
            art = "an" if adj[0] in "aeiou" else "a"
            text = self.c([f"{noun} that have {art} {adj} {pw}", f"{noun} with {art} {adj} {pw}",
                           f"{noun} with {adj} {pl(pw)}"])
            prog = f"scene() | object2part{pf} | partfilter_partname[{sup}] | part2object{ms.filters(d)}"
            return text, prog
        d = self.rand_desc(w, w.all) if self.rng.random() < 0.85 else {}
        if not d:
            return pl(self.c(THING)), "scene()"
        return self.plural_np(d), f"scene(){ms.filters(d)}"

    def one(self):
        w = self.c(self.worlds)
        op, t = self.c(T)
        xa, xp = self.side(w)
        ya, yp = self.side(w)
        if xp == yp:
            raise ms.NoQuestion("same")
        q = t.format(X=xa, Y=ya)
        prog = f"{op}(count({xp}), count({yp}))"
        return q, prog, op, w, t


def main() -> None:
    rng = random.Random(SEED)
    worlds = ms.load_worlds()
    g = G(rng, worlds)
    out, seen, answers = [], set(), Counter()
    tries = 0
    while len(out) < N:
        tries += 1
        assert tries < 100000
        try:
            q, prog, op, w, t = g.one()
        except ms.NoQuestion:
            continue
        res = ms.run_program(w.scene, prog)
        if not res.valid:
            continue
        ans = ms.jsonable(res.answer)
        if answers[(op, ans)] - answers[(op, not ans)] >= 2:
            continue
        if (q.lower(), w.path) in seen:
            continue
        notes = [f"form: {t}"]
        if rng.random() < 0.06:
            typo = ms.make_typo(q, rng)
            if typo:
                q, note = typo
                notes.append(note)
        seen.add((q.lower(), w.path))
        answers[(op, ans)] += 1
        out.append({"id": f"c{len(out):05d}", "question": q, "program": prog, "family_group": "core_compare_integer",
                    "family": f"compare_integer_{op}", "scene": w.path, "answer": ans,
                    "phrasing_notes": "; ".join(notes)})
    ms.write_jsonl(HERE / "compare_integer_extra.jsonl", out)
    print(f"{len(out)} questions; answers {dict(answers)}")


if __name__ == "__main__":
    main()

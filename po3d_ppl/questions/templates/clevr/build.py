"""Writes the CLEVR-core template files of this folder (``python -m po3d_ppl.questions.templates.clevr.build``).

The 90 families follow the structure of CLEVR's nine template files (zero/one/two/three-hop, single and/or,
integer comparison, attribute comparison, same-relate); programs use our operations and the wording is ours. The
question parser's corpus (:mod:`po3d_ppl.questions.parser_corpus`) instantiates them; dataset builds do not (the
question files of a build are fixed by ``question_sets.py``).
"""

from __future__ import annotations

import json
from pathlib import Path

ATTRS = ("size", "color", "material", "shape")
LETTER = {"size": "Z", "color": "C", "material": "M", "shape": "S"}
TYPE = {"Z": "Size", "C": "Color", "M": "Material", "S": "Shape"}


class _T:
    def __init__(self):
        self.nodes, self.params, self.constraints = [], [], []

    def add(self, type_, inputs=(), side=None):
        node = {"type": type_, "inputs": list(inputs)}
        if side:
            node["side_inputs"] = side
        self.nodes.append(node)
        return len(self.nodes) - 1

    def obj(self, d: str):
        keys = [f"<{x}{d}>" for x in "ZCMS"]
        for k, x in zip(keys, "ZCMS"):
            self.params.append({"type": TYPE[x], "name": k})
        return keys

    def rel(self, d: str):
        name = f"<R{d}>"
        self.params.append({"type": "Relation", "name": name, "values": ["left", "right", "behind", "front"]})
        return name

    def null(self, *names):
        self.constraints.append({"type": "NULL", "params": list(names)})

    def done(self, texts):
        return {"text": texts, "nodes": self.nodes, "params": self.params, "constraints": self.constraints}


def np(d: str) -> str:
    return f"<Z{d}> <C{d}> <M{d}> <S{d}>"


def np_without(d: str, attr: str) -> str:
    """The noun phrase without ``attr``'s slot; without the shape slot the noun is "thing" (as CLEVR says it)."""
    words = " ".join(f"<{x}{d}>" for x in "ZCMS" if x != LETTER[attr])
    return words + " thing" if attr == "shape" else words


QUERY_TEXT = {
    "size": ["What size is {x}?", "How big is {x}?", "What is the size of {x}?"],
    "color": ["What color is {x}?", "What is the color of {x}?", "{X} has what color?"],
    "material": ["What material is {x}?", "What is {x} made of?", "{X} is made of what material?"],
    "shape": ["What shape is {x}?", "What kind of vehicle is {x}?", "What is the shape of {x}?"],
}


def _fmt(texts, **kw):
    out = []
    for t in texts:
        kw2 = dict(kw)
        if "x" in kw:
            kw2["X"] = kw["x"][:1].upper() + kw["x"][1:]
        out.append(t.format(**kw2))
    return out


def hop_families(hops: int) -> list[dict]:
    """count, exist, query x4 after ``hops`` relations (zero_hop: a plain filter)."""
    out = []
    for kind in ("count", "exist", *ATTRS):
        t = _T()
        s = t.add("scene")
        digits = [str(i) if i > 1 else "" for i in range(1, hops + 2)]
        keys = t.obj(digits[0])
        if hops == 0:
            if kind in ("count", "exist"):
                t.add(f"filter_{kind}", [s], keys)
                texts = ({"count": ["How many {a}s are there?", "What number of {a}s are there?"],
                          "exist": ["Are there any {a}s?", "Is there a {a}?"]}[kind])
                out.append(t.done(_fmt(texts, a=np(""))))
            else:
                u = t.add("filter_unique", [s], keys)
                t.add(f"query_{kind}", [u])
                t.null(f"<{LETTER[kind]}>")
                out.append(t.done(_fmt(QUERY_TEXT[kind], x="the " + np_without("", kind))))
            continue
        cur = t.add("filter_unique", [s], keys)
        phrase = f"the {np(digits[0])}"
        rels = []
        for h in range(1, hops + 1):
            r = t.rel(digits[h - 1])
            rels.append(r)
            keys = t.obj(digits[h])
            last = h == hops
            if not last:
                cur = t.add("relate_filter_unique", [cur], [r, *keys])
                phrase = f"the {np(digits[h])} [that is ]{r} {phrase}"
                continue
            if kind in ("count", "exist"):
                t.add(f"relate_filter_{kind}", [cur], [r, *keys])
                texts = {"count": [f"How many {np(digits[h])}s are {r} {phrase}?",
                                   f"What number of {np(digits[h])}s are {r} {phrase}?"],
                         "exist": [f"Are there any {np(digits[h])}s {r} {phrase}?",
                                   f"Is there a {np(digits[h])} {r} {phrase}?"]}[kind]
                out.append(t.done(texts))
            else:
                u = t.add("relate_filter_unique", [cur], [r, *keys])
                t.add(f"query_{kind}", [u])
                t.null(f"<{LETTER[kind]}{digits[h]}>")
                x = f"the {np_without(digits[h], kind)} [that is ]{r} {phrase}"
                out.append(t.done(_fmt(QUERY_TEXT[kind], x=x)))
    return out


def single_and() -> list[dict]:
    out = []
    for kind in ("count", "exist", *ATTRS):
        t = _T()
        s = t.add("scene")
        a = t.add("filter_unique", [s], t.obj(""))
        r = t.rel("")
        ra = t.add("relate", [a], [r])
        b = t.add("filter_unique", [s], t.obj("2"))
        r2 = t.rel("2")
        rb = t.add("relate", [b], [r2])
        both = t.add("intersect", [ra, rb])
        keys = t.obj("3")
        where = f"{r} the {np('')} and {r2} the {np('2')}"
        if kind in ("count", "exist"):
            t.add(f"filter_{kind}", [both], keys)
            texts = {"count": [f"How many {np('3')}s are both {where}?", f"What number of {np('3')}s are {where}?"],
                     "exist": [f"Are there any {np('3')}s that are {where}?", f"Is there a {np('3')} {where}?"]}[kind]
        else:
            u = t.add("filter_unique", [both], keys)
            t.add(f"query_{kind}", [u])
            t.null(f"<{LETTER[kind]}3>")
            texts = _fmt(QUERY_TEXT[kind], x=f"the {np_without('3', kind)} that is {where}")
        t.constraints.append({"type": "OUT_NEQ", "params": [a, b]})
        out.append(t.done(texts))
    for attr in ATTRS:
        t = _T()
        s = t.add("scene")
        a = t.add("filter_unique", [s], t.obj(""))
        r = t.rel("")
        ra = t.add("relate", [a], [r])
        b = t.add("filter_unique", [s], t.obj("2"))
        sb = t.add(f"same_{attr}", [b])
        both = t.add("intersect", [ra, sb])
        t.add("count", [both])
        t.null(f"<{LETTER[attr]}2>")
        texts = [f"How many things are {r} the {np('')} and the same {attr} as the {np_without('2', attr)}?",
                 (f"What number of objects are {r} the {np('')} and have the same {attr} as the "
                 f"{np_without('2', attr)}?")]
        out.append(t.done(texts))
    return out


def single_or() -> list[dict]:
    out = []
    for kind in ("count", "exist"):
        t = _T()
        s = t.add("scene")
        a = t.add("filter", [s], t.obj(""))
        b = t.add("filter", [s], t.obj("2"))
        u = t.add("union", [a, b])
        t.add(kind, [u])
        t.constraints += [{"type": "OUT_NEQ", "params": [a, b]},
                          {"type": "NOT_ALL_NULL", "params": ["<Z>", "<C>", "<M>", "<S>"]},
                          {"type": "NOT_ALL_NULL", "params": ["<Z2>", "<C2>", "<M2>", "<S2>"]}]
        texts = {"count": [f"How many things are {np('')}s or {np('2')}s?",
                           f"How many {np('')}s or {np('2')}s are there?"],
                 "exist": [f"Are there any {np('')}s or {np('2')}s?",
                           f"Is there a {np('')} or a {np('2')}?"]}[kind]
        out.append(t.done(texts))
    for kind in ("count", "exist"):
        t = _T()
        s = t.add("scene")
        a = t.add("filter_unique", [s], t.obj(""))
        r = t.rel("")
        ra = t.add("relate", [a], [r])
        b = t.add("filter_unique", [s], t.obj("2"))
        r2 = t.rel("2")
        rb = t.add("relate", [b], [r2])
        u = t.add("union", [ra, rb])
        t.add(f"filter_{kind}", [u], t.obj("3"))
        t.constraints.append({"type": "OUT_NEQ", "params": [a, b]})
        texts = {"count": [f"How many {np('3')}s are {r} the {np('')} or {r2} the {np('2')}?",
                           f"What number of {np('3')}s are either {r} the {np('')} or {r2} the {np('2')}?"],
                 "exist": [f"Are there any {np('3')}s {r} the {np('')} or {r2} the {np('2')}?",
                           f"Is there a {np('3')} that is {r} the {np('')} or {r2} the {np('2')}?"]}[kind]
        out.append(t.done(texts))
    return out


def compare_integer() -> list[dict]:
    words = {"equal_integer": ("Are there the same number of {a} and {b}?", "Are there as many {a} as {b}?"),
             "less_than": ("Are there fewer {a} than {b}?", "Is the number of {a} less than the number of {b}?"),
             "greater_than": ("Are there more {a} than {b}?",
                              "Is the number of {a} greater than the number of {b}?")}
    out = []
    for op, texts in words.items():
        for first_rel, second_rel in ((False, False), (True, False), (False, True), (True, True)):
            t = _T()
            s = t.add("scene")
            counts, phrases, heads = [], [], []
            for k, (rel, d, ad) in enumerate(((first_rel, "", "3"), (second_rel, "2", "4"))):
                if rel:
                    a = t.add("filter_unique", [s], t.obj(ad))
                    r = t.rel(ad)
                    c = t.add("relate_filter_count", [a], [r, *t.obj(d)])
                    phrases.append(f"{np(d)}s {r} the {np(ad)}")
                else:
                    f = t.add("filter", [s], t.obj(d))
                    c = t.add("count", [f])
                    heads.append(f)
                    phrases.append(f"{np(d)}s")
                counts.append(c)
            t.add(op, counts)
            if len(heads) == 2:
                t.constraints.append({"type": "OUT_NEQ", "params": heads})
            t.constraints.append({"type": "NOT_ALL_NULL", "params": ["<Z>", "<C>", "<M>", "<S>"]})
            t.constraints.append({"type": "NOT_ALL_NULL", "params": ["<Z2>", "<C2>", "<M2>", "<S2>"]})
            out.append(t.done([x.format(a=phrases[0], b=phrases[1]) for x in texts]))
    return out


def comparison() -> list[dict]:
    out = []
    for attr in ATTRS:
        for variant in ("plain", "rel_first", "rel_second", "rel_both", "two_hop_first"):
            t = _T()
            s = t.add("scene")
            phrases, queried = [], []
            specs = {"plain": (0, 0), "rel_first": (1, 0), "rel_second": (0, 1), "rel_both": (1, 1),
                     "two_hop_first": (2, 0)}[variant]
            digit = iter(["", "2", "3", "4", "5", "6"])
            for hops in specs:
                d0 = next(digit)
                cur = t.add("filter_unique", [s], t.obj(d0))
                phrase = f"the {np(d0)}"
                for _h in range(hops):
                    d = next(digit)
                    r = t.rel(d0 if _h == 0 else d)
                    cur = t.add("relate_filter_unique", [cur], [r, *t.obj(d)])
                    phrase = f"the {np_without(d, attr) if _h == hops - 1 else np(d)} [that is ]{r} {phrase}"
                    d0 = d
                if hops == 0:
                    phrase = f"the {np_without(d0, attr)}"
                t.null(f"<{LETTER[attr]}{d0}>")
                queried.append(t.add(f"query_{attr}", [cur]))
                phrases.append(phrase)
            t.add(f"equal_{attr}", queried)
            t.constraints.append({"type": "OUT_NEQ", "params": [t.nodes[queried[0]]["inputs"][0],
                                                                 t.nodes[queried[1]]["inputs"][0]]})
            x, y = phrases
            texts = [f"Do {x} and {y} have the same {attr}?", f"Is {x} the same {attr} as {y}?",
                     f"Does {x} have the same {attr} as {y}?"]
            out.append(t.done(texts))
    return out


def same_relate() -> list[dict]:
    out = []
    for attr in ATTRS:
        for kind in ("count", "exist", *(a for a in ATTRS if a != attr)):
            t = _T()
            s = t.add("scene")
            a = t.add("filter_unique", [s], t.obj(""))
            same = t.add(f"same_{attr}", [a])
            keys = t.obj("2")
            t.null(f"<{LETTER[attr]}>", f"<{LETTER[attr]}2>")
            anchor = f"the {np_without('', attr)}"
            if kind in ("count", "exist"):
                t.add(f"filter_{kind}", [same], keys)
                thing = np_without("2", attr)
                texts = {"count": [f"How many other {thing}s have the same {attr} as {anchor}?",
                                   f"How many {thing}s are the same {attr} as {anchor}?"],
                         "exist": [f"Are there any other {thing}s that have the same {attr} as {anchor}?",
                                   f"Is there another {thing} that is the same {attr} as {anchor}?"]}[kind]
            else:
                u = t.add("filter_unique", [same], keys)
                t.add(f"query_{kind}", [u])
                t.null(f"<{LETTER[kind]}2>")
                thing = " ".join(f"<{x}2>" for x in "ZCMS" if x not in (LETTER[attr], LETTER[kind]))
                thing += " thing" if "shape" in (attr, kind) else ""
                texts = _fmt(QUERY_TEXT[kind], x=f"the other {thing} that has the same {attr} as {anchor}")
            out.append(t.done(texts))
    return out


FILES = {
    "zero_hop.json": lambda: hop_families(0), "one_hop.json": lambda: hop_families(1),
    "two_hop.json": lambda: hop_families(2), "three_hop.json": lambda: hop_families(3),
    "single_and.json": single_and, "single_or.json": single_or, "compare_integer.json": compare_integer,
    "comparison.json": comparison, "same_relate.json": same_relate,
}


def main() -> None:
    here = Path(__file__).parent
    for name, build in FILES.items():
        (here / name).write_text(json.dumps(build(), indent=1) + "\n")


if __name__ == "__main__":
    main()

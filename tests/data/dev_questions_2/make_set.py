"""Generator of the second development question set (``generated.jsonl``) and filler of ``hand_written.jsonl``.

    python tests/data/dev_questions_2/make_set.py            # rebuild generated.jsonl (deterministic from --seed)
    python tests/data/dev_questions_2/make_set.py --hand     # recompute the answers of hand_written.jsonl

Every question is built from this file's own phrase lists, on a real scene of ``scenes/``: referents are real
objects (or real recoloured / occluded parts), described minimally (except in the ``redundant`` group), the program
is written in our program syntax following the v1 README's "Program conventions", the reference executor runs it,
and the question is kept only if the program is valid (and the answer keeps the family roughly balanced).
The phrase lists were written without reading the project's templates, realiser, verbaliser or any question file.
"""

from __future__ import annotations

import argparse
import json
import random
import sys
from collections import Counter, defaultdict
from dataclasses import dataclass
from itertools import combinations
from pathlib import Path

from po3d_ppl import ontology as O
from po3d_ppl.language import check_program, parse_program
from po3d_ppl.questions.context import SceneContext
from po3d_ppl.questions.executor import execute
from po3d_ppl.world import load_scene

HERE = Path(__file__).resolve().parent
SEEDS = range(7200, 7264)
PER_GROUP = 113

# ----------------------------------------------------------------------------------------------------------------
# scenes


@dataclass
class Obj:
    i: int
    subtype: str
    cat: str
    color: str
    material: str
    size: str
    pose: str | None  # front/back/left/right, None in a dead zone
    deg: float
    parts: dict  # recoloured raw part name -> (colour, material)
    occluded: bool
    occluders: frozenset
    occludees: frozenset
    occ_parts: frozenset  # raw names of parts whose state is occluded
    all_parts: frozenset  # recoloured or occluded raw names (object2part_all)
    part_occ: dict  # raw name -> objects occluding that part


class World:
    def __init__(self, seed: int):
        self.seed = seed
        self.rel = f"scenes/scene_{seed}.json"
        self.ctx = ctx = SceneContext(load_scene(HERE / self.rel))
        self.o: list[Obj] = []
        for i, so in enumerate(ctx.objects):
            label = O.pose_label(so.pose_degree)
            occ_parts = frozenset(ctx.part_names[p] for p in ctx.occluded_parts if p[0] == i)
            part_occ = {ctx.part_names[p]: frozenset(by) for p, by in ctx.part_occluders.items() if p[0] == i}
            parts = {raw: (st.color, st.material) for raw, st in so.parts.items()}
            self.o.append(Obj(i, so.subtype, O.CATEGORY_OF[so.subtype], so.color, so.material, so.size,
                              None if label == O.NO_POSE else label[:-5], so.pose_degree, parts,
                              bool(so.annotation.occlusion.occluded), frozenset(so.occluded_by),
                              ctx.occludees_of[i], occ_parts, frozenset(parts) | occ_parts, part_occ))
        self.n = len(self.o)
        self.all = frozenset(range(self.n))

    def related(self, i: int, rel: str) -> frozenset:
        return frozenset(self.ctx.related(i, rel))

    def pose_rel(self, i: int, kind: str) -> frozenset:
        a = self.o[i]
        if a.pose is None:
            return frozenset()
        return frozenset(j for j in self.all if j != i and O.pose_relation(a.deg, a.pose + "_pose", self.o[j].deg) == kind)

    def same(self, i: int, attr: str) -> frozenset:
        a = self.o[i]
        key = "subtype" if attr == "shape" else attr
        return frozenset(j for j in self.all if j != i and getattr(self.o[j], key) == getattr(a, key))

    def hidden_parts_by(self, j: int) -> list:
        return sorted((p[0], self.ctx.part_names[p]) for p in self.ctx.parts_occluded_by[j])

    def run(self, program: str):
        return execute(self.ctx, check_program(parse_program(program)))


def plain(value):
    if isinstance(value, (frozenset, set)):
        return sorted(value)
    if isinstance(value, tuple):
        return list(value)
    return value


# ----------------------------------------------------------------------------------------------------------------
# descriptions: dicts slot -> value (pose, size, color, material, shape); shape may be a subtype or a category

ORDER = ("pose", "size", "color", "material", "shape")
SLOTS = ("size", "color", "material", "shape")


def matches(o: Obj, d: dict) -> bool:
    for k, v in d.items():
        if k == "shape":
            if v != o.subtype and v != o.cat:
                return False
        elif k == "pose":
            if o.pose != v:
                return False
        elif getattr(o, k) != v:
            return False
    return True


def sel(W: World, cands, d: dict) -> frozenset:
    return frozenset(i for i in cands if matches(W.o[i], d))


def minimal(W: World, t: int, cands, rng, exclude=(), need: dict | None = None, extra: int = 0):
    """A random minimal description of object t within ``cands`` (None if none); ``need`` slots are always
    included and must be needed; ``extra`` true attributes are then added (the redundant group)."""
    o = W.o[t]
    cands = frozenset(cands)
    need = dict(need or {})
    slots = [s for s in SLOTS if s not in exclude and s not in need]
    for k in range(len(slots) + 1):
        found = []
        for combo in combinations(slots, k):
            for sv in ([o.subtype, o.cat] if "shape" in combo else [None]):
                d = dict(need)
                for s in combo:
                    d[s] = sv if s == "shape" else getattr(o, s)
                if sel(W, cands, d) != {t}:
                    continue
                if need and sel(W, cands, {a: b for a, b in d.items() if a not in need}) == {t}:
                    continue
                found.append(d)
        if found:
            weights = [3 if "shape" in d else 1 for d in found]
            d = rng.choices(found, weights)[0]
            if extra:
                free = [s for s in slots if s not in d]
                rng.shuffle(free)
                for s in free[:extra]:
                    d[s] = rng.choice([o.subtype, o.cat]) if s == "shape" else getattr(o, s)
                if len(d) - len(need) - k < 1:
                    return None
            return d
    return None


def random_filter(W: World, rng, cands=None, exclude=(), kmin=1, kmax=2, absent=False):
    """A filter dict for a set of objects (count / exist questions): the values of a real object of ``cands``, or,
    with ``absent``, one value changed so that nothing may match."""
    cands = sorted(W.all if cands is None else cands)
    base = W.o[rng.choice(cands)] if cands else W.o[rng.choice(sorted(W.all))]
    slots = [s for s in SLOTS if s not in exclude]
    k = rng.randint(kmin, min(kmax, len(slots)))
    chosen = rng.sample(slots, k)
    d = {s: (rng.choice([base.subtype, base.cat, base.cat]) if s == "shape" else getattr(base, s)) for s in chosen}
    if absent:
        s = rng.choice(chosen)
        if s == "shape":
            d[s] = rng.choice(O.CATEGORIES + O.SUBTYPES)
        else:
            d[s] = rng.choice({"size": O.SIZES, "color": O.COLORS, "material": O.MATERIALS}[s])
    return d


def chain(d: dict, src: str = "scene()") -> str:
    s = src
    for k in ORDER:
        if k in d:
            s += f" | filter_{k}[{d[k]}_pose]" if k == "pose" else f" | filter_{k}[{d[k]}]"
    return s


def uniq(d: dict, src: str = "scene()") -> str:
    return chain(d, src) + " | unique"


PORDER = ("size", "color", "material", "partname")


def pchain(pd: dict, src: str) -> str:
    s = src
    for k in PORDER:
        if k in pd:
            s += f" | partfilter_{k}[{pd[k]}]"
    return s


# ----------------------------------------------------------------------------------------------------------------
# words

SIZE_W = {"large": ["large", "big", "large", "big"], "small": ["small", "tiny", "small", "little"]}
SIZE_WIDE = {"large": ["huge", "giant", "massive"], "small": ["miniature", "wee", "teeny"]}
MAT_ADJ = {"metal": ["metal", "metallic", "shiny", "metal"], "rubber": ["rubber", "matte", "rubber"]}
MAT_WIDE = {"metal": ["metallic", "shiny metal", "glossy"], "rubber": ["matt", "rubbery", "dull rubber"]}
COLOR_W = {c: [c] for c in O.COLORS}
COLOR_W["gray"] = ["gray", "gray", "grey"]
COLOR_WIDE = dict(COLOR_W, gray=["grey"])

SUB_W = {
    "suv": ["SUV", "suv"], "wagon": ["wagon"], "minivan": ["minivan"], "sedan": ["sedan"], "truck": ["truck"],
    "articulated": ["articulated bus"], "regular": ["regular bus"], "double": ["double bus"],
    "school": ["school bus"], "chopper": ["chopper"], "dirtbike": ["dirtbike", "dirt bike"], "scooter": ["scooter"],
    "cruiser": ["cruiser"], "jet": ["jet"], "fighter": ["fighter"], "biplane": ["biplane"], "airliner": ["airliner"],
    "road": ["road bike"], "utility": ["utility bike"], "mountain": ["mountain bike"], "tandem": ["tandem bike"],
}
SUB_WIDE = {
    "suv": ["sport utility vehicle", "sports utility vehicle"], "wagon": ["station wagon", "estate car", "estate"],
    "minivan": ["mini van", "people carrier", "mini-van"], "sedan": ["saloon", "saloon car"],
    "truck": ["pickup truck", "pick-up"], "articulated": ["bendy bus", "articulated coach"],
    "regular": ["normal bus", "ordinary bus", "standard bus"], "double": ["double-decker bus", "double decker", "double-decker"],
    "school": ["schoolbus", "school coach"], "chopper": ["chopper motorcycle", "chopper motorbike"],
    "dirtbike": ["dirt-bike", "trail bike", "motocross bike"], "scooter": ["motor scooter", "motorscooter"],
    "cruiser": ["cruiser motorcycle", "cruiser motorbike"], "jet": ["jet plane", "jet aircraft"],
    "fighter": ["fighter jet", "fighter plane", "fighter aircraft"], "biplane": ["bi-plane", "double-winged plane"],
    "airliner": ["passenger plane", "passenger airliner"], "road": ["road bicycle", "racing bike", "racing bicycle"],
    "utility": ["utility bicycle", "city bike"], "mountain": ["mountain bicycle", "MTB"],
    "tandem": ["tandem", "tandem bicycle", "bicycle built for two"],
}
CAT_W = {"car": ["car"], "bus": ["bus"], "motorbike": ["motorbike"], "aeroplane": ["aeroplane", "airplane"],
         "bicycle": ["bicycle"]}
CAT_WIDE = {"car": ["automobile", "auto", "motorcar"], "bus": ["coach", "autobus"],
            "motorbike": ["motorcycle", "motor bike", "motor-bike"], "aeroplane": ["plane", "aircraft", "airplane"],
            "bicycle": ["bike", "cycle", "push bike", "pushbike"]}
GENERIC = ["thing", "object", "thing", "object", "item", "vehicle"]
GENERIC_WIDE = ["vehicle", "vehicle", "toy", "entity", "toy vehicle"]

IRREGULAR = {"bus": "buses", "aircraft": "aircraft", "MTB": "MTBs", "entity": "entities", "coach": "coaches",
             "autobus": "autobuses", "schoolbus": "schoolbuses"}


def plural(noun: str, buss: bool = False) -> str:
    if noun.endswith(" built for two"):
        return plural(noun[: -len(" built for two")], buss) + " built for two"
    head, _, last = noun.rpartition(" ")
    if last == "bus" and buss:
        pl = "buss"
    elif last in IRREGULAR:
        pl = IRREGULAR[last]
    else:
        pl = last + "s"
    return (head + " " + pl) if head else pl


def article(phrase: str) -> str:
    w = phrase.split()[0].lower()
    if w in ("suv", "mtb") or (w[0] in "aeio" and not w.startswith("one")) or w.startswith("un"):
        return "an " + phrase
    return "a " + phrase


def join_and(words: list[str]) -> str:
    if len(words) <= 1:
        return "".join(words)
    return ", ".join(words[:-1]) + " and " + words[-1]


POSE_PRED = {
    "left": ["facing left", "facing to the left", "pointing left", "heading left", "turned to the left",
             "oriented to the left", "facing leftwards", "looking left"],
    "right": ["facing right", "facing to the right", "pointing right", "heading right", "turned to the right",
              "oriented to the right", "facing rightwards", "looking right"],
    "front": ["facing the camera", "facing towards the camera", "facing toward us", "facing forward", "facing us",
              "pointing towards the camera", "heading towards the viewer", "facing front", "coming towards us"],
    "back": ["facing away from the camera", "facing away", "pointing away from us", "heading away from the camera",
             "facing backwards", "with its back to the camera", "driving away from us", "turned away from us"],
}
POSE_PRED_PL = {k: [p.replace("its back", "their backs") for p in v] for k, v in POSE_PRED.items()}


class NP:
    """A noun phrase for a description: the/a/bare/plural/possessive forms, with randomly chosen words."""

    def __init__(self, d: dict, rng, vocab: str = "core", style: str | None = None, buss: bool = False,
                 generic: str | None = None):
        self.rng, self.buss = rng, buss
        wide = vocab == "wide"
        pick = rng.choice
        self.size = pick((SIZE_WIDE if wide and rng.random() < 0.4 else SIZE_W)[d["size"]]) if "size" in d else None
        self.color = pick((COLOR_WIDE if wide else COLOR_W)[d["color"]]) if "color" in d else None
        self.mat = d.get("material")
        self.mat_adj = pick((MAT_WIDE if wide and rng.random() < 0.4 else MAT_ADJ)[self.mat]) if self.mat else None
        self.pose = pick(POSE_PRED[d["pose"]]) if "pose" in d else None
        self.pose_pl = self.pose.replace("its back", "their backs") if self.pose else None
        shape = d.get("shape")
        self.generic = shape is None
        if shape in O.SUBTYPES:
            self.noun = pick((SUB_WIDE if wide else SUB_W)[shape])
        elif shape is not None:
            self.noun = pick((CAT_WIDE if wide else CAT_W)[shape])
        else:
            self.noun = generic or pick(GENERIC_WIDE if wide and rng.random() < 0.5 else GENERIC)
        self.has_adj = any((self.size, self.color, self.mat))
        if style is None:
            r = rng.random()
            style = "pre" if r < 0.72 or not self.has_adj else ("post_mat" if self.mat and r < 0.86 else "rel")
        self.style = style

    def _adj(self, with_mat=True):
        return [w for w in (self.size, self.color, self.mat_adj if with_mat else None) if w]

    def bare(self, pl: bool = False, style: str | None = None) -> str:
        style = style or self.style
        noun = plural(self.noun, self.buss) if pl else self.noun
        be = "are" if pl else "is"
        if style == "rel" and self.has_adj:
            preds = [w for w in (self.size, self.color) if w]
            if self.mat:
                preds.append(self.rng.choice([self.mat_adj, "made of " + self.mat]))
            rel = self.rng.choice(["that", "which"]) if not pl else "that"
            out = f"{noun} {rel} {be} {join_and(preds)}"
        elif style == "post_mat" and self.mat:
            out = " ".join(self._adj(False) + [noun]) + self.rng.choice([" made of ", " made of ", " made from "]) + self.mat
        else:
            out = " ".join(self._adj() + [noun])
        if self.pose:
            out += " " + (self.pose_pl if pl else self.pose) if style != "rel" else f" and {'are' if pl else 'is'} " + (self.pose_pl if pl else self.pose)
        return out

    def the(self, style: str | None = None) -> str:
        if self.generic and self.has_adj and not self.pose and (style or self.style) == "pre" and self.rng.random() < 0.15:
            return "the " + " ".join(self._adj() + ["one"])
        return "the " + self.bare(style=style)

    def a(self, style: str | None = None) -> str:
        return article(self.bare(style=style))

    def pl(self, style: str | None = None) -> str:
        return self.bare(pl=True, style=style)

    def pos(self) -> str:
        return "the " + self.bare(style="pre") + "'s"


def anc(d: dict, rng, vocab="core", buss=False) -> NP:
    """A noun phrase for a referent named inside a longer phrase: mostly prenominal, so that it does not swallow
    what follows."""
    return NP(d, rng, vocab, buss=buss, style="pre" if rng.random() < 0.85 else None)


def pred_words(d: dict, rng, vocab="core") -> str:
    """A predicate for the non-shape slots of d: 'red', 'large and metallic', 'made of rubber'."""
    wide = vocab == "wide"
    words = []
    if "size" in d:
        words.append(rng.choice(SIZE_W[d["size"]]))
    if "color" in d:
        words.append(rng.choice((COLOR_WIDE if wide else COLOR_W)[d["color"]]))
    if "material" in d:
        words.append(rng.choice(MAT_ADJ[d["material"]] + ["made of " + d["material"]] * 2))
    if "pose" in d:
        words.append(rng.choice(POSE_PRED[d["pose"]]))
    return join_and(words)


REL_W = {
    "left": ["left of", "to the left of", "on the left side of", "on the left of", "to the left of"],
    "right": ["right of", "to the right of", "on the right side of", "on the right of", "to the right of"],
    "behind": ["behind", "behind", "in back of"],
    "front": ["in front of", "in front of", "before"],
}
REL_W["front"] = ["in front of"]
REL_W["behind"] = ["behind"]
REL_WIDE = {"left": ["at the left of", "to the left side of", "left from", "leftward of"],
            "right": ["at the right of", "to the right side of", "right from", "rightward of"],
            "behind": ["in back of", "at the back of", "behind"], "front": ["in front of", "ahead of"]}


def rel_w(r: str, rng, vocab="core") -> str:
    return rng.choice(REL_WIDE[r] if vocab == "wide" and rng.random() < 0.5 else REL_W[r])


COLOUR = ["colour", "color", "color", "colour"]


WIDE_PART_WORDS = (("license plate", ["licence plate", "number plate"]), ("hood", ["bonnet"]), ("trunk", ["boot"]),
                   ("windscreen", ["windshield"]), ("gas tank", ["fuel tank", "petrol tank"]),
                   ("side stand", ["kickstand"]), ("mid ", ["middle "]), ("back ", ["rear "]))


def part_words(raw: str, rng, vocab="core") -> str:
    """Readable words for a raw part name, with the everyday spellings ("headlight"/"head light", ...)."""
    w = O.readable_name(raw)
    variants = [w]
    for a, bs in (("head light", ["headlight"]), ("headlight", ["head light"]), ("tail light", ["taillight"]),
                  ("taillight", ["tail light"]), ("footrest", ["foot rest"]), ("windscreen", ["wind screen"]),
                  ("tailplane", ["tail plane"]), ("rearlight", ["rear light"]), ("side stand", ["sidestand"]),
                  ("gas tank", ["gas tank"]), ("crank arm", ["crank arm"])):
        if a in w:
            variants += [w.replace(a, b) for b in bs]
    toks = w.split()
    if len(toks) == 3 and toks[0] in ("front", "back") and toks[1] in ("left", "right"):
        variants.append(f"{toks[1]} {toks[0]} {toks[2]}")  # "left front wheel"
    if vocab == "wide":
        for a, bs in WIDE_PART_WORDS:
            if a in w:
                variants = [w.replace(a, b) for b in bs]
                break
    return rng.choice(variants)


def super_words(sup: str, rng, vocab="core") -> str:
    w = sup.replace("_", " ")
    variants = {"head light": ["headlight", "head light"], "headlight": ["headlight", "head light"],
                "tail light": ["taillight", "tail light"], "taillight": ["taillight", "tail light"],
                "footrest": ["footrest", "foot rest"], "tailplane": ["tailplane", "tail plane"],
                "license plate": ["license plate"], "side stand": ["side stand", "sidestand"]}.get(w, [w])
    if vocab == "wide":
        variants = {"license plate": ["licence plate", "number plate"], "hood": ["bonnet"], "trunk": ["boot"],
                    "windscreen": ["windshield"], "gas tank": ["fuel tank", "petrol tank"],
                    "side stand": ["kickstand"]}.get(w, variants)
    return rng.choice(variants)


def part_plural(words: str) -> str:
    return words + ("es" if words.endswith(("sh", "ch", "s")) else "s")


# ----------------------------------------------------------------------------------------------------------------
# filling templates

import string


@dataclass
class Item:
    question: str
    program: str
    family: str
    notes: str | None = None


def _fields(t: str) -> set:
    return {f for _, f, _, _ in string.Formatter().parse(t) if f}


def fill(rng, templates, **kw) -> str:
    kw.setdefault("colour", rng.choice(COLOUR))
    have = {k for k, v in kw.items() if v is not None}
    ok = [t for t in templates if _fields(t) <= have]
    q = rng.choice(ok).format(**kw)
    q = " ".join(q.split())
    return q[0].upper() + q[1:]


def forms(np_: NP, p: str = "X", simple: bool = True) -> dict:
    return {p: np_.the(), "a" + p: np_.a(), p + "p": np_.pos() if simple else None}


# ---- attribute questions about one referent {X} (also used with long referents, where {Xp} is None)

Q = {
    "color": [
        "What {colour} is {X}?", "What is the {colour} of {X}?", "Which {colour} is {X}?",
        "What {colour} does {X} have?", "Tell me the {colour} of {X}.", "{X} is what {colour}?",
        "I want to know the {colour} of {X}.", "Can you tell me what {colour} {X} is?",
        "There is {aX}; what {colour} is it?", "Look at {X}. What {colour} is it?", "What's the {colour} of {X}?",
        "Name the {colour} of {X}.", "What {colour} has {X} been painted?", "In what {colour} is {X} painted?",
        "What is {Xp} {colour}?", "Which {colour} was used to paint {X}?", "I'd like to know which {colour} {X} has.",
        "{X}: what {colour} is it?", "What {colour} would you say {X} is?", "What {colour} is {Xp} paint?",
    ],
    "material": [
        "What is {X} made of?", "What material is {X}?", "What material is {X} made of?",
        "What's {X} made out of?", "Tell me what {X} is made of.", "Which material was used for {X}?",
        "Is {X} made of metal or rubber?", "Is {X} rubber or metal?", "There is {aX}; what is it made of?",
        "{X} is made of what material?", "What is the material of {X}?", "I want to know the material of {X}.",
        "What kind of material is {X} made from?", "What is {Xp} material?",
        "Can you tell me what material {X} is?", "What substance is {X} made of?",
        "Look at {X}. Is it metallic or rubber?", "What type of material does {X} have?",
        "Is {X} metal or is it rubber?",
    ],
    "size": [
        "How big is {X}?", "What size is {X}?", "Is {X} large or small?", "Is {X} big or small?",
        "Is {X} small or large?", "What is the size of {X}?", "What's the size of {X}?", "Tell me the size of {X}.",
        "{X} is what size?", "There is {aX}; is it big or small?", "Which size is {X}?", "How large is {X}?",
        "I want to know how big {X} is.", "What is {Xp} size?", "Is {X} a big one or a small one?",
        "Would you call {X} large or small?", "Look at {X}. How big is it?", "Can you tell me the size of {X}?",
    ],
    "shape": [
        "What shape is {X}?", "What is the shape of {X}?", "What kind of vehicle is {X}?",
        "What type of object is {X}?", "What is {X}?", "What sort of thing is {X}?", "Tell me what {X} is.",
        "Which type of vehicle is {X}?", "There is {aX}; what kind of vehicle is it?", "What exactly is {X}?",
        "Can you identify {X}?", "I want to know what kind of object {X} is.", "What model of vehicle is {X}?",
        "{X} is what kind of thing?", "What is the type of {X}?", "Name {X}.", "Look at {X}. What is it?",
        "What is {Xp} shape?", "What type is {X}?", "Which vehicle is {X}?",
    ],
}
SHAPE_GENERIC = ["thing", "object", "thing", "item"]
ATTR_NOUN = {"color": None, "material": "material", "size": "size", "shape": "shape"}


def _generic_for(attr, rng):
    return rng.choice(SHAPE_GENERIC) if attr == "shape" else None


def f_query(W, rng, want, attr, vocab="core", extra=0, buss=False):
    t = rng.choice(sorted(W.all))
    d = minimal(W, t, W.all, rng, exclude=(attr,), extra=extra)
    if d is None:
        return None
    np_ = NP(d, rng, vocab, buss=buss, generic=_generic_for(attr, rng))
    return Item(fill(rng, Q[attr], **forms(np_)), uniq(d) + f" | query_{attr}", f"query_{attr}")


# ---- counting

C_NP = [
    "How many {xs} are there?", "How many {xs} are in the picture?", "How many {xs} can you see?",
    "What is the number of {xs}?", "Count the {xs}.", "Tell me how many {xs} there are.",
    "What number of {xs} are there?", "How many {xs} does the scene contain?",
    "I want to know how many {xs} are in the image.", "Can you count the {xs}?", "How many {xs} do you see?",
    "What's the total number of {xs}?", "The scene has how many {xs}?", "Number of {xs}?",
    "How many {xs} are present?", "How many {xs} are shown?", "Give me the number of {xs}.",
    "How many {xs} are visible in the scene?", "How many {xs} have been placed in the scene?",
]
C_PRED = [
    "How many {ns} are {pred}?", "How many of the {ns} are {pred}?", "How many {ns} in the scene are {pred}?",
    "What number of {ns} are {pred}?", "Count the {ns} that are {pred}.", "How many {ns} that are {pred} are there?",
    "How many {ns} which are {pred} can you see?", "Of all the {ns}, how many are {pred}?",
    "Tell me how many {ns} are {pred}.", "How many {ns} happen to be {pred}?",
]
C_ALL = [
    "How many objects are there?", "How many things are in the scene?", "How many vehicles can you see?",
    "Count all the objects.", "What is the total number of objects?", "How many items are in the picture?",
    "Tell me how many things there are in total.", "How many objects does the image show?",
    "How many things are there altogether?", "In total, how many vehicles are there?",
    "How many objects are there in all?", "What number of things can be seen?", "How many objects do you count?",
    "Count the vehicles in the scene.", "How many things are in this picture?",
]
C_OR = [
    "How many things are {pa} or {pb}?", "How many objects are either {pa} or {pb}?",
    "What is the number of things that are {pa} or {pb}?", "Count the objects that are {pa} or {pb}.",
    "How many vehicles are {pa} or {pb}?",
]
C_OR_NP = [
    "How many {as} or {bs} are there?", "Count the {as} and the {bs}.", "How many {as} plus {bs} are there?",
    "What is the total number of {as} and {bs}?", "Altogether, how many {as} and {bs} are there?",
    "How many things are {as} or {bs}?", "What is the combined number of {as} and {bs}?",
    "How many {as} and {bs} are there in total?", "If you add up the {as} and the {bs}, how many are there?",
]


def _split_shape(d):
    return ({"shape": d["shape"]} if "shape" in d else {}), {k: v for k, v in d.items() if k != "shape"}


def set_np(d, rng, vocab="core", buss=False):
    """(plural noun phrase, plural noun, predicate or None) for a filter set."""
    np_ = NP(d, rng, vocab, buss=buss, style="pre" if rng.random() < 0.8 else None)
    sd, rest = _split_shape(d)
    nn = NP(sd, rng, vocab, buss=buss, generic=rng.choice(["thing", "object", "vehicle", "thing"]))
    return np_.pl(), nn.pl(), (pred_words(rest, rng, vocab) if rest else None)


def f_count(W, rng, want, vocab="core", buss=False, multi=False, shape_only=False):
    if shape_only:
        o = W.o[rng.choice(sorted(W.all))]
        d = {"shape": rng.choice([o.cat, o.cat, o.subtype] if not buss else ["bus"])}
    else:
        d = random_filter(W, rng, kmin=2 if multi else 1, kmax=3 if multi else 1, absent=rng.random() < 0.15)
    xs, ns, pred = set_np(d, rng, vocab, buss)
    if pred and rng.random() < 0.4:
        q = fill(rng, C_PRED, ns=ns, pred=pred)
    else:
        q = fill(rng, C_NP, xs=xs)
    return Item(q, f"count({chain(d)})", "count_attributes" if multi else "count_attribute")


def f_count_all(W, rng, want, **kw):
    return Item(fill(rng, C_ALL), "count(scene())", "count_all")


def f_count_union(W, rng, want, vocab="core", buss=False):
    a = random_filter(W, rng, kmin=1, kmax=1)
    b = random_filter(W, rng, kmin=1, kmax=1)
    if a == b:
        return None
    if "shape" not in a and "shape" not in b and rng.random() < 0.6:
        q = fill(rng, C_OR, pa=pred_words(a, rng, vocab), pb=pred_words(b, rng, vocab))
    else:
        q = fill(rng, C_OR_NP, **{"as": set_np(a, rng, vocab, buss)[0], "bs": set_np(b, rng, vocab, buss)[0]})
    return Item(q, f"count(union({chain(a)}, {chain(b)}))", "count_union")


# ---- existence

E_NP = [
    "Is there {ax}?", "Are there any {xs}?", "Is there any {x}?", "Can you see {ax}?", "Do you see any {xs}?",
    "Does the scene contain {ax}?", "Does the picture have any {xs} in it?", "Is {ax} present?",
    "Are any {xs} visible?", "Is there at least one {x}?", "Tell me whether there is {ax}.",
    "I want to know if there are any {xs}.", "Any {xs} in the scene?", "Is {ax} in the image?",
    "Can I find {ax} here?", "Are there {xs} in this picture?", "Does {ax} appear in the scene?",
    "Is there {ax} anywhere?", "Do we have {ax} in the scene?", "Is there {ax} in the picture or not?",
]
E_PRED = [
    "Is there anything {pred}?", "Is any object {pred}?", "Are any of the {ns} {pred}?", "Is anything {pred}?",
    "Are there {ns} that are {pred}?", "Is there {an} that is {pred}?", "Is there {an} which is {pred}?",
    "Does any {n} happen to be {pred}?", "Is at least one {n} {pred}?", "Are some of the {ns} {pred}?",
    "Can you see {an} that's {pred}?",
]


def f_exist(W, rng, want, vocab="core", buss=False):
    d = random_filter(W, rng, kmin=1, kmax=3, absent=want is False)
    np_ = NP(d, rng, vocab, buss=buss)
    sd, rest = _split_shape(d)
    if rest and rng.random() < 0.4:
        nn = NP(sd, rng, vocab, buss=buss, generic=rng.choice(["thing", "object", "vehicle"]))
        T = E_PRED if not sd else [t for t in E_PRED if "{n" in t or "{an}" in t]
        q = fill(rng, T, pred=pred_words(rest, rng, vocab), ns=nn.pl(), n=nn.bare(), an=nn.a())
        fam = "exist_predicate"
    else:
        q = fill(rng, E_NP, ax=np_.a(), xs=np_.pl(), x=np_.bare())
        fam = "exist_attributes"
    return Item(q, f"exist({chain(d)})", fam)


E_REL = [
    "Is there {ay} {rel} {X}?", "Are there any {ys} {rel} {X}?", "Can you see {ay} {rel} {X}?",
    "There is {aX}; is there {ay} {rel} it?", "Is there {ay} {relc} {X}?", "Do you see any {ys} {rel} {X}?",
    "Are any {ys} {rel} {X}?", "Is {ay} standing {rel} {X}?", "Does {X} have {ay} {rel} it?",
    "Tell me if there is {ay} {rel} {X}.", "I want to know whether there are {ys} {rel} {X}.",
    "Look at {X}: is there {ay} {rel} it?", "{Relc} {X}, is there {ay}?", "Is there {ay} placed {rel} {X}?",
]
E_REL_ANY = [
    "Is anything {rel} {X}?", "Is there something {rel} {X}?", "Is there anything {rel} {X}?",
    "Are there objects {rel} {X}?", "Does anything stand {rel} {X}?", "Is any object {rel} {X}?",
]


def f_exist_relate(W, rng, want, vocab="core", buss=False, extra=0):
    x = rng.choice(sorted(W.all))
    dx = minimal(W, x, W.all, rng, extra=extra)
    if dx is None:
        return None
    r = rng.choice(O.RELATIONS)
    rs = W.related(x, r)
    npx = NP(dx, rng, vocab, buss=buss)
    rp = rel_w(r, rng, vocab)
    if rng.random() < 0.25:
        q = fill(rng, E_REL_ANY, rel=rp, X=npx.the())
        return Item(q, f"exist({uniq(dx)} | relate[{r}])", "exist_relate")
    d = random_filter(W, rng, cands=rs if rs and want is not False else None, kmin=1, kmax=2,
                      absent=want is False and rng.random() < 0.5)
    npy = NP(d, rng, vocab, buss=buss, style="pre")
    q = fill(rng, E_REL, ay=npy.a(), ys=npy.pl(), rel=rp, relc=rp, Relc=rp, X=npx.the(), aX=npx.a())
    return Item(q, f"exist({chain(d, uniq(dx) + f' | relate[{r}]')})", "exist_relate")


# ---- comparing attributes of two referents

SAME_N = {"color": ["colour", "color"], "material": ["material"], "size": ["size"], "shape": ["shape", "type", "kind"]}
CMP = {
    "color": [
        "Is {A} the same {colour} as {B}?", "Does {A} have the same {colour} as {B}?",
        "Are {A} and {B} the same {colour}?", "Do {A} and {B} share a {colour}?",
        "Is the {colour} of {A} the same as the {colour} of {B}?", "Are {A} and {B} painted the same {colour}?",
        "Tell me if {A} and {B} have matching {colour}s.", "Is {A} coloured like {B}?",
        "Does {A} match {B} in {colour}?", "Is {Ap} {colour} equal to {Bp}?", "There is {aA}; does it have the same {colour} as {B}?",
        "Do {A} and {B} have the same {colour}?", "Is {A} painted in the same {colour} as {B}?",
        "I want to know whether {A} is the same {colour} as {B}.", "Are {A} and {B} of the same {colour}?",
        "Is {Ap} {colour} the same as {Bp}?", "Has {A} got the same {colour} as {B}?",
    ],
    "material": [
        "Is {A} made of the same material as {B}?", "Are {A} and {B} made of the same material?",
        "Do {A} and {B} have the same material?", "Is {A} the same material as {B}?",
        "Does {A} have the same material as {B}?", "Are {A} and {B} made from the same stuff?",
        "Is the material of {A} the same as that of {B}?", "Do {A} and {B} share a material?",
        "There is {aA}; is it made of the same material as {B}?", "Is {Ap} material the same as {Bp}?",
        "Tell me whether {A} and {B} are made of the same material.", "Does {A} match {B} in material?",
        "Are {A} and {B} of the same material?", "Is {A} made out of the same thing as {B}?",
    ],
    "size": [
        "Is {A} the same size as {B}?", "Are {A} and {B} the same size?", "Do {A} and {B} have the same size?",
        "Does {A} have the same size as {B}?", "Is the size of {A} the same as the size of {B}?",
        "Are {A} and {B} equally big?", "Are {A} and {B} equal in size?", "Do {A} and {B} share a size?",
        "There is {aA}; is it the same size as {B}?", "Is {Ap} size equal to {Bp}?",
        "Tell me if {A} is the same size as {B}.", "Does {A} match {B} in size?", "Are {A} and {B} of equal size?",
        "Is {A} of the same size as {B}?",
    ],
    "shape": [
        "Is {A} the same shape as {B}?", "Are {A} and {B} the same kind of vehicle?",
        "Do {A} and {B} have the same shape?", "Is {A} the same type of vehicle as {B}?",
        "Are {A} and {B} the same type?", "Does {A} have the same shape as {B}?",
        "Is the shape of {A} the same as the shape of {B}?", "Are {A} and {B} the same model?",
        "There is {aA}; is it the same kind of thing as {B}?", "Is {Ap} shape the same as {Bp}?",
        "Tell me whether {A} and {B} are the same sort of vehicle.", "Do {A} and {B} share a shape?",
        "Is {A} the same kind of object as {B}?", "Are {A} and {B} vehicles of the same type?",
    ],
}


def _referent(W, rng, cands=None, exclude=(), extra=0, not_=()):
    cands = W.all if cands is None else cands
    pool = sorted(set(cands) - set(not_))
    if not pool:
        return None, None
    t = rng.choice(pool)
    return t, minimal(W, t, cands, rng, exclude=exclude, extra=extra)


def f_compare(W, rng, want, attr, vocab="core", extra=0, buss=False, relate=False):
    key = "subtype" if attr == "shape" else attr
    a, da = _referent(W, rng, exclude=(attr,), extra=extra)
    if da is None:
        return None
    others = [j for j in W.all if j != a and (getattr(W.o[j], key) == getattr(W.o[a], key)) == bool(want)]
    if not others:
        return None
    b = rng.choice(sorted(others))
    if relate:
        # B as "the <y> <rel> <X>"
        opts = [(x, r) for x in sorted(W.all) for r in O.RELATIONS if x not in (a, b) and b in W.related(x, r)]
        if not opts:
            return None
        x, r = rng.choice(opts)
        dx = minimal(W, x, W.all, rng, extra=extra)
        db = minimal(W, b, W.related(x, r), rng, exclude=(attr,), extra=extra)
        if dx is None or db is None:
            return None
        npx = anc(dx, rng, vocab, buss)
        npb = NP(db, rng, vocab, buss=buss, generic=_generic_for(attr, rng))
        rp = rel_w(r, rng, vocab)
        link = rng.choice(["", "", "that is ", "which is ", "that's "])
        bthe = f"the {npb.bare()} {link}{rp} {npx.the()}"
        bprog = uniq(db, uniq(dx) + f" | relate[{r}]")
        bp = None
    else:
        db = minimal(W, b, W.all, rng, exclude=(attr,), extra=extra)
        if db is None:
            return None
        npb = NP(db, rng, vocab, buss=buss, generic=_generic_for(attr, rng))
        bthe, bprog, bp = npb.the(), uniq(db), npb.pos()
    npa = NP(da, rng, vocab, buss=buss, generic=_generic_for(attr, rng))
    q = fill(rng, CMP[attr], A=npa.the(), aA=npa.a(), Ap=npa.pos() if bp else None, B=bthe, Bp=bp)
    prog = f"equal_{attr}({uniq(da)} | query_{attr}, {bprog} | query_{attr})"
    return Item(q, prog, f"compare_{attr}" + ("_relate" if relate else ""))


# ---- comparing counts

GT = [
    "Are there more {as} than {bs}?", "Do the {as} outnumber the {bs}?", "Is the number of {as} greater than the number of {bs}?",
    "Is the number of {as} larger than that of {bs}?", "Are {as} more numerous than {bs}?",
    "Does the scene have more {as} than {bs}?", "Is it true that there are more {as} than {bs}?",
    "I'd like to know whether there are more {as} than {bs}.", "Are there more {as} in the picture than {bs}?",
    "Is the count of {as} bigger than the count of {bs}?", "Do {as} outnumber {bs}?",
    "Can you see more {as} than {bs}?", "Are the {bs} outnumbered by the {as}?",
    "Are there a greater number of {as} than {bs}?", "Tell me if the {as} are more than the {bs}.",
]
LT = [
    "Are there fewer {as} than {bs}?", "Are there less {as} than {bs}?", "Is the number of {as} smaller than the number of {bs}?",
    "Is the number of {as} less than the number of {bs}?", "Are {as} fewer in number than {bs}?",
    "Does the scene have fewer {as} than {bs}?", "Is the count of {as} lower than the count of {bs}?",
    "Can you see fewer {as} than {bs}?", "Are there a smaller number of {as} than {bs}?",
    "Is it the case that there are fewer {as} than {bs}?", "Are the {as} fewer than the {bs}?",
    "Are there not so many {as} as {bs}?", "Tell me whether the {as} are less numerous than the {bs}.",
]
EQ = [
    "Are there as many {as} as {bs}?", "Is the number of {as} the same as the number of {bs}?",
    "Are there the same amount of {as} and {bs}?", "Is there an equal number of {as} and {bs}?",
    "Are the {as} and the {bs} equal in number?", "Are there equally many {as} and {bs}?",
    "Does the number of {as} equal the number of {bs}?", "Same number of {as} and {bs}?",
    "Is the count of {as} equal to the count of {bs}?", "Are there exactly as many {as} as there are {bs}?",
    "Do the {as} and {bs} have the same count?", "Is the number of {as} equal to that of {bs}?",
    "Are the numbers of {as} and {bs} the same?", "Tell me if there are as many {as} as {bs}.",
    "Are there the same number of {as} as {bs}?",
]
OPS = {"gt": ("greater_than", GT), "lt": ("less_than", LT), "eq": ("equal_integer", EQ)}


def f_compare_count(W, rng, want, op, vocab="core", buss=False):
    a = random_filter(W, rng, kmin=1, kmax=2, absent=rng.random() < 0.1)
    b = random_filter(W, rng, kmin=1, kmax=2, absent=rng.random() < 0.1)
    if a == b:
        return None
    ca, cb = len(sel(W, W.all, a)), len(sel(W, W.all, b))
    truth = {"gt": ca > cb, "lt": ca < cb, "eq": ca == cb}[op]
    if want is not None and truth != want:
        return None
    fn, T = OPS[op]
    q = fill(rng, T, **{"as": set_np(a, rng, vocab, buss)[0], "bs": set_np(b, rng, vocab, buss)[0]})
    note = "passive: the program follows the active form (A outnumber B)" if "outnumbered by" in q else None
    return Item(q, f"{fn}(count({chain(a)}), count({chain(b)}))", f"compare_count_{op}", note)


GT_REL = [
    "Are there more {fs} {r1} {X} than {r2} it?", "Are there more {fs} {r1} {X} than {r2} {X}?",
    "Is the number of {fs} {r1} {X} greater than the number {r2} it?",
    "There is {aX}; are there more {fs} {r1} it than {r2} it?", "Do the {fs} {r1} {X} outnumber those {r2} it?",
    "Does {X} have more {fs} {r1} it than {r2} it?", "Tell me if there are more {fs} {r1} {X} than {r2} it.",
    "Are more {fs} {r1} {X} than {r2} it?", "Is the number of {fs} {r1} {X} larger than the number of {fs} {r2} it?",
    "Looking at {X}, are there more {fs} {r1} it than {r2} it?",
]
LT_REL = [
    "Are there fewer {fs} {r1} {X} than {r2} it?", "Are there less {fs} {r1} {X} than {r2} it?",
    "Is the number of {fs} {r1} {X} smaller than the number {r2} it?",
    "There is {aX}; are there fewer {fs} {r1} it than {r2} it?", "Does {X} have fewer {fs} {r1} it than {r2} it?",
    "Are the {fs} {r1} {X} fewer than those {r2} it?", "Are there fewer {fs} {r1} {X} than there are {r2} it?",
    "Is the count of {fs} {r1} {X} lower than the count {r2} it?",
    "Are there less {fs} {r1} {X} than {fs} {r2} {X}?",
]
EQ_REL = [
    "Are there as many {fs} {r1} {X} as {r2} it?", "Is the number of {fs} {r1} {X} the same as the number {r2} it?",
    "Are there equally many {fs} {r1} {X} and {r2} it?", "Does {X} have the same number of {fs} {r1} it as {r2} it?",
    "Are there the same amount of {fs} {r1} {X} as {r2} it?", "There is {aX}; are there as many {fs} {r1} it as {r2} it?",
    "Is there an equal number of {fs} {r1} {X} and {r2} it?", "Are the {fs} {r1} {X} as many as those {r2} it?",
    "Is the count of {fs} {r1} {X} equal to the count {r2} it?",
]
OPS_REL = {"gt": ("greater_than", GT_REL), "lt": ("less_than", LT_REL), "eq": ("equal_integer", EQ_REL)}


def f_compare_relate(W, rng, want, op, vocab="core", buss=False, extra=0):
    x, dx = _referent(W, rng, extra=extra)
    if dx is None:
        return None
    r1, r2 = rng.sample(O.RELATIONS, 2)
    f = {} if rng.random() < 0.55 else random_filter(W, rng, kmin=1, kmax=1)
    c1 = len(sel(W, W.related(x, r1), f))
    c2 = len(sel(W, W.related(x, r2), f))
    truth = {"gt": c1 > c2, "lt": c1 < c2, "eq": c1 == c2}[op]
    if want is not None and truth != want:
        return None
    fn, T = OPS_REL[op]
    npx = NP(dx, rng, vocab, buss=buss)
    fs = NP(f, rng, vocab, buss=buss, style="pre", generic=rng.choice(["thing", "object", "vehicle"])).pl()
    q = fill(rng, T, fs=fs, r1=rel_w(r1, rng, vocab), r2=rel_w(r2, rng, vocab), X=npx.the(), aX=npx.a())
    base = uniq(dx)
    prog = f"{fn}(count({chain(f, base + f' | relate[{r1}]')}), count({chain(f, base + f' | relate[{r2}]')}))"
    return Item(q, prog, f"compare_relate_{op}")


# ---- same-attribute relations

SAME_P = {
    "color": ["the same colour as", "the same color as", "painted the same colour as", "the same colour as"],
    "material": ["made of the same material as", "of the same material as", "the same material as",
                 "made from the same material as"],
    "size": ["the same size as", "of the same size as", "equal in size to", "the same size as"],
    "shape": ["the same shape as", "the same type as", "the same kind of vehicle as", "of the same type as"],
}
SAME_COUNT = [
    "How many other things are {same} {X}?", "How many objects are {same} {X}?",
    "How many other objects have the same {n} as {X}?", "How many other objects share {Xp} {n}?",
    "What number of other things are {same} {X}?", "Count the other objects that have the same {n} as {X}.",
    "There is {aX}; how many other things are {same} it?", "How many {fs} are {same} {X}?",
    "How many {fs} have the same {n} as {X}?", "How many {fs} share a {n} with {X}?",
    "Tell me how many {fs} match {X} in {n}.", "How many {fs} besides {X} have its {n}?",
    "How many other {fs} are {same} {X}?", "I want to know how many {fs} have the same {n} as {X}.",
    "{X} has the same {n} as how many other things?",
]
SAME_EXIST = [
    "Is there anything else {same} {X}?", "Is there another object with the same {n} as {X}?",
    "Are there other things that share {Xp} {n}?", "Is there {af} that is {same} {X}?",
    "Does anything else have the same {n} as {X}?", "Are any other things {same} {X}?",
    "Is there any other {f} {same} {X}?", "Can you see another thing that has the same {n} as {X}?",
    "There is {aX}; is anything else {same} it?", "Are there any {fs} {same} {X}?",
    "Is there {af} with the same {n} as {X}?", "Do any other {fs} have the same {n} as {X}?",
    "Does {X} share its {n} with any {f}?",
]
SAME_QUERY = {
    "color": ["What {colour} is the {f} that is {same} {X}?", "What is the {colour} of the {other}{f} {same} {X}?",
              "There is {another} {f} {same} {X}; what {colour} is it?", "Tell me the {colour} of the {f} that has the same {n} as {X}.",
              "The {f} that shares {Xp} {n} is what {colour}?", "Which {colour} does the {f} {same} {X} have?"],
    "material": ["What is the {f} that is {same} {X} made of?", "What material is the {other}{f} {same} {X}?",
                 "There is {another} {f} {same} {X}; what is it made of?", "Tell me the material of the {f} that has the same {n} as {X}.",
                 "The {f} that shares {Xp} {n} is made of what?", "Is the {f} {same} {X} metal or rubber?"],
    "size": ["What size is the {f} that is {same} {X}?", "How big is the {other}{f} {same} {X}?",
             "There is {another} {f} {same} {X}; how big is it?", "Tell me the size of the {f} that has the same {n} as {X}.",
             "The {f} that shares {Xp} {n} is what size?", "Is the {f} {same} {X} large or small?"],
    "shape": ["What kind of vehicle is the {f} that is {same} {X}?", "What shape is the {other}{f} {same} {X}?",
              "There is {another} {f} {same} {X}; what type of vehicle is it?", "Tell me the shape of the {f} that has the same {n} as {X}.",
              "The {f} that shares {Xp} {n} is what kind of thing?", "What is the {f} {same} {X}?"],
}


def f_same(W, rng, want, attr, kind, vocab="core", buss=False, extra=0):
    x, dx = _referent(W, rng, exclude=(attr,), extra=extra)
    if dx is None:
        return None
    ss = W.same(x, attr)
    npx = NP(dx, rng, vocab, buss=buss)
    same = rng.choice(SAME_P[attr])
    n = rng.choice(SAME_N[attr]) if attr != "color" else rng.choice(COLOUR)
    base = uniq(dx) + f" | same_{attr}"
    if kind == "query":
        qattr = rng.choice([a for a in ("color", "material", "size", "shape") if a != attr])
        if not ss:
            return None
        t = rng.choice(sorted(ss))
        dt = minimal(W, t, ss, rng, exclude=(qattr, attr), extra=extra)
        if dt is None:
            return None
        fnp = NP(dt, rng, vocab, buss=buss, style="pre", generic=rng.choice(["thing", "object"]))
        other = "other " if fnp.generic else ""
        q = fill(rng, SAME_QUERY[qattr], f=fnp.bare(), same=same, X=npx.the(), Xp=npx.pos(), n=n, other=other,
                 another="another" if fnp.generic else article(fnp.bare()).split()[0])
        return Item(q, uniq(dt, base) + f" | query_{qattr}", f"same_{attr}_query")
    fd = {} if rng.random() < 0.5 else random_filter(W, rng, cands=ss or None, exclude=(attr,), kmin=1, kmax=1)
    fnp = NP(fd, rng, vocab, buss=buss, style="pre", generic=rng.choice(["thing", "object"]))
    kw = {"same": same, "X": npx.the(), "Xp": npx.pos(), "aX": npx.a(), "n": n}
    if fd:
        kw.update(fs=fnp.pl(), f=fnp.bare(), af=fnp.a())
        T = [t for t in (SAME_COUNT if kind == "count" else SAME_EXIST) if "{f" in t or "{af}" in t]
    else:
        T = [t for t in (SAME_COUNT if kind == "count" else SAME_EXIST) if "{f" not in t and "{af}" not in t]
    q = fill(rng, T, **kw)
    return Item(q, f"{'count' if kind == 'count' else 'exist'}({chain(fd, base)})", f"same_{attr}_{kind}")


# ---- spatial relations

REL_Q_PRON = {
    "color": ["There is {aX}; what {colour} is the {y} {rel} it?", "Look at {X}. What {colour} is the {y} {rel} it?",
              "{Relc} {X} there is {ay}; what {colour} is it?", "I see {aX}. Which {colour} is the {y} {rel} it?"],
    "material": ["There is {aX}; what is the {y} {rel} it made of?", "Look at {X}. What material is the {y} {rel} it?",
                 "{Relc} {X} there is {ay}; what is it made of?", "I see {aX}. Is the {y} {rel} it metal or rubber?"],
    "size": ["There is {aX}; how big is the {y} {rel} it?", "Look at {X}. What size is the {y} {rel} it?",
             "{Relc} {X} there is {ay}; is it large or small?", "I see {aX}. Is the {y} {rel} it big or small?"],
    "shape": ["There is {aX}; what kind of vehicle is the {y} {rel} it?", "Look at {X}. What is the {y} {rel} it?",
              "{Relc} {X} there is {ay}; what type of vehicle is it?", "I see {aX}. What shape is the {y} {rel} it?"],
}
LINKS = ["", "", "", "that is ", "which is ", "that's ", "located ", "positioned "]


def rel_np(npy: NP, rp: str, anchor: str, rng, link=None) -> dict:
    link = rng.choice(LINKS) if link is None else link
    y = npy.bare()
    plink = "that are " if link in ("that is ", "which is ", "that's ") else link
    return {"X": f"the {y} {link}{rp} {anchor}", "aX": f"{article(y)} {link}{rp} {anchor}", "Xp": None,
            "ys": f"{npy.pl()} {plink}{rp} {anchor}"}


def f_relate_query(W, rng, want, attr, vocab="core", buss=False, extra=0):
    x, dx = _referent(W, rng, extra=extra)
    if dx is None:
        return None
    r = rng.choice(O.RELATIONS)
    rs = W.related(x, r)
    _t, dt = _referent(W, rng, cands=rs, exclude=(attr,), extra=extra)
    if dt is None:
        return None
    npx = anc(dx, rng, vocab, buss)
    npy = NP(dt, rng, vocab, buss=buss, generic=_generic_for(attr, rng), style="pre" if rng.random() < 0.7 else None)
    rp = rel_w(r, rng, vocab)
    if rng.random() < 0.3:
        q = fill(rng, REL_Q_PRON[attr], X=npx.the(), aX=npx.a(), y=npy.bare(), ay=npy.a(), rel=rp, Relc=rp)
    else:
        q = fill(rng, Q[attr], **rel_np(npy, rp, npx.the(), rng))
    return Item(q, uniq(dt, uniq(dx) + f" | relate[{r}]") + f" | query_{attr}", f"relate_query_{attr}")


REL_COUNT = [
    "How many {ys} are {rel} {X}?", "What number of {ys} are {rel} {X}?", "There is {aX}; how many {ys} are {rel} it?",
    "Count the {ys} {rel} {X}.", "How many {ys} can be seen {rel} {X}?", "How many {ys} are located {rel} {X}?",
    "{Relc} {X}, how many {ys} are there?", "Tell me the number of {ys} {rel} {X}.", "How many {ys} sit {rel} {X}?",
    "How many {ys} are there {rel} {X}?", "What is the number of {ys} that are {rel} {X}?",
    "I want to know how many {ys} are {rel} {X}.", "Look at {X}: how many {ys} are {rel} it?",
    "How many {ys} stand {rel} {X}?", "{X} has how many {ys} {rel} it?",
]


def f_relate_count(W, rng, want, vocab="core", buss=False, extra=0):
    x, dx = _referent(W, rng, extra=extra)
    if dx is None:
        return None
    r = rng.choice(O.RELATIONS)
    rs = W.related(x, r)
    f = {} if rng.random() < 0.4 else random_filter(W, rng, cands=rs or None, kmin=1, kmax=2)
    npx = NP(dx, rng, vocab, buss=buss)
    ys = NP(f, rng, vocab, buss=buss, style="pre", generic=rng.choice(["thing", "object", "vehicle", "thing"])).pl()
    rp = rel_w(r, rng, vocab)
    q = fill(rng, REL_COUNT, ys=ys, rel=rp, Relc=rp, X=npx.the(), aX=npx.a())
    return Item(q, f"count({chain(f, uniq(dx) + f' | relate[{r}]')})", "relate_count")


def f_two_hop(W, rng, want, attr=None, vocab="core", buss=False):
    x, dx = _referent(W, rng)
    if dx is None:
        return None
    r1, r2 = rng.choice(O.RELATIONS), rng.choice(O.RELATIONS)
    y, dy = _referent(W, rng, cands=W.related(x, r1))
    if dy is None:
        return None
    npx = anc(dx, rng, vocab, buss)
    npy = NP(dy, rng, vocab, buss=buss, style="pre")
    mid = f"the {npy.bare()} {rng.choice(['that is ', 'which is ', 'that is ', ''])}{rel_w(r1, rng, vocab)} {npx.the()}"
    src = uniq(dy, uniq(dx) + f" | relate[{r1}]") + f" | relate[{r2}]"
    rp = rel_w(r2, rng, vocab)
    if attr is None:
        f = {} if rng.random() < 0.5 else random_filter(W, rng, cands=W.related(y, r2) or None, kmin=1, kmax=1)
        ys = NP(f, rng, vocab, buss=buss, style="pre", generic=rng.choice(["thing", "object"])).pl()
        q = fill(rng, [t for t in REL_COUNT if "{aX}" not in t and "{X} has" not in t], ys=ys, rel=rp, Relc=rp, X=mid)
        return Item(q, f"count({chain(f, src)})", "two_hop_count")
    _t, dt = _referent(W, rng, cands=W.related(y, r2), exclude=(attr,))
    if dt is None:
        return None
    npt = NP(dt, rng, vocab, buss=buss, generic=_generic_for(attr, rng), style="pre")
    q = fill(rng, [s for s in Q[attr] if "{aX}" not in s], **rel_np(npt, rp, mid, rng, link=rng.choice(["", "that is ", "which is "])))
    return Item(q, uniq(dt, src) + f" | query_{attr}", f"two_hop_query_{attr}")


AND_COUNT = [
    "How many {fs} are {r1} {A} and {r2} {B}?", "How many {fs} are both {r1} {A} and {r2} {B}?",
    "What number of {fs} are {r1} {A} and also {r2} {B}?", "Count the {fs} that are {r1} {A} and {r2} {B}.",
    "How many {fs} are there that are {r1} {A} and {r2} {B}?", "Tell me how many {fs} are {r1} {A} as well as {r2} {B}.",
    "How many {fs} are at the same time {r1} {A} and {r2} {B}?", "How many {fs} lie {r1} {A} and {r2} {B}?",
]
OR_COUNT = [
    "How many {fs} are {r1} {A} or {r2} {B}?", "How many {fs} are either {r1} {A} or {r2} {B}?",
    "What number of {fs} are {r1} {A} or {r2} {B}?", "Count the {fs} that are {r1} {A} or {r2} {B}.",
    "How many {fs} are {r1} {A} or else {r2} {B}?", "Tell me how many {fs} are {r1} {A} or {r2} {B}.",
]


def f_and_or(W, rng, want, op, vocab="core", buss=False):
    a, da = _referent(W, rng)
    _b, db = _referent(W, rng, not_=(a,) if a is not None else ())
    if da is None or db is None:
        return None
    r1, r2 = rng.choice(O.RELATIONS), rng.choice(O.RELATIONS)
    f = {} if rng.random() < 0.5 else random_filter(W, rng, kmin=1, kmax=1)
    fs = NP(f, rng, vocab, buss=buss, style="pre", generic=rng.choice(["things", "objects"])[:-1]).pl()
    q = fill(rng, AND_COUNT if op == "intersect" else OR_COUNT, fs=fs, r1=rel_w(r1, rng, vocab), r2=rel_w(r2, rng, vocab),
             A=anc(da, rng, vocab, buss).the(), B=anc(db, rng, vocab, buss).the())
    prog = f"count({chain(f, f'{op}({uniq(da)} | relate[{r1}], {uniq(db)} | relate[{r2}])')})"
    return Item(q, prog, "and_count" if op == "intersect" else "or_count")


# ---- parts

def part_name_value(W, i, raw, rng, super_ok=True):
    """(program value, words) naming part raw of object i: the canonical name, or the super-part name when the
    subtype has only one part of that kind."""
    sub = W.o[i].subtype
    sup = O.super_part_name(raw)
    n_sup = sum(O.super_part_name(r) == sup for r in O.PARTS[sub])
    if super_ok and n_sup == 1 and rng.random() < 0.7:
        return sup, super_words(sup, rng)
    return O.canonical_part_name(raw), None


def _pwords(value, raw, rng, vocab):
    if value == O.super_part_name(raw) and value != O.canonical_part_name(raw):
        return super_words(value, rng, vocab)
    return part_words(raw, rng, vocab)


def phys(W, objs):
    """Every physical part (recoloured or not) of the objects: what a reader of the question can see."""
    return [(i, r) for i in sorted(objs) for r in O.PARTS[W.o[i].subtype]]


def pmatch(W, i, raw, pd):
    """Whether the part raw of object i fits the part description pd as a reader sees it: a recoloured part has its
    own colour and material, any other part looks like its object (so "the rubber part" of a rubber car is not a
    unique description, although only recoloured parts carry attributes in programs)."""
    o = W.o[i]
    color, material = o.parts.get(raw, (o.color, o.material))
    for k, v in pd.items():
        if k == "partname":
            if not O.partname_matches(raw, v):
                return False
        elif k == "color" and color != v or k == "material" and material != v or k == "size" and o.size != v:
            return False
    return True


def part_minimal(W, target, cands, rng, exclude=(), need_name=True, prefer_super=True, no_name=False):
    """A minimal part description (dict over color, material, partname) of target (i, raw) among cands."""
    i, raw = target
    o = W.o[i]
    names = [O.canonical_part_name(raw)]
    sup = O.super_part_name(raw)
    if sup != names[0]:
        names.insert(0, sup) if prefer_super else names.append(sup)
    slots = [s for s in ("color", "material") if s not in exclude and raw in o.parts]
    options = []
    for k in range(len(slots) + 1):
        for combo in combinations(slots, k):
            for nm in ([None] if no_name else names if need_name else names + [None]):
                pd = {s: o.parts[raw][0 if s == "color" else 1] for s in combo}
                if nm:
                    pd["partname"] = nm
                if not pd:
                    continue
                if [p for p in cands if pmatch(W, p[0], p[1], pd)] == [target]:
                    options.append(pd)
        if options:
            w = [3 if pd.get("partname") == sup else 1 for pd in options]
            return rng.choices(options, w)[0]
    return None


def part_np(W, i, raw, pd, rng, vocab="core") -> str:
    words = []
    if "color" in pd:
        words.append(rng.choice((COLOR_WIDE if vocab == "wide" else COLOR_W)[pd["color"]]))
    if "material" in pd:
        words.append(rng.choice(MAT_ADJ[pd["material"]]))
    words.append(_pwords(pd["partname"], raw, rng, vocab) if "partname" in pd else "part")
    return " ".join(words)


PQ = {
    "color": ["What {colour} is the {p} of {X}?", "What {colour} is {Xp} {p}?", "What is the {colour} of {Xp} {p}?",
              "Which {colour} is the {p} on {X}?", "Tell me the {colour} of the {p} of {X}.",
              "There is {aX}; what {colour} is its {p}?", "{Xp} {p} is what {colour}?", "What {colour} does {Xp} {p} have?",
              "Look at {X}. What {colour} is its {p}?", "I want to know the {colour} of the {p} that belongs to {X}.",
              "The {p} of {X} is painted what {colour}?", "What {colour} is the {p} that {X} has?",
              "What's the {colour} of {X}'s {p}?", "In what {colour} is the {p} of {X}?"],
    "material": ["What is the {p} of {X} made of?", "What material is {Xp} {p}?", "What is {Xp} {p} made of?",
                 "Is the {p} of {X} metal or rubber?", "Tell me the material of the {p} of {X}.",
                 "There is {aX}; what is its {p} made of?", "{Xp} {p} is made of what?", "What's the material of {Xp} {p}?",
                 "Look at {X}. Is its {p} metallic or rubber?", "What material was used for the {p} of {X}?",
                 "Which material is the {p} that belongs to {X}?", "What is the {p} on {X} made out of?"],
    "partname": ["Which part of {X} is {pp}?", "What part of {X} is {pp}?", "What is the name of the {pn} of {X}?",
                 "Which of {Xp} parts is {pp}?", "Tell me which part of {X} is {pp}.", "What is the {pn} of {X} called?",
                 "There is {aX}; which of its parts is {pp}?", "Name the {pn} of {X}.", "{X} has {apn}; what part is it?",
                 "What part of {X} has been painted {ppc}?", "Which part on {X} is {pp}?", "What do you call the {pn} of {X}?"],
}


def f_part_query(W, rng, want, attr, vocab="core", buss=False, extra=0):
    pool = [(i, raw) for i in sorted(W.all) for raw in sorted(W.o[i].parts)]
    if not pool:
        return None
    i, raw = rng.choice(pool)
    dx = minimal(W, i, W.all, rng, extra=extra)
    if dx is None:
        return None
    cands = phys(W, [i])
    npx = NP(dx, rng, vocab, buss=buss)
    kw = {"X": npx.the(), "aX": npx.a(), "Xp": npx.pos()}
    if attr == "partname":
        pd = part_minimal(W, (i, raw), cands, rng, no_name=True)
        if pd is None or "partname" in pd:
            return None
        c, m = W.o[i].parts[raw]
        pp = join_and(([rng.choice(COLOR_W[c])] if "color" in pd else []) + (["made of " + m] if "material" in pd else []))
        pn = part_np(W, i, raw, pd, rng, vocab)
        kw.update(pp=pp, pn=pn, apn=article(pn), ppc=pp if "material" not in pd else None)
    else:
        pd = part_minimal(W, (i, raw), cands, rng, exclude=(attr,))
        if pd is None or "color" in pd and attr == "color":
            return None
        kw["p"] = part_np(W, i, raw, pd, rng, vocab)
    q = fill(rng, PQ[attr], **kw)
    prog = pchain(pd, uniq(dx) + " | object2part") + f" | unique | partquery_{attr}"
    return Item(q, prog, f"part_query_{attr}")


def f_owner_query(W, rng, want, attr, vocab="core", buss=False, extra=0):
    pool = [(i, raw) for i in sorted(W.all) for raw in sorted(W.o[i].parts)]
    if not pool:
        return None
    i, raw = rng.choice(pool)
    pd = part_minimal(W, (i, raw), phys(W, W.all), rng)
    if pd is None:
        return None
    p = part_np(W, i, raw, pd, rng, vocab)
    noun = rng.choice(["thing", "object", "vehicle", "one"])
    holds = [f"the {noun} that has {article(p)}", f"the {noun} with {article(p)}", f"the {noun} which has {article(p)}",
             f"the {noun} that owns {article(p)}", f"the {noun} with the {p}", f"the {noun} that the {p} belongs to",
             f"the {noun} having {article(p)}", f"the {noun} that's got {article(p)}"]
    if set(pd) == {"color", "partname"}:
        p2 = _pwords(pd["partname"], raw, rng, vocab)
        holds += [f"the {noun} whose {p2} is {rng.choice(COLOR_W[pd['color']])}"] * 3
    hold = rng.choice(holds)
    q = fill(rng, [t for t in Q[attr] if "{aX}" not in t and "{Xp}" not in t], X=hold)
    prog = pchain(pd, "scene() | object2part") + f" | unique | part2object | unique | query_{attr}"
    return Item(q, prog, f"owner_query_{attr}")


SAMEOBJ = [
    "What {qa} is the {p1} of the {o} that has {ap2}?", "What {qa} is the {p1} that belongs to the same object as the {p2}?",
    "The {o} with {ap2} has {ap1}; what {qa} is it?", "What {qa} is the {p1} on the same {o} as the {p2}?",
    "There is {ap2}; what {qa} is the {p1} of the same {o}?", "Which {qa} is the {p1} of the {o} whose {p2w} is {c2}?",
    "Tell me the {qa} of the {p1} of the {o} that has {ap2}.", "What {qa} is the {p1} belonging to the {o} with the {p2}?",
]
SAMEOBJ_Q = {"color": "colour", "material": "material"}


def f_same_object_part(W, rng, want, attr, vocab="core", buss=False):
    pool = [i for i in sorted(W.all) if len(W.o[i].parts) >= 2]
    if not pool:
        return None
    i = rng.choice(pool)
    r1, r2 = rng.sample(sorted(W.o[i].parts), 2)
    pd2 = part_minimal(W, (i, r2), phys(W, W.all), rng)
    own = phys(W, [i])
    if attr == "partname":
        pd1 = part_minimal(W, (i, r1), own, rng, no_name=True)
        if pd1 is None or "partname" in pd1:
            return None
    else:
        pd1 = part_minimal(W, (i, r1), own, rng, exclude=(attr,))
    if pd1 is None or pd2 is None:
        return None
    p1 = part_np(W, i, r1, pd1, rng, vocab)
    p2 = part_np(W, i, r2, pd2, rng, vocab)
    c2 = rng.choice(COLOR_W[pd2["color"]]) if "color" in pd2 else None
    p2w = _pwords(pd2["partname"], r2, rng, vocab) if "partname" in pd2 and c2 and len(pd2) == 2 else None
    if attr == "partname":
        T = ["What is the name of the {p1} of the {o} that has {ap2}?", "What part is the {p1} that belongs to the same object as the {p2}?",
             "Which part is {pp1} on the {o} with {ap2}?", "There is {ap2}; which part of the same {o} is {pp1}?",
             "Name the {p1} that is on the same {o} as the {p2}.", "What is the {p1} of the {o} whose {p2w} is {c2} called?",
             "Which part of the {o} that has {ap2} is {pp1}?"]
    else:
        T = [t.replace("{qa}", "{colour}" if attr == "color" else "material") for t in SAMEOBJ]
        if attr == "material":
            T += ["What is the {p1} of the {o} that has {ap2} made of?", "Is the {p1} on the same {o} as the {p2} metal or rubber?"]
    pp1 = None
    if attr == "partname":
        c, m = W.o[i].parts[r1]
        pp1 = join_and(([c] if "color" in pd1 else []) + (["made of " + m] if "material" in pd1 else []))
    q = fill(rng, T, p1=p1, ap1=article(p1), p2=p2, ap2=article(p2), o=rng.choice(["thing", "object", "vehicle"]),
             c2=c2, p2w=p2w, pp1=pp1)
    prog = (pchain(pd2, "scene() | object2part") + " | unique | part2object | object2part"
            + pchain(pd1, "") + f" | unique | partquery_{attr}")
    return Item(q, prog, f"same_object_part_{attr}")


PCOUNT = [
    "How many {pw} parts does {X} have?", "How many parts of {X} are {pw}?", "How many of {Xp} parts are {pw}?",
    "Count the {pw} parts of {X}.", "What number of {pw} parts does {X} have?", "How many parts on {X} are {pw}?",
    "There is {aX}; how many of its parts are {pw}?", "Tell me how many {pw} parts {X} has.",
    "How many {pw} parts can you see on {X}?", "{X} has how many {pw} parts?", "How many {pws} does {X} have?",
    "How many {pws} are on {X}?", "Count the {pws} of {X}.",
]


def f_part_count(W, rng, want, vocab="core", buss=False, extra=0):
    i, dx = _referent(W, rng, extra=extra)
    if dx is None:
        return None
    o = W.o[i]
    use_mat = rng.random() < 0.25
    if use_mat:
        v = "metal" if o.material == "rubber" else "rubber"
        pd = {"material": v}
        pw = rng.choice(MAT_ADJ[v] + ["made of " + v])
    else:
        opts = sorted({c for c, _ in o.parts.values()}) if rng.random() < 0.75 and o.parts else [c for c in O.COLORS if c != o.color]
        v = rng.choice(opts)
        pd = {"color": v}
        pw = rng.choice(COLOR_W[v])
    pws = None
    if rng.random() < 0.35 and not use_mat:
        sups = sorted({O.super_part_name(r) for r in O.PARTS[o.subtype]})
        sup = rng.choice(sorted({O.super_part_name(r) for r in o.parts}) or sups) if rng.random() < 0.7 else rng.choice(sups)
        pd["partname"] = sup
        pws = f"{pw} {part_plural(super_words(sup, rng, vocab))}"
    npx = NP(dx, rng, vocab, buss=buss)
    T = [t for t in PCOUNT if ("{pws}" in t) == (pws is not None)]
    if pw.startswith("made of"):
        T = [t for t in T if "{pw} parts" not in t]
    q = fill(rng, T, pw=pw, pws=pws, X=npx.the(), aX=npx.a(), Xp=npx.pos())
    return Item(q, f"count({pchain(pd, uniq(dx) + ' | object2part')})", "part_count")


PEXIST = [
    "Does {X} have {ap}?", "Is there {ap} on {X}?", "Has {X} got {ap}?", "Can you see {ap} on {X}?",
    "Does {X} have any {pps}?", "There is {aX}; does it have {ap}?", "Is {X} equipped with {ap}?",
    "Tell me whether {X} has {ap}.", "Is any {p} of {X} {c}?", "Are any of {Xp} {ps} {c}?",
    "Is one of {Xp} {ps} {c}?", "Does {X} come with {ap}?",
]
PEXIST_ANY = [
    "Is there {ao} with {ap}?", "Does any {o} have {ap}?", "Can you see {ao} that has {ap}?",
    "Is there {ao} whose {p} is {c}?", "Do any {os} have {pps}?", "Are there {os} with {pps}?",
]


def f_part_exist(W, rng, want, vocab="core", buss=False, extra=0):
    if rng.random() < 0.3:
        d = random_filter(W, rng, kmin=1, kmax=1, exclude=("color",))
        objs = sorted(sel(W, W.all, d))
        if not objs:
            return None
        bad = {W.o[j].color for j in objs}
        pick = rng.choice(objs)
        pool = [(pick, r) for r in sorted(W.o[pick].parts)]
        if want and pool:
            j, raw = rng.choice(pool)
            c = W.o[j].parts[raw][0]
        else:
            raw = rng.choice(O.PARTS[W.o[pick].subtype])
            c = rng.choice(sorted(set(O.COLORS) - bad))
        if c in bad:
            return None
        sup = O.super_part_name(raw)
        pd = {"color": c, "partname": sup}
        p = f"{rng.choice(COLOR_W[c])} {super_words(sup, rng, vocab)}"
        nn = NP(d, rng, vocab, buss=buss, style="pre")
        q = fill(rng, PEXIST_ANY, ao=nn.a(), o=nn.bare(), os=nn.pl(), ap=article(p), pps=part_plural(p),
                 p=super_words(sup, rng, vocab), c=rng.choice(COLOR_W[c]))
        return Item(q, f"exist({pchain(pd, chain(d) + ' | object2part')})", "part_exist_any")
    i, dx = _referent(W, rng, extra=extra)
    if dx is None:
        return None
    o = W.o[i]
    if want and o.parts:
        raw = rng.choice(sorted(o.parts))
        c = o.parts[raw][0]
    else:
        raw = rng.choice(O.PARTS[o.subtype])
        c = rng.choice([c for c in O.COLORS if c != o.color])
    sup = O.super_part_name(raw)
    n_sup = sum(O.super_part_name(r) == sup for r in O.PARTS[o.subtype])
    if rng.random() < 0.6:
        pd, pwords = {"color": c, "partname": sup}, super_words(sup, rng, vocab)
    else:
        pd, pwords = {"color": c, "partname": O.canonical_part_name(raw)}, part_words(raw, rng, vocab)
        n_sup = 1
    cw = rng.choice(COLOR_W[c])
    p = f"{cw} {pwords}"
    npx = NP(dx, rng, vocab, buss=buss)
    T = PEXIST if n_sup > 1 else [t for t in PEXIST if "{ps}" not in t and "any {p}" not in t and "{pps}" not in t]
    q = fill(rng, T, X=npx.the(), aX=npx.a(), Xp=npx.pos(), ap=article(p), pps=part_plural(p), p=pwords,
             ps=part_plural(pwords), c=cw)
    return Item(q, f"exist({pchain(pd, uniq(dx) + ' | object2part')})", "part_exist")


# ---- pose

QP = [
    "Which direction is {X} facing?", "Which way is {X} facing?", "What direction is {X} pointing?",
    "Which direction does {X} face?", "Where is {X} heading?", "What is the orientation of {X}?",
    "What is the pose of {X}?", "Tell me which way {X} faces.", "Is {X} facing left, right, towards us or away from us?",
    "In which direction is {X} pointed?", "{X} faces which direction?", "Which way does {X} point?",
    "What's {Xp} heading?", "What is {Xp} facing direction?", "There is {aX}; which way is it facing?",
    "Which direction is {X} headed?", "I want to know which direction {X} is facing.", "How is {X} oriented?",
    "What direction does {X} face in?", "Can you tell me where {X} is pointing?", "What is {Xp} orientation?",
    "Which way is {X} turned?",
]


def f_query_pose(W, rng, want, vocab="core", buss=False, extra=0):
    pool = [i for i in sorted(W.all) if W.o[i].pose and (not isinstance(want, str) or W.o[i].pose == want)]
    if not pool:
        return None
    t = rng.choice(pool)
    d = minimal(W, t, W.all, rng, extra=extra)
    if d is None:
        return None
    np_ = NP(d, rng, vocab, buss=buss)
    return Item(fill(rng, QP, **forms(np_)), uniq(d) + " | query_pose", "query_pose")


def f_pose_filter_query(W, rng, want, attr, vocab="core", buss=False, extra=0):
    pool = [i for i in sorted(W.all) if W.o[i].pose]
    if not pool:
        return None
    t = rng.choice(pool)
    d = minimal(W, t, W.all, rng, exclude=(attr,), need={"pose": W.o[t].pose}, extra=extra)
    if d is None:
        return None
    np_ = NP(d, rng, vocab, buss=buss, generic=_generic_for(attr, rng), style="pre")
    return Item(fill(rng, [s for s in Q[attr] if "{Xp}" not in s], X=np_.the(), aX=np_.a()),
                uniq(d) + f" | query_{attr}", f"pose_filter_query_{attr}")


PCOUNT_POSE = [
    "How many {ys} are {pose}?", "How many {ys} {face}?", "What number of {ys} are {pose}?", "Count the {ys} {pose}.",
    "How many {ys} that are {pose} are there?", "Tell me how many {ys} are {pose}.", "How many {ys} do you see {pose}?",
    "Of the {ys}, how many are {pose}?", "How many {ys} have their fronts pointing {dirw}?",
    "How many {ys} are oriented {dirw}?",
]
PEXIST_POSE = [
    "Is there {ay} {pose}?", "Are there any {ys} {pose}?", "Is any {y} {pose}?", "Does any {y} {face}?",
    "Can you see {ay} that is {pose}?", "Is there {ay} which is {pose}?", "Are any of the {ys} {pose}?",
    "Is there {ay} whose front points {dirw}?", "Do any {ys} {face}?", "Is at least one {y} {pose}?",
]
FACE = {"left": ["face left", "point to the left", "head left"], "right": ["face right", "point to the right", "head right"],
        "front": ["face the camera", "face towards us", "point at the camera"],
        "back": ["face away from the camera", "point away from us", "face away"]}
DIRW = {"left": ["left", "to the left"], "right": ["right", "to the right"], "front": ["towards the camera", "at us"],
        "back": ["away from the camera", "away from us"]}


def f_pose_count(W, rng, want, kind="count", vocab="core", buss=False):
    p = rng.choice(O.POSES)
    f = {} if rng.random() < 0.4 else random_filter(W, rng, kmin=1, kmax=1, absent=want is False and rng.random() < 0.3)
    pl = len(sel(W, W.all, dict(f, pose=p)))
    if kind == "exist" and want is not None and (pl > 0) != want:
        return None
    np_ = NP(f, rng, vocab, buss=buss, style="pre", generic=rng.choice(["thing", "object", "vehicle"]))
    kw = {"ys": np_.pl(), "y": np_.bare(), "ay": np_.a(),
          "pose": rng.choice(POSE_PRED_PL[p] if kind == "count" else POSE_PRED[p]),
          "face": rng.choice(FACE[p]), "dirw": rng.choice(DIRW[p])}
    q = fill(rng, PCOUNT_POSE if kind == "count" else PEXIST_POSE, **kw)
    return Item(q, f"{kind}({chain(dict(f, pose=p))})", f"pose_filter_{kind}")


POSE_REL = {
    "same": ["facing the same direction as", "facing the same way as", "pointing in the same direction as",
             "heading the same way as", "with the same orientation as", "oriented the same way as",
             "facing in the same direction as", "turned the same way as", "parallel to and facing the same way as"],
    "opposite": ["facing the opposite direction to", "facing the opposite way from", "pointing the opposite way to",
                 "heading in the opposite direction from", "facing opposite to", "with the opposite orientation to",
                 "facing the other way from", "turned the opposite way from", "facing the opposite direction as"],
    "vertical": ["facing perpendicular to", "at a right angle to", "facing at right angles to", "pointing perpendicular to",
                 "oriented perpendicular to", "facing the vertical direction as", "turned ninety degrees from",
                 "facing crosswise to", "perpendicular in direction to"],
}
POSE_REL_COUNT = [
    "How many {ys} are {prel} {X}?", "What number of {ys} are {prel} {X}?", "Count the {ys} {prel} {X}.",
    "There is {aX}; how many {ys} are {prel} it?", "How many {ys} face the {pway} {X}?",
    "Tell me how many {ys} are {prel} {X}.", "How many {ys} have {porient} {X}?", "How many other {ys} are {prel} {X}?",
]
POSE_REL_EXIST = [
    "Is there {ay} {prel} {X}?", "Are there any {ys} {prel} {X}?", "Is any {y} {prel} {X}?",
    "There is {aX}; is anything {prel} it?", "Does any {y} face the {pway} {X}?", "Is there {ay} that has {porient} {X}?",
    "Can you see {ay} {prel} {X}?", "Is anything else {prel} {X}?",
]
PWAY = {"same": ["same way as", "same direction as"], "opposite": ["opposite way to", "opposite direction from"],
        "vertical": ["perpendicular direction to"]}
PORIENT = {"same": ["the same orientation as", "the same pose as", "the same heading as"],
           "opposite": ["the opposite orientation to", "the opposite heading to", "an opposite pose to"],
           "vertical": ["a perpendicular orientation to", "an orientation at right angles to"]}


def f_pose_rel(W, rng, want, kind, what, vocab="core", buss=False, extra=0):
    pool = [i for i in sorted(W.all) if W.o[i].pose]
    if not pool:
        return None
    x = rng.choice(pool)
    dx = minimal(W, x, W.all, rng, extra=extra)
    if dx is None:
        return None
    rs = W.pose_rel(x, kind)
    npx = anc(dx, rng, vocab, buss)
    prel = rng.choice(POSE_REL[kind])
    base = uniq(dx) + f" | {kind}_pose"
    if what in ("count", "exist"):
        f = {} if rng.random() < 0.45 else random_filter(W, rng, cands=rs or None, kmin=1, kmax=1)
        if what == "exist" and want is not None and bool(sel(W, rs, f)) != want:
            return None
        np_ = NP(f, rng, vocab, buss=buss, style="pre", generic=rng.choice(["thing", "object", "vehicle"]))
        prel_ = prel
        T = POSE_REL_COUNT if what == "count" else POSE_REL_EXIST
        if f:
            T = [t for t in T if "anything" not in t]
        q = fill(rng, T, ys=np_.pl(), y=np_.bare(), ay=np_.a(), prel=prel_, X=npx.the(), aX=npx.a(),
                 pway=rng.choice(PWAY[kind]), porient=rng.choice(PORIENT[kind]))
        return Item(q, f"{what}({chain(f, base)})", f"{kind}_pose_{what}")
    attr = what
    _t, dt = _referent(W, rng, cands=rs, exclude=(attr,), extra=extra)
    if dt is None:
        return None
    npt = NP(dt, rng, vocab, buss=buss, generic=_generic_for(attr, rng), style="pre")
    kw = {"X": f"the {npt.bare()} {prel} {npx.the()}", "aX": f"{npt.a()} {prel} {npx.the()}", "Xp": None}
    q = fill(rng, Q[attr], **kw)
    return Item(q, uniq(dt, base) + f" | query_{attr}", f"{kind}_pose_query_{attr}")


# ---- occlusion of objects

OCC_PRE = ["occluded", "hidden", "partly hidden", "partially occluded", "partially hidden", "obscured", "partly covered",
           "half-hidden", "partially blocked"]
OCC_POST = ["that is occluded", "that is partly hidden", "which is hidden", "that is partially blocked from view",
            "that is not fully visible", "that's obscured", "which is partially covered", "that can't be seen completely"]
OCC_BY = ["occluded by", "hidden by", "blocked by", "covered by", "obscured by", "partly hidden behind", "partially covered by",
          "hidden from view by", "that is occluded by", "which is hidden by"]
OCCLUDES = ["that occludes", "that hides", "that is blocking", "which covers", "that obscures", "hiding", "blocking the view of",
            "which partly hides", "that is in front of and hiding", "occluding"]


def f_occ_query(W, rng, want, attr, vocab="core", buss=False, extra=0):
    occ = sorted(i for i in W.all if W.o[i].occluded)
    if not occ:
        return None
    t = rng.choice(occ)
    d = minimal(W, t, occ, rng, exclude=(attr,), extra=extra)
    if d is None:
        return None
    if extra == 0 and sel(W, W.all, d) == {t}:
        return None  # the occlusion is not needed
    np_ = NP(d, rng, vocab, buss=buss, generic=_generic_for(attr, rng), style="pre")
    if rng.random() < 0.5:
        X = "the " + rng.choice(OCC_PRE) + " " + np_.bare()
        aX = article(X[4:])
    else:
        post = rng.choice(OCC_POST)
        X, aX = f"the {np_.bare()} {post}", f"{np_.a()} {post}"
    q = fill(rng, Q[attr], X=X, aX=aX)
    return Item(q, uniq(d, "scene() | filter_occludee") + f" | query_{attr}", f"occluded_query_{attr}")


def f_occ_rel_query(W, rng, want, attr, direction, vocab="core", buss=False, extra=0):
    """direction 'by': the thing occluded by Y (Y | relate_occluding); 'of': the thing that occludes Y."""
    pool = [i for i in sorted(W.all) if (W.o[i].occludees if direction == "by" else W.o[i].occluders)]
    if not pool:
        return None
    y = rng.choice(pool)
    rs = W.o[y].occludees if direction == "by" else W.o[y].occluders
    dy = minimal(W, y, W.all, rng, extra=extra)
    _t, dt = _referent(W, rng, cands=rs, exclude=(attr,), extra=extra)
    if dy is None or dt is None:
        return None
    npy = anc(dy, rng, vocab, buss)
    npt = NP(dt, rng, vocab, buss=buss, generic=_generic_for(attr, rng), style="pre")
    if direction == "by":
        if rng.random() < 0.3:
            verb = rng.choice(["hides", "occludes", "blocks", "covers", "is hiding", "partly covers"])
            X, aX = f"the {npt.bare()} that {npy.the()} {verb}", f"{npt.a()} that {npy.the()} {verb}"
        else:
            ph = rng.choice(OCC_BY)
            X, aX = f"the {npt.bare()} {ph} {npy.the()}", f"{npt.a()} {ph} {npy.the()}"
        op, fam = "relate_occluding", f"occluded_by_query_{attr}"
    else:
        ph = rng.choice(OCCLUDES)
        X, aX = f"the {npt.bare()} {ph} {npy.the()}", f"{npt.a()} {ph} {npy.the()}"
        op, fam = "relate_occluded", f"occluder_query_{attr}"
    q = fill(rng, Q[attr], X=X, aX=aX)
    return Item(q, uniq(dt, uniq(dy) + f" | {op}") + f" | query_{attr}", fam)


OCC_COUNT = [
    "How many {ys} are occluded?", "How many {ys} are partly hidden?", "How many occluded {ys} are there?",
    "Count the {ys} that are hidden.", "What number of {ys} are partially blocked from view?",
    "How many of the {ys} can't be fully seen?", "How many {ys} are obscured by something?",
    "How many {ys} are covered by another object?", "Tell me how many {ys} are occluded.",
    "How many {ys} are at least partly hidden?", "How many hidden {ys} can you see?", "How many {ys} are partially occluded?",
]
OCC_EXIST = [
    "Is {X} occluded?", "Is {X} partly hidden?", "Is {X} hidden behind something?", "Is {X} blocked by anything?",
    "Is {X} partially hidden from view?", "Is something blocking {X}?", "Is {X} obscured?", "Is the view of {X} blocked?",
    "Does something occlude {X}?", "Is {X} covered by something?", "There is {aX}; is it occluded?",
    "Is {X} partially covered by another object?", "Tell me whether {X} is occluded.", "Is {X} occluded by anything?",
    "Is any other object hiding {X}?",
]
OCC_EXIST_SET = [
    "Are any {ys} occluded?", "Is there an occluded {y}?", "Is any {y} partly hidden?", "Are there hidden {ys}?",
    "Is there {ay} that is partially covered?", "Can you see {ay} that is occluded?", "Is some {y} blocked from view?",
]


def f_occ_count(W, rng, want, vocab="core", buss=False):
    f = {} if rng.random() < 0.35 else random_filter(W, rng, cands=[i for i in W.all if W.o[i].occluded] or None, kmin=1, kmax=1)
    np_ = NP(f, rng, vocab, buss=buss, style="pre", generic=rng.choice(["thing", "object", "vehicle"]))
    q = fill(rng, OCC_COUNT, ys=np_.pl())
    return Item(q, f"count({chain(f, 'scene() | filter_occludee')})", "occluded_count")


def f_occ_exist(W, rng, want, vocab="core", buss=False, extra=0):
    if rng.random() < 0.3:
        f = random_filter(W, rng, kmin=1, kmax=1)
        if want is not None and bool(sel(W, [i for i in W.all if W.o[i].occluded], f)) != want:
            return None
        np_ = NP(f, rng, vocab, buss=buss, style="pre")
        q = fill(rng, OCC_EXIST_SET, ys=np_.pl(), y=np_.bare(), ay=np_.a())
        return Item(q, f"exist({chain(f, 'scene() | filter_occludee')})", "occluded_exist_any")
    pool = [i for i in sorted(W.all) if want is None or W.o[i].occluded == want]
    if not pool:
        return None
    t = rng.choice(pool)
    d = minimal(W, t, W.all, rng, extra=extra)
    if d is None:
        return None
    np_ = NP(d, rng, vocab, buss=buss)
    q = fill(rng, OCC_EXIST, X=np_.the(), aX=np_.a())
    return Item(q, f"exist({chain(d, 'scene() | filter_occludee')})", "occluded_exist")


OCC_BY_EXIST = [
    "Is {X} occluded by {Y}?", "Is {X} hidden by {Y}?", "Does {Y} occlude {X}?", "Does {Y} block {X}?",
    "Is {X} partly covered by {Y}?", "Is {Y} hiding {X}?", "Is {X} obscured by {Y}?", "Is {X} partially hidden behind {Y}?",
    "Does {Y} hide part of {X}?", "There is {aX}; is it occluded by {Y}?", "Is part of {X} blocked from view by {Y}?",
    "Tell me whether {Y} occludes {X}.", "Is {Y} in the way of {X}, hiding part of it?",
]
OCC_N = {
    "occluders": ["How many things occlude {X}?", "How many objects are hiding {X}?", "By how many objects is {X} occluded?",
                  "How many {ys} block the view of {X}?", "Count the {ys} that occlude {X}.", "How many {ys} hide part of {X}?",
                  "There is {aX}; how many {ys} are occluding it?", "What number of {ys} cover {X}?"],
    "occludees": ["How many things does {X} occlude?", "How many objects are hidden by {X}?", "How many {ys} does {X} hide?",
                  "Count the {ys} occluded by {X}.", "How many {ys} are partly covered by {X}?",
                  "There is {aX}; how many {ys} does it block?", "What number of {ys} are obscured by {X}?",
                  "How many {ys} is {X} hiding?"],
}


def f_occ_by_exist(W, rng, want, vocab="core", buss=False, extra=0):
    pool = [i for i in sorted(W.all) if W.o[i].occluders] if want else sorted(W.all)
    if not pool:
        return None
    x = rng.choice(pool)
    ys = sorted(W.o[x].occluders) if want else sorted(set(W.all) - W.o[x].occluders - {x})
    if not ys:
        return None
    y = rng.choice(ys)
    dx, dy = minimal(W, x, W.all, rng, extra=extra), minimal(W, y, W.all, rng, extra=extra)
    if dx is None or dy is None:
        return None
    npx, npy = NP(dx, rng, vocab, buss=buss), NP(dy, rng, vocab, buss=buss)
    q = fill(rng, OCC_BY_EXIST, X=npx.the(), aX=npx.a(), Y=npy.the())
    return Item(q, f"exist({chain(dy, uniq(dx) + ' | relate_occluded')})", "occluded_by_exist")


def f_occ_n(W, rng, want, kind, vocab="core", buss=False, extra=0):
    attr = "occluders" if kind == "occluders" else "occludees"
    pool = [i for i in sorted(W.all) if getattr(W.o[i], attr)] if rng.random() < 0.7 else sorted(W.all)
    if not pool:
        return None
    x = rng.choice(pool)
    dx = minimal(W, x, W.all, rng, extra=extra)
    if dx is None:
        return None
    rs = getattr(W.o[x], attr)
    f = {} if rng.random() < 0.6 else random_filter(W, rng, cands=rs or None, kmin=1, kmax=1)
    np_ = NP(f, rng, vocab, buss=buss, style="pre", generic=rng.choice(["thing", "object", "vehicle"]))
    npx = NP(dx, rng, vocab, buss=buss)
    T = OCC_N[kind] if f else [t for t in OCC_N[kind] if "{ys}" not in t] + [t for t in OCC_N[kind] if "{ys}" in t]
    q = fill(rng, T, X=npx.the(), aX=npx.a(), ys=np_.pl())
    op = "relate_occluded" if kind == "occluders" else "relate_occluding"
    return Item(q, f"count({chain(f, uniq(dx) + ' | ' + op)})", f"{kind}_count")


# ---- occlusion of parts

PART_OCC = [
    "Is {Xp} {p} occluded?", "Is the {p} of {X} occluded?", "Is the {p} of {X} hidden?", "Is {Xp} {p} blocked from view?",
    "Is the {p} on {X} partly covered?", "There is {aX}; is its {p} occluded?", "Is {Xp} {p} hidden by something?",
    "Does something hide the {p} of {X}?", "Is the {p} that belongs to {X} occluded?",
    "Tell me whether the {p} of {X} is hidden.", "Is the {p} of {X} partially obscured?", "Is {X} 's {p} occluded?",
    "Look at {X}: is its {p} hidden?", "Is the {p} of {X} covered by another object?", "Is {Xp} {p} partly out of view?",
]
PART_OCC_BY = [
    "Is {Xp} {p} occluded by {Y}?", "Is the {p} of {X} hidden by {Y}?", "Does {Y} occlude the {p} of {X}?",
    "Does {Y} hide {Xp} {p}?", "Is the {p} of {X} blocked by {Y}?", "Is {Y} covering the {p} of {X}?",
    "There is {aX}; is its {p} occluded by {Y}?", "Is the {p} on {X} partly hidden behind {Y}?",
    "Tell me if {Y} hides the {p} of {X}.", "Is {Xp} {p} obscured by {Y}?", "Is it {Y} that occludes the {p} of {X}?",
]


def _pname(W, i, raw, rng, vocab):
    value, words = part_name_value(W, i, raw, rng)
    return value, words or part_words(raw, rng, vocab)


def f_part_occluded(W, rng, want, vocab="core", buss=False, extra=0):
    pool = [(i, r) for i in sorted(W.all) for r in sorted(W.o[i].all_parts if want is None else
                                                          (W.o[i].occ_parts if want else set(W.o[i].parts) - W.o[i].occ_parts))]
    if not pool:
        return None
    i, raw = rng.choice(pool)
    dx = minimal(W, i, W.all, rng, extra=extra)
    if dx is None:
        return None
    value, pw = _pname(W, i, raw, rng, vocab)
    npx = NP(dx, rng, vocab, buss=buss)
    q = fill(rng, PART_OCC, X=npx.the(), aX=npx.a(), Xp=npx.pos(), p=pw).replace(" 's ", "'s ")
    return Item(q, uniq(dx) + f" | object2part_all | partfilter_partname[{value}] | unique | partquery_occlusion",
                "part_occluded")


def f_part_occluded_by(W, rng, want, vocab="core", buss=False, extra=0):
    if want:
        pool = [(i, r) for i in sorted(W.all) for r in sorted(W.o[i].part_occ)]
    else:
        pool = [(i, r) for i in sorted(W.all) for r in sorted(W.o[i].all_parts)]
    if not pool:
        return None
    i, raw = rng.choice(pool)
    occ = W.o[i].part_occ.get(raw, frozenset())
    ys = sorted(occ) if want else sorted(set(W.all) - occ - {i})
    if not ys:
        return None
    y = rng.choice(ys)
    dx, dy = minimal(W, i, W.all, rng, extra=extra), minimal(W, y, W.all, rng, extra=extra)
    if dx is None or dy is None:
        return None
    value, pw = _pname(W, i, raw, rng, vocab)
    npx, npy = NP(dx, rng, vocab, buss=buss), NP(dy, rng, vocab, buss=buss)
    q = fill(rng, PART_OCC_BY, X=npx.the(), aX=npx.a(), Xp=npx.pos(), p=pw, Y=npy.the())
    prog = f"exist({chain(dy, uniq(dx) + f' | object2part_all | partfilter_partname[{value}] | unique | relate_part_occluded')})"
    return Item(q, prog, "part_occluded_by")


WHICH_PART = [
    "Which part of {X} is occluded?", "What part of {X} is hidden?", "Which of {Xp} parts is hidden from view?",
    "Name the occluded part of {X}.", "What is the name of the part of {X} that is occluded?",
    "Tell me which part of {X} is blocked.", "There is {aX}; which of its parts is covered?",
    "What part of {X} can't be fully seen?", "Which part of {X} is partly hidden?", "What is the hidden part of {X}?",
    "Which part of {X} is obscured by another object?", "{X} has one occluded part; which one?",
    "Look at {X}. Which of its parts is hidden?", "What's the name of {Xp} occluded part?",
]


def f_which_part(W, rng, want, vocab="core", buss=False, extra=0):
    pool = [i for i in sorted(W.all) if len(W.o[i].occ_parts) == 1]
    if not pool:
        return None
    i = rng.choice(pool)
    dx = minimal(W, i, W.all, rng, extra=extra)
    if dx is None:
        return None
    npx = NP(dx, rng, vocab, buss=buss)
    q = fill(rng, WHICH_PART, X=npx.the(), aX=npx.a(), Xp=npx.pos())
    return Item(q, uniq(dx) + " | object2part_all | partfilter_occludee | unique | partquery_partname", "which_part_occluded")


WHOSE_OCC = ["whose {p} is occluded", "whose {p} is hidden", "whose {p} is partly hidden", "with an occluded {p}",
             "that has its {p} hidden", "whose {p} is blocked from view", "that has a hidden {p}", "whose {p} can't be fully seen",
             "whose {p} is partially covered", "with a {p} that is occluded"]
WHOSE_OCC_BY = ["whose {p} is occluded by {Y}", "whose {p} is hidden by {Y}", "whose {p} {Y} hides", "whose {p} is blocked by {Y}",
                "that has its {p} covered by {Y}", "whose {p} is partly hidden behind {Y}", "with a {p} occluded by {Y}",
                "whose {p} is being blocked by {Y}"]


def f_whose_part(W, rng, want, attr, vocab="core", buss=False, extra=0):
    pool = [(i, r) for i in sorted(W.all) for r in sorted(W.o[i].occ_parts)]
    if not pool:
        return None
    i, raw = rng.choice(pool)
    value, words = part_name_value(W, i, raw, rng)
    if rng.random() < 0.5:
        value, words = O.super_part_name(raw), super_words(O.super_part_name(raw), rng, vocab)
    words = words or part_words(raw, rng, vocab)
    cands = [j for j in sorted(W.all) if any(O.partname_matches(r, value) for r in W.o[j].occ_parts)]
    dx = minimal(W, i, cands, rng, exclude=(attr,), extra=extra)
    if dx is None:
        return None
    npx = NP(dx, rng, vocab, buss=buss, generic=_generic_for(attr, rng), style="pre")
    ph = rng.choice(WHOSE_OCC).format(p=words)
    X = f"the {npx.bare()} {ph}"
    q = fill(rng, Q[attr], X=X, aX=f"{npx.a()} {ph}")
    prog = chain(dx) + f" | object2part_all | partfilter_occludee | partfilter_partname[{value}] | part2object | unique | query_{attr}"
    return Item(q, prog, f"whose_part_occluded_query_{attr}")


def f_whose_part_by(W, rng, want, attr, vocab="core", buss=False, extra=0):
    pool = [y for y in sorted(W.all) if W.hidden_parts_by(y)]
    if not pool:
        return None
    y = rng.choice(pool)
    hidden = W.hidden_parts_by(y)
    i, raw = rng.choice(hidden)
    pd = part_minimal(W, (i, raw), hidden, rng, exclude=("color", "material"))
    dy = minimal(W, y, W.all, rng, extra=extra)
    dx = minimal(W, i, {i}, rng, exclude=(attr,), extra=extra)
    if pd is None or dy is None or dx is None:
        return None
    npy = anc(dy, rng, vocab, buss)
    npx = NP(dx, rng, vocab, buss=buss, generic=_generic_for(attr, rng), style="pre")
    ph = rng.choice(WHOSE_OCC_BY).format(p=_pwords(pd["partname"], raw, rng, vocab), Y=npy.the())
    q = fill(rng, Q[attr], X=f"the {npx.bare()} {ph}", aX=f"{npx.a()} {ph}")
    prog = uniq(dx, pchain(pd, uniq(dy) + " | relate_occluding_part") + " | unique | part2object") + f" | query_{attr}"
    return Item(q, prog, f"whose_part_occluded_by_query_{attr}")


OCC_OBJ_PART = {
    "color": ["What {colour} is the {p} of {X}?", "What is the {colour} of the {p} of {X}?", "{X} has {ap}; what {colour} is it?",
              "Tell me the {colour} of the {p} that belongs to {X}.", "Which {colour} is the {p} on {X}?",
              "What {colour} is the {p} belonging to {X}?"],
    "material": ["What is the {p} of {X} made of?", "What material is the {p} of {X}?", "{X} has {ap}; what is it made of?",
                 "Is the {p} of {X} metal or rubber?", "Tell me the material of the {p} that belongs to {X}.",
                 "What material is the {p} belonging to {X}?"],
    "partname": ["Which part of {X} is {pp}?", "What is the name of the {p} of {X}?", "What part of {X} is {pp}?",
                 "{X} has {ap}; which part is it?", "Name the {p} of {X}.", "What is the {p} belonging to {X} called?"],
}


def f_occluded_obj_part(W, rng, want, attr, vocab="core", buss=False, extra=0):
    occ = sorted(i for i in W.all if W.o[i].occluded and W.o[i].parts)
    if not occ:
        return None
    i = rng.choice(occ)
    occ_all = sorted(j for j in W.all if W.o[j].occluded)
    dx = minimal(W, i, occ_all, rng, extra=extra)
    if not dx:
        return None
    raw = rng.choice(sorted(W.o[i].parts))
    own = phys(W, [i])
    if attr == "partname":
        pd = part_minimal(W, (i, raw), own, rng, no_name=True)
        if pd is None or "partname" in pd:
            return None
    else:
        pd = part_minimal(W, (i, raw), own, rng, exclude=(attr,))
        if pd is None:
            return None
    npx = NP(dx, rng, vocab, buss=buss, style="pre")
    if rng.random() < 0.5:
        X = "the " + rng.choice(OCC_PRE) + " " + npx.bare()
    else:
        X = f"the {npx.bare()} {rng.choice(OCC_POST)}"
    if rng.random() < 0.25:
        X = "an " + X[4:] if X[4] in "aeiou" else "a " + X[4:]
    p = part_np(W, i, raw, pd, rng, vocab)
    c, m = W.o[i].parts[raw]
    pp = join_and(([c] if "color" in pd else []) + (["made of " + m] if "material" in pd else [])) if attr == "partname" else None
    q = fill(rng, OCC_OBJ_PART[attr], X=X, p=p, ap=article(p), pp=pp)
    prog = pchain(pd, chain(dx, "scene() | filter_occludee") + " | object2part") + f" | unique | partquery_{attr}"
    return Item(q, prog, f"occluded_object_part_query_{attr}")


PCOUNT_OCC = [
    "How many parts of {X} are occluded?", "How many of {Xp} parts are hidden?", "Count the hidden parts of {X}.",
    "What number of parts of {X} are blocked from view?", "How many occluded parts does {X} have?",
    "There is {aX}; how many of its parts are occluded?", "How many parts of {X} can't be fully seen?",
    "Tell me how many parts of {X} are partly hidden.", "How many of the parts of {X} are covered by other objects?",
    "{X} has how many hidden parts?",
]
PCOUNT_BY = [
    "How many parts of other objects does {X} hide?", "How many parts are occluded by {X}?", "How many parts does {X} occlude?",
    "Count the parts that {X} is hiding.", "How many parts of other things are covered by {X}?",
    "There is {aX}; how many parts does it block?", "How many {ps} does {X} hide?", "How many {ps} are hidden by {X}?",
    "What number of parts are obscured by {X}?",
]
PEXIST_OCC = [
    "Is any part of {X} occluded?", "Are any of {Xp} parts hidden?", "Does {X} have an occluded part?",
    "Is some part of {X} blocked from view?", "There is {aX}; is any of its parts hidden?", "Does {X} have a hidden {p}?",
    "Is there an occluded {p} on {X}?", "Is any {p} of {X} hidden?", "Does {X} hide any part of another object?",
    "Does {X} occlude a {p} of something?", "Is {X} hiding some {p}?",
]


def f_part_occ_count(W, rng, want, kind, vocab="core", buss=False, extra=0):
    if kind == "by":
        pool = [y for y in sorted(W.all) if W.hidden_parts_by(y)] if rng.random() < 0.75 else sorted(W.all)
    else:
        pool = [i for i in sorted(W.all) if W.o[i].occ_parts] if rng.random() < 0.75 else sorted(W.all)
    if not pool:
        return None
    x = rng.choice(pool)
    dx = minimal(W, x, W.all, rng, extra=extra)
    if dx is None:
        return None
    npx = NP(dx, rng, vocab, buss=buss)
    if kind == "by":
        hidden = W.hidden_parts_by(x)
        sup = None
        if hidden and rng.random() < 0.35:
            sup = O.super_part_name(rng.choice(hidden)[1])
        T = [t for t in PCOUNT_BY if ("{ps}" in t) == (sup is not None)]
        q = fill(rng, T, X=npx.the(), aX=npx.a(), ps=part_plural(super_words(sup, rng, vocab)) if sup else None)
        prog = f"count({uniq(dx)} | relate_occluding_part{f' | partfilter_partname[{sup}]' if sup else ''})"
        return Item(q, prog, "parts_occluded_by_count")
    q = fill(rng, PCOUNT_OCC, X=npx.the(), aX=npx.a(), Xp=npx.pos())
    return Item(q, f"count({uniq(dx)} | object2part_all | partfilter_occludee)", "occluded_part_count")


def f_part_occ_exist(W, rng, want, vocab="core", buss=False, extra=0):
    x = rng.choice(sorted(W.all))
    dx = minimal(W, x, W.all, rng, extra=extra)
    if dx is None:
        return None
    npx = NP(dx, rng, vocab, buss=buss)
    o = W.o[x]
    r = rng.random()
    if r < 0.4:
        T = [t for t in PEXIST_OCC if "{p}" not in t and "another" not in t]
        return Item(fill(rng, T, X=npx.the(), aX=npx.a(), Xp=npx.pos()),
                    f"exist({uniq(dx)} | object2part_all | partfilter_occludee)", "occluded_part_exist")
    if r < 0.7:
        raws = sorted(o.occ_parts) if want and o.occ_parts else list(O.PARTS[o.subtype])
        sup = O.super_part_name(rng.choice(raws))
        if sum(O.super_part_name(r) == sup for r in O.PARTS[o.subtype]) < 2:
            return None
        T = [t for t in PEXIST_OCC if "{p}" in t and "something" not in t and "some {p}" not in t]
        return Item(fill(rng, T, X=npx.the(), p=super_words(sup, rng, vocab)),
                    f"exist({uniq(dx)} | object2part_all | partfilter_occludee | partfilter_partname[{sup}])",
                    "occluded_part_exist")
    hidden = W.hidden_parts_by(x)
    if hidden and rng.random() < 0.6:
        sup = O.super_part_name(rng.choice(hidden)[1])
        T = ["Does {X} occlude a {p} of something?", "Is {X} hiding some {p}?", "Does {X} hide any {p}?",
             "Is there a {p} that {X} occludes?"]
        return Item(fill(rng, T, X=npx.the(), p=super_words(sup, rng, vocab)),
                    f"exist({uniq(dx)} | relate_occluding_part | partfilter_partname[{sup}])", "hides_part_exist")
    T = ["Does {X} hide any part of another object?", "Is {X} occluding part of something else?",
         "Does {X} cover any part of another vehicle?", "Are any parts hidden by {X}?"]
    return Item(fill(rng, T, X=npx.the()), f"exist({uniq(dx)} | relate_occluding_part)", "hides_part_exist")


# ---- the public plural quirk "buss"

BUSS_T = {
    "count": ["How many {bs} are there?", "How many {bs} can you see?", "Count the {bs}.", "What number of {bs} are in the scene?",
              "How many {bs} are in the picture?", "Tell me how many {bs} there are."],
    "exist": ["Are there any {bs}?", "Are there {bs} in the scene?", "Do you see any {bs}?", "Are any {bs} visible?"],
    "relate": ["How many {bs} are {rel} {X}?", "What number of {bs} are {rel} {X}?", "Are there any {bs} {rel} {X}?"],
    "gt": ["Are there more {bs} than {os}?", "Do the {bs} outnumber the {os}?", "Are there more {os} than {bs}?"],
    "eq": ["Are there as many {bs} as {os}?", "Is the number of {bs} the same as the number of {os}?",
           "Are there the same amount of {os} and {bs}?"],
}


def f_buss(W, rng, want, vocab="core", **kw):
    buses = sorted(i for i in W.all if W.o[i].cat == "bus")
    kind = rng.choice(["count", "count", "exist", "relate", "gt", "eq"])
    if buses and rng.random() < 0.7:
        o = W.o[rng.choice(buses)]
        d = rng.choice([{"shape": "bus"}, {"shape": o.subtype}, {"shape": "bus", "color": o.color},
                        {"shape": "bus", "size": o.size}, {"shape": "bus", "material": o.material}])
    else:
        d = {"shape": rng.choice(["bus", "bus", "school", "double", "regular", "articulated"])}
    np_ = NP(d, rng, "core", buss=True, style="pre")
    bs = np_.pl()
    note = "public plural quirk 'buss'"
    if kind in ("count", "exist"):
        q = fill(rng, BUSS_T[kind], bs=bs)
        return Item(q, f"{kind}({chain(d)})", f"buss_{kind}", note)
    if kind == "relate":
        _x, dx = _referent(W, rng, not_=buses)
        if dx is None:
            return None
        r = rng.choice(O.RELATIONS)
        t = rng.choice(BUSS_T["relate"])
        q = fill(rng, [t], bs=bs, rel=rel_w(r, rng), X=NP(dx, rng).the())
        fn = "exist" if t.startswith("Are there") else "count"
        return Item(q, f"{fn}({chain(d, uniq(dx) + f' | relate[{r}]')})", f"buss_relate_{fn}", note)
    other = random_filter(W, rng, kmin=1, kmax=1)
    if "shape" in other and other["shape"] in ("bus",) + tuple(s for s in O.SUBTYPES if O.CATEGORY_OF[s] == "bus"):
        return None
    os_ = set_np(other, rng)[0]
    t = rng.choice(BUSS_T[kind])
    q = fill(rng, [t], bs=bs, os=os_)
    first, second = (d, other) if t.index("{bs}") < t.index("{os}") else (other, d)
    fn = "greater_than" if kind == "gt" else "equal_integer"
    return Item(q, f"{fn}(count({chain(first)}), count({chain(second)}))", f"buss_compare_{kind}", note)


# ---- which wider words a question uses (the synonyms group keeps a question only if it uses one)

def _wide_meanings() -> dict:
    core = set()
    for lst in list(SUB_W.values()) + list(CAT_W.values()) + list(SIZE_W.values()) + list(MAT_ADJ.values()) + \
            list(REL_W.values()) + [GENERIC]:
        core.update(w.lower() for w in lst)
    out = {}
    for table in (SUB_WIDE, CAT_WIDE):
        for k, words in table.items():
            for w in words:
                out.setdefault(w.lower(), k)
    for k, words in list(SIZE_WIDE.items()) + list(MAT_WIDE.items()) + list(REL_WIDE.items()):
        for w in words:
            out.setdefault(w.lower(), k)
    for w in GENERIC_WIDE:
        out.setdefault(w, "thing")
    for a, bs in WIDE_PART_WORDS:
        for b in bs:
            out.setdefault(b.strip(), a.strip())
    out.update({"grey": "gray (British spelling)", "airplane": "aeroplane (American spelling)"})
    return {w: m for w, m in out.items() if w not in core or w in ("grey", "airplane")}


WIDE_MEANING: dict = {}


def wide_used(q: str) -> list[str]:
    import re

    if not WIDE_MEANING:
        WIDE_MEANING.update(_wide_meanings())
    text = " " + q.lower() + " "
    found = []
    for w in sorted((w for w in WIDE_MEANING if " " in w or "-" in w), key=len, reverse=True):  # phrases first
        pat = r"\b" + re.escape(w) + r"s?\b"
        if re.search(pat, text):
            found.append(f"{w} = {WIDE_MEANING[w]}")
            text = re.sub(pat, " # ", text)
    for names in SUB_W.values():  # core names first, so that "bike" in "road bike" is not a synonym
        for n in names:
            if n.lower() not in WIDE_MEANING:
                text = re.sub(r"\b" + re.escape(n.lower()) + r"\b", " # ", text)
    for w in sorted(WIDE_MEANING, key=len, reverse=True):
        pat = r"\b" + re.escape(w) + r"s?\b"
        if re.search(pat, text):
            found.append(f"{w} = {WIDE_MEANING[w]}")
            text = re.sub(pat, " # ", text)
    return found


# ---- typos (edit distance 1)

NEIGHBOURS = {
    "a": "qwsz", "b": "vghn", "c": "xdfv", "d": "serfcx", "e": "wsdr", "f": "drtgvc", "g": "ftyhbv", "h": "gyujnb",
    "i": "ujko", "j": "huikmn", "k": "jiolm", "l": "kop", "m": "njk", "n": "bhjm", "o": "iklp", "p": "ol",
    "q": "wa", "r": "edft", "s": "awedxz", "t": "rfgy", "u": "yhji", "v": "cfgb", "w": "qase", "x": "zsdc",
    "y": "tghu", "z": "asx",
}


def _known_words() -> set:
    words = set()
    for v in globals().values():
        items = []
        if isinstance(v, (list, tuple)):
            items = v
        elif isinstance(v, dict):
            for x in v.values():
                items += x if isinstance(x, (list, tuple)) else [x]
        for s in items:
            if isinstance(s, str):
                words.update(w.lower() for w in "".join(c if c.isalpha() else " " for c in s).split())
    words.update(O.COLORS + O.MATERIALS + O.SIZES + O.SUBTYPES + O.CATEGORIES)
    words.update("the then than that this there their these those them they what when where which who why how "  # noqa: SIM905
                 "is it its in on of or and at be by as an are was were has had have do does did can see seen bar "
                 "bat cat cap rod ride rid hid hide wide side tide car cars care cars bud but bus bust buy bug may man "
                 "mane many thin thins think thinks smell stall colon these three where medal petal eight fight light "
                 "night sight tight might lager barge mall male meal mental bight height weight wright fright front "
                 "font from form frost rubbed rubble robber matter mate mats mat meta metals fetal total tonal rental "
                 "lift lefts loft left lest list last leaf leaft cared carts scared shape shave shame share sharp "
                 "rad red rod raid read bed bee beg thong thongs thing things bow bowl lace lane lore lark there "
                 "three other others otter mother bother either ether whether hither tither thither".split())
    return words


CONTENT = set(O.COLORS) | {"colour", "color", "material", "metal", "rubber", "metallic", "shiny", "matte", "large", "small",
                           "big", "tiny", "little", "left", "right", "behind", "front", "occluded", "hidden", "facing",
                           "direction", "many", "number", "objects", "things", "thing", "object", "vehicle"}


def typo(q: str, rng, known: set):
    words = ["".join(c for c in w if c.isalpha()) for w in q.split()]
    words = [w for w in words if len(w) >= 4]
    content = [w for w in words if w.lower() in CONTENT or w.lower().rstrip("s") in set(SUB_W) | set(CAT_W)
               or any(w.lower() in n.lower().split() for ns in SUB_W.values() for n in ns)]
    if not words:
        return None
    w = rng.choice(content) if content and rng.random() < 0.7 else rng.choice(words)
    for _ in range(30):
        op = rng.choice(["delete", "substitute", "insert", "double"])
        pos = rng.randrange(1, len(w))
        if op == "delete":
            w2 = w[:pos] + w[pos + 1:]
        elif op == "substitute":
            c = w[pos].lower()
            w2 = w[:pos] + rng.choice(NEIGHBOURS.get(c, "e")) + w[pos + 1:]
        elif op == "insert":
            w2 = w[:pos] + rng.choice("aeioulnrst") + w[pos:]
        else:
            w2 = w[:pos] + w[pos - 1] + w[pos:]
        if w2 != w and w2.lower() not in known:
            break
    else:
        return None
    out, done = [], False
    for tok in q.split(" "):
        core = "".join(c for c in tok if c.isalpha())
        if not done and core == w:
            tok = tok.replace(w, w2, 1)
            done = True
        out.append(tok)
    return " ".join(out), f"typo: {w} -> {w2}"


# ----------------------------------------------------------------------------------------------------------------
# groups

A4 = ("color", "material", "size", "shape")


def _spec(fn, **kw):
    return (fn, kw)


def group_specs() -> dict:
    specs = {
        "core_query": [_spec(f_query, attr=a) for a in A4] * 2,
        "core_count": [_spec(f_count), _spec(f_count), _spec(f_count, multi=True), _spec(f_count, multi=True),
                       _spec(f_count_all), _spec(f_count_union), _spec(f_count_union), _spec(f_count, shape_only=True)],
        "core_exist": [_spec(f_exist)] * 3 + [_spec(f_exist_relate)] * 2,
        "core_compare_attribute": [_spec(f_compare, attr=a) for a in A4] * 2 + [_spec(f_compare, attr=a, relate=True) for a in A4],
        "core_compare_integer": [_spec(f_compare_count, op=o) for o in ("gt", "lt", "eq")]
                                + [_spec(f_compare_relate, op=o) for o in ("gt", "lt", "eq")],
        "core_same_relate": [_spec(f_same, attr=a, kind=k) for a in A4 for k in ("count", "exist", "query")],
        "core_spatial": [_spec(f_relate_query, attr=a) for a in A4] + [_spec(f_relate_count)] * 2
                        + [_spec(f_two_hop, attr=a) for a in (None, "color", "shape", "material", "size")]
                        + [_spec(f_and_or, op="intersect"), _spec(f_and_or, op="union")],
        "parts": [_spec(f_part_query, attr=a) for a in ("color", "material", "partname")]
                 + [_spec(f_owner_query, attr=a) for a in ("color", "shape", "material")]
                 + [_spec(f_same_object_part, attr=a) for a in ("color", "material", "partname")]
                 + [_spec(f_part_count)] * 2 + [_spec(f_part_exist)] * 2,
        "pose": [_spec(f_query_pose)] * 3 + [_spec(f_pose_filter_query, attr=a) for a in A4]
                + [_spec(f_pose_count, kind="count"), _spec(f_pose_count, kind="exist")]
                + [_spec(f_pose_rel, kind=k, what=w) for k in ("same", "opposite", "vertical")
                   for w in ("count", "exist", "color", "shape")],
        "occlusion": [_spec(f_occ_query, attr=a) for a in A4]
                     + [_spec(f_occ_rel_query, attr=a, direction=d) for a in ("color", "shape", "material", "size")
                        for d in ("by", "of")]
                     + [_spec(f_occ_count)] * 2 + [_spec(f_occ_exist)] * 2 + [_spec(f_occ_by_exist)] * 2
                     + [_spec(f_occ_n, kind="occluders"), _spec(f_occ_n, kind="occludees")],
        "part_occlusion": [_spec(f_part_occluded)] * 2 + [_spec(f_part_occluded_by)] * 2 + [_spec(f_which_part)]
                          + [_spec(f_whose_part, attr=a) for a in ("color", "shape")]
                          + [_spec(f_whose_part_by, attr=a) for a in ("color", "shape", "material")]
                          + [_spec(f_occluded_obj_part, attr=a) for a in ("color", "material", "partname")]
                          + [_spec(f_part_occ_count, kind=k) for k in ("of", "by")] + [_spec(f_part_occ_exist)],
    }
    red = []
    for e in (1, 2):
        red += [_spec(f_query, attr=a, extra=e) for a in A4]
        red += [_spec(f_relate_query, attr="color", extra=e), _spec(f_compare, attr="material", extra=e),
                _spec(f_relate_count, extra=e), _spec(f_part_query, attr="color", extra=e),
                _spec(f_query_pose, extra=e), _spec(f_occ_rel_query, attr="shape", direction="by", extra=e)]
    red += [_spec(f_exist_relate, extra=1), _spec(f_same, attr="color", kind="count", extra=1),
            _spec(f_compare_relate, op="eq", extra=1), _spec(f_part_occluded, extra=1),
            _spec(f_pose_rel, kind="same", what="color", extra=1), _spec(f_occ_exist, extra=1)]
    specs["redundant"] = red
    syn = [_spec(f_query, attr=a, vocab="wide") for a in A4]
    syn += [_spec(f_count, shape_only=True, vocab="wide"), _spec(f_count, vocab="wide"), _spec(f_exist, vocab="wide"),
            _spec(f_compare_count, op="gt", vocab="wide"), _spec(f_relate_query, attr="color", vocab="wide"),
            _spec(f_relate_count, vocab="wide"), _spec(f_part_query, attr="color", vocab="wide"),
            _spec(f_part_occluded, vocab="wide"), _spec(f_query_pose, vocab="wide"), _spec(f_buss), _spec(f_buss)]
    syn += [("typo", None)] * 9
    specs["synonyms_quirks_typos"] = syn
    return specs


TYPO_BASE = [_spec(f_query, attr="color"), _spec(f_query, attr="shape"), _spec(f_count), _spec(f_exist),
             _spec(f_relate_count), _spec(f_compare, attr="color"), _spec(f_part_query, attr="color"),
             _spec(f_query_pose), _spec(f_occ_exist), _spec(f_compare_count, op="gt"), _spec(f_same, attr="size", kind="count")]

TWO_VALUED = {"metal", "rubber", "large", "small"}


def generate(seed: int, per_group: int = PER_GROUP, verbose: bool = True) -> list[dict]:
    rng = random.Random(seed)
    worlds = [World(s) for s in SEEDS]
    known = _known_words()
    out = []
    seen = set()
    label_hist: dict = defaultdict(Counter)
    for group, specs in group_specs().items():
        quota = per_group
        per_spec = quota / len(specs)
        hist = [Counter() for _ in specs]
        filled = [0] * len(specs)
        failures = [0] * len(specs)
        made = 0
        k = 0
        while made < quota:
            live = [j for j in range(len(specs)) if failures[j] < 400]
            if not live:
                raise RuntimeError(f"{group}: every family failed")
            j = min(live, key=lambda s: (filled[s] / 1.0, s))
            k += 1
            fn, kw = specs[j]
            H = hist[j]
            want = None
            if H:
                bools = {a: c for a, c in H.items() if isinstance(a, bool)}
                if bools or H.get(True) is not None:
                    want = H[True] <= H[False]
            if not H or want is None:
                want = rng.random() < 0.5
            W = rng.choice(worlds)
            notes = None
            if fn == "typo":
                bfn, bkw = rng.choice(TYPO_BASE)
                item = bfn(W, rng, want, **bkw)
                if item is not None:
                    t = typo(item.question, rng, known)
                    if t is None:
                        item = None
                    else:
                        item = Item(t[0], item.program, "typo_" + item.family, t[1])
            else:
                item = fn(W, rng, want, **kw)
                if item is not None and group == "redundant":
                    item = Item(item.question, item.program, "redundant_" + item.family,
                                f"{kw.get('extra', 1)} redundant attribute(s)")
                elif item is not None and group == "synonyms_quirks_typos" and fn is not f_buss:
                    used = wide_used(item.question)
                    item = Item(item.question, item.program, "synonym_" + item.family,
                                "synonyms: " + "; ".join(used)) if used else None
            if item is None or (W.rel, item.question) in seen or "{" in item.question:
                failures[j] += 1
                continue
            res = W.run(item.program)
            if not res.valid:
                failures[j] += 1
                continue
            ans = plain(res.answer)
            cap = max(2, round(0.4 * per_spec))
            H = label_hist[(group, item.family)]
            if isinstance(ans, bool):
                ok = H[ans] - H[not ans] < 2
            elif ans in TWO_VALUED:
                other = {"metal": "rubber", "rubber": "metal", "large": "small", "small": "large"}[ans]
                ok = H[ans] - H[other] < 2
            else:
                ok = H[ans] < cap
            if not ok:
                failures[j] += 1
                continue
            failures[j] = 0
            H[ans] += 1
            hist[j][ans] += 1
            filled[j] += 1
            made += 1
            seen.add((W.rel, item.question))
            rec = {"id": None, "question": item.question, "program": item.program, "family_group": group,
                   "family": item.family, "scene": W.rel, "answer": ans}
            if item.notes or notes:
                rec["phrasing_notes"] = item.notes or notes
            out.append(rec)
        if verbose:
            print(f"{group}: {made} ({k} tries)", file=sys.stderr)
    for n, rec in enumerate(out, 1):
        rec["id"] = f"d2g{n:05d}"
    return out


def fill_hand(path: Path) -> None:
    worlds: dict[str, World] = {}
    recs = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    bad = []
    for r in recs:
        W = worlds.get(r["scene"]) or worlds.setdefault(r["scene"], World(int(r["scene"].split("_")[1][:4])))
        res = W.run(r["program"])
        if not res.valid:
            bad.append((r["id"], r["question"], res.reason))
            continue
        r["answer"] = plain(res.answer)
    if bad:
        for b in bad:
            print("INVALID", *b, file=sys.stderr)
        raise SystemExit(1)
    keys = ["id", "question", "program", "family_group", "family", "scene", "answer", "phrasing_notes"]
    path.write_text("".join(json.dumps({k: r[k] for k in keys if k in r}) + "\n" for r in recs))
    print(f"{len(recs)} hand-written answers filled", file=sys.stderr)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seed", type=int, default=13)
    ap.add_argument("--hand", action="store_true", help="recompute the answers of hand_written.jsonl")
    ap.add_argument("--out", type=Path, default=HERE / "generated.jsonl")
    args = ap.parse_args()
    if args.hand:
        fill_hand(HERE / "hand_written.jsonl")
        return
    recs = generate(args.seed)
    args.out.write_text("".join(json.dumps(r) + "\n" for r in recs))
    fams = Counter(r["family"] for r in recs)
    print(f"{len(recs)} questions, {len(fams)} families -> {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()

"""Generator of the fifth independent question set (v5): questions with programs, grounded in stored scenes.

    python tests/data/independent_questions_v5/make_set.py               # writes generated.jsonl (seed 7500)
    python tests/data/independent_questions_v5/make_set.py --hand        # fills/checks hand_written.jsonl answers
    python tests/data/independent_questions_v5/make_set.py --show 7503   # prints a scene's facts (for hand-writing)

Written from scratch with its own phrase lists. Every kept question's program parses, type-checks and is valid on
its scene with the reference executor; descriptions are the fewest attributes that single the referent out among
the objects it is chosen from (except in the ``redundant`` group). Evaluation only: see README.md.
"""

from __future__ import annotations

import argparse
import json
import random
import re
import sys
from collections import Counter, defaultdict
from itertools import combinations
from pathlib import Path

from po3d_ppl import ontology
from po3d_ppl.language import check_program, parse_program
from po3d_ppl.questions.context import SceneContext
from po3d_ppl.questions.executor import execute
from po3d_ppl.world import load_scene

HERE = Path(__file__).resolve().parent
SCENE_DIR = HERE / "scenes"
QUOTA = 110  # generated questions per family group

ATTRS = ("size", "color", "material", "shape")
EDGES = (30.0, 60.0, 120.0, 150.0, 210.0, 240.0, 300.0, 330.0)

# ----------------------------------------------------------------------------------------------------------------
# words (this author's own lists)

SIZE_W = {"large": ["large", "big", "large", "big"], "small": ["small", "tiny", "small"]}
SIZE_WIDE = {"large": ["huge", "giant", "massive", "jumbo"], "small": ["little", "miniature", "teeny", "mini"]}
MAT_W = {"metal": ["metal", "metallic", "shiny"], "rubber": ["rubber", "matte"]}
MAT_WIDE = {"metal": ["steel", "chrome", "metal-looking"], "rubber": ["rubbery", "matt", "dull"]}
COL_WIDE = {"gray": ["grey", "greyish"], "purple": ["violet", "purplish"], "cyan": ["turquoise", "teal", "aqua"],
            "brown": ["brownish", "tan"], "yellow": ["yellowish"], "green": ["greenish"], "blue": ["bluish"],
            "red": ["reddish", "scarlet"]}
NOUN_W = {
    "suv": ["SUV"], "wagon": ["wagon"], "minivan": ["minivan"], "sedan": ["sedan"], "truck": ["truck"],
    "articulated": ["articulated bus"], "regular": ["regular bus"], "double": ["double bus"],
    "school": ["school bus"], "chopper": ["chopper"], "dirtbike": ["dirtbike", "dirt bike"],
    "scooter": ["scooter"], "cruiser": ["cruiser"], "jet": ["jet"], "fighter": ["fighter"],
    "biplane": ["biplane"], "airliner": ["airliner"], "road": ["road bike"], "utility": ["utility bike"],
    "mountain": ["mountain bike"], "tandem": ["tandem bike", "tandem"],
    "car": ["car"], "bus": ["bus"], "motorbike": ["motorbike"], "aeroplane": ["aeroplane", "airplane"],
    "bicycle": ["bicycle"], None: ["thing", "object"],
}
NOUN_WIDE = {
    "suv": ["sport utility vehicle", "4x4", "off-roader"], "wagon": ["station wagon", "estate car", "estate"],
    "minivan": ["van", "people carrier", "MPV"], "sedan": ["saloon", "saloon car"],
    "truck": ["pickup", "pickup truck", "pick-up"],
    "articulated": ["bendy bus", "articulated coach"], "regular": ["normal bus", "ordinary bus", "city bus"],
    "double": ["double-decker", "double decker bus", "double-decker bus"], "school": ["schoolbus", "school coach"],
    "chopper": ["chopper motorcycle", "chopper bike"], "dirtbike": ["trail bike", "motocross bike", "dirt motorcycle"],
    "scooter": ["moped", "motor scooter"], "cruiser": ["cruiser motorcycle", "cruiser bike"],
    "jet": ["jet plane", "private jet"], "fighter": ["fighter jet", "fighter plane", "warplane"],
    "biplane": ["bi-plane", "double-wing plane"], "airliner": ["passenger jet", "passenger plane", "jetliner"],
    "road": ["racing bike", "road bicycle", "racer bike"], "utility": ["city bike", "utility bicycle", "commuter bike"],
    "mountain": ["MTB", "mountain bicycle"], "tandem": ["tandem bicycle", "two-seater bike"],
    "car": ["automobile", "auto"], "bus": ["coach", "omnibus"], "motorbike": ["motorcycle", "motor bike"],
    "aeroplane": ["plane", "aircraft"], "bicycle": ["bike", "cycle", "push bike"],
    None: ["item", "vehicle"],
}
REL_W = {"left": ["left of", "to the left of", "on the left side of", "on the left of"],
         "right": ["right of", "to the right of", "on the right side of", "on the right of"],
         "behind": ["behind"], "front": ["in front of"]}
REL_WIDE = {"left": ["on the left-hand side of", "to the left-hand side of"],
            "right": ["on the right-hand side of", "to the right-hand side of"],
            "behind": ["in back of"], "front": ["ahead of"]}
POSE_W = {"front_pose": ["facing the camera", "facing us", "facing toward the camera", "facing forward",
                         "facing the viewer", "pointing at the camera"],
          "back_pose": ["facing away from the camera", "facing away from us", "with its back to the camera",
                        "facing away", "pointing away from the camera"],
          "left_pose": ["facing left", "facing to the left", "pointing left", "turned to the left", "heading left"],
          "right_pose": ["facing right", "facing to the right", "pointing right", "turned to the right",
                         "heading right"]}
POSE_PL = {"front_pose": ["facing the camera", "facing us", "facing forward", "facing toward the viewer"],
           "back_pose": ["facing away from the camera", "facing away from us", "facing away"],
           "left_pose": ["facing left", "facing to the left", "pointing left", "turned to the left"],
           "right_pose": ["facing right", "facing to the right", "pointing right", "turned to the right"]}
PREL_W = {"same_pose": ["facing the same direction as", "facing the same way as", "pointing the same way as",
                        "that faces the same direction as", "oriented the same way as"],
          "opposite_pose": ["facing the opposite direction to", "facing the opposite way from",
                            "that faces the opposite direction as", "pointing the opposite way to",
                            "facing opposite to", "facing the other way from"],
          "vertical_pose": ["facing perpendicular to", "that faces at a right angle to",
                            "that faces the vertical direction as", "turned at 90 degrees to",
                            "pointing perpendicular to", "facing crosswise to"]}
# part word substitutions for the wide vocabulary (applied to readable part names)
PART_WIDE = [("windscreen", "windshield"), ("hood", "bonnet"), ("trunk", "boot"), ("side stand", "kickstand"),
             ("license plate", "number plate"), ("fender", "mudguard"), ("handle", "handlebar"),
             ("head light", "headlamp"), ("headlight", "headlamp"), ("tail light", "rear light"),
             ("taillight", "tail lamp"), ("fin", "tail fin"), ("propeller", "prop"), ("engine", "motor"),
             ("mirror", "side mirror"), ("drive chain", "chain"), ("crank arm", "crank"), ("gas tank", "fuel tank"),
             ("exhaust", "exhaust pipe"), ("footrest", "footpeg"), ("carrier", "luggage rack"),
             ("tailplane", "tail wing"), ("wheel", "tyre"), ("back", "rear"), ("mid", "middle"),
             ("saddle", "bike seat"), ("panel", "side panel")]

# typos: word -> non-words at edit distance 1 (never the first letter)
TYPOS = {
    "color": ["colr", "coler"], "colour": ["colur", "coulour"], "material": ["materal", "matrial", "matterial"],
    "many": ["manny", "mny"], "there": ["thre", "theere"], "bicycle": ["bicyle", "biccycle"],
    "motorbike": ["motorbke", "motrbike"], "aeroplane": ["aeroplan", "aeroplne"], "airplane": ["airplan", "airpline"],
    "sedan": ["sedn", "sedann"], "truck": ["truk", "trruck"], "minivan": ["minivn", "minivaan"],
    "wagon": ["wagn", "wagoon"], "scooter": ["scooer", "scoter"], "cruiser": ["cruser", "cruisr"],
    "chopper": ["choper", "chopperr"], "airliner": ["airlner", "airliiner"], "biplane": ["biplan", "biplanne"],
    "fighter": ["figher", "fightr"], "jet": ["jeet"], "bus": ["bux"], "object": ["objet", "objject"],
    "objects": ["objets", "objcts"], "things": ["thngs", "thinngs"], "thing": ["thng", "thinng"],
    "behind": ["behnd", "behid"], "front": ["frnt", "fromt"], "left": ["lefft", "lft"], "right": ["rigt", "righht"],
    "metal": ["metl", "mettal"], "rubber": ["ruber", "rubbr"], "purple": ["purle", "puple"],
    "yellow": ["yelow", "yelllow"], "green": ["gren", "greeen"], "brown": ["brwn", "broown"], "cyan": ["cyn", "cyyan"],
    "gray": ["gry", "graay"], "large": ["lage", "larrge"], "small": ["smal", "smalll"],
    "occluded": ["occuded", "ocluded", "occludded"], "hidden": ["hiden", "hiddn"], "facing": ["facng", "faceing"],
    "direction": ["directon", "drection"], "wheel": ["wheell", "whel"], "same": ["sme", "samme"],
    "shiny": ["shinny", "shny"], "number": ["numbr", "nuumber"], "school": ["scool", "schol"],
    "mountain": ["mountan", "mountin"], "utility": ["utilty", "utiliy"], "tandem": ["tandm", "taandem"],
    "road": ["roaad", "rooad"], "articulated": ["articulatd", "artculated"], "regular": ["reguler", "regullar"],
    "dirtbike": ["dirtbke", "dirrtbike"], "occludes": ["ocludes", "occlues"], "parts": ["prts", "paarts"],
    "part": ["prt", "parrt"], "SUV": ["SUVV"], "blue": ["blu"], "red": ["rd", "redd"],
    "size": ["sze", "sizze"], "type": ["tyoe"], "kind": ["knd", "kinnd"],
}


def _lev(a: str, b: str) -> int:
    prev = list(range(len(b) + 1))
    for i, ca in enumerate(a, 1):
        cur = [i]
        for j, cb in enumerate(b, 1):
            cur.append(min(prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (ca != cb)))
        prev = cur
    return prev[-1]


for _w, _ts in TYPOS.items():
    TYPOS[_w] = [t for t in _ts if t and _lev(_w, t) == 1 and t[0] == _w[0] and t != "colour"]
    assert TYPOS[_w], _w

OPENERS = ["Look at the picture: ", "Quick question: ", "Hey, ", "In this image, ", "So ", "OK, ",
           "From what you can see, ", "Question: ", "I'm curious, ", "Looking at the scene, ", "Um, ",
           "Could you tell me: ", "Right, ", "In the picture, "]

# ----------------------------------------------------------------------------------------------------------------
# scenes


class Obj:
    def __init__(self, i, o, ctx):
        self.i = i
        self.sub, self.cat = o.subtype, ontology.CATEGORY_OF[o.subtype]
        self.size, self.color, self.material = o.size, o.color, o.material
        self.deg = o.pose_degree % 360.0
        self.pose = ontology.pose_label(self.deg)
        self.parts = {raw: (s.color, s.material) for raw, s in o.parts.items()}
        self.occluded = o.occluded
        self.occ_by = tuple(o.occluded_by)
        self.occ_parts = {raw: tuple(a.occlusion.occluded_by) for raw, a in o.part_annotations.items()
                          if a.occlusion.occluded}
        self.all_parts = set(self.parts) | set(self.occ_parts)

    def val(self, slot):
        return getattr(self, slot if slot != "shape" else "sub")

    def clear_pose(self, margin=6.0):
        """In a labelled sector and at least ``margin`` degrees from its edges."""
        if self.pose == "None":
            return False
        return all(min(abs(self.deg - e), 360 - abs(self.deg - e)) >= margin for e in EDGES)

    def near_edge(self, margin=6.0):
        return any(min(abs(self.deg - e), 360 - abs(self.deg - e)) < margin for e in EDGES)


class Scn:
    def __init__(self, seed):
        self.seed = seed
        self.path = SCENE_DIR / f"scene_{seed}.json"
        self.rel_path = f"scenes/scene_{seed}.json"
        self.scene = load_scene(self.path)
        self.ctx = SceneContext(self.scene)
        self.objs = [Obj(i, o, self.ctx) for i, o in enumerate(self.scene.objects)]
        self.n = len(self.objs)
        self.rel = {r: [set(row) for row in self.scene.relationships[r]] for r in ontology.RELATIONS}
        self.occludees = {j: set(self.ctx.occludees_of[j]) for j in range(self.n)}
        self.parts_hidden_by = defaultdict(list)  # j -> [(i, raw)]
        for o in self.objs:
            for raw, by in o.occ_parts.items():
                for j in by:
                    self.parts_hidden_by[j].append((o.i, raw))

    def pose_rel(self, i, j):
        a, b = self.objs[i], self.objs[j]
        if a.pose == "None":
            return None
        d = abs(a.deg - b.deg) % 360
        d = min(d, 360 - d)
        return "same_pose" if d < 45 else "opposite_pose" if d > 135 else "vertical_pose"

    def pose_rel_clear(self, i, margin=6.0):
        a = self.objs[i]
        if not a.clear_pose(margin):
            return False
        for b in self.objs:
            if b.i == i:
                continue
            d = abs(a.deg - b.deg) % 360
            d = min(d, 360 - d)
            if abs(d - 45) < margin or abs(d - 135) < margin:
                return False
        return True


def plain(v):
    if isinstance(v, (frozenset, set)):
        return sorted(v)
    if isinstance(v, tuple):
        return list(v)
    return v


def run(sc, program):
    typed = check_program(parse_program(program))
    res = execute(sc.ctx, typed)
    return res.valid, (plain(res.answer) if res.valid else res.reason)


def matches(o, d):
    for k, v in d.items():
        if k == "shape":
            if v not in (o.sub, o.cat):
                return False
        elif getattr(o, k) != v:
            return False
    return True


def members(sc, among, d):
    return [j for j in among if matches(sc.objs[j], d)]


def filt(d, pose=None):
    out = []
    if pose:
        out.append(f"filter_pose[{pose}]")
    for k in ATTRS:
        if k in d:
            out.append(f"filter_{k}[{d[k]}]")
    return out


def pipe(*stages):
    return " | ".join(s for s in stages if s)


def part_words(raw):
    return ontology.readable_name(raw)


def super_unique(sub, raw):
    sp = ontology.super_part_name(raw)
    return sum(ontology.super_part_name(r) == sp for r in ontology.PARTS[sub]) == 1


def plural(noun):
    if noun.endswith("aircraft"):
        return noun
    if noun.endswith("bus") or noun.endswith("s") or noun.endswith("x") or noun.endswith("ch"):
        return noun + "es"
    return noun + "s"


def article(phrase):
    w = phrase.split()[0]
    low = w.lower()
    if w in ("SUV", "MPV", "MTB") or w.startswith("SUV"):
        return "an"
    if low.startswith(("uti", "uni", "eu", "one")):
        return "a"
    return "an" if low[0] in "aeiou" else "a"


def cap(s):
    return s[0].upper() + s[1:] if s else s


# ----------------------------------------------------------------------------------------------------------------
# the voice: picks words (base or wide), records notes


class Voice:
    def __init__(self, rng, wide=False, redundant=False):
        self.rng, self.wide, self.redundant = rng, wide, redundant
        self.wide_used = []
        self.force_bus_plural = False

    def pick(self, base, wide=None, p=0.6):
        if self.wide and wide and self.rng.random() < p:
            w = self.rng.choice(wide)
            self.wide_used.append(w)
            return w
        return self.rng.choice(base)

    def size(self, v):
        return self.pick(SIZE_W[v], SIZE_WIDE[v])

    def color(self, v):
        return self.pick([v], COL_WIDE.get(v), p=0.5)

    def material(self, v):
        return self.pick(MAT_W[v], MAT_WIDE[v])

    def noun(self, shape, plural_=False, allow_one=False):
        if shape is None and allow_one and not plural_ and self.rng.random() < 0.2:
            return "one"
        w = self.pick(NOUN_W[shape], NOUN_WIDE.get(shape), p=0.7)
        return plural(w) if plural_ else w

    def rel(self, r):
        return self.pick(REL_W[r], REL_WIDE[r], p=0.5)

    def part(self, raw, bare=False):
        words = ontology.super_part_name(raw).replace("_", " ") if bare else part_words(raw)
        if self.rng.random() < 0.5:
            words = words.replace("head light", "headlight").replace("tail light", "taillight")
        if self.wide and self.rng.random() < 0.7:
            for a, b in PART_WIDE:
                if re.search(rf"\b{a}\b", words) and not re.search(rf"\b{b}\b", words):
                    words = re.sub(rf"\b{a}\b", b, words)
                    self.wide_used.append(b)
                    break
        return words

    def np(self, d, plural_=False, det="the", allow_one=True, post_material=False, pose=None):
        """Noun phrase for description d (size, colour, material, shape)."""
        words = []
        if "size" in d:
            words.append(self.size(d["size"]))
        if "color" in d:
            words.append(self.color(d["color"]))
        post = None
        if "material" in d:
            if post_material or (self.redundant and self.rng.random() < 0.3):
                post = "made of " + self.pick([d["material"]], None)
            else:
                words.append(self.material(d["material"]))
        noun = self.noun(d.get("shape"), plural_, allow_one=allow_one and bool(words) and post is None)
        words.append(noun)
        text = " ".join(words)
        if post:
            text += " " + post
        if pose:
            text += " " + pose
        if det == "a":
            return f"{article(text)} {text}"
        return f"{det} {text}" if det else text

    def adj(self, slot, v):
        return {"size": self.size, "color": self.color, "material": self.material}[slot](v)


# ----------------------------------------------------------------------------------------------------------------
# generator


class Gen:
    """One candidate question per call of a family method; None when the scene does not allow it."""

    def __init__(self, rng, scenes):
        self.rng = rng
        self.scenes = scenes

    # ---- descriptions
    def describe(self, sc, i, among, exclude=(), v=None, min_slots=0):
        o = sc.objs[i]
        among = list(among)
        assert i in among
        slots = [s for s in ATTRS if s not in exclude]
        found = []
        for k in range(min_slots, len(slots) + 1):
            for combo in combinations(slots, k):
                shapes = [o.sub, o.cat] if "shape" in combo else [None]
                for sv in shapes:
                    d = {s: o.val(s) for s in combo if s != "shape"}
                    if sv:
                        d["shape"] = sv
                    if members(sc, among, d) == [i]:
                        found.append(d)
            if found:
                break
        if not found:
            return None
        with_shape = [d for d in found if "shape" in d]
        d = dict(self.rng.choice(with_shape if with_shape and self.rng.random() < 0.75 else found))
        if v is not None and v.redundant:
            free = [s for s in slots if s not in d]
            if "shape" in d and d["shape"] == o.cat and "shape" in slots and self.rng.random() < 0.3:
                d["shape"] = o.sub
                v.redundant_added = True
            elif free:
                for s in self.rng.sample(free, min(len(free), self.rng.choice([1, 1, 2]))):
                    d[s] = o.val(s) if s != "shape" else self.rng.choice([o.sub, o.cat])
                v.redundant_added = True
        return d

    def ref(self, sc, i, among=None, exclude=(), v=None, min_slots=0):
        return self.describe(sc, i, range(sc.n) if among is None else among, exclude, v, min_slots)

    def query_end(self, body, op):
        if self.rng.random() < 0.3:
            return f"{op}({body})"
        return f"{body} | {op}"

    # ---------------------------------------------------------------- core_query
    QF = {
        "color": ["What color is {X}?", "What colour is {X}?", "What is the color of {X}?", "Which colour is {X}?",
                  "Tell me the color of {X}.", "{X} is what color?", "What color does {X} have?",
                  "Can you tell me what colour {X} is?", "what's the colour of {X}", "Name the color of {X}.",
                  "Colour of {X}?", "What color would you say {X} is?"],
        "material": ["What is {X} made of?", "What material is {X}?", "What's {X} made out of?",
                     "Which material is {X} made from?", "Is {X} made of metal or rubber?",
                     "What kind of material is {X}?", "Tell me what {X} is made of.", "Material of {X}?",
                     "{X} is made of what material?", "what is the material of {X}"],
        "size": ["How big is {X}?", "What size is {X}?", "Is {X} large or small?", "What is the size of {X}?",
                 "Is {X} big or small?", "{X}: big or small?", "Tell me the size of {X}.",
                 "how large is {X}", "Would you call {X} large or small?"],
        "shape": ["What is {X}?", "What kind of vehicle is {X}?", "What type of object is {X}?",
                  "What is the shape of {X}?", "Which model is {X}?", "What sort of thing is {X}?",
                  "Identify {X}.", "What exactly is {X}?", "{X} is what kind of vehicle?",
                  "What type is {X}?", "Can you name {X}?"],
    }
    QP = {
        "color": ["There is {aX}; what color is it?", "Look at {X}. What colour is it?",
                  "I see {aX} - what color is it?", "There's {aX}. Which color does it have?",
                  "Find {X}; what is its colour?"],
        "material": ["There is {aX}; what is it made of?", "Look at {X}. What material is it?",
                     "There's {aX} - is it metal or rubber?", "Find {X}. What's it made from?"],
        "size": ["There is {aX}; how big is it?", "Look at {X}. Is it large or small?",
                 "There's {aX} - what size is it?", "Find {X}; is it big or small?"],
        "shape": ["There is {aX}; what is it?", "Look at {X}. What kind of vehicle is it?",
                  "There's {aX} - what type of thing is it?", "Find {X}. What is it exactly?"],
    }

    def core_query(self, sc, v, pronoun=False):
        i = self.rng.randrange(sc.n)
        a = self.rng.choice(ATTRS)
        d = self.ref(sc, i, exclude=(a,), v=v)
        if d is None:
            return None
        noun_pref = a == "shape"
        X = v.np(d, allow_one=True)
        if noun_pref and "shape" not in d and self.rng.random() < 0.5:
            X = X.replace(" thing", " one").replace(" object", " one") if len(d) else X
        if pronoun:
            aX = v.np(d, det="a", allow_one=False)
            q = self.rng.choice(self.QP[a]).format(X=X, aX=aX)
            fam = f"pronoun_query_{a}"
        else:
            q = self.rng.choice(self.QF[a]).format(X=X)
            fam = f"zero_hop_query_{a}"
        prog = self.query_end(pipe("scene()", *filt(d), "unique"), f"query_{a}")
        return cap(q), prog, fam

    def core_query_pronoun(self, sc, v):
        return self.core_query(sc, v, pronoun=True)

    def core_query_subtype(self, sc, v):
        i = self.rng.randrange(sc.n)
        o = sc.objs[i]
        same_cat = [j for j in range(sc.n) if sc.objs[j].cat == o.cat]
        d = self.describe(sc, i, same_cat, exclude=("shape",), v=v, min_slots=1)
        if d is None:
            return None
        cat = v.noun(o.cat)
        adj = " ".join(v.adj(s, d[s]) for s in ("size", "color", "material") if s in d)
        q = self.rng.choice([
            "What kind of {c} is the {a} one?", "What type of {c} is the {a} one?", "Which kind of {c} is {a}?",
            "The {a} {c} is which type?", "What sort of {c} is the {a} {c}?", "What model of {c} is the {a} one?",
            "Which type of {c} is the {a} {c}?"]).format(c=cat, a=adj)
        prog = self.query_end(pipe("scene()", *filt(dict(d, shape=o.cat)), "unique"), "query_shape")
        return cap(q), prog, "query_subtype_of_category"

    # ---------------------------------------------------------------- sets (count / exist)
    def random_set_desc(self, sc, v, kmax=3, allow_empty=False):
        """1-3 attribute values, either from a real object or random (so counts can be 0)."""
        k = self.rng.choice([1, 1, 2, 2, 3][: 5 if kmax >= 3 else 4])
        slots = self.rng.sample(ATTRS, k)
        if self.rng.random() < 0.55:
            o = self.rng.choice(sc.objs)
            d = {s: (o.val(s) if s != "shape" else self.rng.choice([o.sub, o.cat, o.cat])) for s in slots}
        else:
            d = {}
            for s in slots:
                if s == "shape":
                    d[s] = self.rng.choice(ontology.CATEGORIES + tuple(self.rng.sample(ontology.SUBTYPES, 3)))
                else:
                    d[s] = self.rng.choice({"size": ontology.SIZES, "color": ontology.COLORS,
                                            "material": ontology.MATERIALS}[s])
        if v.force_bus_plural:
            d["shape"] = self.rng.choice(["bus", "bus", "bus", "school", "articulated", "double", "regular"])
        return d

    CF = ["How many {P} are there?", "How many {P} are in the picture?", "Count the {P}.",
          "What number of {P} are there?", "Number of {P}?", "how many {P} can you see",
          "How many {P} do you see in the image?", "Tell me how many {P} there are.",
          "How many {P} are in this scene?", "Can you count the {P} for me?", "How many {P} is there?",
          "{P}: how many?", "what is the number of {P}"]

    def core_count(self, sc, v):
        d = self.random_set_desc(sc, v)
        P = v.np(d, plural_=True, det="")
        q = self.rng.choice(self.CF).format(P=P)
        return cap(q), f"count({pipe('scene()', *filt(d))})", f"count_{len(d)}_attr"

    def core_count_all(self, sc, v):
        q = self.rng.choice(["How many {n} are there?", "How many {n} are in the image?", "Count all the {n}.",
                             "What is the total number of {n}?", "How many {n} can you see in total?",
                             "how many {n} are in the scene", "Count the {n} in the picture."])
        n = v.noun(None, plural_=True)
        return cap(q.format(n=n)), "count(scene())", "count_all"

    def two_sets(self, sc, v):
        while True:
            a, b = self.random_set_desc(sc, v, 2), self.random_set_desc(sc, v, 2)
            if a != b:
                return a, b

    def core_count_union(self, sc, v):
        a, b = self.two_sets(sc, v)
        if len(a) == 1 and len(b) == 1 and "shape" not in a and "shape" not in b and self.rng.random() < 0.6:
            (sa, va), = a.items()
            (sb, vb), = b.items()
            q = self.rng.choice(["How many things are {x} or {y}?", "How many objects are either {x} or {y}?",
                                 "Count the things that are {x} or {y}.", "How many {n} are {x} or {y}?"])
            q = q.format(x=v.adj(sa, va), y=v.adj(sb, vb), n=v.noun(None, True))
        else:
            A, B = v.np(a, True, ""), v.np(b, True, "")
            q = self.rng.choice(["How many {A} or {B} are there?", "Count the {A} or {B}.",
                                 "How many things are {A} or {B}?", "What is the number of {A} or {B}?",
                                 "How many objects are either {A} or {B}?"]).format(A=A, B=B)
        prog = f"count(union({pipe('scene()', *filt(a))}, {pipe('scene()', *filt(b))}))"
        return cap(q), prog, "count_union"

    EF = ["Are there any {P}?", "Is there {a}?", "Is there any {s} in the image?", "Do you see {a}?",
          "Can you find {a} in the picture?", "Does the scene contain {a}?", "Are any {P} visible?",
          "Is there at least one {s}?", "is there {a} here", "Any {P} in the picture?", "Do you spot {a}?",
          "Are there {P} in this scene?"]

    def core_exist(self, sc, v):
        d = self.random_set_desc(sc, v)
        P, a, s = v.np(d, True, ""), v.np(d, det="a", allow_one=False), v.np(d, det="", allow_one=False)
        q = self.rng.choice(self.EF).format(P=P, a=a, s=s)
        return cap(q), f"exist({pipe('scene()', *filt(d))})", f"exist_{len(d)}_attr"

    def core_exist_union(self, sc, v):
        a, b = self.two_sets(sc, v)
        A, B = v.np(a, det="a", allow_one=False), v.np(b, det="a", allow_one=False)
        q = self.rng.choice(["Is there {A} or {B}?", "Do you see {A} or {B}?", "Is there either {A} or {B}?",
                             "Does the picture show {A} or {B}?", "Can you see {A} or {B} anywhere?"])
        prog = f"exist(union({pipe('scene()', *filt(a))}, {pipe('scene()', *filt(b))}))"
        return cap(q.format(A=A, B=B)), prog, "exist_union"

    # ---------------------------------------------------------------- compare attribute
    CMP = {
        "color": ["Is {X} the same color as {Y}?", "Do {X} and {Y} have the same colour?",
                  "Are {X} and {Y} the same color?", "Does {X} have the same color as {Y}?",
                  "Is {X} colored the same as {Y}?", "Do {X} and {Y} share a colour?",
                  "is {X} the same colour as {Y}", "Are {X} and {Y} painted the same color?"],
        "material": ["Is {X} made of the same material as {Y}?", "Are {X} and {Y} made of the same material?",
                     "Do {X} and {Y} have the same material?", "Is {X} the same material as {Y}?",
                     "Are {X} and {Y} made from the same stuff?", "Does {X} share its material with {Y}?"],
        "size": ["Is {X} the same size as {Y}?", "Are {X} and {Y} the same size?",
                 "Do {X} and {Y} have the same size?", "Is {X} as big as {Y}?",
                 "Are {X} and {Y} equally big?", "is {X} the same size as {Y}"],
        "shape": ["Is {X} the same type as {Y}?", "Are {X} and {Y} the same kind of vehicle?",
                  "Do {X} and {Y} have the same shape?", "Is {X} the same model as {Y}?",
                  "Are {X} and {Y} the same type of object?", "Is {X} the same kind of thing as {Y}?"],
    }

    def _cmp_prog(self, a, pa, pb):
        return f"equal_{a}(query_{a}({pa}), query_{a}({pb}))"

    def core_compare(self, sc, v):
        if sc.n < 2:
            return None
        i, j = self.rng.sample(range(sc.n), 2)
        a = self.rng.choice(ATTRS)
        twins = [x for x in range(sc.n) if x != i and sc.objs[x].val(a) == sc.objs[i].val(a)]
        if twins and self.rng.random() < 0.5:
            j = self.rng.choice(twins)
        di, dj = self.ref(sc, i, exclude=(a,), v=v), self.ref(sc, j, exclude=(a,), v=v)
        if di is None or dj is None:
            return None
        X, Y = v.np(di, allow_one=False), v.np(dj, allow_one=False)
        if X == Y:
            return None
        q = self.rng.choice(self.CMP[a]).format(X=X, Y=Y)
        prog = self._cmp_prog(a, pipe("scene()", *filt(di), "unique"), pipe("scene()", *filt(dj), "unique"))
        return cap(q), prog, f"compare_{a}"

    def core_compare_related(self, sc, v):
        if sc.n < 3:
            return None
        i = self.rng.randrange(sc.n)
        r = self.rng.choice(ontology.RELATIONS)
        rs = sorted(sc.rel[r][i])
        if not rs:
            return None
        k = self.rng.choice(rs)
        j = self.rng.choice([x for x in range(sc.n) if x != k])
        a = self.rng.choice(ATTRS)
        di, dj = self.ref(sc, i, v=v), self.ref(sc, j, exclude=(a,), v=v)
        dk = self.describe(sc, k, rs, exclude=(a,), v=v)
        if None in (di, dj, dk):
            return None
        K = v.np(dk, allow_one=False) + " " + v.rel(r) + " " + v.np(di, allow_one=False)
        Y = v.np(dj, allow_one=False)
        q = self.rng.choice(self.CMP[a][:4]).format(X=K, Y=Y)
        pk = pipe("scene()", *filt(di), "unique", f"relate[{r}]", *filt(dk), "unique")
        prog = self._cmp_prog(a, pk, pipe("scene()", *filt(dj), "unique"))
        return cap(q), prog, f"compare_{a}_related"

    # ---------------------------------------------------------------- compare integer
    CI = {
        "greater_than": ["Are there more {A} than {B}?", "Do the {A} outnumber the {B}?",
                         "Is the number of {A} greater than the number of {B}?", "Are there more {A} than {B} here?",
                         "Is the count of {A} bigger than that of {B}?", "more {A} than {B}?",
                         "Are {A} more numerous than {B}?"],
        "less_than": ["Are there fewer {A} than {B}?", "Are there less {A} than {B}?",
                      "Is the number of {A} smaller than the number of {B}?", "Is the number of {A} less than the number of {B}?",
                      "fewer {A} than {B}?", "Are {A} less common than {B} in the picture?"],
        "equal_integer": ["Are there as many {A} as {B}?", "Is the number of {A} the same as the number of {B}?",
                          "Are there the same number of {A} and {B}?", "Is there an equal number of {A} and {B}?",
                          "Do the {A} and the {B} come in equal numbers?", "same number of {A} and {B}?"],
    }

    def core_compare_integer(self, sc, v):
        a, b = self.two_sets(sc, v)
        op = self.rng.choice(list(self.CI))
        A, B = v.np(a, True, ""), v.np(b, True, "")
        q = self.rng.choice(self.CI[op]).format(A=A, B=B)
        prog = f"{op}(count({pipe('scene()', *filt(a))}), count({pipe('scene()', *filt(b))}))"
        return cap(q), prog, f"compare_count_{op}"

    def core_compare_integer_rel(self, sc, v):
        i = self.rng.randrange(sc.n)
        di = self.ref(sc, i, v=v)
        if di is None:
            return None
        r1, r2 = self.rng.choice([("left", "right"), ("right", "left"), ("behind", "front"), ("front", "behind")])
        f = {} if self.rng.random() < 0.5 else self.random_set_desc(sc, v, 1)
        op = self.rng.choice(["greater_than", "less_than", "equal_integer"])
        X = v.np(di, allow_one=False)
        P = v.np(f, True, "") if f else v.noun(None, True)
        rw1 = v.rel(r1)
        side = {"left": "on its left", "right": "on its right", "behind": "behind it", "front": "in front of it"}
        q = {"greater_than": ["Are there more {P} {r1} {X} than {s2}?", "Does {X} have more {P} {s1} than {s2}?"],
             "less_than": ["Are there fewer {P} {r1} {X} than {s2}?", "Are there less {P} {r1} {X} than {s2}?"],
             "equal_integer": ["Are there as many {P} {r1} {X} as {s2}?",
                               "Does {X} have the same number of {P} {s1} as {s2}?"]}[op]
        q = self.rng.choice(q).format(P=P, r1=rw1, X=X, s1=side[r1], s2=side[r2])
        base = pipe("scene()", *filt(di), "unique")
        prog = f"{op}(count({pipe(base, f'relate[{r1}]', *filt(f))}), count({pipe(base, f'relate[{r2}]', *filt(f))}))"
        return cap(q), prog, f"compare_count_relations_{op}"

    # ---------------------------------------------------------------- same relate
    SAME_WORD = {"color": ["the same color as", "the same colour as", "in the same color as"],
                 "material": ["made of the same material as", "the same material as", "of the same material as"],
                 "size": ["the same size as", "of the same size as", "as big as"],
                 "shape": ["the same type as", "the same kind as", "the same model as"]}

    def core_same(self, sc, v):
        i = self.rng.randrange(sc.n)
        a = self.rng.choice(ATTRS)
        d = self.ref(sc, i, exclude=(a,), v=v)
        if d is None:
            return None
        X = v.np(d, allow_one=False)
        same = [j for j in range(sc.n) if j != i and sc.objs[j].val(a) == sc.objs[i].val(a)]
        kind = self.rng.choice(["count", "count", "exist", "query"])
        sw = self.rng.choice(self.SAME_WORD[a])
        base = pipe("scene()", *filt(d), "unique", f"same_{a}")
        if kind == "query":
            if not same:
                return None
            k = self.rng.choice(same)
            qa = self.rng.choice([x for x in ATTRS if x != a])
            dk = self.describe(sc, k, same, exclude=(qa, a), v=v)
            if dk is None:
                return None
            K = v.np(dk, det="", allow_one=False)
            qw = {"color": "What color is", "material": "What is the material of", "size": "What size is",
                  "shape": "What kind of vehicle is"}[qa]
            q = self.rng.choice([f"{qw} the other {K} that is {sw} {X}?", f"{qw} the {K} that is {sw} {X}?",
                                 f"There is another {K} {sw} {X}; {qw.lower()} it?"])
            return cap(q), self.query_end(pipe(base, *filt(dk), "unique"), f"query_{qa}"), f"same_{a}_query_{qa}"
        f = {} if self.rng.random() < 0.5 else self.random_set_desc(sc, v, 1)
        f.pop(a, None)
        P = v.np(f, True, "") if f else v.noun(None, True)
        if kind == "count":
            q = self.rng.choice([f"How many other {P} are {sw} {X}?", f"How many {P} are {sw} {X}?",
                                 f"Count the other {P} that are {sw} {X}.",
                                 f"How many {P} besides {X} are {sw} it?"])
            return cap(q), f"count({pipe(base, *filt(f))})", f"same_{a}_count"
        s = v.np(f, det="", allow_one=False) if f else v.noun(None)
        q = self.rng.choice([f"Is there another {s} {sw} {X}?", f"Are there any other {P} {sw} {X}?",
                             f"Is any other {s} {sw} {X}?", f"Does anything else look {sw} {X}?" if a == "color"
                             else f"Is there any other {s} that is {sw} {X}?"])
        return cap(q), f"exist({pipe(base, *filt(f))})", f"same_{a}_exist"

    # ---------------------------------------------------------------- spatial
    def core_spatial(self, sc, v):
        kind = self.rng.choice(["q1", "q1", "c1", "e1", "q2", "c2", "e2", "q3", "and_c", "and_e", "bare"])
        i = self.rng.randrange(sc.n)
        di = self.ref(sc, i, v=v)
        if di is None:
            return None
        X = v.np(di, allow_one=False)
        xp = pipe("scene()", *filt(di), "unique")
        r = self.rng.choice(ontology.RELATIONS)
        rs = sorted(sc.rel[r][i])
        if kind == "bare":
            if len(rs) != 1:
                return None
            q = self.rng.choice(["What is {r} {X}?", "What's {r} {X}?", "Which object is {r} {X}?",
                                 "What is the thing {r} {X}?", "Tell me what is {r} {X}."])
            return cap(q.format(r=v.rel(r), X=X)), self.query_end(pipe(xp, f"relate[{r}]", "unique"), "query_shape"), \
                "bare_relate_query_shape"
        if kind in ("c1", "e1"):
            f = {} if self.rng.random() < 0.4 else self.random_set_desc(sc, v, 2)
            P = v.np(f, True, "") if f else v.noun(None, True)
            if kind == "c1":
                q = self.rng.choice(["How many {P} are {r} {X}?", "Count the {P} {r} {X}.",
                                     "What number of {P} are {r} {X}?", "how many {P} are {r} {X}",
                                     "There is {aX}; how many {P} are {r} it?"])
                q = q.format(P=P, r=v.rel(r), X=X, aX=v.np(di, det="a", allow_one=False))
                return cap(q), f"count({pipe(xp, f'relate[{r}]', *filt(f))})", "one_hop_count"
            a = v.np(f, det="a", allow_one=False) if f else "anything"
            q = self.rng.choice(["Is there {a} {r} {X}?", "Are there any {P} {r} {X}?", "Is {a} {r} {X}?",
                                 "Do you see {a} {r} {X}?"])
            q = q.format(a=a, P=P, r=v.rel(r), X=X)
            return cap(q), f"exist({pipe(xp, f'relate[{r}]', *filt(f))})", "one_hop_exist"
        if kind == "and_c" or kind == "and_e":
            j = self.rng.choice([x for x in range(sc.n) if x != i] or [None])
            if j is None:
                return None
            dj = self.ref(sc, j, v=v)
            r2 = self.rng.choice(ontology.RELATIONS)
            if dj is None:
                return None
            Y = v.np(dj, allow_one=False)
            f = {} if self.rng.random() < 0.5 else self.random_set_desc(sc, v, 1)
            P = v.np(f, True, "") if f else v.noun(None, True)
            inter = f"intersect({pipe(xp, f'relate[{r}]')}, {pipe('scene()', *filt(dj), 'unique', f'relate[{r2}]')})"
            if kind == "and_c":
                q = self.rng.choice(["How many {P} are both {r} {X} and {r2} {Y}?",
                                     "How many {P} are {r} {X} and {r2} {Y}?",
                                     "Count the {P} that are {r} {X} and also {r2} {Y}."])
                prog = f"count({pipe(inter, *filt(f))})"
                fam = "and_count"
            else:
                s = v.np(f, det="a", allow_one=False) if f else "anything"
                q = self.rng.choice(["Is there {s} that is both {r} {X} and {r2} {Y}?",
                                     "Is there {s} {r} {X} and {r2} {Y}?",
                                     "Is {s} both {r} {X} and {r2} {Y}?"]).replace("{s}", s)
                prog = f"exist({pipe(inter, *filt(f))})"
                fam = "and_exist"
            return cap(q.format(P=P, r=v.rel(r), X=X, r2=v.rel(r2), Y=Y)), prog, fam
        # queries / two hops
        if not rs:
            return None
        k = self.rng.choice(rs)
        qa = self.rng.choice(ATTRS)
        if kind == "q1":
            dk = self.describe(sc, k, rs, exclude=(qa,), v=v)
            if dk is None:
                return None
            K = v.np(dk, allow_one=True)
            qf = self.QF[qa][:5]
            q = self.rng.choice(qf).format(X=f"{K} {v.rel(r)} {X}")
            if self.rng.random() < 0.3:
                q = self.rng.choice(self.QF[qa][:3]).format(X=f"{K} that is {v.rel(r)} {X}")
            return cap(q), self.query_end(pipe(xp, f"relate[{r}]", *filt(dk), "unique"), f"query_{qa}"), \
                f"one_hop_query_{qa}"
        dk = self.describe(sc, k, rs, v=v)
        if dk is None:
            return None
        r2 = self.rng.choice(ontology.RELATIONS)
        rs2 = sorted(sc.rel[r2][k])
        K = v.np(dk, allow_one=False)
        kp = pipe(xp, f"relate[{r}]", *filt(dk), "unique")
        chain = f"{K} {v.rel(r)} {X}"
        if kind in ("c2", "e2"):
            f = {} if self.rng.random() < 0.5 else self.random_set_desc(sc, v, 1)
            P = v.np(f, True, "") if f else v.noun(None, True)
            if kind == "c2":
                q = self.rng.choice(["How many {P} are {r2} {K}?", "Count the {P} {r2} {K}.",
                                     "What number of {P} are {r2} {K}?"])
                q = q.format(P=P, r2=v.rel(r2), K=chain if self.rng.random() < 0.5 else
                             f"{K} that is {v.rel(r)} {X}")
                return cap(q), f"count({pipe(kp, f'relate[{r2}]', *filt(f))})", "two_hop_count"
            a = v.np(f, det="a", allow_one=False) if f else "anything"
            q = self.rng.choice(["Is there {a} {r2} {K}?", "Are there any {P} {r2} {K}?"])
            q = q.format(a=a, P=P, r2=v.rel(r2), K=chain)
            return cap(q), f"exist({pipe(kp, f'relate[{r2}]', *filt(f))})", "two_hop_exist"
        if not rs2:
            return None
        m = self.rng.choice(rs2)
        if kind == "q3":
            r3 = self.rng.choice(ontology.RELATIONS)
            dm = self.describe(sc, m, rs2, v=v)
            rs3 = sorted(sc.rel[r3][m])
            if dm is None or not rs3:
                return None
            t = self.rng.choice(rs3)
            dt = self.describe(sc, t, rs3, exclude=(qa,), v=v)
            if dt is None:
                return None
            M = v.np(dm, allow_one=False)
            T = v.np(dt, allow_one=True)
            q = self.rng.choice(self.QF[qa][:3]).format(
                X=f"{T} that is {v.rel(r3)} {M} {v.rel(r2)} {K} {v.rel(r)} {X}")
            prog = self.query_end(pipe(kp, f"relate[{r2}]", *filt(dm), "unique", f"relate[{r3}]", *filt(dt),
                                       "unique"), f"query_{qa}")
            return cap(q), prog, f"three_hop_query_{qa}"
        dm = self.describe(sc, m, rs2, exclude=(qa,), v=v)
        if dm is None:
            return None
        M = v.np(dm, allow_one=True)
        q = self.rng.choice(self.QF[qa][:4]).format(X=f"{M} that is {v.rel(r2)} {chain}")
        prog = self.query_end(pipe(kp, f"relate[{r2}]", *filt(dm), "unique"), f"query_{qa}")
        return cap(q), prog, f"two_hop_query_{qa}"

    # ---------------------------------------------------------------- parts
    def _pick_part(self, sc, i, bare_ok=True):
        o = sc.objs[i]
        if not o.parts:
            return None
        raw = self.rng.choice(sorted(o.parts))
        bare = bare_ok and super_unique(o.sub, raw) and self.rng.random() < 0.6
        name = ontology.super_part_name(raw) if bare else ontology.canonical_part_name(raw)
        return raw, bare, name

    def parts_query(self, sc, v):
        i = self.rng.randrange(sc.n)
        o = sc.objs[i]
        pk = self._pick_part(sc, i)
        if pk is None:
            return None
        raw, bare, name = pk
        d = self.ref(sc, i, v=v)
        if d is None:
            return None
        X = v.np(d, allow_one=False)
        Pw = v.part(raw, bare)
        a = self.rng.choice(["color", "color", "material", "partname"])
        base = pipe("scene()", *filt(d), "unique", "object2part")
        if a == "partname":
            c, m = o.parts[raw]
            same_c = [r for r, s in o.parts.items() if s[0] == c]
            pf = [f"partfilter_color[{c}]"]
            cw = v.color(c)
            if len(same_c) > 1:
                if [r for r in same_c if o.parts[r][1] == m] != [raw]:
                    return None
                pf.append(f"partfilter_material[{m}]")
                cw = f"{cw} {v.material(m)}"
            if c == o.color or c == "gray":
                return None
            q = self.rng.choice(["Which part of {X} is {c}?", "What part of {X} is {c}?",
                                 "Which of the parts of {X} is {c}?", "Name the {c} part of {X}.",
                                 "What is the {c} part of {X} called?", "What is the name of the {c} part of {X}?",
                                 "{X} has a {c} part; which one?"]).format(X=X, c=cw)
            return cap(q), self.query_end(pipe(base, *pf, "unique"), "partquery_partname"), "part_query_partname"
        pp = pipe(base, f"partfilter_partname[{name}]", "unique")
        poss = f"{X}'s {Pw}" if len(X.split()) <= 3 else f"the {Pw} of {X}"
        if a == "color":
            q = self.rng.choice(["What color is the {P} of {X}?", "What colour is {poss}?",
                                 "What is the color of the {P} of {X}?", "Which color is the {P} on {X}?",
                                 "The {P} of {X} is what colour?", "Tell me the color of {poss}.",
                                 "what colour is the {P} on {X}", "What color does {X} have on its {P}?"])
        else:
            q = self.rng.choice(["What material is the {P} of {X}?", "What is {poss} made of?",
                                 "What is the {P} of {X} made of?", "Is the {P} of {X} metal or rubber?",
                                 "Which material is the {P} on {X} made from?", "The {P} of {X} is made of what?"])
        q = q.format(P=Pw, X=X, poss=poss)
        return cap(q), self.query_end(pp, f"partquery_{a}"), f"part_query_{a}"

    def _scene_part(self, sc, v, owners=None):
        """A recoloured part picked across objects: (i, raw, colour, name, text) with name the super-part name
        (or the full name), unique among the recoloured parts of ``owners``, and no owner body of that colour
        having such a part (which would show the colour without being recoloured)."""
        owners = list(range(sc.n)) if owners is None else owners
        cands = [(i, raw) for i in owners for raw in sc.objs[i].parts]
        if not cands:
            return None
        i, raw = self.rng.choice(cands)
        c, m = sc.objs[i].parts[raw]
        if c == "gray":
            return None
        full = self.rng.random() < 0.35
        name = ontology.canonical_part_name(raw) if full else ontology.super_part_name(raw)
        hits = [(j, r) for j in owners for r, s in sc.objs[j].parts.items()
                if s[0] == c and ontology.partname_matches(r, name)]
        if hits != [(i, raw)]:
            return None
        for j in owners:
            if sc.objs[j].color == c and any(ontology.partname_matches(r, name) for r in ontology.PARTS[sc.objs[j].sub]):
                return None
        text = f"{v.color(c)} {v.part(raw, bare=not full)}"
        return i, raw, c, name, text

    def parts_owner(self, sc, v):
        a = self.rng.choice(["color", "material", "shape", "size"])
        # the fewest object filters first, then the part
        i0 = self.rng.randrange(sc.n)
        o = sc.objs[i0]
        exclude = (a,)
        slots = [s for s in ATTRS if s not in exclude]
        d = {}
        if self.rng.random() < 0.4 and slots:
            s = self.rng.choice(slots)
            d = {s: (o.val(s) if s != "shape" else self.rng.choice([o.sub, o.cat]))}
        owners = members(sc, range(sc.n), d)
        sp = self._scene_part(sc, v, owners)
        if sp is None:
            return None
        i, raw, c, name, text = sp
        if i != i0:
            return None
        # minimality: without d the part must not be unique (else d is dropped)
        if d and self._unique_part(sc, list(range(sc.n)), c, name):
            d = {}
        X = v.np(d, allow_one=False) if d else "the " + v.noun(None)
        whose = self.rng.random() < 0.35
        qa = {"color": "What color is", "material": "What is the material of", "shape": "What kind of vehicle is",
              "size": "How big is"}[a]
        if whose:
            q = self.rng.choice([f"{qa} {X} whose {v.part(raw, bare=name == ontology.super_part_name(raw))} is "
                                 f"{v.color(c)}?"])
            note = "whose"
        else:
            q = self.rng.choice([f"{qa} {X} that has {article(text)} {text}?", f"{qa} {X} with the {text}?",
                                 f"{qa} {X} with {article(text)} {text}?"])
            note = None
        prog = pipe("scene()", *filt(d), "object2part", f"partfilter_color[{c}]", f"partfilter_partname[{name}]",
                    "unique", "part2object", "unique")
        fam = f"part_owner_query_{a}" + ("_whose" if whose else "")
        if whose:
            v.note = "whose"
        return cap(q), self.query_end(prog, f"query_{a}"), fam

    def _unique_part(self, sc, owners, c, name):
        hits = [(j, r) for j in owners for r, s in sc.objs[j].parts.items()
                if s[0] == c and ontology.partname_matches(r, name)]
        return len(hits) == 1

    def parts_same_object(self, sc, v):
        sp = self._scene_part(sc, v)
        if sp is None:
            return None
        i, raw, c, name, text = sp
        o = sc.objs[i]
        others = [r for r in o.parts if r != raw]
        if not others:
            return None
        r1 = self.rng.choice(others)
        a = self.rng.choice(["color", "material", "partname"])
        base = pipe("scene()", "object2part", f"partfilter_color[{c}]", f"partfilter_partname[{name}]", "unique",
                    "part2object", "object2part")
        if a == "partname":
            c1, m1 = o.parts[r1]
            if c1 == o.color or c1 == "gray" or [r for r in others if o.parts[r][0] == c1] != [r1]:
                return None
            q = self.rng.choice(["Which part is {c1} on the same object as the {t}?",
                                 "What is the {c1} part of the thing with the {t}?",
                                 "Name the {c1} part that belongs to the same vehicle as the {t}.",
                                 "What is the name of the {c1} part that belongs to the same object as the {t}?"])
            q = q.format(c1=v.color(c1), t=text)
            prog = pipe(base, f"partfilter_color[{c1}]", "unique")
            return cap(q), self.query_end(prog, "partquery_partname"), "part_same_object_query_partname"
        bare = super_unique(o.sub, r1) and self.rng.random() < 0.5
        n1 = ontology.super_part_name(r1) if bare else ontology.canonical_part_name(r1)
        P1 = v.part(r1, bare)
        if a == "color":
            q = self.rng.choice(["What color is the {p} that belongs to the same object as the {t}?",
                                 "What colour is the {p} of the thing that has the {t}?",
                                 "The object with the {t}: what color is its {p}?",
                                 "What is the color of the {p} on the same vehicle as the {t}?"])
        else:
            q = self.rng.choice(["What material is the {p} that belongs to the same object as the {t}?",
                                 "What is the {p} of the thing with the {t} made of?",
                                 "The object with the {t} - what is its {p} made of?"])
        prog = pipe(base, f"partfilter_partname[{n1}]", "unique")
        return cap(q.format(p=P1, t=text)), self.query_end(prog, f"partquery_{a}"), f"part_same_object_query_{a}"

    def parts_count(self, sc, v):
        i = self.rng.randrange(sc.n)
        o = sc.objs[i]
        d = self.ref(sc, i, v=v)
        if d is None:
            return None
        cols = [c for c in ontology.COLORS if c not in (o.color, "gray")]
        if o.parts and self.rng.random() < 0.6:
            c = self.rng.choice([s[0] for s in o.parts.values()])
            if c in (o.color, "gray"):
                return None
        else:
            c = self.rng.choice(cols)
        X = v.np(d, allow_one=False)
        cw = v.color(c)
        kind = self.rng.choice(["count", "exist", "count", "exist_named"])
        base = pipe("scene()", *filt(d), "unique", "object2part", f"partfilter_color[{c}]")
        if kind == "count":
            q = self.rng.choice(["How many {c} parts does {X} have?", "How many parts of {X} are {c}?",
                                 "Count the {c} parts of {X}.", "How many {c} parts are there on {X}?",
                                 "how many of the parts of {X} are {c}"])
            return cap(q.format(c=cw, X=X)), f"count({base})", "part_count_color"
        if kind == "exist":
            q = self.rng.choice(["Does {X} have a {c} part?", "Is any part of {X} {c}?", "Is there a {c} part on {X}?",
                                 "Does {X} have any {c} parts?", "Has {X} got a {c} part?"])
            return cap(q.format(c=cw, X=X)), f"exist({base})", "part_exist_color"
        raw = self.rng.choice(ontology.PARTS[o.sub])
        if not super_unique(o.sub, raw) and self.rng.random() < 0.5:
            name, Pw = ontology.super_part_name(raw), v.part(raw, True)
            if ontology.super_part_name(raw) in ("wheel", "door", "mirror", "wing", "engine", "tailplane"):
                pass
            else:
                return None
            q = self.rng.choice(["Does {X} have a {c} {p}?", "Is one of the {pp} of {X} {c}?"])
            q = q.format(X=X, c=cw, p=Pw, pp=plural(Pw))
        else:
            name, Pw = ontology.canonical_part_name(raw), v.part(raw)
            q = self.rng.choice(["Is the {p} of {X} {c}?", "Does {X} have a {c} {p}?"]).format(X=X, c=cw, p=Pw)
        return cap(q), f"exist({pipe(base, f'partfilter_partname[{name}]')})", "part_exist_named_color"

    def parts_objects_with(self, sc, v):
        f = {} if self.rng.random() < 0.5 else self.random_set_desc(sc, v, 1)
        owners = members(sc, range(sc.n), f)
        if self.rng.random() < 0.6:
            cands = [(i, raw) for i in owners for raw in sc.objs[i].parts]
            if not cands:
                return None
            i, raw = self.rng.choice(cands)
            c = sc.objs[i].parts[raw][0]
            sp = ontology.super_part_name(raw)
        else:
            c = self.rng.choice(ontology.COLORS[1:])
            sub = self.rng.choice([sc.objs[j].sub for j in owners] or list(ontology.SUBTYPES))
            raw = self.rng.choice(ontology.PARTS[sub])
            sp = ontology.super_part_name(raw)
        if c == "gray":
            return None
        for j in owners:
            if sc.objs[j].color == c and any(ontology.super_part_name(r) == sp for r in ontology.PARTS[sc.objs[j].sub]):
                return None
        Pw = v.part(raw, True)
        cw = v.color(c)
        N = v.np(f, True, "") if f else v.noun(None, True)
        prog_set = pipe("scene()", *filt(f), "object2part", f"partfilter_color[{c}]", f"partfilter_partname[{sp}]",
                        "part2object")
        if self.rng.random() < 0.5:
            q = self.rng.choice(["How many {N} have a {c} {p}?", "How many {N} with a {c} {p} are there?",
                                 "Count the {N} that have a {c} {p}.", "How many {N} have got a {c} {p}?"])
            return cap(q.format(N=N, c=cw, p=Pw)), f"count({prog_set})", "count_objects_with_part_color"
        s = v.np(f, det="", allow_one=False) if f else v.noun(None)
        q = self.rng.choice(["Is there {a} with a {c} {p}?", "Does any {s} have a {c} {p}?",
                             "Is there {a} that has a {c} {p}?", "Can you see {a} with a {c} {p}?"])
        q = q.format(a=f"{article(s)} {s}", s=s, c=cw, p=Pw)
        return cap(q), f"exist({prog_set})", "exist_objects_with_part_color"

    # ---------------------------------------------------------------- pose
    PQ = ["Which direction is {X} facing?", "Which way is {X} facing?", "What direction does {X} face?",
          "Which way does {X} point?", "In which direction is {X} facing?", "Where is {X} facing?",
          "Which direction {X} is facing?", "Is {X} facing left, right, towards us or away?",
          "What direction is {X} pointed in?", "which way is {X} turned", "Tell me which way {X} faces.",
          "What is the orientation of {X}?"]

    def pose_query(self, sc, v):
        i = self.rng.randrange(sc.n)
        if not sc.objs[i].clear_pose():
            return None
        d = self.ref(sc, i, v=v)
        if d is None:
            return None
        q = self.rng.choice(self.PQ).format(X=v.np(d, allow_one=False))
        return cap(q), self.query_end(pipe("scene()", *filt(d), "unique"), "query_pose"), "pose_query"

    def pose_filter(self, sc, v):
        kind = self.rng.choice(["query", "query", "count", "exist"])
        if kind == "query":
            i = self.rng.randrange(sc.n)
            o = sc.objs[i]
            if not o.clear_pose():
                return None
            a = self.rng.choice(ATTRS)
            posed = [j for j in range(sc.n) if sc.objs[j].pose == o.pose]
            d = self.describe(sc, i, posed, exclude=(a,), v=v)
            if d is None:
                return None
            similar = members(sc, range(sc.n), d)
            if len(similar) < 2 or any(sc.objs[j].near_edge() for j in similar):
                return None  # the pose must be needed, and clear for all the look-alikes
            pw = self.rng.choice(POSE_W[o.pose])
            X = v.np(d, allow_one=True) + " " + (pw if self.rng.random() < 0.6 or pw.startswith("with")
                                                 else "that is " + pw)
            qf = self.QF[a][:6]
            q = self.rng.choice(qf).format(X=X)
            prog = self.query_end(pipe("scene()", *filt(d, o.pose), "unique"), f"query_{a}")
            return cap(q), prog, f"pose_filter_query_{a}"
        pose = self.rng.choice(ontology.POSE_LABELS)
        f = {} if self.rng.random() < 0.4 else self.random_set_desc(sc, v, 2)
        cand = members(sc, range(sc.n), f)
        if any(sc.objs[j].near_edge() for j in cand):
            return None
        pw = self.rng.choice(POSE_PL[pose])
        N = v.np(f, True, "") if f else v.noun(None, True)
        prog = pipe("scene()", *filt(f, pose))
        if kind == "count":
            q = self.rng.choice(["How many {N} are {p}?", "How many {N} are there {p}?", "Count the {N} {p}.",
                                 "What number of {N} are {p}?", "how many {N} {p} are there"])
            return cap(q.format(N=N, p=pw)), f"count({prog})", "pose_filter_count"
        s = v.np(f, det="", allow_one=False) if f else v.noun(None)
        q = self.rng.choice(["Is there {a} {p}?", "Are any {N} {p}?", "Is any {s} {p}?", "Do you see {a} {p}?"])
        return cap(q.format(a=f"{article(s)} {s}", s=s, N=N, p=pw)), f"exist({prog})", "pose_filter_exist"

    def pose_relate(self, sc, v):
        i = self.rng.randrange(sc.n)
        if not sc.pose_rel_clear(i):
            return None
        d = self.ref(sc, i, v=v)
        if d is None:
            return None
        rel = self.rng.choice(["same_pose", "opposite_pose", "vertical_pose"])
        rs = [j for j in range(sc.n) if j != i and sc.pose_rel(i, j) == rel]
        X = v.np(d, allow_one=False)
        pw = self.rng.choice(PREL_W[rel])
        base = pipe("scene()", *filt(d), "unique", rel)
        short = rel.split("_")[0]
        kind = self.rng.choice(["query", "query", "count", "exist"])
        if kind == "query":
            if not rs:
                return None
            k = self.rng.choice(rs)
            a = self.rng.choice(ATTRS)
            dk = self.describe(sc, k, rs, exclude=(a,), v=v)
            if dk is None:
                return None
            K = v.np(dk, allow_one=True)
            if not pw.startswith("that"):
                pw2 = pw if self.rng.random() < 0.6 else "that is " + pw
            else:
                pw2 = pw
            q = self.rng.choice(self.QF[a][:5]).format(X=f"{K} {pw2} {X}")
            return cap(q), self.query_end(pipe(base, *filt(dk), "unique"), f"query_{a}"), f"{short}_pose_query_{a}"
        f = {} if self.rng.random() < 0.5 else self.random_set_desc(sc, v, 1)
        N = v.np(f, True, "") if f else v.noun(None, True)
        pwp = pw.replace("that faces", "facing")
        if kind == "count":
            q = self.rng.choice(["How many {N} are {p} {X}?", "Count the {N} {p} {X}.",
                                 "How many {N} are there {p} {X}?"])
            return cap(q.format(N=N, p=pwp, X=X)), f"count({pipe(base, *filt(f))})", f"{short}_pose_count"
        s = v.np(f, det="", allow_one=False) if f else v.noun(None)
        q = self.rng.choice(["Is there {a} {p} {X}?", "Are any {N} {p} {X}?", "Is any other {s} {p} {X}?"])
        return cap(q.format(a=f"{article(s)} {s}", N=N, s=s, p=pwp, X=X)), f"exist({pipe(base, *filt(f))})", \
            f"{short}_pose_exist"

    # ---------------------------------------------------------------- occlusion
    OCC = ["occluded", "partly hidden", "partially occluded", "partially hidden", "partly blocked from view",
           "partially covered"]
    OCC_BY = ["occluded by", "partly hidden by", "partially blocked by", "partly covered by", "hidden behind",
              "obstructed by"]
    OCCING = ["occludes", "is occluding", "partly hides", "is blocking the view of", "is in the way of",
              "covers part of"]

    def occlusion(self, sc, v):
        kind = self.rng.choice(["q", "q_by", "q_ing", "yn", "yn_by", "c", "c_by", "c_ing"])
        occ = [j for j in range(sc.n) if sc.objs[j].occluded]
        if kind == "q":
            if not occ:
                return None
            i = self.rng.choice(occ)
            a = self.rng.choice(ATTRS)
            d = self.describe(sc, i, occ, exclude=(a,), v=v)
            if d is None or len(members(sc, range(sc.n), d)) < 2:
                return None  # occlusion must be needed
            ow = self.rng.choice(self.OCC)
            X = self.rng.choice([f"{v.np(d)} that is {ow}", f"the {ow} {v.np(d, det='')}"]) \
                if " " not in ow else f"{v.np(d)} that is {ow}"
            q = self.rng.choice(self.QF[a][:6]).format(X=X)
            return cap(q), self.query_end(pipe("scene()", "filter_occludee", *filt(d), "unique"), f"query_{a}"), \
                f"occluded_query_{a}"
        j = self.rng.randrange(sc.n)
        dj = self.ref(sc, j, v=v, min_slots=1)
        if dj is None:
            return None
        Y = v.np(dj, allow_one=False)
        yp = pipe("scene()", *filt(dj), "unique")
        if kind in ("q_by", "q_ing"):
            rs = sorted(sc.occludees[j]) if kind == "q_by" else sorted(sc.objs[j].occ_by)
            if not rs:
                return None
            i = self.rng.choice(rs)
            a = self.rng.choice(ATTRS)
            d = self.describe(sc, i, rs, exclude=(a,), v=v)
            if d is None:
                return None
            X = v.np(d, allow_one=True)
            if kind == "q_by":
                X = f"{X} {'that is ' if self.rng.random() < 0.5 else ''}{self.rng.choice(self.OCC_BY)} {Y}"
                op, fam = "relate_occluding", f"occluded_by_query_{a}"
            else:
                X = f"{X} that {self.rng.choice(self.OCCING)} {Y}"
                op, fam = "relate_occluded", f"occluding_query_{a}"
            q = self.rng.choice(self.QF[a][:6]).format(X=X)
            if a == "shape" and not d and self.rng.random() < 0.5:
                q = (f"What is {self.rng.choice(self.OCC_BY)} {Y}?" if kind == "q_by"
                     else f"What {self.rng.choice(self.OCCING)} {Y}?")
            return cap(q), self.query_end(pipe(yp, op, *filt(d), "unique"), f"query_{a}"), fam
        if kind == "yn":
            i = j
            d = dj
            q = self.rng.choice(["Is {X} occluded?", "Is {X} partly hidden?", "Is {X} partially occluded?",
                                 "Is {X} blocked from view by something?", "Is part of {X} covered by something?",
                                 "Is anything in front of {X} hiding part of it?", "is {X} occluded",
                                 "Is {X} hidden behind anything?", "Does something occlude {X}?"])
            return cap(q.format(X=Y)), f"exist({pipe('scene()', 'filter_occludee', *filt(d))})", "object_occluded_yes_no"
        if kind == "yn_by":
            i = self.rng.choice([x for x in range(sc.n) if x != j] or [j])
            if i == j:
                return None
            if self.rng.random() < 0.6 and sc.occludees[j]:
                i = self.rng.choice(sorted(sc.occludees[j]))
            d = self.ref(sc, i, v=v)
            if d is None:
                return None
            X = v.np(d, allow_one=False)
            q = self.rng.choice(["Is {X} occluded by {Y}?", "Does {Y} occlude {X}?", "Is {X} partly hidden by {Y}?",
                                 "Is {Y} blocking the view of {X}?", "Does {Y} hide part of {X}?",
                                 "Is {X} hidden behind {Y}?", "is {Y} occluding {X}"])
            return cap(q.format(X=X, Y=Y)), f"exist({pipe(yp, 'relate_occluding', *filt(d))})", \
                "occluded_by_yes_no"
        f = {} if self.rng.random() < 0.5 else self.random_set_desc(sc, v, 1)
        N = v.np(f, True, "") if f else v.noun(None, True)
        if kind == "c":
            q = self.rng.choice(["How many {N} are occluded?", "How many {N} are partly hidden?",
                                 "Count the occluded {N}.", "How many {N} are partially blocked from view?",
                                 "How many of the {N} are occluded?", "how many {N} are hidden partly"])
            return cap(q.format(N=N)), f"count({pipe('scene()', 'filter_occludee', *filt(f))})", "occluded_count"
        if kind == "c_by":
            q = self.rng.choice(["How many {N} does {Y} occlude?", "How many {N} are occluded by {Y}?",
                                 "How many {N} are partly hidden by {Y}?", "Count the {N} that {Y} is blocking.",
                                 "How many {N} is {Y} hiding?"])
            return cap(q.format(N=N, Y=Y)), f"count({pipe(yp, 'relate_occluding', *filt(f))})", "occluded_by_count"
        q = self.rng.choice(["How many {N} occlude {Y}?", "How many {N} are occluding {Y}?",
                             "By how many {N} is {Y} occluded?", "How many {N} block the view of {Y}?",
                             "How many {N} are hiding part of {Y}?"])
        return cap(q.format(N=N, Y=Y)), f"count({pipe(yp, 'relate_occluded', *filt(f))})", "occluder_count"

    # ---------------------------------------------------------------- part occlusion
    def part_occlusion(self, sc, v):
        kind = self.rng.choice(["yn", "yn_by", "which", "whose", "whose_by", "part_of_occ", "part_of_occ_by",
                                "count", "same_obj"])
        i = self.rng.randrange(sc.n)
        o = sc.objs[i]
        if kind in ("yn", "yn_by", "which", "count"):
            d = self.ref(sc, i, v=v)
            if d is None:
                return None
            X = v.np(d, allow_one=False)
            xp = pipe("scene()", *filt(d), "unique", "object2part_all")
            if kind == "which":
                if len(o.occ_parts) != 1:
                    return None
                q = self.rng.choice(["Which part of {X} is occluded?", "What part of {X} is hidden?",
                                     "Which of the parts of {X} is occluded?", "What part of {X} is blocked from view?",
                                     "Which part of {X} is partly hidden?", "which part of {X} can't be fully seen",
                                     "Name the occluded part of {X}."])
                return cap(q.format(X=X)), self.query_end(pipe(xp, "partfilter_occludee", "unique"),
                                                          "partquery_partname"), "which_part_occluded"
            if kind == "count":
                q = self.rng.choice(["How many parts of {X} are occluded?", "How many of the parts of {X} are hidden?",
                                     "Count the occluded parts of {X}.", "How many parts of {X} are partly hidden?",
                                     "how many occluded parts does {X} have"])
                return cap(q.format(X=X)), f"count({pipe(xp, 'partfilter_occludee')})", "occluded_part_count"
            if not o.all_parts:
                return None
            raw = self.rng.choice(sorted(o.all_parts))
            bare = super_unique(o.sub, raw) and self.rng.random() < 0.5
            name = ontology.super_part_name(raw) if bare else ontology.canonical_part_name(raw)
            Pw = v.part(raw, bare)
            pp = pipe(xp, f"partfilter_partname[{name}]", "unique")
            if kind == "yn":
                q = self.rng.choice(["Is the {P} of {X} occluded?", "Is the {P} of {X} hidden?",
                                     "Is the {P} on {X} partly hidden?", "Is the {P} of {X} blocked from view?",
                                     "Is something covering the {P} of {X}?", "is the {P} of {X} occluded",
                                     "Is {X}'s {P} occluded?"])
                if "'s" in q and len(X.split()) > 3:
                    return None
                return cap(q.format(P=Pw, X=X)), self.query_end(pp, "partquery_occlusion"), "part_occluded_yes_no"
            j = self.rng.choice([x for x in range(sc.n) if x != i] or [i])
            by = o.occ_parts.get(raw, ())
            if by and self.rng.random() < 0.6:
                j = self.rng.choice(by)
            if j == i:
                return None
            dj = self.ref(sc, j, v=v, min_slots=1)
            if dj is None:
                return None
            Y = v.np(dj, allow_one=False)
            q = self.rng.choice(["Is the {P} of {X} occluded by {Y}?", "Does {Y} occlude the {P} of {X}?",
                                 "Is the {P} of {X} hidden by {Y}?", "Is {Y} blocking the {P} of {X}?",
                                 "Does {Y} hide the {P} of {X}?"])
            return cap(q.format(P=Pw, X=X, Y=Y)), f"exist({pipe(pp, 'relate_part_occluded', *filt(dj))})", \
                "part_occluded_by_yes_no"
        if kind == "whose":
            cands = [(x, raw) for x in range(sc.n) for raw in sc.objs[x].occ_parts]
            if not cands:
                return None
            i, raw = self.rng.choice(cands)
            o = sc.objs[i]
            full = not super_unique(o.sub, raw) and self.rng.random() < 0.4
            name = ontology.canonical_part_name(raw) if full else ontology.super_part_name(raw)
            owners = [x for x in range(sc.n) if any(ontology.partname_matches(r, name) for r in sc.objs[x].occ_parts)]
            a = self.rng.choice(ATTRS)
            d = {} if owners == [i] else self.describe(sc, i, owners, exclude=(a,), v=v)
            if d is None:
                return None
            X = v.np(d, allow_one=False) if d else "the " + v.noun(None)
            Pw = v.part(raw, not full)
            ow = self.rng.choice(["occluded", "hidden", "partly hidden", "blocked from view", "occluded"])
            qf = {"color": "What color is", "material": "What is the material of", "size": "What size is",
                  "shape": "What type of vehicle is"}[a]
            q = self.rng.choice([f"{qf} {X} whose {Pw} is {ow}?", f"{qf} {X} that has its {Pw} {ow}?",
                                 f"{qf} {X} with an {ow} {Pw}?" if ow[0] in "aeiou" else f"{qf} {X} with a {ow} {Pw}?"])
            prog = pipe("scene()", *filt(d), "object2part_all", "partfilter_occludee", f"partfilter_partname[{name}]",
                        "part2object", "unique")
            v.note = "whose" if "whose" in q else None
            return cap(q), self.query_end(prog, f"query_{a}"), f"whose_part_occluded_query_{a}"
        if kind == "whose_by":
            j = self.rng.randrange(sc.n)
            hidden = sc.parts_hidden_by[j]
            if not hidden:
                return None
            i, raw = self.rng.choice(hidden)
            o = sc.objs[i]
            full = not super_unique(o.sub, raw) and self.rng.random() < 0.5
            name = ontology.canonical_part_name(raw) if full else ontology.super_part_name(raw)
            if [h for h in hidden if ontology.partname_matches(h[1], name)] != [(i, raw)]:
                return None
            dj = self.ref(sc, j, v=v, min_slots=1)
            a = self.rng.choice(ATTRS)
            if dj is None:
                return None
            Y = v.np(dj, allow_one=False)
            d = {}
            if self.rng.random() < 0.4 and a != "shape":
                d = {"shape": o.cat}
            X = v.np(d, allow_one=False) if d else "the " + v.noun(None)
            Pw = v.part(raw, not full)
            qf = {"color": "What color is", "material": "What is the material of", "size": "What size is",
                  "shape": "What type of vehicle is"}[a]
            q = self.rng.choice([f"{qf} {X} whose {Pw} is occluded by {Y}?",
                                 f"{qf} {X} whose {Pw} is hidden by {Y}?",
                                 f"{qf} {X} that has its {Pw} blocked by {Y}?"])
            prog = pipe(pipe("scene()", *filt(dj), "unique"), "relate_occluding_part",
                        f"partfilter_partname[{name}]", "unique", "part2object", *filt(d), "unique")
            v.note = "whose" if "whose" in q else None
            return cap(q), self.query_end(prog, f"query_{a}"), f"whose_part_occluded_by_query_{a}"
        if kind in ("part_of_occ", "part_of_occ_by"):
            if kind == "part_of_occ":
                pool = [x for x in range(sc.n) if sc.objs[x].occluded]
                head = pipe("scene()", "filter_occludee")
                j = None
            else:
                j = self.rng.randrange(sc.n)
                pool = sorted(sc.occludees[j])
            if not pool:
                return None
            i = self.rng.choice(pool)
            o = sc.objs[i]
            pk = self._pick_part(sc, i)
            if pk is None:
                return None
            raw, bare, name = pk
            d = self.describe(sc, i, pool, v=v, min_slots=1)
            if d is None:
                return None
            a = self.rng.choice(["color", "color", "material"])
            Pw = v.part(raw, bare)
            qf = {"color": "What color is", "material": "What material is"}[a]
            if kind == "part_of_occ":
                ow = self.rng.choice(["occluded", "partly hidden", "partially occluded"])
                q = self.rng.choice([f"{qf} the {Pw} of the {ow} {v.np(d, det='', allow_one=False)}?",
                                     f"{qf} the {Pw} that belongs to the {v.np(d, det='', allow_one=False)} that is {ow}?",
                                     f"{qf} the {Pw} of {v.np(d, det='an' if False else 'the', allow_one=False)} that is {ow}?"])
                fam = f"part_of_occluded_query_{a}"
            else:
                dj = self.ref(sc, j, v=v, min_slots=1)
                if dj is None:
                    return None
                Y = v.np(dj, allow_one=False)
                head = pipe("scene()", *filt(dj), "unique", "relate_occluding")
                q = self.rng.choice([f"{qf} the {Pw} of {v.np(d, allow_one=False)} that is occluded by {Y}?",
                                     f"{qf} the {Pw} of {v.np(d, allow_one=False)} that {Y} occludes?",
                                     f"{qf} the {Pw} of {v.np(d, allow_one=False)} partly hidden by {Y}?"])
                fam = f"part_of_occluded_by_query_{a}"
            prog = pipe(head, *filt(d), "object2part", f"partfilter_partname[{name}]", "unique")
            return cap(q), self.query_end(prog, f"partquery_{a}"), fam
        # same_obj: part of the thing whose P2 is occluded
        cands = [(x, raw) for x in range(sc.n) for raw in sc.objs[x].occ_parts]
        if not cands:
            return None
        i, raw2 = self.rng.choice(cands)
        o = sc.objs[i]
        name2 = ontology.super_part_name(raw2)
        owners = [x for x in range(sc.n) if any(ontology.partname_matches(r, name2) for r in sc.objs[x].occ_parts)]
        d = {} if owners == [i] else self.describe(sc, i, owners, v=v)
        if d is None:
            return None
        others = [r for r in o.parts if r not in o.occ_parts or r != raw2]
        others = [r for r in others if ontology.super_part_name(r) != name2]
        if not others:
            return None
        r1 = self.rng.choice(others)
        bare = super_unique(o.sub, r1) and self.rng.random() < 0.5
        n1 = ontology.super_part_name(r1) if bare else ontology.canonical_part_name(r1)
        a = self.rng.choice(["color", "material"])
        X = v.np(d, allow_one=False) if d else "the " + v.noun(None)
        qf = {"color": "What color is", "material": "What material is"}[a]
        q = f"{qf} the {v.part(r1, bare)} of {X} whose {v.part(raw2, True)} is occluded?"
        prog = pipe("scene()", "object2part_all", "partfilter_occludee", f"partfilter_partname[{name2}]",
                    "part2object", *filt(d), "object2part", f"partfilter_partname[{n1}]", "unique")
        v.note = "whose"
        return cap(q), self.query_end(prog, f"partquery_{a}"), f"part_of_object_whose_part_occluded_query_{a}"


# ----------------------------------------------------------------------------------------------------------------
# groups

GROUPS = {
    "core_query": ["core_query", "core_query", "core_query_pronoun", "core_query_subtype"],
    "core_count": ["core_count", "core_count", "core_count_union", "core_count_all"],
    "core_exist": ["core_exist", "core_exist", "core_exist_union"],
    "core_compare_attribute": ["core_compare", "core_compare", "core_compare_related"],
    "core_compare_integer": ["core_compare_integer", "core_compare_integer", "core_compare_integer_rel"],
    "core_same_relate": ["core_same"],
    "core_spatial": ["core_spatial"],
    "parts": ["parts_query", "parts_owner", "parts_same_object", "parts_count", "parts_objects_with"],
    "pose": ["pose_query", "pose_filter", "pose_relate", "pose_relate"],
    "occlusion": ["occlusion"],
    "part_occlusion": ["part_occlusion"],
}
REDUNDANT_FROM = ["core_query", "core_query_pronoun", "core_compare", "core_compare_related", "core_same",
                  "core_spatial", "parts_query", "parts_count", "pose_query", "pose_filter", "pose_relate",
                  "occlusion", "part_occlusion", "core_compare_integer_rel"]
WIDE_FROM = ["core_query", "core_query_pronoun", "core_count", "core_exist", "core_compare", "core_compare_integer",
             "core_same", "core_spatial", "parts_query", "parts_owner", "parts_objects_with", "pose_query",
             "pose_filter", "pose_relate", "occlusion", "part_occlusion"]
QUIRK_FROM = ["core_count", "core_exist", "core_compare_integer"]
TYPO_FROM = ["core_query", "core_count", "core_exist", "core_compare", "core_same", "core_spatial", "parts_query",
             "pose_query", "pose_filter", "pose_relate", "occlusion", "part_occlusion", "core_compare_integer",
             "parts_owner", "core_query_pronoun"]


def register(q, rng):
    """Vary the register: openers, please, lowercase, no question mark."""
    r = rng.random()
    if r < 0.13:
        first = q.split()[0]
        if not (len(first) > 1 and first[1].isupper()):
            q = q[0].lower() + q[1:]
        q = rng.choice(OPENERS) + q
    elif r < 0.18 and not q.endswith("?"):
        q = "Please " + q[0].lower() + q[1:]
    if rng.random() < 0.16:
        q = q.lower()
    if q.endswith("?") and rng.random() < 0.2:
        q = q[:-1]
    elif q.endswith(".") and rng.random() < 0.2:
        q = q[:-1]
    return q


def add_typo(q, rng):
    words = [(m.start(), m.group()) for m in re.finditer(r"[A-Za-z]+", q)]
    cands = [(s, w) for s, w in words if w in TYPOS or w.lower() in TYPOS]
    if not cands:
        return None, None
    s, w = rng.choice(cands)
    key = w if w in TYPOS else w.lower()
    t = rng.choice(TYPOS[key])
    if w[0].isupper() and not t[0].isupper():
        t = t[0].upper() + t[1:]
    return q[:s] + t + q[s + len(w):], f"typo: {w} -> {t}"


def candidate(gen, sc, method, mode):
    v = Voice(gen.rng, wide=mode == "wide", redundant=mode == "redundant")
    v.note = None
    v.redundant_added = False
    if mode == "quirk":
        v.force_bus_plural = True
    out = getattr(gen, method)(sc, v)
    if out is None:
        return None
    q, prog, fam = out
    notes = []
    if mode == "redundant":
        if not v.redundant_added:
            return None
        notes.append("redundant description")
        fam = "redundant_" + fam
    elif mode == "wide":
        used = sorted({w for w in v.wide_used if re.search(rf"(?<![A-Za-z]){re.escape(w)}", q)})
        if not used:
            return None
        notes.append("wider synonyms " + ", ".join(f"'{w}'" for w in used))
        fam = "synonym_" + fam
    elif mode == "quirk":
        if not re.search(r"\bbuses\b", q):
            return None
        quirk = gen.rng.choice(["buss", "buss", "busses"])
        q = re.sub(r"\bbuses\b", quirk, q)
        notes.append(f"public plural quirk '{quirk}'")
        fam = "plural_quirk_" + fam
    if v.note:
        notes.append(v.note)
    q = register(q, gen.rng)
    if mode == "typo":
        q, note = add_typo(q, gen.rng)
        if q is None:
            return None
        notes.append(note)
        fam = "typo_" + fam
    ok, ans = run(sc, prog)
    if not ok:
        return None
    return {"question": q, "program": prog, "family": fam, "scene": sc.rel_path, "answer": ans,
            "phrasing_notes": "; ".join(notes) if notes else None}


def pool_for(gen, scenes, method, mode, want, tries):
    """Up to ``want`` candidates; yes/no answers are kept balanced per family as they are drawn."""
    out = []
    yn = defaultdict(Counter)
    for _ in range(tries):
        if len(out) >= want:
            break
        sc = gen.rng.choice(scenes)
        c = candidate(gen, sc, method, mode)
        if c is None:
            continue
        if isinstance(c["answer"], bool):
            seen = yn[c["family"]]
            if seen[c["answer"]] > seen[not c["answer"]] + 1:
                continue
            seen[c["answer"]] += 1
        out.append(c)
    return out


def balanced_pick(cands, quota, rng, taken_keys):
    by_fam = defaultdict(list)
    for c in cands:
        by_fam[c["family"]].append(c)
    fams = sorted(by_fam)
    rng.shuffle(fams)
    counts = {f: Counter() for f in fams}
    out = []
    while len(out) < quota and fams:
        for f in list(fams):
            if len(out) >= quota:
                break
            pool = by_fam[f]
            pool = [c for c in pool if (c["scene"], c["question"]) not in taken_keys
                    and (c["scene"], c["program"]) not in taken_keys]
            by_fam[f] = pool
            if not pool:
                fams.remove(f)
                continue
            least = min(counts[f][json.dumps(c["answer"])] for c in pool)
            choice = next(c for c in pool if counts[f][json.dumps(c["answer"])] == least)
            pool.remove(choice)
            counts[f][json.dumps(choice["answer"])] += 1
            taken_keys.add((choice["scene"], choice["question"]))
            taken_keys.add((choice["scene"], choice["program"]))
            out.append(choice)
    return out


def generate(seed):
    rng = random.Random(seed)
    scenes = [Scn(s) for s in range(7500, 7564)]
    gen = Gen(rng, scenes)
    hand = HERE / "hand_written.jsonl"
    taken = set()
    if hand.exists():
        for line in hand.read_text().splitlines():
            if line.strip():
                r = json.loads(line)
                taken.add((r["scene"], r["question"]))
    records = []
    for group, methods in list(GROUPS.items()) + [("redundant", None), ("synonyms_quirks_typos", None)]:
        cands = []
        if methods:
            for m in sorted(set(methods)):
                w = methods.count(m)
                want = 360 * w // len(methods)
                cands += pool_for(gen, scenes, m, "base", want, 25 * want)
        elif group == "redundant":
            for m in REDUNDANT_FROM:
                cands += pool_for(gen, scenes, m, "redundant", 30, 1200)
        else:
            for m in WIDE_FROM:
                cands += pool_for(gen, scenes, m, "wide", 14, 700)
            for m in QUIRK_FROM:
                cands += pool_for(gen, scenes, m, "quirk", 12, 900)
            for m in TYPO_FROM:
                cands += pool_for(gen, scenes, m, "typo", 10, 500)
        if group == "synonyms_quirks_typos":
            # keep the three kinds in proportion: about 55 synonym, 12 quirk, 43 typo questions
            parts = {"synonym_": 55, "plural_quirk_": 12, "typo_": 43}
            picked = []
            for pre, n in parts.items():
                picked += balanced_pick([c for c in cands if c["family"].startswith(pre)], n, rng, taken)
            if len(picked) < QUOTA:
                picked += balanced_pick(cands, QUOTA - len(picked), rng, taken)
        else:
            picked = balanced_pick(cands, QUOTA, rng, taken)
        for c in picked:
            c["family_group"] = group
        records += picked
        print(f"{group}: {len(picked)} of {len(cands)} candidates, {len({c['family'] for c in picked})} families",
              file=sys.stderr)
    out = []
    for n, r in enumerate(records):
        rec = {"id": f"v5g{n:05d}", "question": r["question"], "program": r["program"],
               "family_group": r["family_group"], "family": r["family"], "scene": r["scene"], "answer": r["answer"]}
        if r["phrasing_notes"]:
            rec["phrasing_notes"] = r["phrasing_notes"]
        out.append(rec)
    (HERE / "generated.jsonl").write_text("".join(json.dumps(r) + "\n" for r in out))
    print(f"wrote {len(out)} questions", file=sys.stderr)


# ----------------------------------------------------------------------------------------------------------------
# hand-written answers and --show


def check_part_names(program):
    bad = []
    for value in re.findall(r"partfilter_partname\[([A-Za-z0-9_]+)\]", program):
        if value not in ontology.CANONICAL_PARTNAME_VALUES:
            bad.append(value)
    return bad


def fill_hand():
    path = HERE / "hand_written.jsonl"
    recs = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    cache = {}
    problems = []
    seen = Counter()
    for n, r in enumerate(recs):
        seed = int(re.search(r"scene_(\d+)", r["scene"]).group(1))
        sc = cache.get(seed) or cache.setdefault(seed, Scn(seed))
        bad = check_part_names(r["program"])
        if bad:
            problems.append(f"{r.get('id', n)}: non-canonical part name(s) {bad}")
            continue
        try:
            ok, ans = run(sc, r["program"])
        except Exception as e:  # noqa: BLE001 - report every malformed program
            problems.append(f"{r.get('id', n)}: {type(e).__name__}: {e}")
            continue
        if not ok:
            problems.append(f"{r.get('id', n)}: invalid on its scene: {ans} | {r['question']}")
            continue
        if "expect" in r and r["expect"] != ans:
            problems.append(f"{r.get('id', n)}: answer {ans!r} differs from the expected {r['expect']!r} | "
                            f"{r['question']}")
        r["answer"] = ans
        r["id"] = f"v5h{n:03d}"
        seen[(r["scene"], r["question"])] += 1
    problems += [f"duplicate question {k}" for k, c in seen.items() if c > 1]
    if problems:
        print("\n".join(problems), file=sys.stderr)
        sys.exit(f"{len(problems)} problem(s); hand_written.jsonl not written")
    order = ["id", "question", "program", "family_group", "family", "scene", "answer", "phrasing_notes"]
    lines = []
    for r in recs:
        r.pop("expect", None)
        lines.append(json.dumps({k: r[k] for k in order if k in r and r[k] is not None}))
    path.write_text("\n".join(lines) + "\n")
    print(f"{len(recs)} hand-written questions checked and filled", file=sys.stderr)


def show(seed):
    sc = Scn(seed)
    print(f"== scene {seed}: {sc.n} objects")
    for o in sc.objs:
        edge = " (near edge)" if o.near_edge() else ""
        print(f"[{o.i}] {o.size} {o.color} {o.material} {o.sub} ({o.cat}); pose {o.pose} {o.deg:.0f}deg{edge}")
        for raw, (c, m) in sorted(o.parts.items()):
            print(f"      part {raw} -> {ontology.canonical_part_name(raw)}: {c} {m}")
        if o.occ_by:
            print(f"      occluded by {list(o.occ_by)}")
        for raw, by in sorted(o.occ_parts.items()):
            print(f"      part {raw} ({ontology.canonical_part_name(raw)}) occluded by {list(by)}")
    for r in ontology.RELATIONS:
        print(f"{r}: " + "; ".join(f"{i}:{sorted(s)}" for i, s in enumerate(sc.rel[r])))
    print("occludes: " + "; ".join(f"{j}:{sorted(s)}" for j, s in sc.occludees.items() if s))
    for i in range(sc.n):
        if sc.objs[i].pose == "None":
            continue
        rels = defaultdict(list)
        for j in range(sc.n):
            if j != i:
                rels[sc.pose_rel(i, j)].append(j)
        clear = "" if sc.pose_rel_clear(i) else " (some pair near 45/135)"
        print(f"pose rel of {i}: " + ", ".join(f"{k} {v}" for k, v in sorted(rels.items())) + clear)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seed", type=int, default=7500)
    ap.add_argument("--hand", action="store_true", help="fill/check the answers of hand_written.jsonl")
    ap.add_argument("--show", type=int, nargs="+", metavar="SEED", help="print scenes' facts")
    args = ap.parse_args()
    if args.show:
        for s in args.show:
            show(s)
    elif args.hand:
        fill_hand()
    else:
        generate(args.seed)


if __name__ == "__main__":
    main()

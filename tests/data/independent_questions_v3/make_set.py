"""Build the third independent question set (evaluation only; see README.md next to this file).

    python tests/data/independent_questions_v3/make_set.py            # writes generated.jsonl (seed 7300)
    python tests/data/independent_questions_v3/make_set.py --hand     # fills the answers of hand_written.jsonl
    python tests/data/independent_questions_v3/make_set.py --show 7305 7310   # prints scene facts (for writing)

Written from scratch, with its own phrase lists: it reads only the program language, the ontology and the
reference executor. Every program is run on its scene with the reference executor and kept only if valid.
"""

from __future__ import annotations

import argparse
import itertools
import json
import random
import re
import sys
from collections import Counter, defaultdict
from pathlib import Path

from po3d_ppl import ontology
from po3d_ppl.language import check_program, parse_program
from po3d_ppl.questions.context import SceneContext
from po3d_ppl.questions.executor import execute
from po3d_ppl.world import load_scene

HERE = Path(__file__).resolve().parent
SCENE_DIR = HERE / "scenes"
PER_GROUP = 115
POOL_FACTOR = 10

SLOTS = ("size", "color", "material", "shape")
RELS = ("left", "right", "behind", "front")
COLORS = ontology.COLORS


# ----------------------------------------------------------------------------------------------------------------
# scene facts


class Obj:
    def __init__(self, i, o):
        self.i = i
        self.size, self.color, self.material, self.subtype = o.size, o.color, o.material, o.subtype
        self.cat = ontology.CATEGORY_OF[o.subtype]
        self.pose = None if o.pose == ontology.NO_POSE else o.pose
        self.deg = o.pose_degree % 360.0
        self.parts = {raw: (st.color, st.material) for raw, st in o.parts.items()}
        self.occluded = o.occluded
        self.occ_by = tuple(o.occluded_by)
        self.part_occ = {raw: tuple(a.occlusion.occluded_by) for raw, a in o.part_annotations.items()
                         if a.occlusion.occluded}
        self.all_parts = ontology.PARTS[o.subtype]

    def val(self, slot, shape_opt="subtype"):
        if slot == "shape":
            return self.subtype if shape_opt == "subtype" else self.cat
        if slot == "pose":
            return self.pose
        return getattr(self, slot)

    def matches(self, key):
        for slot, v in key.items():
            if slot == "shape":
                if v != self.subtype and v != self.cat:
                    return False
            elif slot == "pose":
                if self.pose != v:
                    return False
            elif getattr(self, slot) != v:
                return False
        return True

    def pose_clear(self, margin=6.0):
        """A labelled pose at least ``margin`` degrees inside its sector."""
        if self.pose is None:
            return False
        for edge in (30, 60, 120, 150, 210, 240, 300, 330):
            d = abs(self.deg - edge) % 360
            if min(d, 360 - d) < margin:
                return False
        return True


def pose_rel(a: Obj, b: Obj):
    d = abs(a.deg - b.deg) % 360
    d = min(d, 360 - d)
    return d


class Facts:
    def __init__(self, path: Path):
        self.path = path
        self.rel = f"scenes/{path.name}"
        self.seed = int(path.stem.split("_")[1])
        self.scene = load_scene(path)
        self.ctx = SceneContext(self.scene)
        self.objs = [Obj(i, o) for i, o in enumerate(self.scene.objects)]
        self.n = len(self.objs)
        self.rels = {r: [set(self.scene.relationships[r][i]) for i in range(self.n)] for r in RELS}
        self.occludes = {j: {o.i for o in self.objs if j in o.occ_by} for j in range(self.n)}
        self.parts_hidden_by = {j: {(o.i, raw) for o in self.objs for raw, by in o.part_occ.items() if j in by}
                                for j in range(self.n)}

    def select(self, pool, key):
        return {i for i in pool if self.objs[i].matches(key)}

    @property
    def all(self):
        return set(range(self.n))


def run(facts: Facts, program: str):
    typed = check_program(parse_program(program))
    res = execute(facts.ctx, typed)
    if not res.valid:
        return False, res.reason
    a = res.answer
    if isinstance(a, (set, frozenset)):
        a = sorted(a)
    return True, a


# ----------------------------------------------------------------------------------------------------------------
# words (own phrase lists)

SIZE_W = {"large": ["large", "big"], "small": ["small", "tiny"]}
SIZE_WIDE = {"large": ["huge", "giant", "massive"], "small": ["little", "teeny", "miniature"]}
COLOR_WIDE = {"gray": ["grey"], "purple": ["violet"], "cyan": ["turquoise", "teal", "aqua"]}
MAT_W = {"metal": ["metal", "metallic", "shiny"], "rubber": ["rubber", "matte"]}
MAT_WIDE = {"metal": ["steel", "chrome", "metallic-looking"], "rubber": ["rubbery", "matt", "dull"]}
MAT_POST = {"metal": ["made of metal", "made of metal"], "rubber": ["made of rubber", "made of rubber"]}

SUBTYPE_W = {
    "suv": ["suv", "SUV"], "wagon": ["wagon"], "minivan": ["minivan"], "sedan": ["sedan"], "truck": ["truck"],
    "articulated": ["articulated bus"], "regular": ["regular bus"], "double": ["double bus"],
    "school": ["school bus"], "chopper": ["chopper"], "dirtbike": ["dirtbike", "dirt bike"],
    "scooter": ["scooter"], "cruiser": ["cruiser"], "jet": ["jet"], "fighter": ["fighter"],
    "biplane": ["biplane"], "airliner": ["airliner"], "road": ["road bike"], "utility": ["utility bike"],
    "mountain": ["mountain bike"], "tandem": ["tandem bike"],
}
SUBTYPE_WIDE = {
    "suv": ["sport utility vehicle", "4x4"], "wagon": ["station wagon", "estate car"],
    "minivan": ["van", "people carrier", "mini-van"], "sedan": ["saloon", "saloon car"],
    "truck": ["pickup", "pickup truck"], "articulated": ["bendy bus", "articulated coach"],
    "regular": ["ordinary bus", "standard bus", "city bus"], "double": ["double-decker", "double-decker bus"],
    "school": ["schoolbus", "school coach"], "chopper": ["chopper motorcycle"],
    "dirtbike": ["trail bike", "motocross bike"], "scooter": ["moped", "motor scooter"],
    "cruiser": ["cruiser motorcycle"], "jet": ["jet plane"], "fighter": ["fighter jet", "warplane", "fighter plane"],
    "biplane": ["bi-plane"], "airliner": ["passenger jet", "passenger plane", "jetliner"],
    "road": ["racing bike", "road bicycle"], "utility": ["city bike", "utility bicycle"],
    "mountain": ["mountain bicycle", "MTB"], "tandem": ["tandem bicycle", "bicycle built for two"],
}
CAT_W = {"car": ["car"], "bus": ["bus"], "motorbike": ["motorbike"], "aeroplane": ["aeroplane"],
         "bicycle": ["bicycle"]}
CAT_WIDE = {"car": ["automobile", "auto"], "bus": ["coach"], "motorbike": ["motorcycle", "motor bike"],
            "aeroplane": ["airplane", "plane", "aircraft"], "bicycle": ["bike", "cycle", "push bike"]}
BUS_SHAPES = ("bus", "bus", "bus", "school", "double", "regular", "articulated")  # for the "buss" quirk
THING_W = ["thing", "object"]
THING_WIDE = ["item", "vehicle"]

REL_W = {
    "left": ["left of", "to the left of", "on the left side of", "on the left of"],
    "right": ["right of", "to the right of", "on the right side of", "on the right of"],
    "behind": ["behind"],
    "front": ["in front of"],
}
REL_WIDE = {"left": ["to the left-hand side of", "leftward of"], "right": ["to the right-hand side of",
            "rightward of"], "behind": ["in back of"], "front": ["ahead of"]}

POSE_SUFFIX = {
    "front_pose": ["facing the camera", "facing towards the camera", "facing us", "facing forward",
                   "pointing at the camera", "turned toward the viewer"],
    "back_pose": ["facing away", "facing away from the camera", "facing away from us",
                  "pointing away from the camera", "with its back to the camera"],
    "left_pose": ["facing left", "facing to the left", "pointing left", "turned to the left", "heading left"],
    "right_pose": ["facing right", "facing to the right", "pointing right", "turned to the right",
                   "heading right"],
}
POSE_PREFIX = {"left_pose": ["left-facing"], "right_pose": ["right-facing"], "front_pose": ["camera-facing"]}
POSE_REL = {
    "same_pose": ["facing the same direction as", "facing the same way as", "pointing the same way as",
                  "that faces the same direction as", "that points in the same direction as",
                  "oriented the same way as"],
    "opposite_pose": ["facing the opposite direction to", "facing the other way from", "pointing the opposite way to",
                      "that faces the opposite direction from", "facing opposite to"],
    "vertical_pose": ["facing perpendicular to", "that faces at a right angle to", "turned 90 degrees from",
                      "pointing at right angles to", "that is perpendicular in direction to",
                      "facing crosswise to"],
}

PART_WIDE = {
    "hood": ["bonnet"], "trunk": ["boot"], "windscreen": ["windshield", "wind screen"],
    "side stand": ["kickstand", "kick stand"], "license plate": ["number plate", "licence plate", "registration plate"],
    "fender": ["mudguard", "mud guard"], "handle": ["handlebar", "handle bar", "grip"],
    "head light": ["headlamp", "headlight"], "headlight": ["headlamp", "head lamp"],
    "tail light": ["rear light", "taillight", "tail lamp"], "taillight": ["tail lamp", "rear lamp"],
    "saddle": ["seat"], "seat": ["saddle"], "gas tank": ["fuel tank", "petrol tank"],
    "exhaust": ["exhaust pipe", "tailpipe"], "footrest": ["footpeg", "foot peg"],
    "tailplane": ["tail wing", "horizontal stabiliser"], "fin": ["tail fin", "vertical stabilizer"],
    "propeller": ["prop"], "engine": ["motor"], "mirror": ["side mirror", "wing mirror", "rear-view mirror"],
    "wheel": ["tire", "tyre"], "bumper": ["bumper bar"], "drive chain": ["chain", "bike chain"],
    "crank arm": ["crank"], "brake system": ["brakes"], "carrier": ["luggage rack", "rack"],
    "cover": ["fairing", "cowl"], "rearlight": ["rear lamp", "rear light"], "fork": ["front fork"],
}

COLOR_Q = {"normal": ["color", "colour"], "wide": ["shade", "hue"]}

# single typos: edit distance 1, never the first letter, none of them another English word (checked by hand)
TYPOS = {
    "sedan": ["sedn", "sedam", "seddan"], "wagon": ["wagn", "wagoon", "wagom"],
    "minivan": ["minivn", "minivam", "minnivan", "minvan"], "truck": ["truk", "trucck"],
    "articulated": ["articlated", "articulatd", "artiulated"], "school": ["schol", "schoool"],
    "double": ["doble", "doublle", "dounle"], "regular": ["regulr", "reguler", "regullar"],
    "chopper": ["choper", "choppper"], "dirtbike": ["dirtbik", "dirtbke", "dirtbbike"],
    "scooter": ["scooer", "scootr", "scoooter"], "cruiser": ["cruser", "cruisr", "cruisser"],
    "fighter": ["fightr", "figter", "fighther"], "biplane": ["biplan", "bipane", "biplanne"],
    "airliner": ["airlner", "airliiner", "airlinr"], "mountain": ["mountan", "moutain", "mountainn"],
    "tandem": ["tandm", "tandemm", "tanden"], "utility": ["utilty", "utillity", "utiliy"],
    "motorbike": ["motorbke", "motorbik", "motorbbike"], "aeroplane": ["aeroplne", "aeroplanee", "aerplane"],
    "bicycle": ["bicyle", "bicycl", "biccycle"], "thing": ["thng", "thinng"], "object": ["objct", "obect", "objject"],
    "purple": ["purle", "purplee", "purpple"], "yellow": ["yelow", "yelllow", "yellw"],
    "green": ["gren", "greem", "grreen"], "brown": ["brwn", "browm", "brownn"], "cyan": ["cyann", "cyaan"],
    "gray": ["grayy", "graay"], "blue": ["bluee", "bllue"], "metal": ["metl", "mettal", "metall"],
    "rubber": ["ruber", "rubbber", "rubbr"], "metallic": ["metalic", "metallc"], "large": ["lage", "larrge", "larg"],
    "small": ["smal", "smmall"], "wheel": ["whel", "wheeel", "whell"], "roof": ["rooff"],
    "hood": ["hoood"], "trunk": ["trnk", "trunck"], "mirror": ["miror", "mirrror", "mirrorr"],
    "door": ["dooor"], "bumper": ["bumpr", "bummper"], "wing": ["winng"], "propeller": ["propeler", "propelller"],
    "engine": ["engne", "enginne"], "fender": ["fendr", "fennder"], "saddle": ["sadle", "saddl"],
    "license": ["lisense", "licnse"], "tailplane": ["tailpane", "tailplan"], "windscreen": ["windscren", "windsceen"],
    "pedal": ["pedl", "peddal"], "handle": ["hndle", "handdle"], "exhaust": ["exaust", "exhaut"],
    "headlight": ["hedlight", "headlght"], "behind": ["behnd", "behiind"], "right": ["rigt", "rright"],
    "front": ["frnt", "fromt"], "occluded": ["ocluded", "occludded", "occluted"], "hidden": ["hiden", "hidfen"],
    "facing": ["facin", "faceing", "faccing"], "color": ["colr", "coolor"], "colour": ["colur", "coulour"],
    "material": ["materal", "matrial", "materiall"], "direction": ["directon", "diretion"],
    "occludes": ["ocludes", "occluds"], "many": ["mny"], "shape": ["shap", "shappe"],
    "scooters": ["scooterz"], "sedans": ["sedanss", "sedns"], "trucks": ["truks"], "jets": ["jetts"],
    "things": ["thngs", "thinggs"], "objects": ["objcts", "obects"], "cars": ["carss"],
    "buses": ["busez"], "bicycles": ["bicyles"], "motorbikes": ["motorbkes", "motorbiks"],
    "aeroplanes": ["aeroplnes"], "airliners": ["airlners"], "fighters": ["fightrs"], "wagons": ["wagns"],
    "minivans": ["minivns"], "choppers": ["chopers"], "cruisers": ["crusers"], "biplanes": ["biplans"],
    "opposite": ["oposite", "opposit"],
}


def lower_first(t: str) -> str:
    return t[0].lower() + t[1:] if t and not t.split()[0].isupper() else t


FUNCTION_TYPO_WORDS = {"many", "color", "colour", "facing", "direction", "material", "shape", "behind", "front",
                       "right", "same", "opposite"}


def article(phrase: str) -> str:
    w = phrase.split()[0].lower()
    if w in ("suv", "mtb"):  # "an SUV"
        return "an"
    if w.startswith(("4x4", "uti", "uni", "one", "use")):
        return "a"
    return "an" if w[0] in "aeiou" else "a"


def pluralise(noun: str) -> str:
    if noun.endswith("built for two"):
        return noun.replace("bicycle", "bicycles")
    if noun.endswith("bus"):
        return noun + "es"
    if noun.endswith(("ch", "sh", "s", "x")):
        return noun + "es"
    if noun.endswith("SUV"):
        return noun + "s"
    return noun + "s"


def part_words(raw: str, use_super: bool) -> str:
    if use_super:
        return ontology.super_part_name(raw).replace("_", " ")
    return ontology.readable_name(raw).replace("_", " ")


def part_value(raw: str, use_super: bool) -> str:
    return ontology.super_part_name(raw) if use_super else ontology.canonical_part_name(raw)


def super_unique(subtype: str, raw: str) -> bool:
    sp = ontology.super_part_name(raw)
    return sum(1 for r in ontology.PARTS[subtype] if ontology.super_part_name(r) == sp) == 1


class NP:
    """A noun phrase of a description: .the, .a, .pl (plural without article), .bare, .poss (possessive ok)."""

    def __init__(self, pre, noun, noun_pl, post, post_pl=None):
        self.pre, self.noun, self.noun_pl, self.post = pre, noun, noun_pl, post
        self.post_pl = post if post_pl is None else post_pl

    def _core(self, plural=False):
        words = self.pre + [self.noun_pl if plural else self.noun]
        s = " ".join(words)
        p = self.post_pl if plural else self.post
        return s + (" " + p if p else "")

    @property
    def bare(self):
        return self._core()

    @property
    def the(self):
        return "the " + self._core()

    @property
    def a(self):
        return article(self._core()) + " " + self._core()

    @property
    def pl(self):
        return self._core(plural=True)

    @property
    def poss_ok(self):
        return not self.post and len(self.pre) <= 2 and len(self.noun.split()) <= 2

    @property
    def poss(self):
        return self.the + "'s"

    @property
    def adjs(self):
        return " ".join(self.pre)


# ----------------------------------------------------------------------------------------------------------------
# one question under construction


class Q:
    """Holds the random state, the mode, the scene and the notes of one candidate question."""

    def __init__(self, rng: random.Random, facts: Facts, mode: str):
        self.rng, self.f, self.mode = rng, facts, mode
        self.notes: list[str] = []
        self.red = 0
        self.bus_done = False
        r = rng.random()
        self.style = "pipe" if r < 0.55 else "mixed" if r < 0.8 else "nested"

    # --- randomness
    def pick(self, seq):
        return self.rng.choice(list(seq))

    def chance(self, p):
        return self.rng.random() < p

    # --- words
    def _wide(self, normal, wide_list, what):
        if self.mode == "wide" and wide_list and self.chance(0.6):
            w = self.pick(wide_list)
            self.notes.append(f"wider synonym '{w}'")
            return w
        return self.pick(normal)

    def size_w(self, v):
        return self._wide(SIZE_W[v], SIZE_WIDE.get(v), "size")

    def color_w(self, v):
        return self._wide([v], COLOR_WIDE.get(v), "color")

    def mat_w(self, v):
        return self._wide(MAT_W[v], MAT_WIDE.get(v), "material")

    def noun_w(self, key):
        """(singular, plural) for the shape slot of a key."""
        v = key.get("shape")
        if v is None:
            w = self._wide(THING_W, THING_WIDE, "thing")
            return w, pluralise(w)
        if v in CAT_W:
            w = self._wide(CAT_W[v], CAT_WIDE.get(v), "cat")
        else:
            w = self._wide(SUBTYPE_W[v], SUBTYPE_WIDE.get(v), "subtype")
        pl = pluralise(w)
        if self.mode == "plural" and w.endswith("bus"):
            q = "buss" if self.chance(0.8) else "busses"
            pl = w[:-3] + q
            self.notes.append(f"public plural quirk '{q}'")
        return w, pl

    def rel_w(self, r):
        return self._wide(REL_W[r], REL_WIDE.get(r), "rel")

    def pose_w(self, label):
        return self.pick(POSE_SUFFIX[label])

    def part_w(self, raw, use_super):
        words = part_words(raw, use_super)
        sp = ontology.super_part_name(raw).replace("_", " ")
        if self.mode == "wide" and sp in PART_WIDE and words.endswith(sp) and self.chance(0.7):
            alt = self.pick(PART_WIDE[sp])
            self.notes.append(f"part synonym '{alt}'")
            return words[: len(words) - len(sp)] + alt
        return words

    def colorq(self):
        if self.mode == "wide" and self.chance(0.4):
            w = self.pick(COLOR_Q["wide"])
            self.notes.append(f"wider synonym '{w}'")
            return w
        return self.pick(COLOR_Q["normal"])

    # --- descriptions
    def np(self, key, allow_post=True):
        pre = []
        post = ""
        post_pl = None
        pose = key.get("pose")
        if pose and pose in POSE_PREFIX and self.chance(0.25):
            pre.append(self.pick(POSE_PREFIX[pose]))
            pose = None
        if "size" in key:
            pre.append(self.size_w(key["size"]))
        if "color" in key:
            pre.append(self.color_w(key["color"]))
        mat_post = False
        if "material" in key:
            if allow_post and self.chance(0.12) and self.mode != "wide":
                mat_post = True
            else:
                pre.append(self.mat_w(key["material"]))
        noun, noun_pl = self.noun_w(key)
        if mat_post:
            post = self.pick(MAT_POST[key["material"]])
        if pose:
            ph = self.pose_w(pose)
            post = (post + " and " + ph) if post else ph
            post_pl = post
        return NP(pre, noun, noun_pl, post, post_pl)

    def minimal_key(self, o: Obj, pool, slots=SLOTS, need=(), forbid=(), nonempty=False, check=None,
                    shape_opts=("subtype", "category")):
        slots = [s for s in slots if s not in forbid]
        for r in range(0, len(slots) + 1):
            cands = []
            for combo in itertools.combinations(slots, r):
                if not set(need) <= set(combo):
                    continue
                if nonempty and not combo:
                    continue
                opts = shape_opts if "shape" in combo else ("subtype",)
                for opt in opts:
                    key = {s: o.val(s, "subtype" if opt == "subtype" else "cat") for s in combo}
                    if None in key.values():
                        continue
                    if self.f.select(pool, key) != {o.i}:
                        continue
                    if check and not check(key):
                        continue
                    w = 3.0 if "shape" in combo else 1.0
                    cands.append((w, key))
            if cands:
                total = sum(w for w, _ in cands)
                x = self.rng.random() * total
                for w, key in cands:
                    x -= w
                    if x <= 0:
                        break
                return self.redundant(o, key, slots) if self.mode == "redundant" else key
        return None

    def redundant(self, o: Obj, key, slots):
        free = [s for s in slots if s not in key and s != "pose"]
        if "shape" in key and key["shape"] == o.cat and self.chance(0.3):
            key = dict(key, shape=o.subtype)
            self.red += 1
            self.notes.append("redundant description (subtype for category)")
            return key
        if not free:
            return key
        k = 1 if len(free) == 1 or self.chance(0.6) else 2
        add = self.rng.sample(free, k)
        key = dict(key)
        for s in add:
            key[s] = o.val(s, "subtype" if self.chance(0.5) else "cat")
        self.red += 1
        self.notes.append("redundant description")
        return key

    # --- programs
    def prog(self, chain):
        chain = list(chain)
        if self.style == "pipe" or len(chain) < 3:
            return " | ".join(chain)
        if self.style == "mixed":
            return f"{chain[-1]}({' | '.join(chain[:-1])})"
        e = chain[0]
        for s in chain[1:]:
            e = f"{s}({e})"
        return e

    # --- final text
    def finish(self, text):
        text = re.sub(r"\s+", " ", text).strip()
        text = text[0].upper() + text[1:]
        text = voice(self.rng, text)
        if self.mode == "typo":
            text = self.typo(text)
        return text

    def typo(self, text):
        words = [(m.start(), m.group(0)) for m in re.finditer(r"[A-Za-z]+", text)]
        cands = [(s, w) for s, w in words if w.lower() in TYPOS]
        if not cands:
            return None
        content = [(s, w) for s, w in cands if w.lower() not in FUNCTION_TYPO_WORDS]
        s, w = self.pick(content if content and self.chance(0.8) else cands)
        t = self.pick(TYPOS[w.lower()])
        if w[0].isupper():
            t = t[0].upper() + t[1:]
        self.notes.append(f"typo: {w.lower()} -> {t.lower()}")
        return text[:s] + t + text[s + len(w):]


OPENERS = ["Looking at the picture, ", "In this image, ", "In the scene, ", "Quick question: ", "Hey, ",
           "OK so ", "From the image, ", "Based on what you see, ", "Question: ", "Um, ", "Alright, ",
           "In the picture, ", "Looking at this scene, ", "So, "]


def voice(rng, t):
    if rng.random() < 0.14 and not t.lower().startswith(("look", "there", "in the", "in this")):
        op = rng.choice(OPENERS)
        first = t.split()[0]
        if not (first.isupper() and len(first) > 1) and first != "I":
            t = t[0].lower() + t[1:]
        t = op + t
    if t.endswith("?") and rng.random() < 0.05:
        t = t[:-1] + ", please?"
    r = rng.random()
    if r < 0.12:
        t = t.rstrip("?.")
    elif r < 0.15 and t.endswith("?"):
        t = t + "?"
    if rng.random() < 0.17:
        t = t.lower()
    return t


# ----------------------------------------------------------------------------------------------------------------
# helpers used by many families


def ref_chain(q: Q, key, base="scene()"):
    """Stages selecting a referent with a key (filters in the public order), ending in unique."""
    return [base] + filters(key) + ["unique"]


def filters(key):
    out = []
    for slot in ("pose", "size", "color", "material", "shape"):
        if slot in key:
            out.append(f"filter_{slot}[{key[slot]}]")
    return out


def pfilters(pkey):
    out = []
    for slot in ("color", "material", "name"):
        if slot in pkey:
            out.append(f"partfilter_{'partname' if slot == 'name' else slot}[{pkey[slot]}]")
    return out


def rand_key(q: Q, pool_objs, nslots=None, mutate=0.45, slots=SLOTS):
    """A random description for count/exist sets: from a real object, perhaps with one slot changed."""
    o = q.pick(pool_objs)
    n = nslots or q.pick([1, 1, 2, 2, 3])
    combo = q.rng.sample(list(slots), min(n, len(slots)))
    key = {}
    for s in combo:
        key[s] = o.val(s, "subtype" if q.chance(0.4) else "cat")
    if mutate and q.chance(mutate):
        s = q.pick(combo)
        if s == "size":
            key[s] = "small" if key[s] == "large" else "large"
        elif s == "material":
            key[s] = "rubber" if key[s] == "metal" else "metal"
        elif s == "color":
            key[s] = q.pick([c for c in COLORS if c != key[s]])
        elif s == "shape":
            key[s] = q.pick([c for c in ontology.CATEGORIES if c != key[s]] if key[s] in ontology.CATEGORIES
                            else [t for t in ontology.SUBTYPES if t != key[s]])
    if q.mode == "plural" and not q.bus_done:  # the first counted set is buses, for the "buss" quirk
        key["shape"] = q.pick(BUS_SHAPES)
        q.bus_done = True
    return key


def ask_attr(q: Q, attr, X: NP, pron=False):
    """Text asking attribute ``attr`` of NP X (X.the is used)."""
    c = q.colorq()
    x = X.the
    if attr == "color":
        forms = [f"What {c} is {x}?", f"What is the {c} of {x}?", f"Which {c} is {x}?",
                 f"Tell me the {c} of {x}.", f"{x} is what {c}?", f"Can you tell me what {c} {x} is?",
                 f"What's the {c} of {x}?", f"{c} of {x}?", f"I'd like to know the {c} of {x}.",
                 f"What {c} does {x} have?", f"what {c} has {x}", f"Name the {c} of {x}."]
        if X.poss_ok:
            forms += [f"What is {X.poss} {c}?", f"What's {X.poss} {c}?"]
    elif attr == "material":
        forms = [f"What is {x} made of?", f"What material is {x}?", f"What material is {x} made of?",
                 f"Is {x} metal or rubber?", f"Is {x} made of rubber or metal?", f"What's {x} made out of?",
                 f"Which material does {x} have?", f"material of {x}?", f"Tell me what {x} is made of.",
                 f"What is the material of {x}?", f"Is {x} shiny metal or matte rubber?"]
        if q.mode == "wide":
            forms += [f"What is {x} constructed from?", f"What substance is {x} made of?"]
    elif attr == "size":
        forms = [f"What size is {x}?", f"How big is {x}?", f"Is {x} large or small?", f"Is {x} big or small?",
                 f"What is the size of {x}?", f"Is {x} small or large?", f"size of {x}?",
                 f"Tell me the size of {x}.", f"Would you say {x} is big or small?", f"How large is {x}?"]
    else:
        forms = [f"What shape is {x}?", f"What kind of vehicle is {x}?", f"What type of object is {x}?",
                 f"What is {x}?", f"Which type of vehicle is {x}?", f"What is the shape of {x}?",
                 f"What model is {x}?", f"What sort of thing is {x}?", f"Tell me what kind of vehicle {x} is.",
                 f"What exactly is {x}?", f"Identify {x}.", f"what type is {x}"]
    return q.pick(forms)


def ask_attr_pron(q: Q, attr):
    """The second clause of 'There is a X; what colour is it?'."""
    c = q.colorq()
    return q.pick({
        "color": [f"what {c} is it?", f"what is its {c}?", f"what {c} does it have?", f"tell me its {c}."],
        "material": ["what is it made of?", "what material is it?", "is it metal or rubber?",
                     "which material is it made of?"],
        "size": ["what size is it?", "how big is it?", "is it large or small?", "is it big or small?"],
        "shape": ["what is it?", "what kind of vehicle is it?", "what shape is it?", "what type of object is it?"],
    }[attr])


THERE_IS = ["There is {a}; {rest}", "There's {a}. {Rest}", "Look at {the}. {Rest}", "See {the}? {Rest}",
            "I can see {a}, {rest}", "Focus on {the}: {rest}", "Consider {the}. {Rest}", "{The} — {rest}"]


def there_is(q: Q, X: NP, rest: str):
    t = q.pick(THERE_IS)
    return t.format(a=X.a, the=X.the, The=X.the, rest=rest, Rest=rest[0].upper() + rest[1:]).replace(
        "an other ", "another ")


def qname(attr):
    return f"query_{attr}"


# ----------------------------------------------------------------------------------------------------------------
# families: core_query


def fam_zero_query(q: Q, attr):
    f = q.f
    o = q.pick(f.objs)
    shape_cat = attr == "shape" and q.chance(0.4)
    if shape_cat:
        key = q.minimal_key(o, f.all, forbid=(), shape_opts=("category",))
        if key is None or key.get("shape") != o.cat:
            return None
    else:
        key = q.minimal_key(o, f.all, forbid=(attr,))
    if key is None:
        return None
    X = q.np(key)
    if shape_cat:
        rest = {k: v for k, v in key.items() if k != "shape"}
        catw = X.noun
        if rest:
            Y = q.np(rest)
            text = q.pick([f"What kind of {catw} is the {Y.adjs} one?", f"Which type of {catw} is the {Y.adjs} one?",
                           f"The {Y.adjs} {catw} is what kind of {catw}?"] if Y.adjs else
                          [f"What kind of {X.bare} is it?"])
        else:
            text = q.pick([f"What kind of {catw} is in the picture?", f"What type of {catw} is there?",
                           f"Which kind of {catw} is shown?", f"What sort of {catw} can you see?"])
    else:
        text = ask_attr(q, attr, X)
    prog = q.prog(ref_chain(q, key) + [qname(attr)])
    return text, prog


def fam_there_query(q: Q, attr):
    f = q.f
    o = q.pick(f.objs)
    key = q.minimal_key(o, f.all, forbid=(attr,), nonempty=True)
    if key is None:
        return None
    X = q.np(key)
    text = there_is(q, X, ask_attr_pron(q, attr))
    return text, q.prog(ref_chain(q, key) + [qname(attr)])


# core_count / core_exist

COUNT_T = ["How many {P} are there?", "How many {P} are in the picture?", "What number of {P} are there?",
           "Count the {P}.", "how many {P} can you see", "Number of {P}?", "Tell me how many {P} there are.",
           "Can you count the {P} for me?", "How many {P} do you see?", "What is the number of {P}?",
           "How many {P} are in this scene?", "{P}: how many?", "how many {P} is there", "Count all the {P}."]
COUNT_ADJ_T = ["How many of the objects are {J}?", "How many things are {J}?", "How many objects are {J}?",
               "Count the things that are {J}.", "How many of the things are {J}?"]
EXIST_T = ["Is there {A}?", "Are there any {P}?", "Can you see {A}?", "Do you see any {P}?",
           "Is there {A} in the picture?", "Does the picture contain {A}?", "Any {P}?",
           "Does the image have {A} in it?", "Are any {P} present?", "Is there at least one {S}?",
           "Can you spot {A}?", "is there any {S} here", "Does this scene include {A}?"]
EXIST_ADJ_T = ["Is anything {J}?", "Are any of the objects {J}?", "Is there something {J}?",
               "Is any of the things {J}?"]


def adj_only(key):
    return "shape" not in key and "pose" not in key


def adj_words(q: Q, key):
    parts = []
    if "size" in key:
        parts.append(q.size_w(key["size"]))
    if "color" in key:
        parts.append(q.color_w(key["color"]))
    if "material" in key:
        parts.append(q.pick(MAT_POST[key["material"]] + [q.mat_w(key["material"])]))
    if len(parts) == 1:
        return parts[0]
    if len(parts) == 2:
        return f"{parts[0]} and {parts[1]}"
    return f"{parts[0]}, {parts[1]} and {parts[2]}"


def count_text(q: Q, key):
    if adj_only(key) and key and q.chance(0.3):
        return q.pick(COUNT_ADJ_T).format(J=adj_words(q, key))
    X = q.np(key)
    return q.pick(COUNT_T).format(P=X.pl)


def exist_text(q: Q, key):
    if adj_only(key) and key and q.chance(0.3):
        return q.pick(EXIST_ADJ_T).format(J=adj_words(q, key))
    X = q.np(key)
    return q.pick(EXIST_T).format(A=X.a, P=X.pl, S=X.bare)


def fam_count(q: Q, nslots):
    key = rand_key(q, q.f.objs, nslots=nslots, mutate=0.15)
    return count_text(q, key), q.prog(["scene()"] + filters(key) + ["count"]) if q.chance(0.4) else \
        f"count({q.prog(['scene()'] + filters(key)) if len(filters(key)) else 'scene()'})"


def fam_count_all(q: Q):
    t = q.pick(["How many objects are there?", "How many things are in the picture?", "How many vehicles can you see?",
                "Count the objects.", "What is the total number of things?", "how many items are there in total",
                "How many objects does the scene contain?", "Total number of objects?"])
    return t, q.pick(["count(scene())", "scene() | count"])


def union_parts(q: Q, mutate=0.3):
    k1 = rand_key(q, q.f.objs, nslots=1, mutate=mutate)
    k2 = rand_key(q, q.f.objs, nslots=q.pick([1, 1, 2]), mutate=mutate)
    if k1 == k2 or set(k1.items()) <= set(k2.items()) or set(k2.items()) <= set(k1.items()):
        return None
    if len(k1) == 1 and len(k2) == 1 and set(k1) == set(k2) and next(iter(k1)) in ("size", "material"):
        return None  # "big or small things": everything
    s1, s2 = k1.get("shape"), k2.get("shape")
    if s1 and s2 and ((s1 in ontology.SUBTYPES and ontology.shape_matches(s1, s2))
                      or (s2 in ontology.SUBTYPES and ontology.shape_matches(s2, s1))):
        return None  # "a bicycle or a mountain bike"
    return k1, k2


def union_np(q: Q, k1, k2, plural):
    X, Y = q.np(k1, allow_post=False), q.np(k2, allow_post=False)
    if plural:
        if adj_only(k1) and adj_only(k2) and q.chance(0.5):
            return f"things that are {adj_words(q, k1)} or {adj_words(q, k2)}"
        return f"{X.pl} or {Y.pl}"
    return f"{X.a} or {Y.a}"


def fam_count_union(q: Q):
    u = union_parts(q)
    if u is None:
        return None
    k1, k2 = u
    p = union_np(q, k1, k2, True)
    t = q.pick(["How many {p} are there?", "How many things are {p}?", "Count the {p}.",
                "What is the number of {p}?", "How many {p} can you count?", "In total, how many {p} are there?"])
    if t == "How many things are {p}?":
        if not (adj_only(k1) and adj_only(k2)):
            t = "How many {p} are there?"
        else:
            p = f"{adj_words(q, k1)} or {adj_words(q, k2)}"
    prog = f"count(union({q.prog(['scene()'] + filters(k1))}, {q.prog(['scene()'] + filters(k2))}))"
    return t.format(p=p), prog


def fam_exist(q: Q, nslots):
    key = rand_key(q, q.f.objs, nslots=nslots, mutate=0.55)
    chain = ["scene()"] + filters(key)
    return exist_text(q, key), (q.prog(chain + ["exist"]) if q.chance(0.5) else f"exist({q.prog(chain)})")


def fam_exist_union(q: Q):
    u = union_parts(q, mutate=0.75)
    if u is None:
        return None
    k1, k2 = u
    t = q.pick(["Is there {a}?", "Can you see {a}?", "Does the picture show {a}?", "Are there any {p}?",
                "Is there at least one thing that is {j}?"])
    if "{j}" in t and not (adj_only(k1) and adj_only(k2)):
        t = "Is there {a}?"
    text = t.format(a=union_np(q, k1, k2, False), p=union_np(q, k1, k2, True),
                    j=f"{adj_words(q, k1)} or {adj_words(q, k2)}" if "{j}" in t else "")
    prog = f"exist(union({q.prog(['scene()'] + filters(k1))}, {q.prog(['scene()'] + filters(k2))}))"
    return text, prog


# core_compare_attribute

CMP_T = {
    "color": ["Is {X} the same {c} as {Y}?", "Does {X} have the same {c} as {Y}?", "Are {X} and {Y} the same {c}?",
              "Do {X} and {Y} share a {c}?", "Is the {c} of {X} the same as that of {Y}?",
              "Same {c}: {X} and {Y}?", "Are {X} and {Y} painted the same {c}?", "Do {X} and {Y} have the same {c}?",
              "Is {X} {c}ed like {Y}?"],
    "material": ["Is {X} made of the same material as {Y}?", "Are {X} and {Y} made of the same material?",
                 "Do {X} and {Y} have the same material?", "Is {X} made of the same stuff as {Y}?",
                 "Are {X} and {Y} the same material?", "Does {X} share its material with {Y}?",
                 "Same material for {X} and {Y}?"],
    "size": ["Is {X} the same size as {Y}?", "Are {X} and {Y} the same size?", "Do {X} and {Y} have the same size?",
             "Is {X} as big as {Y}?", "Are {X} and {Y} equally large?", "Does {X} have the same size as {Y}?",
             "same size, {X} and {Y}?"],
    "shape": ["Is {X} the same shape as {Y}?", "Are {X} and {Y} the same kind of vehicle?",
              "Do {X} and {Y} have the same shape?", "Is {X} the same type of thing as {Y}?",
              "Are {X} and {Y} the same model?", "Is {X} the same sort of vehicle as {Y}?",
              "Do {X} and {Y} have an identical shape?"],
}


def fam_compare_attr(q: Q, attr):
    f = q.f
    if f.n < 2:
        return None
    a, b = q.rng.sample(f.objs, 2)
    ka = q.minimal_key(a, f.all, forbid=(attr,))
    kb = q.minimal_key(b, f.all, forbid=(attr,))
    if ka is None or kb is None:
        return None
    X, Y = q.np(ka), q.np(kb)
    t = q.pick(CMP_T[attr])
    if "{c}ed" in t:
        t = t.replace("{c}ed", "colour" + "ed" if q.chance(0.5) else "color" + "ed")
    text = t.format(X=X.the, Y=Y.the, c=q.colorq())
    prog = f"equal_{attr}({q.prog(ref_chain(q, ka) + [qname(attr)])}, {q.prog(ref_chain(q, kb) + [qname(attr)])})"
    return text, prog


def fam_compare_attr_relate(q: Q, attr):
    """'Is the thing left of the X the same colour as the Y?'"""
    f = q.f
    x = q.pick(f.objs)
    r = q.pick(RELS)
    pool = f.rels[r][x.i]
    if not pool:
        return None
    a = f.objs[q.pick(sorted(pool))]
    others = [o for o in f.objs if o.i != a.i and o.i != x.i]
    if not others:
        return None
    b = q.pick(others)
    kx = q.minimal_key(x, f.all)
    ka = q.minimal_key(a, pool, forbid=(attr,))
    kb = q.minimal_key(b, f.all, forbid=(attr,))
    if None in (kx, ka, kb):
        return None
    X, A, B = q.np(kx), q.np(ka), q.np(kb)
    rel = q.rel_w(r)
    c = q.colorq()
    word = {"color": f"the same {c} as", "material": "made of the same material as", "size": "the same size as",
            "shape": "the same shape as"}[attr]
    text = q.pick([f"Is {A.the} {rel} {X.the} {word} {B.the}?",
                   f"There is {A.a} {rel} {X.the}; is it {word} {B.the}?"])
    pa = ref_chain(q, kx) + [f"relate[{r}]"] + filters(ka) + ["unique", qname(attr)]
    prog = f"equal_{attr}({q.prog(pa)}, {q.prog(ref_chain(q, kb) + [qname(attr)])})"
    return text, prog


# core_compare_integer

CMPN_T = {
    "greater_than": ["Are there more {A} than {B}?", "Is the number of {A} greater than the number of {B}?",
                     "Do the {A} outnumber the {B}?", "Are there more {A} than there are {B}?",
                     "Is the number of {A} bigger than that of {B}?", "more {A} than {B}?",
                     "Does the picture have more {A} than {B}?"],
    "less_than": ["Are there fewer {A} than {B}?", "Is the number of {A} smaller than the number of {B}?",
                  "Are there less {A} than {B}?", "Is the count of {A} lower than the count of {B}?",
                  "fewer {A} than {B}?", "Are the {A} fewer than the {B}?"],
    "equal_integer": ["Are there as many {A} as {B}?", "Is the number of {A} the same as the number of {B}?",
                      "Are there equally many {A} and {B}?", "Same number of {A} and {B}?",
                      "Is there an equal number of {A} and {B}?", "Do the {A} and the {B} come in equal numbers?",
                      "Are the {A} and the {B} equal in number?"],
}


def fam_compare_count(q: Q, op):
    f = q.f
    k1 = rand_key(q, f.objs, nslots=q.pick([1, 1, 2]), mutate=0.1)
    k2 = rand_key(q, f.objs, nslots=q.pick([1, 1, 2]), mutate=0.1)
    if k1 == k2:
        return None
    s1, s2 = f.select(f.all, k1), f.select(f.all, k2)
    if s1 == s2 or (not s1 and not s2):
        return None
    A, B = q.np(k1, allow_post=False), q.np(k2, allow_post=False)
    text = q.pick(CMPN_T[op]).format(A=A.pl, B=B.pl)
    prog = f"{op}(count({q.prog(['scene()'] + filters(k1))}), count({q.prog(['scene()'] + filters(k2))}))"
    return text, prog


def fam_compare_count_relate(q: Q, op):
    """Counts of things in two relations to one referent ('... left of the X than behind it?')."""
    f = q.f
    x = q.pick(f.objs)
    r1, r2 = q.rng.sample(RELS, 2)
    if {r1, r2} in ({"left", "right"}, {"behind", "front"}) and q.chance(0.3):
        pass
    kx = q.minimal_key(x, f.all)
    if kx is None:
        return None
    ck = {} if q.chance(0.4) else rand_key(q, [o for o in f.objs if o.i != x.i] or f.objs, nslots=1, mutate=0.1)
    X = q.np(kx)
    C = q.np(ck, allow_post=False)
    w1, w2 = q.rel_w(r1), q.rel_w(r2)
    t = {"greater_than": [f"Are there more {C.pl} {w1} {X.the} than {w2} it?",
                          f"Does {X.the} have more {C.pl} {w1} it than {w2} it?",
                          f"Are more {C.pl} {w1} {X.the} than {w2} it?"],
         "less_than": [f"Are there fewer {C.pl} {w1} {X.the} than {w2} it?",
                       f"Are there less {C.pl} {w1} {X.the} than {w2} it?"],
         "equal_integer": [f"Are there as many {C.pl} {w1} {X.the} as {w2} it?",
                           f"Is the number of {C.pl} {w1} {X.the} the same as the number {w2} it?"]}[op]
    text = q.pick(t)
    c1 = ref_chain(q, kx) + [f"relate[{r1}]"] + filters(ck)
    c2 = ref_chain(q, kx) + [f"relate[{r2}]"] + filters(ck)
    return text, f"{op}(count({q.prog(c1)}), count({q.prog(c2)}))"


# core_same_relate

SAME_W = {"color": ["the same {c} as", "the same {c} as"], "material": ["made of the same material as",
          "the same material as"], "size": ["the same size as"],
          "shape": ["the same shape as", "the same type as", "the same kind of vehicle as", "the same model as"]}
SHARE_W = {"color": "{c}", "material": "material", "size": "size", "shape": "shape"}


def same_phrase(q: Q, attr):
    return q.pick(SAME_W[attr]).format(c=q.colorq())


def fam_same(q: Q, attr, kind):
    f = q.f
    x = q.pick(f.objs)
    kx = q.minimal_key(x, f.all)
    if kx is None:
        return None
    pool = {o.i for o in f.objs if o.i != x.i and getattr(o, attr if attr != "shape" else "subtype") ==
            getattr(x, attr if attr != "shape" else "subtype")}
    X = q.np(kx)
    same = same_phrase(q, attr)
    share = SHARE_W[attr].format(c=q.colorq())
    base = ref_chain(q, kx) + [f"same_{attr}"]
    if kind == "count":
        ck = {} if q.chance(0.5) else rand_key(q, [o for o in f.objs if o.i != x.i] or f.objs, nslots=1,
                                               mutate=0.2, slots=[s for s in SLOTS if s != attr])
        C = q.np(ck, allow_post=False)
        t = q.pick([f"How many other {C.pl} are {same} {X.the}?", f"What number of other {C.pl} are {same} {X.the}?",
                    f"How many {C.pl} besides {X.the} are {same} it?", f"How many other {C.pl} share {X.poss} {share}?"
                    if X.poss_ok else f"How many other {C.pl} share the {share} of {X.the}?",
                    f"Apart from {X.the}, how many {C.pl} are {same} it?",
                    f"There is {X.a}; how many other {C.pl} are {same} it?",
                    f"count the other {C.pl} that are {same} {X.the}"])
        return t, q.prog(base + filters(ck) + ["count"]) if q.chance(0.5) else f"count({q.prog(base + filters(ck))})"
    if kind == "exist":
        ck = {} if q.chance(0.5) else rand_key(q, [o for o in f.objs if o.i != x.i] or f.objs, nslots=1,
                                               mutate=0.3, slots=[s for s in SLOTS if s != attr])
        C = q.np(ck, allow_post=False)
        t = q.pick([f"Is there another {C.bare} that is {same} {X.the}?",
                    f"Is there any other {C.bare} {same} {X.the}?",
                    f"Are there any other {C.pl} {same} {X.the}?", f"Is anything else {same} {X.the}?"
                    if not ck else f"Is there some other {C.bare} {same} {X.the}?",
                    f"Does any other {C.bare} share the {share} of {X.the}?",
                    f"There is {X.a}; is there another {C.bare} {same} it?",
                    f"Can you find another {C.bare} that is {same} {X.the}?"])
        return t, f"exist({q.prog(base + filters(ck))})"
    # query
    if not pool:
        return None
    qa = q.pick([a for a in ("color", "material", "size", "shape") if a != attr])
    y = f.objs[q.pick(sorted(pool))]
    ky = q.minimal_key(y, pool, forbid=(attr, qa))
    if ky is None:
        return None
    Y = q.np(ky)
    other = "other " if q.chance(0.5) else ""
    yt = f"the {other}{Y.bare} that is {same} {X.the}"
    t = q.pick([ask_attr(q, qa, NP([], yt[4:], yt[4:], "")),
                there_is(q, NP([], f"{other}{Y.bare} {same} {X.the}", "", ""), ask_attr_pron(q, qa))])
    return t, q.prog(base + filters(ky) + ["unique", qname(qa)])


# core_spatial

def fam_one_hop(q: Q, kind, attr=None):
    f = q.f
    x = q.pick(f.objs)
    r = q.pick(RELS)
    pool = f.rels[r][x.i]
    kx = q.minimal_key(x, f.all)
    if kx is None:
        return None
    X = q.np(kx)
    rel = q.rel_w(r)
    base = ref_chain(q, kx) + [f"relate[{r}]"]
    if kind == "query":
        if not pool:
            return None
        y = f.objs[q.pick(sorted(pool))]
        ky = q.minimal_key(y, pool, forbid=(attr,))
        if ky is None:
            return None
        if not ky and attr == "shape" and q.chance(0.5):
            t = q.pick([f"What is {rel} {X.the}?", f"What is the thing {rel} {X.the}?",
                        f"Which vehicle is {rel} {X.the}?", f"What can you see {rel} {X.the}?"])
        else:
            Y = q.np(ky)
            yt = NP([], f"{Y.bare} {rel} {X.the}", "", "")
            yt2 = NP([], f"{Y.bare} that is {rel} {X.the}", "", "")
            k = q.pick(range(4))
            if k == 0:
                t = ask_attr(q, attr, yt)
            elif k == 1:
                t = ask_attr(q, attr, yt2)
            elif k == 2:
                t = there_is(q, NP([], f"{Y.bare} {rel} {X.the}", "", ""), ask_attr_pron(q, attr))
            else:
                a = ask_attr(q, attr, NP([], f"{Y.bare} {rel} it", "", ""))
                t = f"There is {X.a}; " + a[0].lower() + a[1:]
        return t, q.prog(base + filters(ky) + ["unique", qname(attr)])
    ck = {} if q.chance(0.35) else rand_key(q, [o for o in f.objs if o.i != x.i] or f.objs, nslots=q.pick([1, 1, 2]),
                                            mutate=0.25 if kind == "exist" else 0.1)
    C = q.np(ck, allow_post=False)
    if kind == "count":
        t = q.pick([f"How many {C.pl} are {rel} {X.the}?", f"What number of {C.pl} are {rel} {X.the}?",
                    f"Count the {C.pl} {rel} {X.the}.", f"How many {C.pl} can be seen {rel} {X.the}?",
                    f"There is {X.a}; how many {C.pl} are {rel} it?", f"how many {C.pl} {rel} {X.the}",
                    f"{rel[0].upper() + rel[1:]} {X.the}, how many {C.pl} are there?"])
        return t, q.prog(base + filters(ck) + ["count"]) if q.chance(0.5) else f"count({q.prog(base + filters(ck))})"
    t = q.pick([f"Is there {C.a} {rel} {X.the}?", f"Are there any {C.pl} {rel} {X.the}?",
                f"Can you see {C.a} {rel} {X.the}?", f"Is anything {rel} {X.the}?" if not ck else
                f"Is any {C.bare} {rel} {X.the}?", f"There is {X.a}; is there {C.a} {rel} it?",
                f"Does {X.the} have {C.a} {rel} it?"])
    return t, f"exist({q.prog(base + filters(ck))})"


def fam_two_hop(q: Q, kind, attr=None):
    f = q.f
    x = q.pick(f.objs)
    r2 = q.pick(RELS)
    pool2 = f.rels[r2][x.i]
    if not pool2:
        return None
    m = f.objs[q.pick(sorted(pool2))]
    r1 = q.pick(RELS)
    pool1 = f.rels[r1][m.i]
    kx = q.minimal_key(x, f.all)
    km = q.minimal_key(m, pool2)
    if kx is None or km is None:
        return None
    X, M = q.np(kx), q.np(km)
    w1, w2 = q.rel_w(r1), q.rel_w(r2)
    base = ref_chain(q, kx) + [f"relate[{r2}]"] + filters(km) + ["unique", f"relate[{r1}]"]
    if kind == "query":
        if not pool1:
            return None
        y = f.objs[q.pick(sorted(pool1))]
        if y.i == x.i:
            return None
        ky = q.minimal_key(y, pool1, forbid=(attr,))
        if ky is None:
            return None
        Y = q.np(ky)
        t = q.pick([ask_attr(q, attr, NP([], f"{Y.bare} {w1} the {M.bare} {w2} {X.the}", "", "")),
                    ask_attr(q, attr, NP([], f"{Y.bare} that is {w1} the {M.bare} that is {w2} {X.the}", "", "")),
                    f"There is {M.a} {w2} {X.the}; "
                    + lower_first(ask_attr(q, attr, NP([], f"{Y.bare} {w1} it", "", "")))])
        return t, q.prog(base + filters(ky) + ["unique", qname(attr)])
    ck = {} if q.chance(0.4) else rand_key(q, f.objs, nslots=1, mutate=0.1)
    C = q.np(ck, allow_post=False)
    t = q.pick([f"How many {C.pl} are {w1} the {M.bare} {w2} {X.the}?",
                f"What number of {C.pl} are {w1} the {M.bare} that is {w2} {X.the}?",
                f"There is {M.a} {w2} {X.the}; how many {C.pl} are {w1} it?"])
    return t, f"count({q.prog(base + filters(ck))})"


def fam_and(q: Q, kind):
    f = q.f
    if f.n < 3:
        return None
    x, y = q.rng.sample(f.objs, 2)
    r1, r2 = q.pick(RELS), q.pick(RELS)
    kx, ky = q.minimal_key(x, f.all), q.minimal_key(y, f.all)
    if kx is None or ky is None:
        return None
    X, Y = q.np(kx), q.np(ky)
    ck = {} if q.chance(0.5) else rand_key(q, f.objs, nslots=1, mutate=0.15)
    C = q.np(ck, allow_post=False)
    w1, w2 = q.rel_w(r1), q.rel_w(r2)
    inter = f"intersect({q.prog(ref_chain(q, kx) + [f'relate[{r1}]'])}, {q.prog(ref_chain(q, ky) + [f'relate[{r2}]'])})"
    chain = [inter] + filters(ck)
    if kind == "count":
        t = q.pick([f"How many {C.pl} are both {w1} {X.the} and {w2} {Y.the}?",
                    f"How many {C.pl} are {w1} {X.the} and also {w2} {Y.the}?",
                    f"Count the {C.pl} that are {w1} {X.the} and {w2} {Y.the}."])
        return t, f"count({q.prog(chain) if len(chain) > 1 else inter})"
    t = q.pick([f"Is there {C.a} that is both {w1} {X.the} and {w2} {Y.the}?",
                f"Is there {C.a} {w1} {X.the} and {w2} {Y.the}?",
                f"Are there any {C.pl} that are {w1} {X.the} and at the same time {w2} {Y.the}?"])
    return t, f"exist({q.prog(chain) if len(chain) > 1 else inter})"


# ----------------------------------------------------------------------------------------------------------------
# parts


def pname(q: Q, o: Obj, raw):
    """(value, words) naming part ``raw`` of ``o`` alone: the super-part name only when the subtype has one."""
    use_super = super_unique(o.subtype, raw) and q.chance(0.85)
    return part_value(raw, use_super), q.part_w(raw, use_super)


def ok_part_colour(o: Obj, c):
    return c != o.color and c != "gray"


def part_ref(q: Q, o: Obj):
    key = q.minimal_key(o, q.f.all)
    return key, (q.np(key) if key is not None else None)


def fam_part_query(q: Q, attr):
    f = q.f
    objs = [o for o in f.objs if o.parts]
    if not objs:
        return None
    o = q.pick(objs)
    raw = q.pick(sorted(o.parts))
    key, X = part_ref(q, o)
    if key is None:
        return None
    v, P = pname(q, o, raw)
    c = q.colorq()
    if attr == "color":
        forms = [f"What {c} is the {P} of {X.the}?", f"The {P} of {X.the} is what {c}?",
                 f"Tell me the {c} of the {P} on {X.the}.", f"What is the {c} of the {P} of {X.the}?",
                 f"what {c} is {P} of {X.the}", f"Which {c} does the {P} of {X.the} have?",
                 there_is(q, X, f"what {c} is its {P}?"), f"{P} of {X.the}: what {c}?"]
        if X.poss_ok:
            forms += [f"What {c} is {X.poss} {P}?", f"What's the {c} of {X.poss} {P}?"]
    else:
        forms = [f"What is the {P} of {X.the} made of?", f"What material is the {P} of {X.the}?",
                 f"Is the {P} of {X.the} metal or rubber?", f"What's the {P} on {X.the} made of?",
                 f"Material of the {P} of {X.the}?", there_is(q, X, f"what material is its {P}?"),
                 f"Is the {P} of {X.the} made of rubber or of metal?"]
        if X.poss_ok:
            forms += [f"What material is {X.poss} {P}?", f"Is {X.poss} {P} shiny or matte?"]
    text = q.pick(forms)
    prog = q.prog(ref_chain(q, key) + ["object2part", f"partfilter_partname[{v}]", "unique", f"partquery_{attr}"])
    return text, prog


def unique_colour_part(q: Q, o: Obj, exclude=()):
    """A recoloured part of o singled out by its colour (a colour the body does not have)."""
    cols = Counter(c for raw, (c, m) in o.parts.items())
    cands = [raw for raw, (c, m) in o.parts.items() if cols[c] == 1 and ok_part_colour(o, c) and raw not in exclude]
    if not cands:
        return None
    return q.pick(sorted(cands))


def fam_part_name(q: Q):
    f = q.f
    objs = [o for o in f.objs if o.parts]
    if not objs:
        return None
    o = q.pick(objs)
    raw = unique_colour_part(q, o)
    if raw is None:
        return None
    c = q.color_w(o.parts[raw][0])
    key, X = part_ref(q, o)
    if key is None:
        return None
    forms = [f"Which part of {X.the} is {c}?", f"What is the name of the {c} part of {X.the}?",
             f"{X.the} has one {c} part. Which part is it?", f"What {c} part does {X.the} have?",
             f"name the {c} part on {X.the}", f"Which part of {X.the} is painted {c}?",
             f"What part of {X.the} has the colour {c}?", f"Which of the parts of {X.the} is {c}?"]
    prog = q.prog(ref_chain(q, key) + ["object2part", f"partfilter_color[{o.parts[raw][0]}]", "unique",
                                       "partquery_partname"])
    return q.pick(forms), prog


def part_key_in(q: Q, pool_parts, target, colour=True):
    """Fewest part slots (name always; colour when asked) singling out ``target`` = (obj, raw) among pool parts."""
    f = q.f
    o = f.objs[target[0]]
    c, m = o.parts[target[1]]
    for use_super in (True, False):
        for extra in ((), ("material",)):
            key = {"name": part_value(target[1], use_super)}
            if colour:
                key["color"] = c
            if "material" in extra:
                key["material"] = m
            sel = [p for p in pool_parts if ontology.partname_matches(p[1], key["name"])
                   and ("color" not in key or f.objs[p[0]].parts[p[1]][0] == key["color"])
                   and ("material" not in key or f.objs[p[0]].parts[p[1]][1] == key["material"])]
            if sel == [target]:
                return key, use_super
    return None, None


def part_desc(q: Q, pkey, raw, use_super):
    words = []
    if "color" in pkey:
        words.append(q.color_w(pkey["color"]))
    if "material" in pkey:
        words.append(q.mat_w(pkey["material"]))
    words.append(q.part_w(raw, use_super))
    return " ".join(words)


def fam_has_part_query(q: Q, attr):
    f = q.f
    objs = [o for o in f.objs if o.parts]
    if not objs:
        return None
    o = q.pick(objs)
    okey = {} if (q.chance(0.6) or attr == "shape" and q.chance(0.5)) else {"shape": o.cat}
    if q.mode == "redundant":
        okey = q.redundant(o, okey, [s for s in SLOTS if s != attr])
    pool = sorted(q.f.select(f.all, okey))
    parts = [(i, raw) for i in pool for raw in f.objs[i].parts]
    raw = q.pick(sorted(o.parts))
    pkey, use_super = part_key_in(q, parts, (o.i, raw))
    if pkey is None:
        return None
    PD = part_desc(q, pkey, raw, use_super)
    X = q.np(okey)
    c = q.colorq()
    a = article(PD)
    if attr == "color":
        forms = [f"What {c} is the {X.bare} that has {a} {PD}?", f"What {c} is the {X.bare} with the {PD}?",
                 f"The {X.bare} with {a} {PD} is what {c}?", f"Tell me the {c} of the {X.bare} that has {a} {PD}.",
                 f"There is {X.a} with {a} {PD}; what {c} is it?"]
    elif attr == "material":
        forms = [f"What is the {X.bare} with the {PD} made of?", f"Is the {X.bare} that has {a} {PD} metal or rubber?",
                 f"What material is the {X.bare} that has {a} {PD}?",
                 f"The {X.bare} with {a} {PD}: what material is it?"]
    else:
        forms = [f"What kind of {X.bare} has {a} {PD}?", f"What is the {X.bare} that has {a} {PD}?",
                 f"Which type of {X.bare} has {a} {PD}?", f"What shape is the {X.bare} with the {PD}?",
                 f"Tell me what the {X.bare} with {a} {PD} is."]
    if "color" in pkey and "material" not in pkey and attr != "shape":
        pw = q.part_w(raw, use_super)
        forms.append(ask_attr(q, attr, NP([], f"{X.bare} whose {pw} is {q.color_w(pkey['color'])}", "", "")))
    chain = ["scene()"] + filters(okey) + ["object2part"] + pfilters(pkey) + ["unique", "part2object", "unique",
                                                                              qname(attr)]
    return q.pick(forms), q.prog(chain)


def fam_same_object_part(q: Q, attr):
    f = q.f
    objs = [o for o in f.objs if len(o.parts) >= 2]
    if not objs:
        return None
    o = q.pick(objs)
    allparts = [(i, raw) for i in range(f.n) for raw in f.objs[i].parts]
    raw2 = q.pick(sorted(o.parts))
    k2, sup2 = part_key_in(q, allparts, (o.i, raw2))
    if k2 is None:
        return None
    P2 = part_desc(q, k2, raw2, sup2)
    others = [r for r in sorted(o.parts) if r != raw2]
    if attr == "partname":
        raw1 = unique_colour_part(q, o, exclude=(raw2,))
        if raw1 is None:
            return None
        col = o.parts[raw1][0]
        k1 = {"color": col}
        C = q.color_w(col)
        forms = [f"Which {C} part is on the same object as the {P2}?",
                 f"What is the name of the {C} part that belongs to the same vehicle as the {P2}?",
                 f"The object with the {P2} also has a {C} part; which part is it?",
                 f"Which part is {C} on the thing that has the {P2}?"]
    else:
        raw1 = q.pick(others)
        v1, P1 = pname(q, o, raw1)
        k1 = {"name": v1}
        c = q.colorq()
        if attr == "color":
            forms = [f"What {c} is the {P1} that belongs to the same object as the {P2}?",
                     f"What {c} is the {P1} of the thing that has the {P2}?",
                     f"On the vehicle with the {P2}, what {c} is the {P1}?",
                     f"The {P2} and a {P1} are on the same object. What {c} is that {P1}?",
                     f"what {c} is the {P1} on the same thing as the {P2}"]
        else:
            forms = [f"What material is the {P1} that belongs to the same object as the {P2}?",
                     f"Is the {P1} of the object with the {P2} metal or rubber?",
                     f"On the thing that has the {P2}, what is the {P1} made of?",
                     f"What's the {P1} made of, on the same vehicle as the {P2}?"]
    chain = ["scene()", "object2part"] + pfilters(k2) + ["unique", "part2object", "object2part"] + pfilters(k1) + [
        "unique", f"partquery_{attr}"]
    return q.pick(forms), q.prog(chain)


def fam_part_count(q: Q):
    f = q.f
    o = q.pick(f.objs)
    cols = [c for raw, (c, m) in o.parts.items() if ok_part_colour(o, c)]
    if cols and q.chance(0.6):
        c = q.pick(cols)
    else:
        c = q.pick([c for c in COLORS if ok_part_colour(o, c)])
    key, X = part_ref(q, o)
    if key is None:
        return None
    C = q.color_w(c)
    forms = [f"How many {C} parts does {X.the} have?", f"How many parts of {X.the} are {C}?",
             f"Count the {C} parts on {X.the}.", f"{X.the}: how many {C} parts?",
             f"What number of parts of {X.the} are {C}?", f"how many {C} parts has {X.the}",
             f"There is {X.a}; how many of its parts are {C}?"]
    if X.poss_ok:
        forms.append(f"How many of {X.poss} parts are {C}?")
    chain = ref_chain(q, key) + ["object2part", f"partfilter_color[{c}]"]
    return q.pick(forms), (q.prog(chain + ["count"]) if q.chance(0.5) else f"count({q.prog(chain)})")


def fam_part_exist(q: Q, named):
    f = q.f
    o = q.pick(f.objs)
    key, X = part_ref(q, o)
    if key is None:
        return None
    if named:
        if o.parts and q.chance(0.5):
            raw = q.pick(sorted(o.parts))
            c = o.parts[raw][0]
            if not ok_part_colour(o, c):
                return None
        else:
            raw = q.pick(o.all_parts)
            c = q.pick([c for c in COLORS if ok_part_colour(o, c)])
        v, P = pname(q, o, raw)
        C = q.color_w(c)
        forms = [f"Does {X.the} have {article(C)} {C} {P}?", f"Is the {P} of {X.the} {C}?",
                 f"Is there {article(C)} {C} {P} on {X.the}?", f"Does the {P} of {X.the} look {C}?",
                 f"Is {X.the} fitted with {article(C)} {C} {P}?"]
        if X.poss_ok:
            forms.append(f"Is {X.poss} {P} {C}?")
        chain = ref_chain(q, key) + ["object2part", f"partfilter_color[{c}]", f"partfilter_partname[{v}]"]
    else:
        cols = [c for raw, (c, m) in o.parts.items() if ok_part_colour(o, c)]
        c = q.pick(cols) if cols and q.chance(0.5) else q.pick([c for c in COLORS if ok_part_colour(o, c)])
        C = q.color_w(c)
        forms = [f"Does {X.the} have {article(C)} {C} part?", f"Is any part of {X.the} {C}?",
                 f"Does {X.the} have any {C} parts?", f"Are any parts of {X.the} {C}?",
                 f"Is there {article(C)} {C} part on {X.the}?", f"has {X.the} got a {C} part"]
        chain = ref_chain(q, key) + ["object2part", f"partfilter_color[{c}]"]
    return q.pick(forms), (q.prog(chain + ["exist"]) if q.chance(0.5) else f"exist({q.prog(chain)})")


def fam_objects_with_part(q: Q):
    f = q.f
    allparts = [(i, raw) for i in range(f.n) for raw in f.objs[i].parts]
    if not allparts:
        return None
    i, raw = q.pick(allparts)
    o = f.objs[i]
    use_super = q.chance(0.6)
    v = part_value(raw, use_super)
    c = o.parts[raw][0] if q.chance(0.7) else q.pick(COLORS)
    if c == "gray":
        return None
    okey = {} if q.chance(0.6) else {"shape": o.cat}
    cands = [p for p in f.objs if p.matches(okey) and any(ontology.partname_matches(r, v) for r in p.all_parts)]
    if any(p.color == c for p in cands):
        return None
    X = q.np(okey, allow_post=False)
    C = q.color_w(c)
    P = q.part_w(raw, use_super)
    forms = [f"How many {X.pl} have {article(C)} {C} {P}?", f"How many {X.pl} have a {P} that is {C}?",
             f"Count the {X.pl} with {article(C)} {C} {P}.", f"What number of {X.pl} have {article(C)} {C} {P}?",
             f"how many {X.pl} got {article(C)} {C} {P}"]
    chain = ["scene()"] + filters(okey) + ["object2part", f"partfilter_color[{c}]", f"partfilter_partname[{v}]",
                                           "part2object"]
    return q.pick(forms), f"count({q.prog(chain)})"


# ----------------------------------------------------------------------------------------------------------------
# pose

POSE_PRED_PL = {
    "front_pose": ["face the camera", "are facing the camera", "are facing towards us", "point towards the camera"],
    "back_pose": ["face away from the camera", "are facing away", "have their backs to the camera",
                  "point away from us"],
    "left_pose": ["face left", "are facing left", "point to the left", "are turned to the left"],
    "right_pose": ["face right", "are facing right", "point to the right", "are turned to the right"],
}
POSE_PRED_SG = {
    "front_pose": ["faces the camera", "is facing the camera", "is facing towards us", "points at the camera"],
    "back_pose": ["faces away from the camera", "is facing away", "has its back to the camera", "points away from us"],
    "left_pose": ["faces left", "is facing left", "points to the left", "is turned to the left"],
    "right_pose": ["faces right", "is facing right", "points to the right", "is turned to the right"],
}
POSE_REL_PL = {
    "same_pose": ["facing the same direction as", "facing the same way as", "pointing the same way as",
                  "oriented the same way as"],
    "opposite_pose": ["facing the opposite direction to", "facing the other way from", "pointing the opposite way to",
                      "facing opposite to"],
    "vertical_pose": ["facing perpendicular to", "pointing at right angles to", "turned 90 degrees from",
                      "facing crosswise to"],
}


def fam_pose_query(q: Q):
    f = q.f
    objs = [o for o in f.objs if o.pose_clear()]
    if not objs:
        return None
    o = q.pick(objs)
    key = q.minimal_key(o, f.all)
    if key is None:
        return None
    X = q.np(key)
    forms = [f"Which direction is {X.the} facing?", f"Which way does {X.the} face?",
             f"What direction is {X.the} pointing?",
             f"Which way is {X.the} facing: left, right, towards the camera or away from it?",
             f"Where is {X.the} facing?", f"{X.the} faces which direction?", f"In which direction does {X.the} point?",
             f"Is {X.the} facing left, right, front or back?", f"which way is {X.the} pointing",
             f"What is the facing direction of {X.the}?", there_is(q, X, "which way is it facing?"),
             f"Tell me which direction {X.the} is facing."]
    if q.mode == "wide":
        forms += [f"What is the heading of {X.the}?", f"How is {X.the} oriented?"]
    return q.pick(forms), q.prog(ref_chain(q, key) + ["query_pose"])


def pose_needed_check(q: Q, o: Obj):
    f = q.f

    def check(key):
        rest = {k: v for k, v in key.items() if k != "pose"}
        sel = f.select(f.all, rest)
        if len(sel) <= 1:
            return False
        return all(f.objs[i].pose_clear() for i in sel)
    return check


def fam_pose_filter_query(q: Q, attr):
    f = q.f
    objs = [o for o in f.objs if o.pose_clear()]
    if not objs:
        return None
    o = q.pick(objs)
    key = q.minimal_key(o, f.all, slots=("pose",) + SLOTS, need=("pose",), forbid=(attr,),
                        check=pose_needed_check(q, o))
    if key is None:
        return None
    if q.mode == "redundant" and q.red == 0:
        return None
    X = q.np(key)
    if q.chance(0.3):
        rest = {k: v for k, v in key.items() if k != "pose"}
        Y = q.np(rest)
        X = NP([], f"{Y.bare} that {q.pick(POSE_PRED_SG[key['pose']])}", "", "")
    text = ask_attr(q, attr, X) if q.chance(0.8) else there_is(q, X, ask_attr_pron(q, attr))
    return text, q.prog(ref_chain(q, key) + [qname(attr)])


def fam_pose_filter_set(q: Q, kind):
    f = q.f
    label = q.pick(ontology.POSE_LABELS)
    ck = {} if q.chance(0.3) else rand_key(q, f.objs, nslots=q.pick([1, 1, 2]), mutate=0.1)
    if q.mode == "plural":
        ck["shape"] = q.pick(BUS_SHAPES)
    sel = f.select(f.all, ck)
    if not sel or not all(f.objs[i].pose_clear() for i in sel):
        return None
    C = q.np(ck, allow_post=False)
    chain = ["scene()", f"filter_pose[{label}]"] + filters(ck)
    if kind == "count":
        forms = [f"How many {C.pl} {q.pick(POSE_PRED_PL[label])}?", f"How many {C.pl} {q.pose_w(label)} are there?",
                 f"Count the {C.pl} that {q.pick(POSE_PRED_PL[label])}.",
                 f"What number of {C.pl} {q.pick(POSE_PRED_PL[label])}?",
                 f"how many {C.pl} {q.pose_w(label)}"]
        if label in POSE_PREFIX and label != "front_pose":
            forms.append(f"How many {POSE_PREFIX[label][0]} {C.pl} are there?")
        return q.pick(forms), (q.prog(chain + ["count"]) if q.chance(0.5) else f"count({q.prog(chain)})")
    forms = [f"Is there {C.a} that {q.pick(POSE_PRED_SG[label])}?", f"Is any {C.bare} {q.pose_w(label)}?",
             f"Is there {C.a} {q.pose_w(label)}?", f"Are there any {C.pl} that {q.pick(POSE_PRED_PL[label])}?",
             f"Can you see {C.a} {q.pose_w(label)}?", f"Do any {C.pl} {q.pick(POSE_PRED_PL[label])}?"]
    return q.pick(forms), (q.prog(chain + ["exist"]) if q.chance(0.5) else f"exist({q.prog(chain)})")


def pose_pool(f: Facts, x: Obj, rel):
    out = set()
    for o in f.objs:
        if o.i == x.i:
            continue
        d = pose_rel(x, o)
        r = "same_pose" if d < 45 else "opposite_pose" if d > 135 else "vertical_pose"
        if r == rel:
            out.add(o.i)
    return out


def pose_margins_ok(f: Facts, x: Obj, margin=6.0):
    return all(abs(pose_rel(x, o) - t) >= margin for o in f.objs if o.i != x.i for t in (45, 135))


def fam_pose_rel(q: Q, rel, kind):
    f = q.f
    objs = [o for o in f.objs if o.pose_clear() and pose_margins_ok(f, o)]
    if not objs:
        return None
    x = q.pick(objs)
    kx = q.minimal_key(x, f.all)
    if kx is None:
        return None
    X = q.np(kx)
    pool = pose_pool(f, x, rel)
    base = ref_chain(q, kx) + [rel]
    if kind == "query":
        if not pool:
            return None
        attr = q.pick(["color", "material", "size", "shape", "shape", "color"])
        y = f.objs[q.pick(sorted(pool))]
        ky = q.minimal_key(y, pool, forbid=(attr,))
        if ky is None:
            return None
        Y = q.np(ky)
        ph = q.pick(POSE_REL[rel])
        text = ask_attr(q, attr, NP([], f"{Y.bare} {ph} {X.the}", "", "")) if q.chance(0.8) else \
            there_is(q, NP([], f"{Y.bare} {ph} {X.the}", "", ""), ask_attr_pron(q, attr))
        return text, q.prog(base + filters(ky) + ["unique", qname(attr)])
    ck = {} if q.chance(0.4) else rand_key(q, [o for o in f.objs if o.i != x.i], nslots=1, mutate=0.2)
    C = q.np(ck, allow_post=False)
    ph = q.pick(POSE_REL_PL[rel])
    other = q.pick(["other ", ""])
    if kind == "count":
        forms = [f"How many {other}{C.pl} are {ph} {X.the}?", f"What number of {other}{C.pl} are {ph} {X.the}?",
                 f"Count the {other}{C.pl} {ph} {X.the}.", f"There is {X.a}; how many {other}{C.pl} are {ph} it?"]
        return q.pick(forms), f"count({q.prog(base + filters(ck))})"
    forms = [f"Is there {C.a} {ph} {X.the}?", f"Is any other {C.bare} {ph} {X.the}?",
             f"Are there any {C.pl} {ph} {X.the}?", f"There is {X.a}; is anything {ph} it?" if not ck else
             f"There is {X.a}; is there {C.a} {ph} it?"]
    return q.pick(forms), f"exist({q.prog(base + filters(ck))})"


# ----------------------------------------------------------------------------------------------------------------
# occlusion

OCC_ADJ = ["occluded", "partly hidden", "partially hidden", "partly covered", "partially occluded", "obstructed"]
OCC_REL = ["that is occluded", "that is partly hidden", "that is partially hidden from view",
           "that's partly covered up", "that is blocked from view in part", "which is occluded"]
OCC_BY = ["occluded by", "that is occluded by", "partly hidden by", "partly hidden behind", "that is partly covered by",
          "that is blocked by", "whose view is blocked by"]
OCCLUDES = ["that occludes", "that is occluding", "blocking", "that partly hides", "covering part of",
            "obstructing the view of", "which occludes"]


def fam_occluded_query(q: Q, attr):
    f = q.f
    occ = {o.i for o in f.objs if o.occluded}
    if not occ:
        return None
    o = f.objs[q.pick(sorted(occ))]
    key = q.minimal_key(o, occ, forbid=(attr,), check=lambda k: len(f.select(f.all, k)) > 1)
    if key is None:
        return None
    Y = q.np(key, allow_post=False)
    if q.chance(0.5) and Y.bare not in ("thing", "object", "item", "vehicle"):
        X = NP([], f"{q.pick(OCC_ADJ)} {Y.bare}", "", "")
    else:
        X = NP([], f"{Y.bare} {q.pick(OCC_REL)}", "", "")
    text = ask_attr(q, attr, X) if q.chance(0.8) else there_is(q, X, ask_attr_pron(q, attr))
    return text, q.prog(["scene()", "filter_occludee"] + filters(key) + ["unique", qname(attr)])


def fam_occ_rel_query(q: Q, attr, direction):
    """direction 'by': the X occluded by Y (relate_occluding); 'of': the X that occludes Y (relate_occluded)."""
    f = q.f
    if direction == "by":
        refs = [o for o in f.objs if f.occludes[o.i]]
    else:
        refs = [o for o in f.objs if o.occ_by]
    if not refs:
        return None
    y = q.pick(refs)
    pool = f.occludes[y.i] if direction == "by" else set(y.occ_by)
    x = f.objs[q.pick(sorted(pool))]
    ky = q.minimal_key(y, f.all, nonempty=True)
    kx = q.minimal_key(x, pool, forbid=(attr,))
    if ky is None or kx is None:
        return None
    Y = q.np(ky)
    op = "relate_occluding" if direction == "by" else "relate_occluded"
    prog = q.prog(ref_chain(q, ky) + [op] + filters(kx) + ["unique", qname(attr)])
    if not kx and attr == "shape" and q.chance(0.6):
        if direction == "by":
            t = q.pick([f"What is {Y.the} occluding?", f"What is partly hidden by {Y.the}?",
                        f"What does {Y.the} block from view?", f"Which vehicle is occluded by {Y.the}?"])
        else:
            t = q.pick([f"What is occluding {Y.the}?", f"What is in the way of {Y.the}?",
                        f"What is blocking the view of {Y.the}?", f"Which vehicle partly hides {Y.the}?"])
        return t, prog
    X = q.np(kx, allow_post=False)
    ph = q.pick(OCC_BY if direction == "by" else OCCLUDES)
    N = NP([], f"{X.bare} {ph} {Y.the}", "", "")
    text = ask_attr(q, attr, N) if q.chance(0.8) else there_is(q, N, ask_attr_pron(q, attr))
    return text, prog


def fam_occluded_yesno(q: Q):
    f = q.f
    o = q.pick(f.objs)
    key = q.minimal_key(o, f.all)
    if key is None:
        return None
    X = q.np(key)
    forms = [f"Is {X.the} occluded?", f"Is {X.the} partly hidden?", f"Is anything blocking the view of {X.the}?",
             f"Is {X.the} partially covered by another object?", f"Is part of {X.the} hidden by something?",
             f"Is {X.the} obstructed?", f"is {X.the} occluded by anything", f"Does something occlude {X.the}?",
             f"Is {X.the} at least partly out of sight?", f"Is {X.the} partially occluded?"]
    chain = ["scene()", "filter_occludee"] + filters(key)
    return q.pick(forms), (q.prog(chain + ["exist"]) if q.chance(0.5) else f"exist({q.prog(chain)})")


def fam_occ_by_yesno(q: Q):
    f = q.f
    pairs_yes = [(x, j) for x in f.objs for j in x.occ_by]
    if pairs_yes and q.chance(0.5):
        x, j = q.pick(pairs_yes)
        y = f.objs[j]
    else:
        if f.n < 2:
            return None
        x, y = q.rng.sample(f.objs, 2)
    kx = q.minimal_key(x, f.all)
    ky = q.minimal_key(y, f.all, nonempty=True)
    if kx is None or ky is None:
        return None
    X, Y = q.np(kx), q.np(ky)
    forms = [f"Is {X.the} occluded by {Y.the}?", f"Does {Y.the} block part of {X.the}?",
             f"Is {X.the} partly hidden by {Y.the}?", f"Does {Y.the} hide part of {X.the}?",
             f"Is {Y.the} occluding {X.the}?", f"Is {X.the} blocked from view by {Y.the}?",
             f"Is {Y.the} in the way of {X.the}, hiding some of it?"]
    return q.pick(forms), f"exist({q.prog(ref_chain(q, ky) + ['relate_occluding'] + filters(kx))})"


def fam_occluded_count(q: Q):
    f = q.f
    ck = {} if q.chance(0.3) else rand_key(q, f.objs, nslots=q.pick([1, 1, 2]), mutate=0.1)
    C = q.np(ck, allow_post=False)
    forms = [f"How many {C.pl} are occluded?", f"How many occluded {C.pl} are there?",
             f"How many {C.pl} are partly hidden?", f"Count the {C.pl} that are partially covered.",
             f"What number of {C.pl} are occluded?", f"how many {C.pl} are partially occluded",
             f"How many of the {C.pl} are hidden in part by something?"]
    chain = ["scene()", "filter_occludee"] + filters(ck)
    return q.pick(forms), f"count({q.prog(chain)})"


def fam_occ_rel_count(q: Q, direction):
    f = q.f
    x = q.pick(f.objs)
    kx = q.minimal_key(x, f.all)
    if kx is None:
        return None
    X = q.np(kx)
    ck = {} if q.chance(0.55) else rand_key(q, [o for o in f.objs if o.i != x.i], nslots=1, mutate=0.2)
    C = q.np(ck, allow_post=False)
    if direction == "occluders":
        forms = [f"How many {C.pl} are occluding {X.the}?", f"By how many {C.pl} is {X.the} occluded?",
                 f"How many {C.pl} block the view of {X.the}?", f"How many {C.pl} hide part of {X.the}?",
                 f"Count the {C.pl} that partly cover {X.the}."]
        op = "relate_occluded"
    else:
        forms = [f"How many {C.pl} does {X.the} occlude?", f"How many {C.pl} are occluded by {X.the}?",
                 f"How many {C.pl} is {X.the} blocking?", f"How many {C.pl} are partly hidden by {X.the}?",
                 f"Count the {C.pl} that {X.the} partly hides."]
        op = "relate_occluding"
    return q.pick(forms), f"count({q.prog(ref_chain(q, kx) + [op] + filters(ck))})"


# ----------------------------------------------------------------------------------------------------------------
# part occlusion


def parts_all(o: Obj):
    return sorted(set(o.parts) | set(o.part_occ))


def fam_part_occ_yesno(q: Q):
    f = q.f
    objs = [o for o in f.objs if parts_all(o)]
    if not objs:
        return None
    o = q.pick(objs)
    occ = sorted(o.part_occ)
    free = [r for r in o.parts if r not in o.part_occ]
    if occ and (q.chance(0.5) or not free):
        raw = q.pick(occ)
    elif free:
        raw = q.pick(sorted(free))
    else:
        return None
    key, X = part_ref(q, o)
    if key is None:
        return None
    v, P = pname(q, o, raw)
    forms = [f"Is the {P} of {X.the} occluded?", f"Is the {P} of {X.the} hidden from view?",
             f"Is something covering the {P} of {X.the}?", f"Is the {P} on {X.the} partly hidden?",
             f"is the {P} of {X.the} occluded or not", f"Is the {P} of {X.the} blocked by another object?",
             there_is(q, X, f"is its {P} occluded?")]
    if X.poss_ok:
        forms += [f"Is {X.poss} {P} hidden?", f"Is {X.poss} {P} blocked by anything?"]
    chain = ref_chain(q, key) + ["object2part_all", f"partfilter_partname[{v}]", "unique"]
    return q.pick(forms), (q.prog(chain + ["partquery_occlusion"]) if q.chance(0.6)
                           else f"partquery_occlusion({q.prog(chain)})")


def fam_which_part_occ(q: Q):
    f = q.f
    objs = [o for o in f.objs if len(o.part_occ) == 1]
    if not objs:
        return None
    o = q.pick(objs)
    key, X = part_ref(q, o)
    if key is None:
        return None
    forms = [f"Which part of {X.the} is occluded?", f"What part of {X.the} is hidden?",
             f"Name the occluded part of {X.the}.", f"What is the occluded part of {X.the}?",
             f"Which part of {X.the} can't be fully seen?", f"Which part of {X.the} is partly covered?",
             there_is(q, X, "which of its parts is hidden?")]
    if X.poss_ok:
        forms.append(f"Which of {X.poss} parts is covered by something?")
    return q.pick(forms), q.prog(ref_chain(q, key) + ["object2part_all", "partfilter_occludee", "unique",
                                                       "partquery_partname"])


def owners_of_occluded(f: Facts, v):
    return {o.i for o in f.objs if any(ontology.partname_matches(r, v) for r in o.part_occ)}


def fam_whose_part_occ(q: Q, attr):
    f = q.f
    occparts = [(o, raw) for o in f.objs for raw in sorted(o.part_occ)]
    if not occparts:
        return None
    o, raw = q.pick(occparts)
    use_super = q.chance(0.5)
    v = part_value(raw, use_super)
    owners = owners_of_occluded(f, v)
    key = q.minimal_key(o, owners, forbid=(attr,))
    if key is None:
        return None
    X = q.np(key, allow_post=False)
    P = q.part_w(raw, use_super)
    hid = q.pick(["occluded", "hidden", "partly hidden", "covered", "blocked from view"])
    if attr == "shape" and not key and q.chance(0.5):
        text = q.pick([f"Which vehicle has its {P} {hid}?", f"What kind of vehicle has {article(hid)} {hid} {P}?",
                       f"Whose {P} is {hid}? Name the type of vehicle."])
    else:
        N = NP([], q.pick([f"{X.bare} whose {P} is {hid}", f"{X.bare} with {article(hid)} {hid} {P}"]), "", "")
        text = ask_attr(q, attr, N)
    chain = ["scene()"] + filters(key) + ["object2part_all", "partfilter_occludee", f"partfilter_partname[{v}]",
                                          "part2object", "unique", qname(attr)]
    return text, q.prog(chain)


def fam_part_of_occluded(q: Q, attr):
    f = q.f
    occ = {o.i for o in f.objs if o.occluded}
    objs = [f.objs[i] for i in sorted(occ) if f.objs[i].parts]
    if not objs:
        return None
    o = q.pick(objs)
    key = q.minimal_key(o, occ, nonempty=True)
    if key is None:
        return None
    Y = q.np(key, allow_post=False)
    occw = q.pick(["occluded", "partly hidden", "partially covered"])
    if attr == "partname":
        raw = unique_colour_part(q, o)
        if raw is None:
            return None
        c = o.parts[raw][0]
        C = q.color_w(c)
        forms = [f"Which part of the {occw} {Y.bare} is {C}?", f"What is the {C} part of the {Y.bare} that is {occw}?",
                 f"The {occw} {Y.bare} has a {C} part. Which one?"]
        pf = [f"partfilter_color[{c}]"]
    else:
        raw = q.pick(sorted(o.parts))
        v, P = pname(q, o, raw)
        c = q.colorq()
        if attr == "color":
            forms = [f"What {c} is the {P} of the {occw} {Y.bare}?",
                     f"What {c} is the {P} that belongs to the {Y.bare} which is {occw}?",
                     f"The {Y.bare} that is {occw} has a {P}; what {c} is it?",
                     f"What is the {c} of the {P} of the {occw} {Y.bare}?"]
        else:
            forms = [f"What is the {P} of the {occw} {Y.bare} made of?",
                     f"What material is the {P} of the {Y.bare} that is {occw}?"]
        pf = [f"partfilter_partname[{v}]"]
    chain = ["scene()", "filter_occludee"] + filters(key) + ["object2part"] + pf + ["unique", f"partquery_{attr}"]
    return q.pick(forms), q.prog(chain)


def fam_part_occ_by_yesno(q: Q):
    f = q.f
    cands = [(o, raw) for o in f.objs for raw in parts_all(o)]
    if not cands:
        return None
    yes = [(o, raw) for o, raw in cands if o.part_occ.get(raw)]
    if yes and q.chance(0.5):
        o, raw = q.pick(yes)
        y = f.objs[q.pick(o.part_occ[raw])]
    else:
        o, raw = q.pick(cands)
        others = [p for p in f.objs if p.i != o.i]
        near = [f.objs[j] for j in o.occ_by] + [f.objs[j] for r in o.part_occ.values() for j in r]
        y = q.pick(near) if near and q.chance(0.5) else q.pick(others)
    key, X = part_ref(q, o)
    ky = q.minimal_key(y, f.all, nonempty=True)
    if key is None or ky is None:
        return None
    Y = q.np(ky)
    v, P = pname(q, o, raw)
    forms = [f"Is the {P} of {X.the} occluded by {Y.the}?", f"Does {Y.the} hide the {P} of {X.the}?",
             f"Is the {P} of {X.the} hidden behind {Y.the}?", f"Is {Y.the} blocking the {P} of {X.the}?",
             f"Does {Y.the} cover the {P} of {X.the}?", f"Is the {P} of {X.the} partly covered by {Y.the}?"]
    if X.poss_ok:
        forms.append(f"Does {Y.the} occlude {X.poss} {P}?")
    chain = ref_chain(q, key) + ["object2part_all", f"partfilter_partname[{v}]", "unique", "relate_part_occluded"] + \
        filters(ky)
    return q.pick(forms), f"exist({q.prog(chain)})"


def fam_whose_part_occ_by(q: Q, attr):
    f = q.f
    refs = [o for o in f.objs if f.parts_hidden_by[o.i]]
    if not refs:
        return None
    y = q.pick(refs)
    H = sorted(f.parts_hidden_by[y.i])
    i, raw = q.pick(H)
    o = f.objs[i]
    use_super = q.chance(0.5)
    v = part_value(raw, use_super)
    if sum(1 for (j, r) in H if ontology.partname_matches(r, v)) != 1:
        return None
    ky = q.minimal_key(y, f.all, nonempty=True)
    if ky is None:
        return None
    okey = {}
    if q.mode == "redundant":
        okey = q.redundant(o, {}, [s for s in SLOTS if s != attr])
    Y = q.np(ky)
    X = q.np(okey, allow_post=False)
    P = q.part_w(raw, use_super)
    hid = q.pick(["occluded by", "hidden by", "covered by", "blocked by", "partly hidden behind"])
    if attr == "shape" and not okey and q.chance(0.5):
        text = q.pick([f"Which vehicle has its {P} {hid} {Y.the}?",
                       f"{Y.the} hides a {P}; what kind of vehicle is it on?",
                       f"What kind of vehicle does the {P} {hid} {Y.the} belong to?"])
    else:
        N = NP([], f"{X.bare} whose {P} is {hid} {Y.the}", "", "")
        text = ask_attr(q, attr, N)
    chain = ref_chain(q, ky) + ["relate_occluding_part", f"partfilter_partname[{v}]", "unique", "part2object"] + \
        filters(okey) + ["unique", qname(attr)]
    return text, q.prog(chain)


def fam_part_of_occ_by(q: Q, attr):
    f = q.f
    refs = [o for o in f.objs if any(f.objs[i].parts for i in f.occludes[o.i])]
    if not refs:
        return None
    y = q.pick(refs)
    pool = f.occludes[y.i]
    o = q.pick([f.objs[i] for i in sorted(pool) if f.objs[i].parts])
    ky = q.minimal_key(y, f.all, nonempty=True)
    kx = q.minimal_key(o, pool)
    if ky is None or kx is None:
        return None
    Y, X = q.np(ky), q.np(kx, allow_post=False)
    by = q.pick(["occluded by", "partly hidden by", "that is occluded by", "that is partly covered by"])
    if attr == "partname":
        raw = unique_colour_part(q, o)
        if raw is None:
            return None
        c = o.parts[raw][0]
        C = q.color_w(c)
        forms = [f"Which part of the {X.bare} {by} {Y.the} is {C}?",
                 f"What is the {C} part of the {X.bare} {by} {Y.the}?",
                 f"{Y.the} partly hides {X.a}; which of its parts is {C}?"]
        pf = [f"partfilter_color[{c}]"]
    else:
        raw = q.pick(sorted(o.parts))
        v, P = pname(q, o, raw)
        c = q.colorq()
        if attr == "color":
            forms = [f"What {c} is the {P} of the {X.bare} {by} {Y.the}?",
                     f"What {c} is the {P} that belongs to the {X.bare} {by} {Y.the}?",
                     f"{Y.the} partly hides {X.a}; what {c} is its {P}?"]
        else:
            forms = [f"What is the {P} of the {X.bare} {by} {Y.the} made of?",
                     f"Is the {P} of the {X.bare} {by} {Y.the} metal or rubber?"]
        pf = [f"partfilter_partname[{v}]"]
    chain = ref_chain(q, ky) + ["relate_occluding"] + filters(kx) + ["object2part"] + pf + ["unique",
                                                                                          f"partquery_{attr}"]
    return q.pick(forms), q.prog(chain)


def fam_same_obj_occ_part(q: Q, attr):
    f = q.f
    cands = [(o, r2) for o in f.objs for r2 in sorted(o.part_occ) if any(r != r2 for r in o.parts)]
    if not cands:
        return None
    o, raw2 = q.pick(cands)
    use_super = q.chance(0.5)
    v2 = part_value(raw2, use_super)
    owners = owners_of_occluded(f, v2)
    key = q.minimal_key(o, owners)
    if key is None:
        return None
    used = {r for r in o.part_occ if ontology.partname_matches(r, v2)}
    X = q.np(key, allow_post=False)
    P2 = q.part_w(raw2, use_super)
    hid = q.pick(["occluded", "hidden", "partly hidden", "covered"])
    if attr == "partname":
        raw1 = unique_colour_part(q, o, exclude=tuple(used))
        if raw1 is None:
            return None
        c = o.parts[raw1][0]
        C = q.color_w(c)
        forms = [f"Which part of the {X.bare} whose {P2} is {hid} is {C}?",
                 f"The {X.bare} whose {P2} is {hid} has a {C} part; which part is it?",
                 f"What is the name of the {C} part on the {X.bare} with the {hid} {P2}?"]
        pf = [f"partfilter_color[{c}]"]
    else:
        r1 = [r for r in sorted(o.parts) if r not in used]
        if not r1:
            return None
        raw1 = q.pick(r1)
        v1, P1 = pname(q, o, raw1)
        if ontology.partname_matches(raw2, v1):
            return None
        c = q.colorq()
        if attr == "color":
            forms = [f"What {c} is the {P1} of the {X.bare} whose {P2} is {hid}?",
                     f"The {X.bare} with the {hid} {P2}: what {c} is its {P1}?",
                     f"What is the {c} of the {P1} that belongs to the {X.bare} whose {P2} is {hid}?"]
        else:
            forms = [f"What is the {P1} made of on the {X.bare} whose {P2} is {hid}?",
                     f"What material is the {P1} of the {X.bare} whose {P2} is {hid}?"]
        pf = [f"partfilter_partname[{v1}]"]
    chain = ["scene()", "object2part_all", "partfilter_occludee", f"partfilter_partname[{v2}]", "part2object"] + \
        filters(key) + ["object2part"] + pf + ["unique", f"partquery_{attr}"]
    return q.pick(forms), q.prog(chain)


def fam_occluded_part_count(q: Q):
    f = q.f
    o = q.pick(f.objs)
    key, X = part_ref(q, o)
    if key is None:
        return None
    forms = [f"How many parts of {X.the} are occluded?", f"Count the occluded parts of {X.the}.",
             f"How many parts of {X.the} are hidden?", f"How many of the parts of {X.the} are partly covered?",
             f"What number of parts of {X.the} are occluded?", there_is(q, X, "how many of its parts are hidden?")]
    if X.poss_ok:
        forms.append(f"How many of {X.poss} parts are occluded?")
    chain = ref_chain(q, key) + ["object2part_all", "partfilter_occludee"]
    return q.pick(forms), f"count({q.prog(chain)})"


# ----------------------------------------------------------------------------------------------------------------
# registry: group -> [(family, function, args)]

A4 = ("color", "material", "size", "shape")

FAMILIES = {
    "core_query": [(f"zero_hop_query_{a}", fam_zero_query, (a,)) for a in A4]
    + [(f"there_is_query_{a}", fam_there_query, (a,)) for a in A4],
    "core_count": [("count_one_attribute", fam_count, (1,)), ("count_two_attributes", fam_count, (2,)),
                   ("count_three_attributes", fam_count, (3,)), ("count_union", fam_count_union, ()),
                   ("count_all", fam_count_all, ())],
    "core_exist": [("exist_one_attribute", fam_exist, (1,)), ("exist_two_attributes", fam_exist, (2,)),
                   ("exist_three_attributes", fam_exist, (3,)), ("exist_union", fam_exist_union, ())],
    "core_compare_attribute": [(f"compare_{a}", fam_compare_attr, (a,)) for a in A4]
    + [(f"compare_{a}_of_related", fam_compare_attr_relate, (a,)) for a in ("color", "material", "shape")],
    "core_compare_integer": [(f"compare_count_{op}", fam_compare_count, (op,))
                             for op in ("greater_than", "less_than", "equal_integer")]
    + [(f"compare_relate_count_{op}", fam_compare_count_relate, (op,))
       for op in ("greater_than", "less_than", "equal_integer")],
    "core_same_relate": [(f"same_{a}_{k}", fam_same, (a, k)) for a in A4 for k in ("count", "exist", "query")],
    "core_spatial": [(f"one_hop_query_{a}", fam_one_hop, ("query", a)) for a in A4]
    + [("one_hop_count", fam_one_hop, ("count",)), ("one_hop_exist", fam_one_hop, ("exist",)),
       ("two_hop_query_color", fam_two_hop, ("query", "color")),
       ("two_hop_query_shape", fam_two_hop, ("query", "shape")), ("two_hop_count", fam_two_hop, ("count",)),
       ("and_count", fam_and, ("count",)), ("and_exist", fam_and, ("exist",))],
    "parts": [("part_query_color", fam_part_query, ("color",)), ("part_query_material", fam_part_query, ("material",)),
              ("part_query_name_by_color", fam_part_name, ())]
    + [(f"has_part_query_{a}", fam_has_part_query, (a,)) for a in ("color", "material", "shape")]
    + [(f"same_object_part_query_{a}", fam_same_object_part, (a,)) for a in ("color", "material", "partname")]
    + [("part_color_count", fam_part_count, ()), ("part_color_exist", fam_part_exist, (False,)),
       ("named_part_color_exist", fam_part_exist, (True,)), ("objects_with_part_count", fam_objects_with_part, ())],
    "pose": [("pose_query", fam_pose_query, ())]
    + [(f"pose_filter_query_{a}", fam_pose_filter_query, (a,)) for a in A4]
    + [("pose_filter_count", fam_pose_filter_set, ("count",)), ("pose_filter_exist", fam_pose_filter_set, ("exist",))]
    + [(f"{r}_{k}", fam_pose_rel, (r, k)) for r in ("same_pose", "opposite_pose", "vertical_pose")
       for k in ("query", "count", "exist")],
    "occlusion": [(f"occluded_query_{a}", fam_occluded_query, (a,)) for a in A4]
    + [(f"occluded_by_query_{a}", fam_occ_rel_query, (a, "by")) for a in ("color", "shape", "size")]
    + [(f"occluding_query_{a}", fam_occ_rel_query, (a, "of")) for a in ("color", "shape", "material")]
    + [("occluded_yesno", fam_occluded_yesno, ()), ("occluded_by_yesno", fam_occ_by_yesno, ()),
       ("occluded_count", fam_occluded_count, ()), ("occluders_count", fam_occ_rel_count, ("occluders",)),
       ("occludees_count", fam_occ_rel_count, ("occludees",))],
    "part_occlusion": [("part_occluded_yesno", fam_part_occ_yesno, ()), ("which_part_occluded", fam_which_part_occ, ()),
                       ("whose_part_occluded_query_color", fam_whose_part_occ, ("color",)),
                       ("whose_part_occluded_query_shape", fam_whose_part_occ, ("shape",)),
                       ("part_of_occluded_query_color", fam_part_of_occluded, ("color",)),
                       ("part_of_occluded_query_partname", fam_part_of_occluded, ("partname",)),
                       ("part_occluded_by_yesno", fam_part_occ_by_yesno, ()),
                       ("whose_part_occluded_by_query_color", fam_whose_part_occ_by, ("color",)),
                       ("whose_part_occluded_by_query_shape", fam_whose_part_occ_by, ("shape",)),
                       ("part_of_occluded_by_query_color", fam_part_of_occ_by, ("color",)),
                       ("part_of_occluded_by_query_partname", fam_part_of_occ_by, ("partname",)),
                       ("same_object_occluded_part_query_color", fam_same_obj_occ_part, ("color",)),
                       ("same_object_occluded_part_query_partname", fam_same_obj_occ_part, ("partname",)),
                       ("occluded_part_count", fam_occluded_part_count, ())],
}

_BY_NAME = {name: (fn, args) for fams in FAMILIES.values() for name, fn, args in fams}

REDUNDANT = ["zero_hop_query_color", "zero_hop_query_shape", "zero_hop_query_material", "one_hop_query_color",
             "one_hop_count", "compare_material", "same_color_count", "part_query_color", "has_part_query_shape",
             "pose_query", "pose_filter_query_color", "same_pose_query", "occluded_by_query_shape",
             "occluded_yesno", "part_occluded_yesno", "whose_part_occluded_query_color"]
SYNONYMS = [("wide", n) for n in ("zero_hop_query_color", "zero_hop_query_material", "zero_hop_query_shape",
                                  "count_two_attributes", "exist_one_attribute", "one_hop_query_color",
                                  "one_hop_exist", "compare_size", "part_query_color", "has_part_query_color",
                                  "pose_query", "pose_filter_count", "occluded_query_color", "part_occluded_yesno")] \
    + [("plural", n) for n in ("count_one_attribute", "exist_one_attribute", "one_hop_count", "pose_filter_count")] \
    + [("typo", n) for n in ("zero_hop_query_color", "count_two_attributes", "exist_two_attributes",
                             "one_hop_query_shape", "part_query_material", "same_size_count",
                             "pose_filter_query_shape", "occluded_by_query_color", "which_part_occluded")]
PREFIX = {"redundant": "redundant_", "wide": "synonym_", "plural": "plural_quirk_", "typo": "typo_"}

FAMILIES["redundant"] = [("redundant_" + n,) + _BY_NAME[n] + ("redundant",) for n in REDUNDANT]
FAMILIES["synonyms_quirks_typos"] = [(PREFIX[m] + n,) + _BY_NAME[n] + (m,) for m, n in SYNONYMS]
GROUP_ORDER = ["core_query", "core_count", "core_exist", "core_compare_attribute", "core_compare_integer",
               "core_same_relate", "core_spatial", "parts", "pose", "occlusion", "part_occlusion", "redundant",
               "synonyms_quirks_typos"]


# ----------------------------------------------------------------------------------------------------------------
# plural quirk: force the counted things to be buses



# ----------------------------------------------------------------------------------------------------------------
# building


def program_signature(program: str) -> str:
    from po3d_ppl.language import program_to_tokens
    return " ".join(program_to_tokens(parse_program(program)))


def candidate(rng, facts, group, fam):
    name, fn, args = fam[0], fam[1], fam[2]
    mode = fam[3] if len(fam) > 3 else "plain"
    q = Q(rng, facts, mode)
    out = fn(q, *args)
    if out is None:
        return None
    text, prog = out[0], out[1]
    label = name + (out[2] if len(out) > 2 else "")
    if mode == "redundant" and q.red == 0:
        return None
    if mode == "wide" and not any(n.startswith(("wider", "part synonym")) for n in q.notes):
        return None
    if mode == "plural" and not any(n.startswith("public plural") for n in q.notes):
        return None
    text = q.finish(text)
    if text is None:
        return None
    low = text.lower()
    q.notes = [n for n in q.notes if "'" not in n or n.split("'")[1].lower() in low]
    if mode == "wide" and not any(n.startswith(("wider", "part synonym")) for n in q.notes):
        return None
    if mode == "plural" and not any(n.startswith("public plural") for n in q.notes):
        return None
    ok, answer = run(facts, prog)
    if not ok:
        return None
    rec = {"question": text, "program": prog, "family_group": group, "family": label, "scene": facts.rel,
           "answer": answer}
    notes = list(dict.fromkeys(q.notes))
    if notes:
        rec["phrasing_notes"] = "; ".join(notes)
    return rec


def balanced(pool, n, rng):
    by = defaultdict(list)
    for r in pool:
        by[json.dumps(r["answer"])].append(r)
    for v in by.values():
        rng.shuffle(v)
    picks, used = [], Counter()
    while len(picks) < n and any(by.values()):
        avail = [a for a, v in by.items() if v]
        low = min(used[a] for a in avail)
        a = rng.choice(sorted(a for a in avail if used[a] == low))
        picks.append(by[a].pop())
        used[a] += 1
    return picks


def build(seed: int, scenes: list[Facts], seen: set):
    rng = random.Random(seed)
    out = []
    for group in GROUP_ORDER:
        fams = FAMILIES[group]
        quota = -(-PER_GROUP // len(fams))
        pools = {}
        for fam in fams:
            pool, keys = [], set()
            tries = 0
            while len(pool) < quota * POOL_FACTOR and tries < quota * POOL_FACTOR * 8:
                tries += 1
                facts = rng.choice(scenes)
                rec = candidate(rng, facts, group, fam)
                if rec is None:
                    continue
                k1 = (rec["scene"], rec["question"].lower())
                k2 = (rec["scene"], program_signature(rec["program"]))
                if k1 in keys or k2 in keys or k1 in seen:
                    continue
                keys.update((k1, k2))
                pool.append(rec)
            pools[fam[0]] = balanced(pool, len(pool), rng)  # balanced order; take from the front
        # round-robin over families until the group is full
        chosen = []
        idx = {k: 0 for k in pools}
        taken = Counter()
        while len(chosen) < PER_GROUP:
            progress = False
            for name in sorted(pools, key=lambda k: taken[k]):
                if len(chosen) >= PER_GROUP:
                    break
                p = pools[name]
                while idx[name] < len(p):
                    rec = p[idx[name]]
                    idx[name] += 1
                    k1 = (rec["scene"], rec["question"].lower())
                    if k1 in seen:
                        continue
                    seen.add(k1)
                    chosen.append(rec)
                    taken[name] += 1
                    progress = True
                    break
            if not progress:
                break
        short = [k for k in pools if taken[k] == 0]
        if short:
            print(f"warning: {group}: no question for {short}", file=sys.stderr)
        out.extend(chosen)
    return out


def load_scenes():
    return [Facts(p) for p in sorted(SCENE_DIR.glob("scene_*.json"))]


def read_jsonl(path: Path):
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def write_jsonl(path: Path, recs):
    path.write_text("".join(json.dumps(r, ensure_ascii=False) + "\n" for r in recs))


FIELD_ORDER = ("id", "question", "program", "family_group", "family", "scene", "answer", "phrasing_notes")


def ordered(rec):
    return {k: rec[k] for k in FIELD_ORDER if k in rec}


def main_generate(seed: int):
    scenes = load_scenes()
    seen = set()
    hand = HERE / "hand_written.jsonl"
    if hand.exists():
        seen.update((r["scene"], r["question"].lower()) for r in read_jsonl(hand))
    recs = build(seed, scenes, seen)
    for n, r in enumerate(recs):
        r["id"] = f"v3g{n:05d}"
    write_jsonl(HERE / "generated.jsonl", [ordered(r) for r in recs])
    summary(recs)


def main_hand():
    path = HERE / "hand_written.jsonl"
    recs = read_jsonl(path)
    by_scene = {}
    bad = []
    ids = Counter(r["id"] for r in recs)
    dup = [i for i, c in ids.items() if c > 1]
    if dup:
        bad.append(("duplicate ids", dup))
    seen = Counter((r["scene"], r["question"]) for r in recs)
    if any(c > 1 for c in seen.values()):
        bad.append(("duplicate questions", [k for k, c in seen.items() if c > 1]))
    for r in recs:
        if r.get("family_group") not in FAMILIES:
            bad.append((r["id"], "unknown family_group " + str(r.get("family_group"))))
            continue
        f = by_scene.get(r["scene"])
        if f is None:
            f = by_scene[r["scene"]] = Facts(HERE / r["scene"])
        for v in re.findall(r"partfilter_partname\[(\w+)\]", r["program"]):
            if v in ontology.PARTNAME_VALUES and ontology.canonical_part_name(v) != v:
                bad.append((r["id"], f"part name {v!r} is not canonical ({ontology.canonical_part_name(v)!r})"))
        try:
            ok, ans = run(f, r["program"])
        except Exception as e:  # a malformed program is as bad as an invalid one
            ok, ans = False, f"{type(e).__name__}: {e}"
        if not ok:
            bad.append((r["id"], r["question"], r["program"], ans))
        else:
            r["answer"] = ans
    if bad:
        for b in bad:
            print("INVALID:", *b, file=sys.stderr)
        print(f"{len(bad)} invalid; hand_written.jsonl not written", file=sys.stderr)
        return 1
    write_jsonl(path, [ordered(r) for r in recs])
    summary(recs)
    return 0


def summary(recs):
    c = Counter(r["family_group"] for r in recs)
    for g in GROUP_ORDER:
        print(f"{g:26s} {c[g]:4d}")
    print(f"{'all':26s} {len(recs):4d}  families: {len({r['family'] for r in recs})}")
    yn = Counter(r["answer"] for r in recs if isinstance(r["answer"], bool))
    print("yes/no:", dict(yn), " counts:", sum(1 for r in recs if type(r["answer"]) is int))


def show(seed: int):
    f = Facts(SCENE_DIR / f"scene_{seed}.json")
    print(f"== scene {seed}: {f.n} objects")
    for o in f.objs:
        print(f" [{o.i}] {o.size} {o.color} {o.material} {o.subtype} ({o.cat})  pose={o.pose} {o.deg:.0f}"
              f"{' OCCLUDED by ' + str(list(o.occ_by)) if o.occluded else ''}")
        for raw, (c, m) in sorted(o.parts.items()):
            occ = o.part_occ.get(raw)
            print(f"      part {raw:22s} {c:7s} {m:7s}{' occluded by ' + str(list(occ)) if occ else ''}")
        for raw, by in sorted(o.part_occ.items()):
            if raw not in o.parts:
                print(f"      part {raw:22s} (not recoloured) occluded by {list(by)}")
    for r in RELS:
        print(f" {r:6s}: " + "  ".join(f"{i}:{sorted(s)}" for i, s in enumerate(f.rels[r])))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seed", type=int, default=7300)
    ap.add_argument("--hand", action="store_true", help="fill the answers of hand_written.jsonl")
    ap.add_argument("--show", type=int, nargs="*", help="print the facts of these scene seeds")
    a = ap.parse_args(argv)
    if a.show:
        for s in a.show:
            show(s)
        return 0
    if a.hand:
        return main_hand()
    main_generate(a.seed)
    return 0


if __name__ == "__main__":
    sys.exit(main())

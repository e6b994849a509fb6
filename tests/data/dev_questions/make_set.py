#!/usr/bin/env python
"""Development question set for the question parser: MODEL SELECTION ONLY (see README.md).

Written without reading our question templates, question generator, verbaliser, realiser, the parser's training
data code or any generated question file. The phrase lists below are this file's own, from general knowledge of
how people and the public CLEVR / Super-CLEVR / Super-CLEVR-3D datasets word questions. Programs follow the
conventions of ``tests/data/independent_questions/README.md`` (public filter order, canonical part names, ...).

    python tests/data/dev_questions/make_set.py             # generated.jsonl (deterministic from --seed)
    python tests/data/dev_questions/make_set.py --hand      # fills the answers of hand_written.jsonl
    python tests/data/dev_questions/make_set.py --scenes    # re-renders scenes 8000-8047, strips the RLE masks and
                                                             # checks that the stripped files give the same answers
    python tests/data/dev_questions/make_set.py --show 8003 # prints a scene's objects (to write questions by hand)
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import random
import re
import sys
from collections import Counter, defaultdict
from itertools import combinations, product
from pathlib import Path

from po3d_ppl import ontology as ont
from po3d_ppl.language import check_program, parse_program
from po3d_ppl.questions.executor import execute
from po3d_ppl.world.scene_io import load_scene

HERE = Path(__file__).resolve().parent
SEEDS = range(8000, 8048)
GROUPS = ("core_query", "core_count", "core_exist", "core_compare_attribute", "core_compare_integer",
          "core_same_relate", "core_spatial", "parts", "pose", "occlusion", "part_occlusion", "redundant",
          "synonyms_quirks_typos")
PER_GROUP = 118
TYPO_RATE = 0.03           # outside the synonyms group; that group gets many more (about 5% overall)
TYPO_RATE_SYN = 0.2


# ------------------------------------------------------------------------------------------------ scene facts

@dataclasses.dataclass
class Obj:
    i: int
    subtype: str
    cat: str
    color: str
    material: str
    size: str
    pose: str | None          # front/back/left/right, None in a dead zone
    deg: float
    parts: dict               # recoloured raw part name -> (colour, material)
    occluded: bool
    occluded_by: frozenset
    part_occ: dict            # occluded raw part name -> frozenset of occluders
    all_parts: tuple

    def val(self, slot):
        return {"size": self.size, "color": self.color, "material": self.material, "pose": self.pose}[slot]


class World:
    def __init__(self, scene, path: str):
        self.scene, self.path = scene, path
        self.objs = []
        for i, o in enumerate(scene.objects):
            label = ont.pose_label(o.pose_degree)
            occ = o.annotation.occlusion
            part_occ = {name: frozenset(a.occlusion.occluded_by) for name, a in o.part_annotations.items()
                        if a.occlusion.occluded}
            self.objs.append(Obj(i, o.subtype, ont.category_of(o.subtype), o.color, o.material, o.size,
                                 None if label == ont.NO_POSE else label[:-5], o.pose_degree,
                                 {n: (st.color, st.material) for n, st in o.parts.items()}, occ.occluded,
                                 frozenset(occ.occluded_by), part_occ, ont.PARTS[o.subtype]))
        self.all = frozenset(range(len(self.objs)))
        self.rel = {r: [frozenset(s) for s in scene.relationships[r]] for r in ont.RELATIONS}

    def same(self, attr, i):
        o = self.objs[i]
        if attr == "shape":
            return frozenset(j for j in self.all if j != i and self.objs[j].subtype == o.subtype)
        return frozenset(j for j in self.all if j != i and self.objs[j].val(attr) == o.val(attr))

    def pose_rel(self, kind, i):
        o = self.objs[i]
        if o.pose is None:
            return frozenset()
        return frozenset(j for j in self.all if j != i and
                         ont.pose_relation(o.deg, o.pose + "_pose", self.objs[j].deg) == kind)

    def occluding(self, i):        # the objects that i occludes
        return frozenset(j for j in self.all if i in self.objs[j].occluded_by)

    def occluders(self, i):        # the objects that occlude i
        return self.objs[i].occluded_by

    def occluded_parts_by(self, i):  # (object, raw part) pairs that object i occludes
        return [(j, p) for j in self.all for p, by in self.objs[j].part_occ.items() if i in by]

    def parts_all(self, i):          # object2part_all: recoloured and occluded parts
        o = self.objs[i]
        return set(o.parts) | set(o.part_occ)


# ------------------------------------------------------------------------------------------------ descriptions

OBJ_SLOTS = ("pose", "size", "color", "material", "shape")


def matches(o: Obj, d: dict) -> bool:
    for k, v in d.items():
        if k == "shape":
            if v not in (o.subtype, o.cat):
                return False
        elif o.val(k) != v:
            return False
    return True


def denote(w: World, d: dict, cands) -> frozenset:
    return frozenset(j for j in cands if matches(w.objs[j], d))


def true_options(o: Obj, slot: str, shape_kinds=("sub", "cat")):
    if slot == "shape":
        return ([o.subtype] if "sub" in shape_kinds else []) + ([o.cat] if "cat" in shape_kinds else [])
    v = o.val(slot)
    return [v] if v is not None else []


def all_descs(o: Obj, slots, shape_kinds=("sub", "cat")):
    opts = {s: true_options(o, s, shape_kinds) for s in slots}
    slots = [s for s in slots if opts[s]]
    for k in range(len(slots) + 1):
        for combo in combinations(slots, k):
            for values in product(*[opts[s] for s in combo]):
                yield dict(zip(combo, values))


def order(d: dict) -> dict:
    return {k: d[k] for k in OBJ_SLOTS if k in d}


def filters(d: dict) -> str:
    out = []
    for k in OBJ_SLOTS:
        if k in d:
            v = d[k] + "_pose" if k == "pose" else d[k]
            out.append(f" | filter_{k}[{v}]")
    return "".join(out)


# ------------------------------------------------------------------------------------------------ vocabulary
# (base words: the public synonyms and plain spellings; wide words: only in the synonyms/quirks group)

SIZE_W = {"large": (["large", "big"], ["huge", "giant", "massive", "bigger-sized"]),
          "small": (["small", "tiny"], ["little", "mini-sized", "smallish"])}
COLOR_W = {c: ([c], []) for c in ont.COLORS}
COLOR_W["gray"] = (["gray", "grey"], [])
MAT_W = {"metal": (["metal", "metallic", "shiny"], ["glossy", "reflective", "chrome"]),
         "rubber": (["rubber", "matte"], ["matt", "dull", "rubbery", "non-metallic"])}
MAT_NOUN = {"metal": (["metal"], ["a shiny metal", "metallic material"]),
            "rubber": (["rubber"], ["a matte rubber", "rubber material"])}
SUB_W = {
    "suv": (["suv", "SUV"], ["S.U.V.", "sport utility vehicle"]),
    "wagon": (["wagon"], ["station wagon", "estate car"]),
    "minivan": (["minivan"], ["mini van", "mini-van"]),
    "sedan": (["sedan"], ["saloon car"]),
    "truck": (["truck"], ["pickup truck", "pick-up truck"]),
    "articulated": (["articulated bus"], ["bendy bus", "articulated coach"]),
    "regular": (["regular bus"], ["normal bus", "ordinary bus"]),
    "double": (["double bus"], ["double-decker bus", "double decker bus", "double-decker"]),
    "school": (["school bus"], ["schoolbus", "school coach"]),
    "chopper": (["chopper"], ["chopper motorbike", "chopper motorcycle"]),
    "dirtbike": (["dirtbike", "dirt bike"], ["dirt-bike", "off-road motorbike"]),
    "scooter": (["scooter"], ["motor scooter", "moped"]),
    "cruiser": (["cruiser"], ["cruiser motorcycle", "cruiser bike"]),
    "jet": (["jet"], ["jet plane", "private jet"]),
    "fighter": (["fighter"], ["fighter jet", "fighter plane"]),
    "biplane": (["biplane"], ["bi-plane", "bi plane"]),
    "airliner": (["airliner"], ["passenger airliner", "air liner"]),
    "road": (["road bike"], ["roadbike", "road bicycle", "racing bike"]),
    "utility": (["utility bike"], ["utility bicycle", "city bike"]),
    "mountain": (["mountain bike"], ["mountainbike", "mountain bicycle", "MTB"]),
    "tandem": (["tandem bike"], ["tandem", "tandem bicycle"]),
}
# wide words that are risky as "same meaning" are kept rare: only the first two wide words are used normally
CAT_W = {"car": (["car"], ["automobile", "auto"]),
         "bus": (["bus"], ["coach"]),
         "motorbike": (["motorbike"], ["motorcycle", "motor bike"]),
         "aeroplane": (["aeroplane", "airplane"], ["plane", "aircraft"]),
         "bicycle": (["bicycle", "bike"], ["cycle", "push bike"])}
THING_W = (["thing", "object"], ["vehicle", "item", "one", "entity"])
HYPERNYM_BUSES = [s for s in ont.SUBTYPES if ont.category_of(s) == "bus"]
IRREGULAR_PL = {"bus": "buses", "coach": "coaches", "entity": "entities", "one": "ones", "S.U.V.": "S.U.V.s",
                "MTB": "MTBs", "aircraft": "aircraft", "double-decker": "double-deckers"}
QUIRK_PL = {"bus": ["buss", "busses"]}

REL_W = {"left": (["left of", "to the left of", "on the left side of"], ["on the left of", "leftward of"]),
         "right": (["right of", "to the right of", "on the right side of"], ["on the right of", "rightward of"]),
         "behind": (["behind"], ["in back of", "at the back of"]),
         "front": (["in front of"], ["in the front of", "located in front of"])}

# "facing ..." complements, per pose label
POSE_W = {
    "left": (["left", "to the left", "towards the left", "the left"], ["leftward", "leftwards", "toward the left side",
                                                                       "to the left pose"]),
    "right": (["right", "to the right", "towards the right", "the right"], ["rightward", "rightwards",
                                                                             "toward the right side",
                                                                             "to the right pose"]),
    "front": (["towards the camera", "toward the camera", "forward", "the camera", "front", "to the front"],
              ["towards us", "toward the viewer", "at the viewer", "to the front pose", "frontwards"]),
    "back": (["away from the camera", "away", "backward", "backwards", "the back", "back"],
             ["away from us", "away from the viewer", "to the back pose", "rearward"]),
}
POSE_VERB = (["facing", "pointing", "heading"], ["oriented", "turned", "pointed", "directed"])
POSE_VERB3 = {"facing": "faces", "pointing": "points", "heading": "heads", "oriented": "is oriented",
              "turned": "is turned", "pointed": "is pointed", "directed": "is directed"}

OCC_ADJ = (["occluded", "partially occluded", "partly hidden", "hidden"],
           ["obscured", "blocked from view", "partially covered", "not fully visible"])
OCC_BY = (["occluded by", "hidden by", "partially hidden by", "blocked by"],
          ["obscured by", "covered by", "partly covered by", "blocked from view by"])
OCC_VERB = (["occludes", "hides", "is occluding", "blocks"], ["obscures", "covers", "partly covers", "is hiding"])
OCC_VERB_PL = {"occludes": "occlude", "hides": "hide", "is occluding": "are occluding", "blocks": "block",
               "obscures": "obscure", "covers": "cover", "partly covers": "partly cover", "is hiding": "are hiding"}

# part-name word variants: (base variants, wide variants), applied to the readable words
PART_WORD_VARIANTS = {
    "head light": (["head light", "headlight"], ["head-light", "headlamp"]),
    "headlight": (["headlight", "head light"], ["head-light", "headlamp"]),
    "tail light": (["tail light", "taillight"], ["tail-light", "tail lamp"]),
    "taillight": (["taillight", "tail light"], ["tail-light", "tail lamp"]),
    "license plate": (["license plate"], ["licence plate", "licenseplate", "number plate", "license-plate"]),
    "gas tank": (["gas tank"], ["gastank", "fuel tank", "petrol tank"]),
    "drive chain": (["drive chain"], ["drivechain", "chain drive"]),
    "side stand": (["side stand", "sidestand"], ["kickstand", "kick stand", "side-stand"]),
    "crank arm": (["crank arm"], ["crankarm", "crank"]),
    "brake system": (["brake system"], ["brakes", "braking system", "brake"]),
    "rearlight": (["rearlight", "rear light"], ["rear-light", "back light"]),
    "windscreen": (["windscreen"], ["windshield", "wind screen"]),
    "tailplane": (["tailplane"], ["tail plane", "horizontal stabilizer"]),
    "fender": (["fender"], ["mudguard", "mud guard"]),
    "exhaust": (["exhaust"], ["exhaust pipe", "tailpipe"]),
    "handle": (["handle"], ["handlebar", "handle bar"]),
    "footrest": (["footrest"], ["foot rest", "foot peg"]),
    "hood": (["hood"], ["bonnet"]),
    "trunk": (["trunk"], ["boot"]),
    "propeller": (["propeller"], ["prop", "propellor"]),
    "fin": (["fin"], ["tail fin", "vertical stabilizer"]),
    "saddle": (["saddle"], ["bike seat"]),
    "carrier": (["carrier"], ["luggage carrier", "rack"]),
    "mirror": (["mirror"], ["side mirror", "wing mirror"]),
    "panel": (["panel"], ["side panel"]),
    "cover": (["cover"], ["fairing"]),
}
COMPOUND_PARTS = {"head_light", "headlight", "tail_light", "taillight", "license_plate", "side_stand", "rearlight",
                  "gas_tank", "drive_chain", "crank_arm", "brake_system", "windscreen", "tailplane", "footrest",
                  "exhaust"}
RARE_PARTS = {"side_stand", "rearlight", "carrier", "brake_system", "crank_arm", "footrest", "windscreen", "tailplane",
              "propeller", "fin", "license_plate", "gas_tank", "drive_chain", "exhaust", "taillight", "headlight"}
POS_VARIANTS = {"back": (["back"], ["rear"]), "center": (["center"], ["centre", "central", "middle"]),
                "mid": (["mid"], ["middle"]), "front": (["front"], [])}


# ------------------------------------------------------------------------------------------------ helpers

def article(phrase: str) -> str:
    low = phrase.lower()
    if phrase.startswith(("SUV", "S.U.V.", "MTB")):
        return "an " + phrase
    if low.startswith(("uni", "uti", "use", "one")):
        return "a " + phrase
    if low[:1] in "aeiou":
        return "an " + phrase
    return "a " + phrase


def plural(word: str, rng, quirks: bool) -> tuple[str, str | None]:
    parts = word.rsplit(" ", 1)
    head = parts[-1]
    note = None
    if head in QUIRK_PL and quirks and rng.random() < 0.7:
        p = rng.choice(QUIRK_PL[head])
        note = f"plural quirk '{p}'"
    elif head in IRREGULAR_PL:
        p = IRREGULAR_PL[head]
    elif head.endswith(("s", "x", "ch", "sh")):
        p = head + "es"
    else:
        p = head + "s"
    return (parts[0] + " " + p if len(parts) == 2 else p), note


def cap(s: str) -> str:
    return s[:1].upper() + s[1:]


KNOWN_WORDS: set[str] = set()   # filled lazily: words a typo must not produce


def all_words():
    if KNOWN_WORDS:
        return KNOWN_WORDS
    tables = [SIZE_W, COLOR_W, MAT_W, SUB_W, CAT_W, REL_W, POSE_W, PART_WORD_VARIANTS, POS_VARIANTS]
    for t in tables:
        for base, wide in t.values():
            for ph in base + wide:
                KNOWN_WORDS.update(ph.lower().split())
    KNOWN_WORDS.update(w for n in ont.RAW_PART_NAMES for w in n.split("_"))
    KNOWN_WORDS.update(["rod", "lift", "bug", "bis", "car", "cat", "cars", "care", "red", "bed", "tan", "ran",
                        "thin", "think", "thins", "things", "object", "objects", "the", "than", "that", "then",
                        "metal", "petal", "medal", "rubber", "robber", "large", "barge", "small", "smell", "blue",
                        "glue", "left", "loft", "lest", "right", "night", "light", "fight", "sight", "wight",
                        "front", "font", "frond", "behind", "bending", "many", "man", "may", "mane", "any",
                        "same", "some", "game", "name", "came", "side", "size", "sizes", "site", "color", "colon",
                        "what", "that", "with", "wish", "part", "park", "pert", "port", "cart", "dart"])
    return KNOWN_WORDS


def make_typo(question: str, rng) -> tuple[str, str] | None:
    """One edit (delete, insert, substitute, transpose) in one content word of length >= 4."""
    words = question.split(" ")
    idx = [k for k, w in enumerate(words) if sum(ch.isalpha() for ch in w) >= 4 and w.strip("?;,.").isalpha()]
    rng.shuffle(idx)
    letters = "abcdefghijklmnopqrstuvwxyz"
    for k in idx[:6]:
        raw = words[k]
        core = raw.rstrip("?;,.")
        tail = raw[len(core):]
        for _ in range(10):
            op = rng.choice(["del", "ins", "sub", "swap"])
            p = rng.randrange(1, len(core))  # never the first letter
            if op == "del":
                new = core[:p] + core[p + 1:]
            elif op == "ins":
                new = core[:p] + rng.choice(letters) + core[p:]
            elif op == "sub":
                new = core[:p] + rng.choice(letters) + core[p + 1:]
            else:
                if p >= len(core) - 1:
                    continue
                new = core[:p] + core[p + 1] + core[p] + core[p + 2:]
            if new.lower() == core.lower() or new.lower() in all_words():
                continue
            words[k] = new + tail
            return " ".join(words), f"typo: {core} -> {new}"
    return None


# ------------------------------------------------------------------------------------------------ the generator

class NoQuestion(Exception):
    pass


class Gen:
    def __init__(self, rng: random.Random, worlds: list[World]):
        self.rng = rng
        self.worlds = worlds
        self.wide = False        # wider synonyms, quirks
        self.redundant = False   # descriptions with extra true attributes
        self.notes: list[str] = []

    # ---- choice helpers
    def pick(self, table_entry, p_wide=0.55):
        base, wide = table_entry
        if self.wide and wide and self.rng.random() < p_wide:
            w = self.rng.choice(wide)
            self.notes.append(f"wide: {w}")
            return w
        return self.rng.choice(base)

    def choice(self, seq):
        return self.rng.choice(seq)

    # ---- descriptions
    def describe(self, w: World, i: int, cands, exclude=(), slots=("size", "color", "material", "shape"),
                 require=(), shape_kinds=("sub", "cat"), min_denotation_all=1):
        """Shortest description of object i that singles it out within cands (random among the shortest);
        in redundant mode, one or two extra true attributes. ``require``: slots that must be present and needed.
        ``min_denotation_all``: the description must select at least that many objects scene-wide."""
        o = w.objs[i]
        slots = [s for s in slots if s not in exclude]
        best, best_len = [], None
        for d in all_descs(o, slots, shape_kinds):
            if best_len is not None and len(d) > best_len:
                break
            if any(r not in d for r in require):
                continue
            if denote(w, d, cands) != {i}:
                continue
            if len(denote(w, d, w.all)) < min_denotation_all:
                continue
            if any(denote(w, {k: v for k, v in d.items() if k != r}, cands) == {i} for r in require):
                continue
            best.append(d)
            best_len = len(d)
        if not best:
            raise NoQuestion("no unique description")
        d = dict(self.choice(best))
        if self.redundant:
            d = self.add_redundant(o, d, slots, allow_pose="pose" not in exclude)
        return order(d)

    def add_redundant(self, o: Obj, d: dict, slots, allow_pose=True):
        if self.rng.random() < 0.3 and "redundant" in " ".join(self.notes):
            return d   # the other referent already carries the redundancy
        free = [s for s in slots if s not in d and s != "pose" and true_options(o, s)]
        if allow_pose and "pose" not in d and o.pose is not None and self.rng.random() < 0.2:
            free.append("pose")
        if "shape" in d and d["shape"] == o.cat and "shape" in slots and self.rng.random() < 0.3:
            d["shape"] = o.subtype   # a more specific word than needed
            self.notes.append("redundant: subtype for category")
        if not free:
            if "redundant" not in " ".join(self.notes):
                raise NoQuestion("nothing to add")
            return d
        k = 1 if len(free) == 1 or self.rng.random() < 0.6 else 2
        for s in self.rng.sample(free, k):
            d[s] = self.choice(true_options(o, s))
        self.notes.append("redundant: +" + "+".join(s for s in OBJ_SLOTS if s in d))
        return d

    def set_desc(self, w: World, cands, min_size=0, nonempty=True, slots=("size", "color", "material", "shape"),
                 max_slots=2, from_obj=True):
        """A description for counting / existence: attributes of a real object (or a random combination)."""
        for _ in range(30):
            if from_obj and cands and self.rng.random() < 0.8:
                o = w.objs[self.choice(sorted(cands))]
                ds = [d for d in all_descs(o, slots) if (len(d) >= 1 if nonempty else True) and len(d) <= max_slots]
                d = self.choice(ds) if ds else {}
            else:
                d = self.random_desc(slots, max_slots, nonempty)
            if len(denote(w, d, cands)) >= min_size:
                return order(d)
        raise NoQuestion("no set description")

    def random_desc(self, slots, max_slots=2, nonempty=True):
        k = self.rng.randint(1 if nonempty else 0, max_slots)
        chosen = self.rng.sample(list(slots), min(k, len(slots)))
        d = {}
        for s in chosen:
            if s == "size":
                d[s] = self.choice(ont.SIZES)
            elif s == "color":
                d[s] = self.choice(ont.COLORS)
            elif s == "material":
                d[s] = self.choice(ont.MATERIALS)
            elif s == "shape":
                d[s] = self.choice(ont.SUBTYPES if self.rng.random() < 0.5 else ont.CATEGORIES)
            elif s == "pose":
                d[s] = self.choice(ont.POSES)
        return d

    # ---- words
    def shape_word(self, shape):
        if shape is None:
            return self.pick(THING_W, 0.5)
        if shape in SUB_W:
            return self.pick(SUB_W[shape], 0.5)
        return self.pick(CAT_W[shape], 0.5)

    def pose_phrase(self, pose, verb=None):
        """'facing left' / 'pointing towards the camera' (participle)."""
        v = verb or self.pick(POSE_VERB, 0.4)
        base, wide = POSE_W[pose]
        if v != "facing":   # "pointing the camera", "heading front" are not English
            base = [c for c in base if not c.startswith("the ") and c not in ("front", "back")]
            wide = [c for c in wide if not c.startswith(("the ", "at the"))]
        comp = self.pick((base, wide))
        if v in ("oriented", "turned", "pointed", "directed") and comp in ("left", "right"):
            comp = "to the " + comp
        return v, comp

    def np(self, d: dict, det="the", pl=False, clause_p=0.2, pose_free=False, force_adj=False):
        """A noun phrase for description d. det: 'the', 'a', '' (bare, plural); pl: plural noun."""
        pre, preds, whose = [], [], []
        for slot in ("size", "color", "material"):
            if slot not in d:
                continue
            v = d[slot]
            table = {"size": SIZE_W, "color": COLOR_W, "material": MAT_W}[slot][v]
            r = self.rng.random()
            if force_adj or r > clause_p:
                pre.append(self.pick(table))
            elif slot == "material" and r < clause_p * 0.5:
                preds.append(("made of " if self.rng.random() < 0.8 else "made out of ") + self.pick(MAT_NOUN[v]))
            elif r < clause_p * 0.3 and not pl:
                word = {"size": "size", "color": self.choice(["color", "colour"]), "material": "material"}[slot]
                whose.append(f"whose {word} is {self.choice(table[0])}")
            else:
                preds.append(self.pick(table))
        noun = self.shape_word(d.get("shape"))
        note = None
        if pl:
            noun, note = plural(noun, self.rng, self.wide)
            if note:
                self.notes.append(note)
        head = " ".join(pre + [noun])
        tail = []
        be = "are" if pl else "is"
        rel = self.choice(["that", "which"]) if not pl else "that"
        if preds:
            tail.append(f"{rel} {be} " + " and ".join(preds))
        if "pose" in d:
            v, comp = self.pose_phrase(d["pose"])
            style = self.rng.random()
            if style < 0.4:
                tail.append(f"{v} {comp}")
            elif style < 0.7:
                tail.append(f"{rel} {be} {v} {comp}")
            else:
                verb3 = POSE_VERB3[v]
                if pl:
                    verb3 = {"faces": "face", "points": "point", "heads": "head"}.get(verb3, verb3.replace("is ", "are "))
                tail.append(f"{rel} {verb3} {comp}")
        tail += whose
        phrase = head + (" " + " and ".join(tail) if len(tail) > 1 and all(t.startswith(rel) for t in tail)
                         else (" " + ", ".join(tail) if len(tail) > 1 else (" " + tail[0] if tail else "")))
        if det == "the":
            return "the " + phrase
        if det == "a":
            return article(phrase)
        return phrase

    def the(self, d, **kw):
        return self.np(d, "the", **kw)

    def a(self, d, **kw):
        return self.np(d, "a", **kw)

    def pl(self, d, **kw):
        return self.np(d, "", pl=True, **kw)

    def poss(self, d):
        """Possessive "the red car's", only for noun phrases without clauses."""
        if "pose" in d:
            raise NoQuestion("possessive of a pose clause")
        s = self.np(d, "the", clause_p=0.0)
        if " that " in s or " which " in s or " whose " in s:
            raise NoQuestion("long possessive")
        return s + ("'" if s.endswith("s") and self.rng.random() < 0.3 else "'s")

    def rel_words(self, r):
        return self.pick(REL_W[r], 0.5)

    # ---- part names
    def part_words(self, raw: str | None = None, sup: str | None = None) -> str:
        """Words for a raw part name (its readable name, or a respelling) or for a super-part name."""
        if raw is not None:
            r = self.rng.random()
            p_raw, p_spaced = (0.15, 0.12) if self.wide else (0.07, 0.05)
            if r < p_raw:
                self.notes.append("raw part spelling")
                return raw
            if r < p_raw + p_spaced:
                self.notes.append("spaced raw part spelling")
                return raw[:-2].replace("_", " ") if raw.endswith("_s") else raw.replace("_", " ")
            words = ont.readable_name(raw)
        else:
            words = sup.replace("_", " ")
        toks = words.split(" ")
        k = 0
        while k < len(toks) - 1 and toks[k] in POS_VARIANTS:
            k += 1
        pos, noun = toks[:k], " ".join(toks[k:])
        if noun in PART_WORD_VARIANTS:
            noun = self.pick(PART_WORD_VARIANTS[noun], 0.6)
        out_pos = []
        for p in pos:
            if not self.wide and p == "back" and self.rng.random() < 0.15:
                out_pos.append("rear")
                self.notes.append("rear for back")
            else:
                out_pos.append(self.pick(POS_VARIANTS[p], 0.5))
        if len(out_pos) == 2 and self.rng.random() < 0.15:
            return "-".join(out_pos) + " " + noun
        return " ".join(out_pos + [noun])

    # ---- sampling helpers
    def pick_part(self, names):
        """A part name, compound names (head light, side stand, rearlight ...) four times as likely."""
        names = sorted(names)
        weights = [4 if ont.super_part_name(n) in COMPOUND_PARTS else 1 for n in names]
        return self.rng.choices(names, weights)[0]

    def world(self):
        return self.choice(self.worlds)

    def obj(self, w: World, pred=None):
        cands = [o.i for o in w.objs if pred is None or pred(o)]
        if not cands:
            raise NoQuestion("no object")
        return self.choice(cands)


def part_value(raw: str) -> str:
    return ont.canonical_part_name(raw)


def super_value(raw: str) -> str:
    sp = ont.super_part_name(raw)
    return ont.canonical_part_name(sp) if sp in ont.RAW_PART_NAMES else sp


def supers_of(subtype: str, sp: str) -> list[str]:
    return [r for r in ont.PARTS[subtype] if ont.super_part_name(r) == sp]


# ------------------------------------------------------------------------------------------------ phrase lists

Q_ATTR = {
    "color": [
        "What color is {X}?", "What is the color of {X}?", "What colour is {X}?", "{X} is what color?",
        "There is {aX}; what color is it?", "What is {Xp} color?", "Tell me the color of {X}.",
        "Which color does {X} have?", "What color does {X} have?", "Can you tell me what color {X} is?",
        "What's the colour of {X}?", "Of what color is {X}?", "I see {aX}. What color is it?",
        "What color has {X} been painted?", "The color of {X} is what?", "What is the colour of {X}?",
        "Which colour is {X}?", "There is {aX}. What is its color?",
    ],
    "material": [
        "What material is {X}?", "What is {X} made of?", "What is the material of {X}?",
        "What is {X} made out of?", "Is {X} metal or rubber?", "Is {X} made of rubber or metal?",
        "Is {X} shiny or matte?", "What kind of material is {X} made of?", "What type of material is {X}?",
        "There is {aX}; what is it made of?", "What's {X} made of?", "Which material is {X}?",
        "{X} is made of what material?", "What material does {X} consist of?", "What is {Xp} material?",
        "There is {aX}. What material is it?", "Tell me what {X} is made of.",
    ],
    "size": [
        "What size is {X}?", "How big is {X}?", "What is the size of {X}?", "Is {X} large or small?",
        "Is {X} big or small?", "Is {X} small or large?", "There is {aX}; what size is it?", "How large is {X}?",
        "What is {Xp} size?", "{X} is what size?", "Which size is {X}?", "What's the size of {X}?",
        "Tell me the size of {X}.", "There is {aX}. How big is it?", "Is {X} a big or a small one?",
    ],
    "shape": [
        "What shape is {X}?", "What is {X}?", "What kind of vehicle is {X}?", "What type of object is {X}?",
        "What is the shape of {X}?", "There is {aX}; what is it?", "There is {aX}; what shape is it?",
        "What is {Xp} shape?", "Which type of vehicle is {X}?", "What sort of thing is {X}?",
        "What is the name of {X}?", "What kind of thing is {X}?", "What type of vehicle is {X}?",
        "What exactly is {X}?", "Which kind of object is {X}?", "There is {aX}. What type of vehicle is it?",
    ],
}
# "What {q} is ..." words and "the {qn} of" nouns per queried attribute
Q_WORD = {"color": ["color", "colour"], "material": ["material"], "size": ["size"], "shape": ["shape", "type"]}
Q_NOUN = {"color": ["color", "colour"], "material": ["material"], "size": ["size"], "shape": ["shape", "type", "name"]}

COUNT_T = [
    "How many {Xs} are there?", "How many {Xs} are in the scene?", "What number of {Xs} are there?",
    "How many {Xs} can you see?", "Count the {Xs}.", "What is the number of {Xs}?", "How many {Xs} are present?",
    "How many {Xs} do you see in the picture?", "Tell me how many {Xs} there are.",
    "What's the total number of {Xs}?", "How many {Xs} are in the image?", "What is the count of {Xs}?",
    "Can you count the {Xs}?", "How many {Xs} does the scene contain?", "In the image, how many {Xs} are there?",
    "How many {Xs} exist in the scene?",
]
COUNT_PRED_T = ["How many {Ns} are {pred}?", "How many of the {Ns} are {pred}?", "What number of {Ns} are {pred}?",
                "How many {Ns} in the scene are {pred}?", "Count the {Ns} that are {pred}."]
COUNT_ALL_T = ["How many objects are there?", "How many things are in the scene?",
               "How many vehicles are there in total?", "What is the total number of objects?",
               "Count all the objects.", "How many objects are in the image?", "How many things are there?",
               "What number of objects can you see?", "How many items are shown in the picture?",
               "Count the things in the scene."]
COUNT_OR_T = ["How many things are {Xs} or {Ys}?", "How many objects are either {Xs} or {Ys}?",
              "What number of things are {Xs} or {Ys}?", "How many {Xs} or {Ys} are there?",
              "What is the total number of {Xs} and {Ys}?", "Count the {Xs} and the {Ys} together.",
              "How many objects are {Xs} or {Ys}?", "How many things are either {Xs} or {Ys}?"]
EXIST_T = [
    "Are there any {Xs}?", "Is there {aX}?", "Does the scene contain {aX}?", "Do you see any {Xs}?",
    "Are any {Xs} present?", "Does {aX} exist in the scene?", "Can you see {aX}?", "Are there {Xs} in the scene?",
    "Is there at least one {X1}?", "Are there any {Xs} in the image?", "Is {aX} present in the scene?",
    "Does the image show any {Xs}?", "Is there {aX} anywhere?", "Is there {aX} in the picture?",
    "Are there any {Xs} in the picture?",
]
EXIST_PRED_T = ["Is anything {pred}?", "Is there anything {pred}?", "Is any {N} {pred}?", "Are any of the {Ns} {pred}?",
                "Is there {aN} that is {pred}?", "Are there any {Ns} that are {pred}?", "Is any object {pred}?"]

CMP_T = {
    "color": ["Is {A} the same color as {B}?", "Does {A} have the same color as {B}?",
              "Do {A} and {B} have the same color?", "Are {A} and {B} the same color?",
              "Is the color of {A} the same as the color of {B}?", "Is {A} colored the same as {B}?",
              "Does {A} match {B} in color?", "Are {A} and {B} of the same colour?",
              "There is {aA}; does it have the same color as {B}?", "Is {A} the same colour as {B}?",
              "Do {A} and {B} share the same color?", "Is {A} painted the same color as {B}?",
              "Are {A} and {B} identical in color?", "Is {Ap} color the same as {Bp}?"],
    "material": ["Is {A} made of the same material as {B}?", "Do {A} and {B} have the same material?",
                 "Are {A} and {B} made of the same material?", "Is {A} the same material as {B}?",
                 "Does {A} have the same material as {B}?", "Is the material of {A} the same as that of {B}?",
                 "There is {aA}; is it made of the same material as {B}?", "Do {A} and {B} share a material?",
                 "Are {A} and {B} of the same material?", "Is {Ap} material the same as {Bp}?",
                 "Are {A} and {B} both made of the same material?"],
    "size": ["Is {A} the same size as {B}?", "Are {A} and {B} the same size?", "Do {A} and {B} have the same size?",
             "Does {A} have the same size as {B}?", "Is the size of {A} equal to the size of {B}?",
             "There is {aA}; is it the same size as {B}?", "Are {A} and {B} equally sized?",
             "Is {A} equal in size to {B}?", "Do {A} and {B} match in size?", "Is {Ap} size the same as {Bp}?"],
    "shape": ["Is {A} the same shape as {B}?", "Do {A} and {B} have the same shape?",
              "Are {A} and {B} the same type of vehicle?", "Is {A} the same kind of vehicle as {B}?",
              "Are {A} and {B} the same kind of object?", "Is {A} the same type of object as {B}?",
              "Does {A} have the same shape as {B}?", "There is {aA}; is it the same shape as {B}?",
              "Are {A} and {B} the same model?", "Is {Ap} shape the same as {Bp}?"],
}

INT_T = {
    "greater_than": ["Are there more {Xs} than {Ys}?", "Is the number of {Xs} greater than the number of {Ys}?",
                     "Do {Xs} outnumber {Ys}?", "Is the number of {Xs} larger than the number of {Ys}?",
                     "Are {Xs} more numerous than {Ys}?", "Are there more {Xs} in the scene than {Ys}?",
                     "Is the count of {Xs} bigger than that of {Ys}?", "Are there a greater number of {Xs} than {Ys}?",
                     "Is the number of {Xs} bigger than the number of {Ys}?",
                     "Does the scene have more {Xs} than {Ys}?", "Do the {Xs} outnumber the {Ys}?"],
    "less_than": ["Are there fewer {Xs} than {Ys}?", "Are there less {Xs} than {Ys}?",
                  "Is the number of {Xs} less than the number of {Ys}?",
                  "Is the number of {Xs} smaller than the number of {Ys}?", "Are {Xs} less numerous than {Ys}?",
                  "Are there fewer {Xs} in the scene than {Ys}?", "Is the count of {Xs} lower than that of {Ys}?",
                  "Does the scene contain fewer {Xs} than {Ys}?", "Are there a smaller number of {Xs} than {Ys}?",
                  "Do {Xs} number fewer than {Ys}?"],
    "equal_integer": ["Are there the same number of {Xs} and {Ys}?",
                      "Is the number of {Xs} the same as the number of {Ys}?", "Are there as many {Xs} as {Ys}?",
                      "Is the number of {Xs} equal to the number of {Ys}?",
                      "Are there an equal number of {Xs} and {Ys}?", "Is the count of {Xs} equal to that of {Ys}?",
                      "Does the scene have just as many {Xs} as {Ys}?", "Are there equally many {Xs} and {Ys}?",
                      "Do the {Xs} and the {Ys} come in equal numbers?",
                      "Is there the same amount of {Xs} as {Ys}?"],
}

SAME_PHRASE = {"color": ["the same color as", "the same colour as"],
               "material": ["made of the same material as", "the same material as"],
               "size": ["the same size as"], "shape": ["the same shape as"]}
SAME_NOUN = {"color": ["color", "colour"], "material": ["material"], "size": ["size"], "shape": ["shape"]}
SAME_COUNT_T = ["How many other {Ys} are {same} {X}?", "How many other {Ys} have the same {an} as {X}?",
                "There is {aX}; how many other {Ys} are {same} it?", "What number of other {Ys} are {same} {X}?",
                "How many {Ys} share {Xp} {an}?", "How many {Ys} besides {X} are {same} it?",
                "Count the other {Ys} that have the same {an} as {X}.",
                "How many {Ys} other than {X} have the same {an}?", "How many {Ys} are {same} {X}?",
                "There is {aX}. How many other {Ys} have the same {an} as it?"]
SAME_EXIST_T = ["Is there another {Y} that is {same} {X}?", "Are there any other {Ys} that are {same} {X}?",
                "Is there any other {Y} with the same {an} as {X}?", "There is {aX}; is there another {Y} {same} it?",
                "Is there another {Y} that has the same {an} as {X}?",
                "Do any other {Ys} have the same {an} as {X}?", "Are there other {Ys} {same} {X}?"]
SAME_EXIST_EMPTY_T = ["Is there anything else {same} {X}?", "Does anything else have the same {an} as {X}?",
                      "Is anything else {same} {X}?", "There is {aX}; is anything else {same} it?",
                      "Is there any other object that has the same {an} as {X}?"]
SAME_QUERY_T = ["What {q} is the other {Yn} that is {same} {X}?",
                "What is the {qn} of the other {Yn} that has the same {an} as {X}?",
                "There is another {Yn} that is {same} {X}; what {q} is it?",
                "The other {Yn} that is {same} {X} is what {q}?",
                "What {q} is the {Yn} that has the same {an} as {X}?",
                "What is the {qn} of the {Yn} that shares {Xp} {an}?",
                "There is {aX}; what {q} is the other {Yn} that is {same} it?"]

REL_COUNT_T = ["How many {Ys} are {rel} {X}?", "There is {aX}; how many {Ys} are {rel} it?",
               "What number of {Ys} are {rel} {X}?", "Count the {Ys} {rel} {X}.",
               "How many {Ys} are there {rel} {X}?", "What is the number of {Ys} {rel} {X}?",
               "How many {Ys} can be seen {rel} {X}?", "There is {aX}. How many {Ys} are {rel} it?",
               "How many {Ys} are located {rel} {X}?"]
REL_EXIST_T = ["Are there any {Ys} {rel} {X}?", "Is there {aY} {rel} {X}?",
               "There is {aX}; are there any {Ys} {rel} it?", "Is {aY} {rel} {X}?",
               "Are any {Ys} {rel} {X}?", "Is there {aY} that is {rel} {X}?", "Do you see {aY} {rel} {X}?"]
REL_EXIST_EMPTY_T = ["Is there anything {rel} {X}?", "Is anything {rel} {X}?", "Is there an object {rel} {X}?",
                     "There is {aX}; is there anything {rel} it?", "Are there any objects {rel} {X}?"]
REL_QUERY_T = ["What {q} is the {Yn} {rel} {X}?", "What is the {qn} of the {Yn} that is {rel} {X}?",
               "There is {aY} {rel} {X}; what {q} is it?", "The {Yn} {rel} {X} is what {q}?",
               "What {q} is the {Yn} that is {rel} {X}?", "What is the {qn} of the {Yn} {rel} {X}?",
               "There is {aX}; what {q} is the {Yn} {rel} it?"]
REL_QUERY_SHAPE_T = ["What is the {Yn} {rel} {X}?", "What kind of vehicle is {rel} {X}?",
                     "What is the {Yn} that is {rel} {X}?", "Which type of object is the {Yn} {rel} {X}?"]
TWO_HOP_QUERY_T = ["What {q} is the {Zn} {rel2} the {Yn} that is {rel1} {X}?",
                   "There is {aY} {rel1} {X}; what {q} is the {Zn} {rel2} it?",
                   "What is the {qn} of the {Zn} that is {rel2} the {Yn} {rel1} {X}?",
                   "There is {aY} that is {rel1} {X}; what is the {qn} of the {Zn} that is {rel2} it?"]
TWO_HOP_COUNT_T = ["How many {Zs} are {rel2} the {Yn} that is {rel1} {X}?",
                   "There is {aY} {rel1} {X}; how many {Zs} are {rel2} it?",
                   "What number of {Zs} are {rel2} the {Yn} {rel1} {X}?"]
AND_COUNT_T = ["How many {Zs} are {rel1} {X} and {rel2} {Y}?", "How many {Zs} are both {rel1} {X} and {rel2} {Y}?",
               "What number of {Zs} are {rel1} {X} and also {rel2} {Y}?",
               "How many {Zs} are {rel1} {X} as well as {rel2} {Y}?"]

PART_Q_T = {
    "color": ["What color is the {P} of {X}?", "What is the color of {Xp} {P}?", "What color is {Xp} {P}?",
              "What colour is the {P} on {X}?", "There is {aX}; what color is its {P}?",
              "What is the color of the {P} of {X}?", "Which color does the {P} of {X} have?",
              "Tell me the color of {Xp} {P}.", "The {P} of {X} is what color?",
              "What color is the {P} belonging to {X}?", "What color is the {P} that belongs to {X}?",
              "{X} has a {P}; what color is it?", "What is the colour of the {P} on {X}?"],
    "material": ["What material is the {P} of {X}?", "What is the {P} of {X} made of?",
                 "What is {Xp} {P} made of?", "What is the material of the {P} of {X}?",
                 "Is the {P} of {X} metal or rubber?", "There is {aX}; what is its {P} made of?",
                 "What material is {Xp} {P}?", "Is {Xp} {P} shiny or matte?",
                 "What material is the {P} that belongs to {X}?", "What is the {P} on {X} made out of?",
                 "{X} has a {P}; what material is it?"],
}
PART_NAME_T = ["Which part of {X} is {pd}?", "What is the name of the {pdadj} part of {X}?",
               "What part of {X} is {pd}?", "Name the {pdadj} part of {X}.", "What is the {pdadj} part of {X} called?",
               "What is the name of {Xp} {pdadj} part?", "There is a {pdadj} part on {X}; which part is it?",
               "{X} has a {pdadj} part; what is it called?", "Which part of {X} has the {pdnoun}?",
               "Which of {Xp} parts is {pd}?"]
HAS_T = ["What {q} is the {Xn} that has {aP}?", "What is the {qn} of the {Xn} that has {aP}?",
         "What {q} is the {Xn} with {aP}?", "The {Xn} that has {aP} is what {q}?",
         "What {q} is the {Xn} which has {aP}?", "There is {aXn} with {aP}; what {q} is it?",
         "What is the {qn} of the {Xn} with {aP}?"]
WHOSE_T = ["What {q} is the {Xn} whose {Pn} is {pd}?", "What is the {qn} of the {Xn} whose {Pn} is {pd}?",
           "The {Xn} whose {Pn} is {pd} is what {q}?", "There is {aXn} whose {Pn} is {pd}; what {q} is it?"]
HAS_SHAPE_EMPTY_T = ["Which vehicle has {aP}?", "What kind of vehicle has {aP}?", "What type of object has {aP}?",
                     "Which object has {aP}?", "What has {aP}?"]
SAME_OBJ_T = ["What {q} is the {P1} that belongs to the same object as the {P2}?",
              "What is the {qn} of the {P1} that belongs to the same object as the {P2}?",
              "What {q} is the {P1} of the object that has the {P2}?",
              "What {q} is the {P1} on the same vehicle as the {P2}?",
              "The {P2} and the {P1} are on the same object; what {q} is the {P1}?",
              "What is the {qn} of the {P1} of the thing with the {P2}?"]
SAME_OBJ_NAME_T = ["What is the name of the {pdadj} part that belongs to the same object as the {P2}?",
                   "Which {pdadj} part is on the same object as the {P2}?",
                   "What is the {pdadj} part of the object that has the {P2} called?",
                   "Which part is {pd} on the vehicle that has the {P2}?"]
PART_COUNT_T = ["How many {pdadj} parts does {X} have?", "How many parts of {X} are {pd}?",
                "What number of {Xp} parts are {pd}?", "Count the {pdadj} parts of {X}.",
                "How many {pdadj} parts are on {X}?"]
PART_EXIST_T = ["Does {X} have any {pdadj} parts?", "Does {X} have a {pdadj} part?", "Is any part of {X} {pd}?",
                "Are any of {Xp} parts {pd}?", "Is there a {pdadj} part on {X}?"]
PART_EXIST_NAMED_T = ["Does {X} have a {pdadj} {Pn}?", "Is the {Pn} of {X} {pd}?" , "Is there a {pdadj} {Pn} on {X}?"]
OWNERS_COUNT_T = ["How many objects have a {pdadj} {Pn}?", "How many things have {aP}?",
                  "What number of vehicles have {aP}?", "How many {Xs} have {aP}?"]

QUERY_POSE_T = ["Which direction is {X} facing?", "What direction is {X} facing?", "Which way is {X} facing?",
                "Which way does {X} face?", "What direction does {X} point?", "Which direction is {X} pointing?",
                "Where is {X} facing?", "What is the orientation of {X}?", "Which direction the {Xn} is facing?",
                "In which direction is {X} heading?", "Which direction does {X} face?",
                "What is the facing direction of {X}?", "Which way is {X} pointed?",
                "There is {aX}; which direction is it facing?", "Which way is {X} heading?",
                "Is {X} facing left, right, towards the camera or away from it?", "What direction is {X} pointed in?"]
POSE_REL = {
    "same": (["faces the same direction as", "is facing the same way as", "points in the same direction as",
              "faces the same way as", "has the same orientation as"],
             ["is oriented the same way as", "has the same heading as", "is aligned in the same direction as",
              "heads the same way as"]),
    "opposite": (["faces the opposite direction as", "faces the opposite direction to", "is facing the opposite way from",
                  "points in the opposite direction to", "has the opposite orientation to", "faces opposite to"],
                 ["is turned the opposite way to", "is heading the other way from", "points the other way from",
                  "faces the reverse direction of"]),
    "vertical": (["faces the vertical direction as", "is perpendicular to", "faces perpendicular to",
                  "is at a right angle to", "faces a direction perpendicular to", "is facing perpendicular to"],
                 ["is orthogonal to", "points at ninety degrees to", "is oriented at 90 degrees to",
                  "is at right angles to"]),
}
POSE_REL_QUERY_T = ["What {q} is the {Yn} that {prel} {X}?", "What is the {qn} of the {Yn} that {prel} {X}?",
                    "There is {aY} that {prel} {X}; what {q} is it?", "The {Yn} that {prel} {X} is what {q}?",
                    "What {q} is the {Yn} which {prel} {X}?"]
POSE_REL_COUNT_T = ["How many {Ys} {prelpl} {X}?", "What number of {Ys} {prelpl} {X}?",
                    "Count the {Ys} that {prelpl} {X}.", "How many other {Ys} {prelpl} {X}?",
                    "There is {aX}; how many {Ys} {prelpl} it?"]
POSE_REL_EXIST_T = ["Is there {aY} that {prel} {X}?", "Are there any {Ys} that {prelpl} {X}?",
                    "Does any {Yn} {prelinf} {X}?", "There is {aX}; is there {aY} that {prel} it?"]

OCC_QUERY_T = ["What {q} is the {Xn} that is {occ}?", "What is the {qn} of the {occ} {Xn}?",
               "What {q} is the {occ} {Xn}?", "There is {aocc} {Xn}; what {q} is it?",
               "What is the {qn} of the {Xn} that is {occ}?", "The {Xn} that is {occ} is what {q}?"]
OCC_BY_QUERY_T = ["What {q} is the {Xn} that is {occby} {Y}?", "What is the {qn} of the {Xn} {occby} {Y}?",
                  "{Y} {occverb} {aX}; what {q} is it?", "There is {aX} {occby} {Y}; what {q} is it?",
                  "The {Xn} {occby} {Y} is what {q}?", "What {q} is the {Xn} that {Y} {occverb}?"]
OCC_BYQ_SHAPE_T = ["What is {occby} {Y}?", "What is the {Xn} that is {occby} {Y}?",
                   "What does {Y} {occverbinf}?", "Which object is {occby} {Y}?"]
OCCLUDES_QUERY_T = ["What {q} is the {Xn} that {occverb} {Y}?", "What is the {qn} of the {Xn} that {occverb} {Y}?",
                    "{Y} is {occby} {aX}; what {q} is it?", "The {Xn} that {occverb} {Y} is what {q}?",
                    "What {q} is the {Xn} {occing} {Y}?"]
OCCLUDES_SHAPE_T = ["What is {occing} {Y}?", "What {occverb} {Y}?", "Which object {occverb} {Y}?",
                    "What is the {Xn} that {occverb} {Y}?"]
OCC_EXIST_T = ["Is {X} occluded?", "Is {X} partially hidden?", "Is {X} hidden by another object?",
               "Is {X} partly occluded?", "Is {X} occluded by something?", "Is {X} blocked from view?",
               "Is {X} partially covered by another object?", "Is {X} an occluded object?"]
OCCLUDER_EXIST_T = ["Is anything occluding {X}?", "Is there something that occludes {X}?",
                    "Does any object occlude {X}?", "Is there an object hiding {X}?", "Does something block {X}?"]
OCC_COUNT_T = ["How many {occ} {Xs} are there?", "How many {Xs} are {occ}?", "What number of {Xs} are {occ}?",
               "Count the {occ} {Xs}.", "How many of the {Xs} are {occ}?"]
OCCLUDING_COUNT_T = ["How many {Ys} does {X} occlude?", "How many {Ys} are {occby} {X}?",
                     "What number of {Ys} are hidden by {X}?", "How many {Ys} is {X} occluding?",
                     "Count the {Ys} that {X} {occverb}."]
OCCLUDER_COUNT_T = ["How many {Ys} occlude {X}?", "How many {Ys} are occluding {X}?",
                    "By how many {Ys} is {X} occluded?", "What number of {Ys} hide {X}?",
                    "How many {Ys} block {X}?"]
OCC_BY_EXIST_T = ["Is {X} occluded by {Y}?", "Is {X} hidden by {Y}?", "Is {X} partially hidden by {Y}?",
                  "Is {X} blocked by {Y}?"]
OCCLUDES_EXIST_T = ["Does {Y} occlude {X}?", "Is {Y} occluding {X}?", "Does {Y} hide {X}?", "Does {Y} block {X}?",
                    "Is {Y} hiding {X}?"]

P_OCC_BOOL_T = ["Is the {P} of {X} occluded?", "Is {Xp} {P} occluded?", "Is the {P} of {X} hidden?",
                "Is {Xp} {P} partially hidden?", "Is the {P} on {X} occluded?",
                "There is {aX}; is its {P} occluded?", "Is the {P} of {X} blocked from view?",
                "Is {Xp} {P} covered by something?"]
WHICH_PART_OCC_T = ["Which part of {X} is occluded?", "What part of {X} is hidden?",
                    "Which part of {X} is partially hidden?", "Which of {Xp} parts is occluded?",
                    "What is the name of the occluded part of {X}?", "What is the occluded part of {X} called?",
                    "There is {aX}; which of its parts is occluded?"]
WHICH_NAMED_OCC_T = ["Which {P} of {X} is occluded?", "Which of {Xp} {Ps} is hidden?",
                     "Which {P} of {X} is partially hidden?", "Which one of the {Ps} of {X} is occluded?",
                     "There is {aX}; which of its {Ps} is occluded?", "What is the name of the occluded {P} of {X}?"]
WHOSE_OCC_T = ["What {q} is the {Xn} whose {P} is {occ}?", "What is the {qn} of the {Xn} whose {P} is {occ}?",
               "The {Xn} whose {P} is {occ} is what {q}?", "There is {aXn} whose {P} is {occ}; what {q} is it?",
               "What {q} is the {Xn} with an occluded {P}?", "What {q} is the {Xn} that has its {P} {occ}?"]
WHOSE_OCC_SHAPE_T = ["Which vehicle has an occluded {P}?", "What is the {Xn} whose {P} is {occ}?",
                     "Whose {P} is {occ}?", "What kind of object has its {P} {occ}?"]
PART_OF_OCC_T = ["What {q} is the {P} of the {occ} {Xn}?",
                 "What is the {qn} of the {P} which belongs to the {Xn} that is {occ}?",
                 "What {q} is the {P} that belongs to an occluded {Xn}?",
                 "The {occ} {Xn} has a {P}; what {q} is it?", "What is the {qn} of the {occ} {Xposs} {P}?"]
PART_OF_OCC_NAME_T = ["Which part of the {occ} {Xn} is {pd}?", "What is the name of the {pdadj} part of the {occ} {Xn}?",
                      "What part of the {Xn} that is {occ} is {pd}?",
                      "What is the name of the {pdadj} part which belongs to an occluded {Xn}?"]
PART_OF_WHOSE_T = ["What {q} is the {P1} of the {Xn} whose {P2} is {occ}?",
                   "What is the {qn} of the {P1} which belongs to the {Xn} whose {P2} is {occ}?",
                   "There is {aXn} whose {P2} is {occ}; what {q} is its {P1}?"]
PART_OF_WHOSE_NAME_T = ["What is the name of the {pdadj} part of the {Xn} whose {P2} is {occ}?",
                        "Which part of the {Xn} whose {P2} is {occ} is {pd}?",
                        "There is {aXn} whose {P2} is {occ}; which of its parts is {pd}?"]
P_OCC_BY_T = ["Is the {P} of {X} occluded by {Y}?", "Is {Xp} {P} hidden by {Y}?", "Does {Y} occlude the {P} of {X}?",
              "Is the {P} of {X} blocked by {Y}?", "Is the {P} of {X} covered by {Y}?",
              "Is {Y} hiding the {P} of {X}?", "Is {Xp} {P} occluded by {Y}?"]
WHOSE_OCC_BY_T = ["What {q} is the {Xn} whose {P} is {occby} {Y}?",
                  "What is the {qn} of the {Xn} whose {P} is {occby} {Y}?",
                  "{Y} {occverb} the {P} of {aXn}; what {q} is it?",
                  "The {Xn} whose {P} {Y} {occverb} is what {q}?"]
PART_OF_OCC_BY_T = ["What {q} is the {P} of the {Xn} that is {occby} {Y}?",
                    "What is the {qn} of the {P} which belongs to the {Xn} {occby} {Y}?",
                    "{Y} {occverb} {aXn}; what {q} is its {P}?",
                    "There is {aXn} {occby} {Y}; what is the {qn} of its {P}?"]
PART_OF_OCC_BY_NAME_T = ["Which part of the {Xn} {occby} {Y} is {pd}?",
                         "What is the name of the {pdadj} part of the {Xn} that is {occby} {Y}?",
                         "{Y} {occverb} {aXn}; which of its parts is {pd}?"]
SAME_OBJ_OCC_BY_T = ["What {q} is the {P1} of the object whose {P2} is {occby} {Y}?",
                     "What is the {qn} of the {P1} which belongs to the same object whose {P2} is {occby} {Y}?",
                     "{Y} {occverb} a {P2}; what {q} is the {P1} of the same object?"]
SAME_OBJ_OCC_BY_NAME_T = ["What is the name of the {pdadj} part of the object whose {P2} is {occby} {Y}?",
                          "Which part is {pd} on the object whose {P2} is {occby} {Y}?"]
P_OCC_COUNT_T = ["How many parts of {X} are occluded?", "How many of {Xp} parts are hidden?",
                 "What number of parts of {X} are occluded?", "How many occluded parts does {X} have?",
                 "Count the occluded parts of {X}.", "How many parts of {X} are partially hidden?"]
P_OCC_EXIST_T = ["Does {X} have any occluded parts?", "Is any part of {X} occluded?",
                 "Are any of {Xp} parts hidden?", "Does {X} have a part that is occluded?"]
P_OCCLUDING_COUNT_T = ["How many parts of other objects does {X} occlude?", "How many parts does {X} hide?",
                       "What number of object parts are occluded by {X}?"]


# ------------------------------------------------------------------------------------------------ families

PH = re.compile(r"\{(\w+)\}")
ATTRS = ("color", "material", "size", "shape")


def pfilters(pd: dict) -> str:
    out = []
    for k in ("size", "color", "material"):
        if k in pd:
            out.append(f" | partfilter_{k}[{pd[k]}]")
    if "name" in pd:
        out.append(f" | partfilter_partname[{pd['name'][0]}]")
    return "".join(out)


def pmatch(o: Obj, raw: str, pd: dict) -> bool:
    for k, v in pd.items():
        if k == "color":
            if raw not in o.parts or o.parts[raw][0] != v:
                return False
        elif k == "material":
            if raw not in o.parts or o.parts[raw][1] != v:
                return False
        elif k == "name" and not ont.partname_matches(raw, v[0]):
            return False
    return True


def name_options(o: Obj, raw: str, allow_super: bool):
    """Part-name slot values for raw part ``raw`` of o: (value, raw, None) and, if allowed, (super value, None, sup)."""
    out = [(part_value(raw), raw, None)]
    sp = ont.super_part_name(raw)
    if allow_super and (sp != raw) and (len(supers_of(o.subtype, sp)) == 1 or allow_super == "any"):
        out.append((super_value(raw), None, sp))
    return out


class Families(Gen):

    # ---- rendering helpers
    def say(self, templates, **slots):
        keep = list(self.notes)
        for _ in range(8):
            t = self.choice(templates)
            cache: dict = {}

            def rep(m, cache=cache):
                k = m.group(1)
                if k not in cache:
                    v = slots[k]
                    cache[k] = v() if callable(v) else v
                return cache[k]
            try:
                return cap(PH.sub(rep, t))
            except NoQuestion:
                self.notes = list(keep)
        raise NoQuestion("no template fits")

    def ref(self, key, d):
        return {key: lambda: self.the(d), "a" + key: lambda: self.a(d), key + "p": lambda: self.poss(d),
                key + "n": lambda: self.np(d, "", clause_p=0.0), key + "s": lambda: self.pl(d),
                "a" + key + "n": lambda: self.a(d, clause_p=0.0), key + "1": lambda: self.np(d, "", clause_p=0.1),
                key + "poss": lambda: self.poss(d)[4:]}

    def qwords(self, attr):
        return {"q": self.choice(Q_WORD[attr]), "qn": self.choice(Q_NOUN[attr])}

    def pred_phrase(self, d):
        bits = []
        for slot in ("size", "color", "material"):
            if slot in d:
                v = d[slot]
                if slot == "material" and self.rng.random() < 0.35:
                    bits.append("made of " + self.pick(MAT_NOUN[v]))
                else:
                    bits.append(self.pick({"size": SIZE_W, "color": COLOR_W, "material": MAT_W}[slot][v]))
        return " and ".join(bits)

    def part_np(self, pd, det=""):
        """'red metal wheel' / 'blue part' for a part description."""
        bits = []
        if "color" in pd:
            bits.append(self.pick(COLOR_W[pd["color"]]))
        if "material" in pd:
            bits.append(self.pick(MAT_W[pd["material"]]))
        if "name" in pd:
            _value, raw, sup = pd["name"]
            bits.append(self.part_words(raw=raw) if raw else self.part_words(sup=sup))
        else:
            bits.append("part")
        s = " ".join(bits)
        return article(s) if det == "a" else s

    def part_pred(self, pd):
        """'red' / 'made of metal' / 'red and metallic' (a part's colour/material as a predicate)."""
        bits = []
        if "color" in pd:
            bits.append(self.pick(COLOR_W[pd["color"]]))
        if "material" in pd:
            v = pd["material"]
            bits.append("made of " + v if self.rng.random() < 0.4 else self.pick(MAT_W[v]))
        return " and ".join(bits)

    def part_adj(self, pd):
        bits = []
        if "color" in pd:
            bits.append(self.pick(COLOR_W[pd["color"]]))
        if "material" in pd:
            bits.append(self.pick(MAT_W[pd["material"]]))
        return " ".join(bits)

    def part_name_words(self, pd):
        _value, raw, sup = pd["name"]
        return self.part_words(raw=raw) if raw else self.part_words(sup=sup)

    def occ_adj(self):
        return self.pick(OCC_ADJ, 0.5)

    def occ_by(self):
        return self.pick(OCC_BY, 0.5)

    def occ_verb(self, plural_subject=False):
        v = self.pick(OCC_VERB, 0.5)
        return OCC_VERB_PL[v] if plural_subject else v

    def prog_obj(self, d):
        return "scene()" + filters(d) + " | unique"

    def maybe_empty_set_desc(self, w, cands, slots=("size", "color", "material", "shape"), p_empty=0.35):
        if self.rng.random() < p_empty:
            return {}
        return self.set_desc(w, cands, slots=slots)

    def empty_desc(self, w, slots=("size", "color", "material", "shape")):
        """A description that matches no object: a real object's description with one slot changed."""
        for _ in range(40):
            o = w.objs[self.obj(w)]
            ds = [d for d in all_descs(o, slots) if 1 <= len(d) <= 3]
            d = dict(self.choice(ds))
            k = self.choice(list(d))
            alt = self.random_desc([k], 1, True)
            d[k] = alt[k]
            if not denote(w, d, w.all):
                return order(d)
        raise NoQuestion("no empty description")

    def describe_nonempty(self, w, i, cands, **kw):
        d = self.describe(w, i, cands, **kw)
        if not d:
            o = w.objs[i]
            slots = [s for s in kw.get("slots", ("size", "color", "material", "shape")) if s not in kw.get("exclude", ())]
            s = self.choice(slots)
            d = order({s: self.choice(true_options(o, s, kw.get("shape_kinds", ("sub", "cat"))))})
        return d

    def kinds_for(self, attr):
        return ("cat",) if attr == "shape" else ("sub", "cat")

    def excl(self, attr):
        return () if attr == "shape" else (attr,)

    # ================================================================ core
    def f_query(self, attr=None):
        attr = attr or self.choice(ATTRS)
        w = self.world()
        i = self.obj(w)
        d = self.describe(w, i, w.all, exclude=self.excl(attr), shape_kinds=self.kinds_for(attr))
        q = self.say(Q_ATTR[attr], **self.ref("X", d))
        return q, self.prog_obj(d) + f" | query_{attr}", f"query_{attr}", w

    def f_count(self):
        w = self.world()
        d = self.set_desc(w, w.all)
        if "shape" in d and len(d) >= 2 and self.rng.random() < 0.35:
            attrs = {k: v for k, v in d.items() if k != "shape"}
            noun, _note = plural(self.shape_word(d["shape"]), self.rng, self.wide)
            q = self.say(COUNT_PRED_T, Ns=noun, pred=lambda: self.pred_phrase(attrs))
            fam = "count_predicative"
        elif "shape" not in d and self.rng.random() < 0.35:
            q = self.say(COUNT_PRED_T, Ns=lambda: plural(self.shape_word(None), self.rng, False)[0],
                         pred=lambda: self.pred_phrase(d))
            fam = "count_predicative"
        else:
            q = self.say(COUNT_T, **self.ref("X", d))
            fam = "count_filter"
        return q, "count(scene()" + filters(d) + ")", fam, w

    def f_plural_quirk(self):
        """Counts, existence and count comparisons about buses, where the public plural quirk 'buss' shows up."""
        w = self.world()
        buses = [o for o in w.objs if o.cat == "bus"]
        o = self.choice(buses) if buses and self.rng.random() < 0.8 else None
        d = {"shape": self.choice(["bus", "bus", o.subtype] if o else ["bus"] + list(HYPERNYM_BUSES))}
        if o and self.rng.random() < 0.5:
            s = self.choice(["size", "color", "material"])
            d[s] = o.val(s)
        d = order(d)
        how = self.choice(["count", "exist", "compare"])
        if how == "count":
            return self.say(COUNT_T, Xs=lambda: self.pl(d, clause_p=0.0)), "count(scene()" + filters(d) + ")", "count_filter", w
        if how == "exist":
            t = [x for x in EXIST_T if "{Xs}" in x]
            return self.say(t, Xs=lambda: self.pl(d, clause_p=0.0)), "exist(scene()" + filters(d) + ")", "exist_filter", w
        op = self.choice(list(INT_T))
        b = self.set_desc(w, w.all)
        if b == d:
            raise NoQuestion("same")
        if self.rng.random() < 0.5:
            q = self.say(INT_T[op], Xs=lambda: self.pl(d, clause_p=0.0), Ys=lambda: self.pl(b))
            return q, f"{op}(count(scene(){filters(d)}), count(scene(){filters(b)}))", f"compare_integer_{op}", w
        q = self.say(INT_T[op], Xs=lambda: self.pl(b), Ys=lambda: self.pl(d, clause_p=0.0))
        return q, f"{op}(count(scene(){filters(b)}), count(scene(){filters(d)}))", f"compare_integer_{op}", w

    def f_count_all(self):
        w = self.world()
        return self.say(COUNT_ALL_T), "count(scene())", "count_all", w

    def f_count_or(self):
        w = self.world()
        a = self.set_desc(w, w.all, max_slots=2)
        b = self.set_desc(w, w.all, max_slots=2)
        if a == b or not a or not b:
            raise NoQuestion("same")
        q = self.say(COUNT_OR_T, Xs=lambda: self.pl(a, clause_p=0.0), Ys=lambda: self.pl(b, clause_p=0.0))
        return q, f"count(union(scene(){filters(a)}, scene(){filters(b)}))", "count_union", w

    def f_exist(self):
        w = self.world()
        d = self.set_desc(w, w.all, min_size=1) if self.rng.random() < 0.5 else self.empty_desc(w)
        if self.rng.random() < 0.3 and any(k in d for k in ("size", "color", "material")):
            attrs = {k: v for k, v in d.items() if k != "shape"}
            if "shape" in d:
                q = self.say([t for t in EXIST_PRED_T if "{N" in t or "{aN}" in t],
                             N=lambda: self.shape_word(d["shape"]), aN=lambda: article(self.shape_word(d["shape"])),
                             Ns=lambda: plural(self.shape_word(d["shape"]), self.rng, self.wide)[0],
                             pred=lambda: self.pred_phrase(attrs))
            else:
                q = self.say(EXIST_PRED_T, N="object", aN=lambda: article(self.shape_word(None)),
                             Ns=lambda: plural(self.shape_word(None), self.rng, False)[0],
                             pred=lambda: self.pred_phrase(attrs))
            fam = "exist_predicative"
        else:
            q = self.say(EXIST_T, **self.ref("X", d))
            fam = "exist_filter"
        return q, "exist(scene()" + filters(d) + ")", fam, w

    def f_compare(self, attr=None):
        attr = attr or self.choice(ATTRS)
        w = self.world()
        if len(w.objs) < 2:
            raise NoQuestion("few objects")
        i, j = self.rng.sample(sorted(w.all), 2)
        kw = {"exclude": ("shape",) if attr == "shape" else (attr,), "shape_kinds": self.kinds_for(attr)}
        if attr == "shape":
            kw = {"exclude": (), "shape_kinds": ("cat",)}
        di = self.describe(w, i, w.all, **kw)
        dj = self.describe(w, j, w.all, **kw)
        q = self.say(CMP_T[attr], A=lambda: self.the(di), B=lambda: self.the(dj), aA=lambda: self.a(di),
                     Ap=lambda: self.poss(di), Bp=lambda: self.poss(dj))
        prog = (f"equal_{attr}(scene(){filters(di)} | unique | query_{attr}, "
                f"scene(){filters(dj)} | unique | query_{attr})")
        return q, prog, f"compare_{attr}", w

    def f_compare_int(self, op=None):
        op = op or self.choice(list(INT_T))
        w = self.world()
        a = self.set_desc(w, w.all)
        b = self.set_desc(w, w.all)
        if a == b:
            raise NoQuestion("same sets")
        if not denote(w, a, w.all) and not denote(w, b, w.all):
            raise NoQuestion("both empty")
        q = self.say(INT_T[op], Xs=lambda: self.pl(a), Ys=lambda: self.pl(b))
        return q, f"{op}(count(scene(){filters(a)}), count(scene(){filters(b)}))", f"compare_integer_{op}", w

    def f_same(self, kind=None, attr=None):
        kind = kind or self.choice(["count", "exist", "query"])
        attr = attr or self.choice(ATTRS)
        w = self.world()
        i = self.obj(w)
        S = w.same(attr, i)
        dx = self.describe(w, i, w.all, exclude=(attr,))
        slots = [s for s in ("size", "color", "material", "shape") if s != attr]
        base = dict(same=lambda: self.choice(SAME_PHRASE[attr]), an=lambda: self.choice(SAME_NOUN[attr]),
                    **self.ref("X", dx))
        head = self.prog_obj(dx) + f" | same_{attr}"
        if kind in ("count", "exist"):
            dy = self.maybe_empty_set_desc(w, S or w.all, slots=slots)
            base.update(Ys=lambda: self.pl(dy, clause_p=0.0), Y=lambda: self.np(dy, "", clause_p=0.0))
            if kind == "count":
                q = self.say(SAME_COUNT_T, **base)
                return q, head + filters(dy) + " | count", f"same_{attr}_count", w
            q = self.say(SAME_EXIST_EMPTY_T if not dy else SAME_EXIST_T, **base)
            return q, head + filters(dy) + " | exist", f"same_{attr}_exist", w
        if not S:
            raise NoQuestion("nothing the same")
        qa = self.choice([a for a in ATTRS if a != attr])
        j = self.choice(sorted(S))
        dy = self.describe(w, j, S, exclude=tuple({attr, qa} - {"shape"}) + (("shape",) if attr == "shape" else ()),
                           shape_kinds=self.kinds_for(qa))
        base.update(Yn=lambda: self.np(dy, "", clause_p=0.0), **self.qwords(qa))
        q = self.say(SAME_QUERY_T, **base)
        return q, head + filters(dy) + f" | unique | query_{qa}", f"same_{attr}_query_{qa}", w

    def f_rel(self, kind=None):
        kind = kind or self.choice(["count", "exist", "query"])
        w = self.world()
        i = self.obj(w)
        r = self.choice(ont.RELATIONS)
        R = w.rel[r][i]
        dx = self.describe(w, i, w.all)
        head = self.prog_obj(dx) + f" | relate[{r}]"
        base = dict(rel=lambda: self.rel_words(r), **self.ref("X", dx))
        if kind in ("count", "exist"):
            dy = self.maybe_empty_set_desc(w, R or w.all, p_empty=0.3)
            base.update(Ys=lambda: self.pl(dy, clause_p=0.0), aY=lambda: self.a(dy, clause_p=0.0))
            if kind == "count":
                return self.say(REL_COUNT_T, **base), head + filters(dy) + " | count", "one_hop_count", w
            t = REL_EXIST_EMPTY_T if not dy else REL_EXIST_T
            return self.say(t, **base), head + filters(dy) + " | exist", "one_hop_exist", w
        if not R:
            raise NoQuestion("empty relation")
        qa = self.choice(ATTRS)
        j = self.choice(sorted(R))
        dy = self.describe(w, j, R, exclude=self.excl(qa), shape_kinds=self.kinds_for(qa))
        base.update(Yn=lambda: self.np(dy, "", clause_p=0.0), aY=lambda: self.a(dy, clause_p=0.0), **self.qwords(qa))
        t = REL_QUERY_T + (REL_QUERY_SHAPE_T if qa == "shape" and not dy else [])
        return self.say(t, **base), head + filters(dy) + f" | unique | query_{qa}", f"one_hop_query_{qa}", w

    def f_two_hop(self, kind=None):
        kind = kind or self.choice(["count", "query"])
        w = self.world()
        i = self.obj(w)
        r1, r2 = self.choice(ont.RELATIONS), self.choice(ont.RELATIONS)
        R1 = w.rel[r1][i]
        if not R1:
            raise NoQuestion("empty")
        j = self.choice(sorted(R1))
        dx = self.describe(w, i, w.all)
        dy = self.describe(w, j, R1)
        R2 = w.rel[r2][j]
        head = self.prog_obj(dx) + f" | relate[{r1}]" + filters(dy) + f" | unique | relate[{r2}]"
        base = dict(rel1=lambda: self.rel_words(r1), rel2=lambda: self.rel_words(r2),
                    Yn=lambda: self.np(dy, "", clause_p=0.0), aY=lambda: self.a(dy, clause_p=0.0),
                    **self.ref("X", dx))
        if kind == "count":
            dz = self.maybe_empty_set_desc(w, R2 or w.all, p_empty=0.3)
            base.update(Zs=lambda: self.pl(dz, clause_p=0.0))
            return self.say(TWO_HOP_COUNT_T, **base), head + filters(dz) + " | count", "two_hop_count", w
        if not R2:
            raise NoQuestion("empty")
        qa = self.choice(ATTRS)
        k = self.choice(sorted(R2))
        dz = self.describe(w, k, R2, exclude=self.excl(qa), shape_kinds=self.kinds_for(qa))
        base.update(Zn=lambda: self.np(dz, "", clause_p=0.0), **self.qwords(qa))
        return (self.say(TWO_HOP_QUERY_T, **base), head + filters(dz) + f" | unique | query_{qa}",
                f"two_hop_query_{qa}", w)

    def f_and_count(self):
        w = self.world()
        if len(w.objs) < 3:
            raise NoQuestion("few")
        i, j = self.rng.sample(sorted(w.all), 2)
        r1, r2 = self.choice(ont.RELATIONS), self.choice(ont.RELATIONS)
        I = w.rel[r1][i] & w.rel[r2][j]
        dx, dy = self.describe(w, i, w.all), self.describe(w, j, w.all)
        dz = self.maybe_empty_set_desc(w, I or w.all, p_empty=0.4)
        q = self.say(AND_COUNT_T, rel1=lambda: self.rel_words(r1), rel2=lambda: self.rel_words(r2),
                     Zs=lambda: self.pl(dz, clause_p=0.0), X=lambda: self.the(dx), Y=lambda: self.the(dy))
        inter = f"intersect({self.prog_obj(dx)} | relate[{r1}], {self.prog_obj(dy)} | relate[{r2}])"
        prog = f"{inter}{filters(dz)} | count" if dz else f"count({inter})"
        return q, prog, "and_count", w

    # ================================================================ parts
    def f_part_attr(self, attr=None):
        attr = attr or self.choice(["color", "material"])
        w = self.world()
        i = self.obj(w, lambda o: o.parts)
        o = w.objs[i]
        raw = self.pick_part(o.parts)
        opts = name_options(o, raw, True)
        pd = {"name": self.choice(opts)}
        dx = self.describe(w, i, w.all)
        q = self.say(PART_Q_T[attr], P=lambda: self.part_name_words(pd), **self.ref("X", dx))
        prog = self.prog_obj(dx) + " | object2part" + pfilters(pd) + f" | unique | partquery_{attr}"
        return q, prog, f"part_query_{attr}", w

    def part_value_desc(self, o: Obj, raw: str, pool, slot=None):
        """A colour or material description of part raw that singles it out among the recoloured parts ``pool``
        (pairs (obj, raw)); the value differs from the owner's own colour / material."""
        slots = [slot] if slot else self.rng.sample(["color", "material"], 2)
        for s in slots:
            k = 0 if s == "color" else 1
            v = o.parts[raw][k]
            if v == (o.color if s == "color" else o.material):
                continue
            pd = {s: v}
            if [x for x in pool if pmatch(x[0], x[1], pd)] == [(o, raw)]:
                return pd
        raise NoQuestion("no part value description")

    def f_part_name(self):
        w = self.world()
        i = self.obj(w, lambda o: o.parts)
        o = w.objs[i]
        raw = self.pick_part(o.parts)
        pd = self.part_value_desc(o, raw, [(o, r) for r in o.parts])
        dx = self.describe(w, i, w.all)
        slot = next(iter(pd))
        noun = {"color": lambda: self.pick(COLOR_W[pd["color"]]) + " " + self.choice(["color", "colour"]),
                "material": lambda: self.pick(MAT_W[pd["material"]]) + " material"}[slot]
        q = self.say(PART_NAME_T, pd=lambda: self.part_pred(pd), pdadj=lambda: self.part_adj(pd), pdnoun=noun,
                     **self.ref("X", dx))
        prog = self.prog_obj(dx) + " | object2part" + pfilters(pd) + " | unique | partquery_partname"
        return q, prog, "part_query_partname", w

    def part_descs(self, o: Obj, raw: str, allow_super=True, slots=("color", "material", "name"), need_name=False):
        """Candidate part descriptions (non-empty) of o's recoloured part raw, smallest first."""
        opts = []
        st = o.parts.get(raw)
        for k in range(1, len(slots) + 1):
            for combo in combinations(slots, k):
                if need_name and "name" not in combo:
                    continue
                vals = []
                for s in combo:
                    if s == "color":
                        if st is None or st[0] == o.color:
                            break
                        vals.append([st[0]])
                    elif s == "material":
                        if st is None or st[1] == o.material:
                            break
                        vals.append([st[1]])
                    else:   # a bare super-part name ("the door") only with a colour/material, or if o has one
                        sup = "any" if allow_super and len(combo) > 1 else allow_super
                        vals.append(name_options(o, raw, sup))
                else:
                    for v in product(*vals):
                        opts.append(dict(zip(combo, v)))
        return opts

    def hygienic(self, w: World, pd: dict, objs, owner: int) -> bool:
        """No other candidate object's body could be read as having such a part (its own colour/material)."""
        for j in objs:
            if j == owner:
                continue
            oj = w.objs[j]
            if "name" in pd and not any(ont.partname_matches(r, pd["name"][0]) for r in oj.all_parts):
                continue
            if set(pd) == {"name"}:
                return False   # "the thing that has a hood" while another candidate has a hood too
            if "color" in pd and oj.color == pd["color"]:
                return False
            if "material" in pd and oj.material == pd["material"]:
                return False
        return True

    def f_has(self, qa=None, whose=None):
        qa = qa or self.choice(["color", "material", "shape"])
        w = self.world()
        i = self.obj(w, lambda o: o.parts)
        o = w.objs[i]
        raw = self.pick_part(o.parts)
        xslots = [s for s in ("size", "color", "material", "shape") if s != qa]
        found, best = [], None
        for pd in self.part_descs(o, raw):
            for d in all_descs(o, xslots):
                n = len(pd) + len(d)
                if best is not None and n > best:
                    continue
                D = denote(w, d, w.all)
                pool = [(w.objs[j], r) for j in D for r in w.objs[j].parts]
                if [x for x in pool if pmatch(x[0], x[1], pd)] != [(o, raw)]:
                    continue
                if not self.hygienic(w, pd, D, i):
                    continue
                if best is None or n < best:
                    found, best = [], n
                found.append((d, pd))
        if not found:
            raise NoQuestion("no has-description")
        d, pd = self.choice(found)
        d = order(d)
        if self.redundant:
            d = self.add_redundant(o, dict(d), xslots)
            d = order(d)
        base = dict(aP=lambda: self.part_np(pd, "a"), Xn=lambda: self.np(d, "", clause_p=0.0),
                    aXn=lambda: self.a(d, clause_p=0.0), **self.qwords(qa))
        use_whose = whose if whose is not None else ("name" in pd and len(pd) >= 2 and self.rng.random() < 0.45)
        if use_whose and "name" in pd and len(pd) >= 2:
            rest = {k: v for k, v in pd.items() if k != "name"}
            q = self.say(WHOSE_T, Pn=lambda: self.part_name_words(pd), pd=lambda: self.part_pred(rest), **base)
            self.notes.append("whose")
            fam = f"whose_part_query_{qa}"
        else:
            t = HAS_T + (HAS_SHAPE_EMPTY_T if qa == "shape" and not d else [])
            q = self.say(t, **base)
            fam = f"has_part_query_{qa}"
        prog = "scene()" + filters(d) + " | object2part" + pfilters(pd) + f" | unique | part2object | unique | query_{qa}"
        return q, prog, fam, w

    def f_same_obj(self, qa=None):
        qa = qa or self.choice(["color", "material", "partname"])
        w = self.world()
        i = self.obj(w, lambda o: len(o.parts) >= 2)
        o = w.objs[i]
        p2, p1 = self.rng.sample(sorted(o.parts), 2)
        pool = [(oj, r) for oj in w.objs for r in oj.parts]
        cands = [pd for pd in self.part_descs(o, p2)
                 if [x for x in pool if pmatch(x[0], x[1], pd)] == [(o, p2)] and self.hygienic(w, pd, w.all, i)]
        if not cands:
            raise NoQuestion("p2 not unique")
        m = min(len(c) for c in cands)
        pd2 = self.choice([c for c in cands if len(c) == m])
        if qa == "partname":
            pd1 = self.part_value_desc(o, p1, [(o, r) for r in o.parts])
            q = self.say(SAME_OBJ_NAME_T, pdadj=lambda: self.part_adj(pd1), pd=lambda: self.part_pred(pd1),
                         P2=lambda: self.part_np(pd2))
        else:
            pd1 = {"name": self.choice(name_options(o, p1, True))}
            q = self.say(SAME_OBJ_T, P1=lambda: self.part_np(pd1), P2=lambda: self.part_np(pd2), **self.qwords(qa))
        prog = ("scene() | object2part" + pfilters(pd2) + " | unique | part2object | object2part" + pfilters(pd1)
                + f" | unique | partquery_{qa}")
        return q, prog, f"same_object_part_query_{qa}", w

    def f_part_count(self, kind=None, rare=False):
        kind = kind or self.choice(["count", "exist", "exist_named"])
        w = self.world()
        if rare:   # the appendix's less common part names: side stand, rearlight, carrier, brake system ...
            i = self.obj(w, lambda o: any(ont.super_part_name(r) in RARE_PARTS for r in o.all_parts))
        else:
            i = self.obj(w)
        o = w.objs[i]
        if rare:
            raw = None
            slot = self.choice(["color", "material"])
            v = self.choice(ont.COLORS if slot == "color" else ont.MATERIALS)
        elif o.parts and self.rng.random() < 0.6:
            raw = self.pick_part(o.parts)
            slot = self.choice(["color", "material"])
            v = o.parts[raw][0 if slot == "color" else 1]
        else:
            raw = None
            slot = self.choice(["color", "material"])
            v = self.choice(ont.COLORS if slot == "color" else ont.MATERIALS)
        if v == (o.color if slot == "color" else o.material):
            raise NoQuestion("same as the body")
        pd = {slot: v}
        dx = self.describe(w, i, w.all)
        base = dict(pd=lambda: self.part_pred(pd), pdadj=lambda: self.part_adj(pd), **self.ref("X", dx))
        if kind == "exist_named":
            if rare:
                cand = self.choice([r for r in o.all_parts if ont.super_part_name(r) in RARE_PARTS])
            else:
                cand = raw if raw and self.rng.random() < 0.5 else self.pick_part(o.all_parts)
            pd["name"] = self.choice(name_options(o, cand, True))
            q = self.say(PART_EXIST_NAMED_T, Pn=lambda: self.part_name_words(pd), **base)
            return q, "exist(" + self.prog_obj(dx) + " | object2part" + pfilters(pd) + ")", "part_exist_named", w
        if kind == "exist":
            q = self.say(PART_EXIST_T, **base)
            return q, "exist(" + self.prog_obj(dx) + " | object2part" + pfilters(pd) + ")", "part_exist", w
        q = self.say(PART_COUNT_T, **base)
        return q, self.prog_obj(dx) + " | object2part" + pfilters(pd) + " | count", "part_count", w

    def f_owners_count(self):
        w = self.world()
        i = self.obj(w, lambda o: o.parts)
        o = w.objs[i]
        raw = self.pick_part(o.parts)
        pd = {"color": o.parts[raw][0], "name": self.choice(name_options(o, raw, "any"))}
        d = {}
        if self.rng.random() < 0.35:
            d = {"shape": self.choice([o.cat, o.subtype])}
        D = denote(w, d, w.all)
        for j in D:
            oj = w.objs[j]
            if oj.color == pd["color"] and any(ont.partname_matches(r, pd["name"][0]) for r in oj.all_parts):
                raise NoQuestion("ambiguous body colour")
        base = {"aP": lambda: self.part_np(pd, "a"), "pdadj": lambda: self.part_adj(pd),
                    "Pn": lambda: self.part_name_words(pd), "Xs": lambda: self.pl(d, clause_p=0.0)}
        t = [x for x in OWNERS_COUNT_T if ("{Xs}" in x) == bool(d)]
        prog = "scene()" + filters(d) + " | object2part" + pfilters(pd) + " | part2object | count"
        return self.say(t, **base), prog, "part_owners_count", w

    # ================================================================ pose
    def f_query_pose(self):
        w = self.world()
        i = self.obj(w, lambda o: o.pose is not None)
        d = self.describe(w, i, w.all, exclude=("pose",))
        return self.say(QUERY_POSE_T, **self.ref("X", d)), self.prog_obj(d) + " | query_pose", "query_pose", w

    def f_pose_filter_query(self, qa=None):
        qa = qa or self.choice(ATTRS)
        w = self.world()
        i = self.obj(w, lambda o: o.pose is not None)
        d = self.describe(w, i, w.all, slots=OBJ_SLOTS, exclude=self.excl(qa), require=("pose",),
                          shape_kinds=self.kinds_for(qa))
        q = self.say(Q_ATTR[qa], **self.ref("X", d))
        return q, self.prog_obj(d) + f" | query_{qa}", f"pose_filter_query_{qa}", w

    def prel(self, kind, form="3"):
        p = self.pick(POSE_REL[kind], 0.5)
        if form == "3":
            return p
        if form == "inf":   # "Does any bus ...": no "be perpendicular to"
            for _ in range(20):
                if not p.startswith("is ") or p.startswith("is facing "):
                    break
                p = self.pick(POSE_REL[kind], 0.5)
            else:
                raise NoQuestion("no verb form")
            if p.startswith("is facing "):
                p = "faces " + p[len("is facing "):]
        first, _, rest = p.partition(" ")
        if form == "pl":
            first = {"faces": "face", "is": "are", "points": "point", "has": "have", "heads": "head"}[first]
        else:
            first = {"faces": "face", "is": "be", "points": "point", "has": "have", "heads": "head"}[first]
        return first + " " + rest

    def f_pose_rel(self, kind=None, how=None):
        kind = kind or self.choice(["same", "opposite", "vertical"])
        how = how or self.choice(["query", "query", "count", "exist"])
        w = self.world()
        i = self.obj(w, lambda o: o.pose is not None)
        S = w.pose_rel(kind, i)
        dx = self.describe(w, i, w.all, exclude=("pose",))
        head = self.prog_obj(dx) + f" | {kind}_pose"
        base = dict(prel=lambda: self.prel(kind), prelpl=lambda: self.prel(kind, "pl"),
                    prelinf=lambda: self.prel(kind, "inf"), **self.ref("X", dx))
        if how == "query":
            if not S:
                raise NoQuestion("none")
            qa = self.choice(ATTRS)
            j = self.choice(sorted(S))
            dy = self.describe(w, j, S, exclude=self.excl(qa) + ("pose",), shape_kinds=self.kinds_for(qa))
            base.update(Yn=lambda: self.np(dy, "", clause_p=0.0), aY=lambda: self.a(dy, clause_p=0.0),
                        **self.qwords(qa))
            return (self.say(POSE_REL_QUERY_T, **base), head + filters(dy) + f" | unique | query_{qa}",
                    f"pose_{kind}_query_{qa}", w)
        dy = self.maybe_empty_set_desc(w, S or w.all, p_empty=0.35)
        base.update(Ys=lambda: self.pl(dy, clause_p=0.0), aY=lambda: self.a(dy, clause_p=0.0),
                    Yn=lambda: self.np(dy, "", clause_p=0.0))
        if how == "count":
            return self.say(POSE_REL_COUNT_T, **base), head + filters(dy) + " | count", f"pose_{kind}_count", w
        return self.say(POSE_REL_EXIST_T, **base), head + filters(dy) + " | exist", f"pose_{kind}_exist", w

    def f_pose_count(self, how=None):
        how = how or self.choice(["count", "exist"])
        w = self.world()
        if self.rng.random() < 0.75:
            i = self.obj(w, lambda o: o.pose is not None)
            o = w.objs[i]
            ds = [d for d in all_descs(o, ("pose", "size", "color", "material", "shape")) if "pose" in d and len(d) <= 2]
            d = order(self.choice(ds))
        else:
            d = order({"pose": self.choice(ont.POSES), **self.random_desc(("size", "color", "shape"), 1, False)})
        if how == "count":
            return self.say(COUNT_T, **self.ref("X", d)), "count(scene()" + filters(d) + ")", "pose_filter_count", w
        return self.say(EXIST_T, **self.ref("X", d)), "exist(scene()" + filters(d) + ")", "pose_filter_exist", w

    # ================================================================ occlusion
    def f_occ_query(self, qa=None):
        qa = qa or self.choice(ATTRS)
        w = self.world()
        O = frozenset(o.i for o in w.objs if o.occluded)
        if not O:
            raise NoQuestion("none occluded")
        i = self.choice(sorted(O))
        d = self.describe(w, i, O, exclude=self.excl(qa), shape_kinds=self.kinds_for(qa), min_denotation_all=2)
        occ = self.occ_adj()
        q = self.say(OCC_QUERY_T, occ=occ, aocc=article(occ), Xn=lambda: self.np(d, "", clause_p=0.0),
                     X=lambda: self.the(d), **self.qwords(qa))
        return q, "scene() | filter_occludee" + filters(d) + f" | unique | query_{qa}", f"occluded_query_{qa}", w

    def f_occ_by_query(self, qa=None, direction=None):
        qa = qa or self.choice(ATTRS)
        direction = direction or self.choice(["by", "occludes"])
        w = self.world()
        if direction == "by":
            y = self.obj(w, lambda o: w.occluding(o.i))
            R = w.occluding(y)
            op = "relate_occluding"
        else:
            y = self.obj(w, lambda o: o.occluded_by)
            R = w.occluders(y)
            op = "relate_occluded"
        x = self.choice(sorted(R))
        dy = self.describe(w, y, w.all)
        dx = self.describe(w, x, R, exclude=self.excl(qa), shape_kinds=self.kinds_for(qa))
        verb = lambda: self.occ_verb()
        base = dict(occby=lambda: self.occ_by(), occverb=verb, occing=lambda: self.choice(["occluding", "hiding",
                                                                                             "blocking"]),
                    occverbinf=lambda: self.choice(["occlude", "hide", "block"]),
                    Xn=lambda: self.np(dx, "", clause_p=0.0), aX=lambda: self.a(dx, clause_p=0.0),
                    Y=lambda: self.the(dy), **self.qwords(qa))
        if direction == "by":
            t = OCC_BY_QUERY_T + (OCC_BYQ_SHAPE_T if qa == "shape" and not dx else [])
            fam = f"occluded_by_query_{qa}"
        else:
            t = OCCLUDES_QUERY_T + (OCCLUDES_SHAPE_T if qa == "shape" and not dx else [])
            fam = f"occluder_of_query_{qa}"
        q = self.say(t, **base)
        return q, self.prog_obj(dy) + f" | {op}" + filters(dx) + f" | unique | query_{qa}", fam, w

    def f_occ_exist(self, kind=None):
        kind = kind or self.choice(["occluded", "occluder", "by", "occludes"])
        w = self.world()
        if kind == "occluded":
            i = self.obj(w)
            d = self.describe_nonempty(w, i, w.all)
            return (self.say(OCC_EXIST_T, **self.ref("X", d)), "exist(scene() | filter_occludee" + filters(d) + ")",
                    "occluded_exist", w)
        if kind == "occluder":
            i = self.obj(w)
            d = self.describe(w, i, w.all)
            return (self.say(OCCLUDER_EXIST_T, **self.ref("X", d)), "exist(" + self.prog_obj(d) + " | relate_occluded)",
                    "occluder_exist", w)
        if len(w.objs) < 2:
            raise NoQuestion("few")
        x = self.obj(w)
        if self.rng.random() < 0.5 and w.occluders(x):
            y = self.choice(sorted(w.occluders(x)))
        else:
            y = self.choice(sorted(w.all - {x}))
        dx = self.describe_nonempty(w, x, w.all)
        dy = self.describe_nonempty(w, y, w.all)
        base = {"X": lambda: self.the(dx), "Y": lambda: self.the(dy)}
        if kind == "by":
            return (self.say(OCC_BY_EXIST_T, **base), "exist(" + self.prog_obj(dx) + " | relate_occluded" + filters(dy) + ")",
                    "occluded_by_exist", w)
        return (self.say(OCCLUDES_EXIST_T, **base), "exist(" + self.prog_obj(dy) + " | relate_occluding" + filters(dx) + ")",
                "occludes_exist", w)

    def f_occ_count(self, kind=None):
        kind = kind or self.choice(["occluded", "occluding", "occluder"])
        w = self.world()
        if kind == "occluded":
            d = self.maybe_empty_set_desc(w, frozenset(o.i for o in w.objs if o.occluded) or w.all, p_empty=0.25)
            occ = self.occ_adj()
            Xs = lambda: self.pl(d, clause_p=0.0)
            q = self.say(OCC_COUNT_T, occ=occ, Xs=Xs)
            return q, "count(scene() | filter_occludee" + filters(d) + ")", "occluded_count", w
        i = self.obj(w)
        dx = self.describe(w, i, w.all)
        R = w.occluding(i) if kind == "occluding" else w.occluders(i)
        dy = self.maybe_empty_set_desc(w, R or w.all, p_empty=0.5)
        base = dict(Ys=lambda: self.pl(dy, clause_p=0.0), occby=lambda: self.occ_by(),
                    occverb=lambda: self.occ_verb(), **self.ref("X", dx))
        if kind == "occluding":
            return (self.say(OCCLUDING_COUNT_T, **base), self.prog_obj(dx) + " | relate_occluding" + filters(dy) + " | count",
                    "occluding_count", w)
        return (self.say(OCCLUDER_COUNT_T, **base), self.prog_obj(dx) + " | relate_occluded" + filters(dy) + " | count",
                "occluder_count", w)

    # ================================================================ part occlusion
    def part_name_in(self, o: Obj, raw: str, pool_raws, allow_super=True):
        """A name value for o's part raw that selects only it among pool_raws (raw names of the same object)."""
        opts = [v for v in name_options(o, raw, allow_super)
                if [r for r in pool_raws if ont.partname_matches(r, v[0])] == [raw]]
        if not opts:
            raise NoQuestion("name not unique")
        return self.choice(opts)

    def f_p_occ_bool(self):
        w = self.world()
        i = self.obj(w, lambda o: w.parts_all(o.i))
        o = w.objs[i]
        pool = sorted(w.parts_all(i))
        occd = [r for r in pool if r in o.part_occ]
        raw = self.pick_part(occd if occd and self.rng.random() < 0.5 else pool)
        pd = {"name": self.part_name_in(o, raw, pool)}
        dx = self.describe(w, i, w.all)
        q = self.say(P_OCC_BOOL_T, P=lambda: self.part_name_words(pd), **self.ref("X", dx))
        prog = self.prog_obj(dx) + " | object2part_all" + pfilters(pd) + " | unique | partquery_occlusion"
        return q, prog, "part_occluded_bool", w

    def f_which_part_occ(self):
        w = self.world()
        i = self.obj(w, lambda o: len(o.part_occ) == 1)
        dx = self.describe(w, i, w.all)
        q = self.say(WHICH_PART_OCC_T, **self.ref("X", dx))
        return (q, self.prog_obj(dx) + " | object2part_all | partfilter_occludee | unique | partquery_partname",
                "which_part_occluded", w)

    def f_which_named_occ(self):
        """'Which wheel of the bus is occluded?': the one occluded part of a kind."""
        w = self.world()
        i = self.obj(w, lambda o: o.part_occ)
        o = w.objs[i]
        sups = sorted({ont.super_part_name(r) for r in o.part_occ
                       if len([x for x in o.part_occ if ont.super_part_name(x) == ont.super_part_name(r)]) == 1
                       and len(supers_of(o.subtype, ont.super_part_name(r))) >= 2})
        if not sups:
            raise NoQuestion("no kind with one occluded part")
        sp = self.choice(sups)
        raw = next(r for r in o.part_occ if ont.super_part_name(r) == sp)
        pd = {"name": (super_value(raw), None, sp)}
        dx = self.describe(w, i, w.all)
        word = lambda: self.part_words(sup=sp)
        q = self.say(WHICH_NAMED_OCC_T, P=word, Ps=lambda: plural(self.part_words(sup=sp), self.rng, False)[0],
                     **self.ref("X", dx))
        prog = (self.prog_obj(dx) + " | object2part_all | partfilter_occludee" + pfilters(pd)
                + " | unique | partquery_partname")
        return q, prog, "which_named_part_occluded", w

    def f_whose_occ(self, qa=None):
        qa = qa or self.choice(ATTRS)
        w = self.world()
        i = self.obj(w, lambda o: o.part_occ)
        o = w.objs[i]
        raw = self.pick_part(o.part_occ)
        nv = self.choice(name_options(o, raw, "any"))
        xslots = [s for s in ("size", "color", "material", "shape") if s != qa]
        found, best = [], None
        for d in all_descs(o, xslots):
            if best is not None and len(d) > best:
                break
            D = denote(w, d, w.all)
            owners = {j for j in D for r in w.objs[j].part_occ if ont.partname_matches(r, nv[0])}
            if owners == {i}:
                found.append(d)
                best = len(d)
        if not found:
            raise NoQuestion("not unique")
        d = order(self.choice(found))
        if self.redundant:
            d = order(self.add_redundant(o, dict(d), xslots))
        pd = {"name": nv}
        occ = self.occ_adj()
        base = dict(P=lambda: self.part_name_words(pd), occ=occ, Xn=lambda: self.np(d, "", clause_p=0.0),
                    aXn=lambda: self.a(d, clause_p=0.0), **self.qwords(qa))
        t = WHOSE_OCC_T + (WHOSE_OCC_SHAPE_T if qa == "shape" and not d else [])
        q = self.say(t, **base)
        prog = ("scene()" + filters(d) + " | object2part_all | partfilter_occludee" + pfilters(pd)
                + f" | part2object | unique | query_{qa}")
        return q, prog, f"whose_part_occluded_query_{qa}", w

    def f_part_of_occ(self, qa=None):
        qa = qa or self.choice(["color", "material", "partname"])
        w = self.world()
        O = frozenset(o.i for o in w.objs if o.occluded)
        i = self.obj(w, lambda o: o.occluded and o.parts)
        o = w.objs[i]
        d = self.describe_nonempty(w, i, O)
        raw = self.pick_part(o.parts)
        occ = self.occ_adj()
        base = dict(occ=occ, Xn=lambda: self.np(d, "", clause_p=0.0), Xposs=lambda: self.poss(d)[4:],
                    **self.qwords(qa if qa != "partname" else "color"))
        if qa == "partname":
            pd = self.part_value_desc(o, raw, [(o, r) for r in o.parts])
            q = self.say(PART_OF_OCC_NAME_T, pd=lambda: self.part_pred(pd), pdadj=lambda: self.part_adj(pd), **base)
        else:
            pd = {"name": self.choice(name_options(o, raw, True))}
            q = self.say(PART_OF_OCC_T, P=lambda: self.part_np(pd), **base)
        prog = "scene() | filter_occludee" + filters(d) + " | object2part" + pfilters(pd) + f" | unique | partquery_{qa}"
        return q, prog, f"part_of_occluded_query_{qa}", w

    def f_part_of_whose(self, qa=None):
        qa = qa or self.choice(["color", "material", "partname"])
        w = self.world()
        i = self.obj(w, lambda o: o.part_occ and o.parts)
        o = w.objs[i]
        p2 = self.pick_part(o.part_occ)
        nv2 = self.choice(name_options(o, p2, "any"))
        p1s = [r for r in o.parts if not (r in o.part_occ and ont.partname_matches(r, nv2[0]))]
        if not p1s:
            raise NoQuestion("no other part")
        p1 = self.pick_part(p1s)
        W = {j for j in w.all for r in w.objs[j].part_occ if ont.partname_matches(r, nv2[0])}
        found, best = [], None
        for d in all_descs(o, ("size", "color", "material", "shape")):
            if best is not None and len(d) > best:
                break
            if denote(w, d, W) == {i}:
                found.append(d)
                best = len(d)
        if not found:
            raise NoQuestion("no")
        d = order(self.choice(found))
        if self.redundant:
            d = order(self.add_redundant(o, dict(d), ("size", "color", "material", "shape")))
        pd2 = {"name": nv2}
        occ = self.occ_adj()
        base = dict(P2=lambda: self.part_name_words(pd2), occ=occ, Xn=lambda: self.np(d, "", clause_p=0.0),
                    aXn=lambda: self.a(d, clause_p=0.0), **self.qwords(qa if qa != "partname" else "color"))
        if qa == "partname":
            pd1 = self.part_value_desc(o, p1, [(o, r) for r in o.parts])
            q = self.say(PART_OF_WHOSE_NAME_T, pd=lambda: self.part_pred(pd1), pdadj=lambda: self.part_adj(pd1), **base)
        else:
            pd1 = {"name": self.choice(name_options(o, p1, True))}
            q = self.say(PART_OF_WHOSE_T, P1=lambda: self.part_np(pd1), **base)
        prog = ("scene() | object2part_all | partfilter_occludee" + pfilters(pd2) + " | part2object" + filters(d)
                + " | object2part" + pfilters(pd1) + f" | unique | partquery_{qa}")
        return q, prog, f"part_of_whose_part_occluded_query_{qa}", w

    def f_p_occ_by_bool(self):
        w = self.world()
        if len(w.objs) < 2:
            raise NoQuestion("few")
        i = self.obj(w, lambda o: w.parts_all(o.i))
        o = w.objs[i]
        pool = sorted(w.parts_all(i))
        occd = [r for r in pool if r in o.part_occ]
        raw = self.pick_part(occd if occd and self.rng.random() < 0.6 else pool)
        by = o.part_occ.get(raw, frozenset())
        y = self.choice(sorted(by)) if by and self.rng.random() < 0.6 else self.choice(sorted(w.all - {i}))
        pd = {"name": self.part_name_in(o, raw, pool)}
        dx = self.describe(w, i, w.all)
        dy = self.describe_nonempty(w, y, w.all)
        q = self.say(P_OCC_BY_T, P=lambda: self.part_name_words(pd), Y=lambda: self.the(dy), **self.ref("X", dx))
        prog = (self.prog_obj(dx) + " | object2part_all" + pfilters(pd) + " | unique | relate_part_occluded"
                + filters(dy) + " | exist")
        return q, prog, "part_occluded_by_bool", w

    def f_whose_occ_by(self, qa=None):
        qa = qa or self.choice(ATTRS)
        w = self.world()
        y = self.obj(w, lambda o: w.occluded_parts_by(o.i))
        pool = w.occluded_parts_by(y)
        j, raw = self.choice(pool)
        o = w.objs[j]
        opts = [v for v in name_options(o, raw, "any")
                if [x for x in pool if ont.partname_matches(x[1], v[0])] == [(j, raw)]]
        if not opts:
            raise NoQuestion("name not unique")
        pd = {"name": self.choice(opts)}
        dy = self.describe(w, y, w.all)
        d = {}
        if self.redundant:
            d = order(self.add_redundant(o, {}, [s for s in ("size", "color", "material", "shape") if s != qa]))
        verb = self.occ_verb()
        base = dict(P=lambda: self.part_name_words(pd), occby=lambda: self.occ_by(), occverb=verb,
                    Xn=lambda: self.np(d, "", clause_p=0.0), aXn=lambda: self.a(d, clause_p=0.0),
                    Y=lambda: self.the(dy), **self.qwords(qa))
        q = self.say(WHOSE_OCC_BY_T, **base)
        prog = (self.prog_obj(dy) + " | relate_occluding_part" + pfilters(pd) + " | unique | part2object" + filters(d)
                + f" | unique | query_{qa}")
        return q, prog, f"whose_part_occluded_by_query_{qa}", w

    def f_part_of_occ_by(self, qa=None):
        qa = qa or self.choice(["color", "material", "partname"])
        w = self.world()
        y = self.obj(w, lambda o: any(w.objs[x].parts for x in w.occluding(o.i)))
        R = w.occluding(y)
        x = self.choice(sorted(j for j in R if w.objs[j].parts))
        o = w.objs[x]
        dy = self.describe(w, y, w.all)
        dx = self.describe(w, x, R)
        raw = self.pick_part(o.parts)
        base = dict(occby=lambda: self.occ_by(), occverb=lambda: self.occ_verb(), Y=lambda: self.the(dy),
                    Xn=lambda: self.np(dx, "", clause_p=0.0), aXn=lambda: self.a(dx, clause_p=0.0),
                    **self.qwords(qa if qa != "partname" else "color"))
        if qa == "partname":
            pd = self.part_value_desc(o, raw, [(o, r) for r in o.parts])
            q = self.say(PART_OF_OCC_BY_NAME_T, pd=lambda: self.part_pred(pd), pdadj=lambda: self.part_adj(pd), **base)
        else:
            pd = {"name": self.choice(name_options(o, raw, True))}
            q = self.say(PART_OF_OCC_BY_T, P=lambda: self.part_np(pd), **base)
        prog = (self.prog_obj(dy) + " | relate_occluding" + filters(dx) + " | object2part" + pfilters(pd)
                + f" | unique | partquery_{qa}")
        return q, prog, f"part_of_occluded_by_query_{qa}", w

    def f_same_obj_occ_by(self, qa=None):
        qa = qa or self.choice(["color", "material", "partname"])
        w = self.world()
        y = self.obj(w, lambda o: any(w.objs[j].parts for j, _ in w.occluded_parts_by(o.i)))
        pool = w.occluded_parts_by(y)
        j, p2 = self.choice([x for x in pool if w.objs[x[0]].parts])
        o = w.objs[j]
        opts = [v for v in name_options(o, p2, "any")
                if [x for x in pool if ont.partname_matches(x[1], v[0])] == [(j, p2)]]
        if not opts:
            raise NoQuestion("name not unique")
        pd2 = {"name": self.choice(opts)}
        p1s = [r for r in o.parts if r != p2]
        if not p1s:
            raise NoQuestion("no other part")
        p1 = self.pick_part(p1s)
        dy = self.describe(w, y, w.all)
        base = dict(P2=lambda: self.part_name_words(pd2), occby=lambda: self.occ_by(), occverb=lambda: self.occ_verb(),
                    Y=lambda: self.the(dy), **self.qwords(qa if qa != "partname" else "color"))
        if qa == "partname":
            pd1 = self.part_value_desc(o, p1, [(o, r) for r in o.parts])
            q = self.say(SAME_OBJ_OCC_BY_NAME_T, pd=lambda: self.part_pred(pd1), pdadj=lambda: self.part_adj(pd1), **base)
        else:
            pd1 = {"name": self.choice(name_options(o, p1, True))}
            q = self.say(SAME_OBJ_OCC_BY_T, P1=lambda: self.part_np(pd1), **base)
        prog = (self.prog_obj(dy) + " | relate_occluding_part" + pfilters(pd2) + " | unique | part2object | object2part"
                + pfilters(pd1) + f" | unique | partquery_{qa}")
        return q, prog, f"same_object_part_occluded_by_query_{qa}", w

    def f_p_occ_count(self, kind=None):
        kind = kind or self.choice(["count", "exist", "occluding"])
        w = self.world()
        i = self.obj(w)
        dx = self.describe(w, i, w.all)
        if kind == "count":
            return (self.say(P_OCC_COUNT_T, **self.ref("X", dx)),
                    self.prog_obj(dx) + " | object2part_all | partfilter_occludee | count", "occluded_part_count", w)
        if kind == "exist":
            return (self.say(P_OCC_EXIST_T, **self.ref("X", dx)),
                    "exist(" + self.prog_obj(dx) + " | object2part_all | partfilter_occludee)", "occluded_part_exist", w)
        return (self.say(P_OCCLUDING_COUNT_T, **self.ref("X", dx)), "count(" + self.prog_obj(dx) + " | relate_occluding_part)",
                "occluding_part_count", w)


def fam(name, *args):
    return (name, args)


FAMILIES = {
    "core_query": [fam("f_query", a) for a in ATTRS],
    "core_count": [fam("f_count"), fam("f_count"), fam("f_count"), fam("f_count_all"), fam("f_count_or")],
    "core_exist": [fam("f_exist")],
    "core_compare_attribute": [fam("f_compare", a) for a in ATTRS],
    "core_compare_integer": [fam("f_compare_int", op) for op in INT_T],
    "core_same_relate": [fam("f_same", k, a) for k in ("count", "exist", "query") for a in ATTRS],
    "core_spatial": [fam("f_rel", "count"), fam("f_rel", "exist"), fam("f_rel", "query"), fam("f_rel", "query"),
                     fam("f_two_hop", "count"), fam("f_two_hop", "query"), fam("f_and_count")],
    "parts": [fam("f_part_attr", "color"), fam("f_part_attr", "material"), fam("f_part_name"),
              fam("f_has", "color"), fam("f_has", "material"), fam("f_has", "shape"),
              fam("f_same_obj", "color"), fam("f_same_obj", "material"), fam("f_same_obj", "partname"),
              fam("f_part_count", "count"), fam("f_part_count", "exist"), fam("f_part_count", "exist_named"),
              fam("f_part_count", "exist_named", True),
              fam("f_owners_count")],
    "pose": [fam("f_query_pose"), fam("f_query_pose"), fam("f_pose_filter_query"), fam("f_pose_filter_query"),
             fam("f_pose_rel", "same"), fam("f_pose_rel", "opposite"), fam("f_pose_rel", "vertical"),
             fam("f_pose_rel", "same", "count"), fam("f_pose_rel", "vertical", "count"),
             fam("f_pose_rel", "opposite", "exist"), fam("f_pose_count", "count"), fam("f_pose_count", "exist")],
    "occlusion": [fam("f_occ_query"), fam("f_occ_query"), fam("f_occ_by_query", None, "by"),
                  fam("f_occ_by_query", None, "by"), fam("f_occ_by_query", None, "occludes"),
                  fam("f_occ_by_query", None, "occludes"), fam("f_occ_exist", "occluded"),
                  fam("f_occ_exist", "occluder"), fam("f_occ_exist", "by"), fam("f_occ_exist", "occludes"),
                  fam("f_occ_count", "occluded"), fam("f_occ_count", "occluding"), fam("f_occ_count", "occluder")],
    "part_occlusion": [fam("f_p_occ_bool"), fam("f_p_occ_bool"), fam("f_which_part_occ"), fam("f_which_named_occ"), fam("f_whose_occ"),
                       fam("f_whose_occ"), fam("f_part_of_occ"), fam("f_part_of_whose"), fam("f_p_occ_by_bool"),
                       fam("f_whose_occ_by"), fam("f_part_of_occ_by"), fam("f_same_obj_occ_by"),
                       fam("f_p_occ_count", "count"), fam("f_p_occ_count", "exist"),
                       fam("f_p_occ_count", "occluding")],
    # descriptions with extra true attributes, on families whose referents are unique
    "redundant": [fam("f_query"), fam("f_query"), fam("f_compare"), fam("f_same", "query"), fam("f_rel", "query"),
                  fam("f_rel", "count"), fam("f_part_attr"), fam("f_part_name"), fam("f_has"), fam("f_query_pose"),
                  fam("f_pose_filter_query"), fam("f_pose_rel", None, "query"), fam("f_occ_by_query"),
                  fam("f_occ_exist", "occluded"), fam("f_p_occ_bool"), fam("f_whose_occ")],
    # wider synonyms, plural quirks, typos (about a third), on a spread of families
    "synonyms_quirks_typos": [fam("f_query"), fam("f_count"), fam("f_plural_quirk"), fam("f_plural_quirk"),
                              fam("f_exist"), fam("f_compare"),
                              fam("f_compare_int"), fam("f_compare_int"), fam("f_same"), fam("f_rel"),
                              fam("f_part_attr"), fam("f_part_name"), fam("f_has"), fam("f_part_count", "exist_named", True),
                              fam("f_query_pose"),
                              fam("f_pose_filter_query"), fam("f_pose_rel"), fam("f_occ_by_query"),
                              fam("f_occ_count", "occluded"), fam("f_p_occ_bool"), fam("f_whose_occ")],
}


# ------------------------------------------------------------------------------------------------ driver

def scene_rel(seed: int) -> str:
    return f"scenes/scene_{seed}.json"


def load_worlds() -> list[World]:
    return [World(load_scene(HERE / scene_rel(s)), scene_rel(s)) for s in SEEDS]


def run_program(scene, text: str):
    program = parse_program(text)
    check_program(program)
    return execute(scene, program)


def jsonable(answer):
    if isinstance(answer, (bool, int, str)):
        return answer
    raise TypeError(f"unexpected answer type {type(answer).__name__}: {answer!r}")


def balanced(counter: Counter, ans) -> bool:
    """Keep yes/no within one or two of each other, and no count or value above ~40% of its family."""
    n = sum(counter.values())
    if isinstance(ans, bool):
        return counter[ans] - counter[not ans] < 2
    if isinstance(ans, int):
        return counter[ans] < 2 or counter[ans] < 0.4 * n + 1
    return counter[ans] < 3 or counter[ans] < 0.45 * n + 1


def self_check(worlds: list[World]) -> None:
    """The facts this generator reads off a scene agree with the reference executor."""
    for w in worlds:
        for slot, values in (("color", ont.COLORS), ("material", ont.MATERIALS), ("size", ont.SIZES),
                             ("shape", ont.SHAPE_VALUES), ("pose", ont.POSES)):
            for v in values:
                value = v + "_pose" if slot == "pose" else v
                got = run_program(w.scene, f"scene() | filter_{slot}[{value}]").answer
                assert got == denote(w, {slot: v}, w.all), (w.path, slot, v)
        assert run_program(w.scene, "scene() | filter_occludee").answer == {o.i for o in w.objs if o.occluded}
        assert run_program(w.scene, "scene() | object2part").answer == {(o.i, ont.part_id(o.subtype, r))
                                                                          for o in w.objs for r in o.parts}
        assert run_program(w.scene, "scene() | object2part_all | partfilter_occludee").answer == {
            (o.i, ont.part_id(o.subtype, r)) for o in w.objs for r in o.part_occ}


def build(seed: int, per_group: int = PER_GROUP) -> list[dict]:
    from po3d_ppl.language import program_to_text
    rng = random.Random(seed)
    worlds = load_worlds()
    self_check(worlds)
    gen = Families(rng, worlds)
    records, seen = [], set()
    for group in GROUPS:
        fams = FAMILIES[group]
        answers: dict[str, Counter] = defaultdict(Counter)
        n = tries = 0
        while n < per_group:
            tries += 1
            if tries > 200 * per_group:
                raise RuntimeError(f"{group}: only {n} questions")
            name, args = fams[tries % len(fams)]
            gen.notes = []
            gen.wide = group == "synonyms_quirks_typos"
            gen.redundant = group == "redundant"
            try:
                question, prog, family, w = getattr(gen, name)(*args)
            except NoQuestion:
                continue
            if gen.redundant and not any(x.startswith("redundant") for x in gen.notes):
                continue
            result = run_program(w.scene, prog)
            if not result.valid:
                continue
            ans = jsonable(result.answer)
            if not balanced(answers[family], ans):
                continue
            key = (question.lower(), w.path)
            if key in seen:
                continue
            notes = list(dict.fromkeys(gen.notes))
            if rng.random() < (TYPO_RATE_SYN if gen.wide else TYPO_RATE):
                typo = make_typo(question, rng)
                if typo:
                    question, note = typo
                    notes.append(note)
            if gen.wide and not notes:
                continue   # the synonyms group keeps only questions with a wide word, a quirk or a typo
            seen.add(key)
            answers[family][ans] += 1
            if rng.random() < 0.2:   # some programs in nested-call form
                prog = program_to_text(parse_program(prog), style="nested")
            if group == "redundant":
                family = "redundant_" + family
            elif gen.wide:
                family = "syn_" + family
            rec = {"id": f"g{len(records):05d}", "question": question, "program": prog, "family_group": group,
                   "family": family, "scene": w.path, "answer": ans}
            if notes:
                rec["phrasing_notes"] = "; ".join(notes)
            records.append(rec)
            n += 1
    return records


def write_jsonl(path: Path, records: list[dict]) -> None:
    with open(path, "w", encoding="utf-8") as f:
        f.writelines(json.dumps(r, ensure_ascii=False) + "\n" for r in records)


def read_jsonl(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def fill_hand() -> None:
    """Parse, type-check and execute every hand-written record; write the reference answers."""
    path = HERE / "hand_written.jsonl"
    records = read_jsonl(path)
    scenes = {}
    bad = 0
    for r in records:
        if r["scene"] not in scenes:
            scenes[r["scene"]] = load_scene(HERE / r["scene"])
        res = run_program(scenes[r["scene"]], r["program"])
        if not res.valid:
            print(f"INVALID {r['id']}: {r['question']} -> {res.reason}", file=sys.stderr)
            bad += 1
            continue
        r["answer"] = jsonable(res.answer)
    if bad:
        raise SystemExit(f"{bad} invalid hand-written programs; nothing written")
    write_jsonl(path, records)
    print(f"{len(records)} hand-written answers filled")


def strip_masks(data: dict) -> dict:
    for ents in data["obj_mask_box"].values():
        for name, v in ents.items():
            if name != "info":
                v[1] = None
    for ents in data.get("occlusion", {}).values():
        for v in ents.values():
            v[1] = None
    for ann in data["po3d"]["annotations"]:
        for e in ann.values():
            e.pop("occlusion_mask", None)
    return data


def build_scenes() -> None:
    """Render seeds 8000-8047 with our world, strip the RLE masks, and check the stripped files against the
    rendered scenes: equal apart from the masks, and equal executor answers on every stored question."""
    from po3d_ppl.world import generate_scene
    from po3d_ppl.world.scene_io import dumps, scene_to_public

    def no_masks(sc):
        objs = []
        for o in sc.objects:
            a = dataclasses.replace(o.annotation, visible_mask=None, occlusion_mask=None)
            pa = {k: dataclasses.replace(v, visible_mask=None, occlusion_mask=None) for k, v in o.part_annotations.items()}
            objs.append(dataclasses.replace(o, annotation=a, part_annotations=pa))
        return dataclasses.replace(sc, objects=tuple(objs))

    (HERE / "scenes").mkdir(exist_ok=True)
    questions = defaultdict(list)
    for name in ("generated.jsonl", "hand_written.jsonl"):
        if (HERE / name).exists():
            for r in read_jsonl(HERE / name):
                questions[r["scene"]].append(r)
    checked = 0
    for seed in SEEDS:
        scene = generate_scene(seed).scene
        path = HERE / scene_rel(seed)
        path.write_text(dumps(strip_masks(scene_to_public(scene))))
        stripped = load_scene(path)
        assert no_masks(stripped) == no_masks(scene), seed
        for r in questions[scene_rel(seed)]:
            a, b = run_program(scene, r["program"]), run_program(stripped, r["program"])
            assert a.valid == b.valid and a.answer == b.answer, (seed, r["id"])
            checked += 1
        print(f"scene {seed}: {len(scene.objects)} objects", flush=True)
    print(f"stripped scenes equal the rendered ones; {checked} stored answers identical on both")


def show(seed: int) -> None:
    w = World(load_scene(HERE / scene_rel(seed)), scene_rel(seed))
    for o in w.objs:
        parts = ", ".join(f"{r}={c}/{m}" for r, (c, m) in sorted(o.parts.items()))
        occ = ", ".join(f"{r}<-{sorted(by)}" for r, by in sorted(o.part_occ.items()))
        print(f"[{o.i}] {o.size} {o.color} {o.material} {o.subtype} ({o.cat}) pose={o.pose} deg={o.deg:.0f}"
              f" occluded_by={sorted(o.occluded_by)}")
        print(f"     recoloured: {parts}")
        print(f"     occluded parts: {occ}")
        print("     " + "  ".join(f"{r}:{sorted(w.rel[r][o.i])}" for r in ont.RELATIONS)
              + "  same/opp/vert pose: " + " ".join(str(sorted(w.pose_rel(k, o.i))) for k in ("same", "opposite", "vertical")))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seed", type=int, default=8)
    ap.add_argument("--per-group", type=int, default=PER_GROUP)
    ap.add_argument("--hand", action="store_true", help="fill the answers of hand_written.jsonl")
    ap.add_argument("--scenes", action="store_true", help="re-render and strip the scenes, check them")
    ap.add_argument("--show", type=int, help="print a scene's objects")
    args = ap.parse_args()
    if args.scenes:
        build_scenes()
        return
    if args.show is not None:
        show(args.show)
        return
    if args.hand:
        fill_hand()
        return
    records = build(args.seed, args.per_group)
    write_jsonl(HERE / "generated.jsonl", records)
    counts = Counter(r["family_group"] for r in records)
    print(f"{len(records)} questions, {len({r['family'] for r in records})} families; "
          + ", ".join(f"{g} {counts[g]}" for g in GROUPS))


if __name__ == "__main__":
    main()

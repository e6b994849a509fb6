"""Build the independent question set (generated part) from the stored scenes.

    python tests/data/independent_questions/make_set.py            # writes generated.jsonl
    python tests/data/independent_questions/make_set.py --hand     # recomputes answers in hand_written.jsonl

Written from the program language (grammar/program.lark, docs/operations.md), the ontology and the public
Super-CLEVR / Super-CLEVR-3D / CLEVR formats only, without reading po3d_ppl's question templates, verbaliser or
generator. Every phrase list here is this file's own. Each question is grounded in one stored scene: referents are
picked among the scene's real objects and parts, descriptions are the shortest ones that pick the referent out
(the ``redundant`` group adds attributes), the program is written in our syntax, and the answer comes from the
reference executor; questions whose program is invalid on their scene are dropped.

THIS SET IS FOR EVALUATION ONLY: never train on it or select models with it.
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

from po3d_ppl import ontology as O
from po3d_ppl.language import check_program, parse_program
from po3d_ppl.questions.context import SceneContext
from po3d_ppl.questions.executor import execute
from po3d_ppl.world import load_scene

HERE = Path(__file__).resolve().parent
SCENES = sorted((HERE / "scenes").glob("scene_*.json"))

# ----------------------------------------------------------------------------------------------------------------
# Lexicon. ``base`` is what the public generators and ordinary users say; ``ext`` adds wider synonyms, used by the
# synonyms group (and sparingly elsewhere).

SIZE_W = {"large": ["large", "big"], "small": ["small", "tiny"]}
SIZE_W_EXT = {"large": ["large", "big", "huge", "giant"], "small": ["small", "tiny", "little"]}
MAT_W = {"metal": ["metal", "metallic", "shiny"], "rubber": ["rubber", "matte"]}
MAT_W_EXT = {"metal": ["metal", "metallic", "shiny", "shiny metal"], "rubber": ["rubber", "matte", "matt", "rubbery"]}
MAT_NOUN = {"metal": ["metal"], "rubber": ["rubber"]}
COLOR_W_EXT = {"gray": ["gray", "grey"]}

SUBTYPE_W = {
    "suv": ["suv", "SUV"], "wagon": ["wagon"], "minivan": ["minivan"], "sedan": ["sedan"], "truck": ["truck"],
    "articulated": ["articulated bus"], "regular": ["regular bus"], "double": ["double bus"],
    "school": ["school bus"], "chopper": ["chopper"], "dirtbike": ["dirtbike"], "scooter": ["scooter"],
    "cruiser": ["cruiser"], "jet": ["jet"], "fighter": ["fighter"], "biplane": ["biplane"], "airliner": ["airliner"],
    "road": ["road bike"], "utility": ["utility bike"], "mountain": ["mountain bike"], "tandem": ["tandem bike"],
}
SUBTYPE_W_EXT = {
    "suv": ["suv", "SUV", "sport utility vehicle"], "wagon": ["wagon", "station wagon"], "minivan": ["minivan", "mini van"],
    "truck": ["truck", "pickup truck"], "articulated": ["articulated bus", "bendy bus"],
    "double": ["double bus", "double-decker bus", "double decker"], "dirtbike": ["dirtbike", "dirt bike"],
    "fighter": ["fighter", "fighter plane"], "airliner": ["airliner", "passenger plane"],
    "road": ["road bike", "road bicycle"], "utility": ["utility bike", "utility bicycle"],
    "mountain": ["mountain bike", "mountain bicycle"], "tandem": ["tandem bike", "tandem", "tandem bicycle"],
    "chopper": ["chopper", "chopper motorbike"], "cruiser": ["cruiser", "cruiser motorcycle"],
    "scooter": ["scooter", "motor scooter"],
}
CAT_W = {"car": ["car"], "bus": ["bus"], "motorbike": ["motorbike"], "aeroplane": ["aeroplane", "airplane", "plane"],
         "bicycle": ["bicycle", "bike"]}
CAT_W_EXT = {"car": ["car", "automobile"], "bus": ["bus", "coach"], "motorbike": ["motorbike", "motorcycle"],
             "aeroplane": ["aeroplane", "airplane", "plane", "aircraft"], "bicycle": ["bicycle", "bike", "cycle"]}
THING_W = ["thing", "object"]
THING_W_EXT = ["thing", "object", "vehicle", "item"]

PLURAL_EXC = {"bus": "buses", "bike": "bikes", "SUV": "SUVs", "double decker": "double deckers", "tandem": "tandems"}

REL_W = {"left": ["left of", "to the left of", "on the left side of"],
         "right": ["right of", "to the right of", "on the right side of"],
         "behind": ["behind"], "front": ["in front of"]}
REL_W_EXT = {"left": ["left of", "to the left of", "on the left side of", "on the left of"],
             "right": ["right of", "to the right of", "on the right side of", "on the right of"],
             "behind": ["behind", "in back of"],
             "front": ["in front of"]}
# (not "closer to the camera than" / "farther back than": those are the relate[closer] / relate[farther] relations)
# "it"-forms for "There is a X; how many Y are <rel-it>?"
REL_IT = {"left": ["left of it", "to the left of it", "on the left side of it", "to its left"],
          "right": ["right of it", "to the right of it", "on the right side of it", "to its right"],
          "behind": ["behind it"], "front": ["in front of it"]}

POSE_FACE = {  # "the X [that faces ...]"
    "left_pose": ["faces left", "faces to the left", "is facing left", "faces the left", "points left",
                  "faces to the left pose", "is heading left"],
    "right_pose": ["faces right", "faces to the right", "is facing right", "faces the right", "points right",
                   "faces to the right pose", "is heading right"],
    "front_pose": ["faces the camera", "faces front", "faces forward", "is facing towards the camera",
                   "faces to the front pose", "faces toward us", "is facing the viewer"],
    "back_pose": ["faces away from the camera", "faces backward", "faces back", "is facing away",
                  "faces to the back pose", "points away from us", "faces away from the viewer"],
}
POSE_PART = {  # participle form: "the X facing ..."
    "left_pose": ["facing left", "facing to the left", "pointing left", "heading left"],
    "right_pose": ["facing right", "facing to the right", "pointing right", "heading right"],
    "front_pose": ["facing the camera", "facing forward", "facing towards us", "facing front"],
    "back_pose": ["facing away from the camera", "facing backward", "facing away", "facing back"],
}


class Style:
    def __init__(self, ext=False, extra=0, quirk=False):
        self.ext, self.extra, self.quirk = ext, extra, quirk
        self.used_extra = 0


BASE = Style()

# ----------------------------------------------------------------------------------------------------------------
# Scene facts


class World:
    def __init__(self, path: Path):
        self.path = path
        self.scene = load_scene(path)
        self.ctx = SceneContext(self.scene)
        self.n = len(self.scene.objects)
        self.obj = []
        for o in self.scene.objects:
            self.obj.append(dict(size=o.size, color=o.color, material=o.material, subtype=o.subtype,
                                 cat=O.CATEGORY_OF[o.subtype], pose=O.pose_label(o.pose_degree), deg=o.pose_degree))
        self.all = frozenset(range(self.n))

    def rel(self, i, r):
        return self.ctx.related(i, r)

    def occluded(self, i):
        return self.scene.objects[i].occluded

    def occluders(self, i):  # relate_occluded
        return frozenset(self.scene.objects[i].occluded_by)

    def occludees(self, j):  # relate_occluding
        return self.ctx.occludees_of[j]

    def parts_rec(self, i):  # object2part
        return sorted(self.ctx.recoloured_of[i])

    def parts_all(self, i):  # object2part_all
        return sorted(self.ctx.parts_all_of[i])

    def pname(self, part):
        return self.ctx.part_names[part]

    def pstyle(self, part):
        return self.ctx.part_style(part)


SLOTS = ("size", "color", "material", "shape")


def matches(o, key):
    for s, v in key.items():
        if s == "shape":
            if v not in (o["subtype"], o["cat"]):
                return False
        elif s == "pose":
            if o["pose"] != v:
                return False
        elif o[s] != v:
            return False
    return True


def denote(w, key, pool):
    return frozenset(i for i in pool if matches(w.obj[i], key))


def keys_of(o, exclude=(), pose=False):
    """Every key (dict) made of o's true attributes, shape as subtype or category or absent."""
    opts = []
    for s in SLOTS:
        if s in exclude:
            opts.append([None])
        elif s == "shape":
            opts.append([None, o["subtype"], o["cat"]])
        else:
            opts.append([None, o[s]])
    out = []
    for combo in itertools.product(*opts):
        out.append({s: v for s, v in zip(SLOTS, combo) if v is not None})
    return out


def describe(w, i, pool, rng, style=BASE, exclude=(), shape_bias=0.7, extra=None, must=None):
    """A key that selects exactly {i} in pool: minimal, plus ``extra`` redundant slots."""
    extra = style.extra if extra is None else extra
    o = w.obj[i]
    cands = [k for k in keys_of(o, exclude) if denote(w, k, pool) == {i}]
    if must:
        cands = [k for k in cands if all(k.get(s) == v for s, v in must.items())]
    if not cands:
        return None
    m = min(len(k) for k in cands)
    level = [k for k in cands if len(k) == m + extra]
    if not level and extra:
        level = [k for k in cands if len(k) == m + 1]
    if level and extra:
        style.used_extra += 1
    if not level:
        level = [k for k in cands if len(k) == m]
    with_shape = [k for k in level if "shape" in k]
    if with_shape and rng.random() < shape_bias:
        level = with_shape
    return dict(rng.choice(level))


def random_key(w, rng, exclude=(), allow_empty=False, nonempty_prob=0.8):
    """A key for count/exist questions: usually drawn from a real object, sometimes arbitrary values."""
    while True:
        if rng.random() < nonempty_prob:
            o = w.obj[rng.randrange(w.n)]
            k = rng.choice(keys_of(o, exclude))
        else:
            k = {}
            for s in SLOTS:
                if s in exclude or rng.random() < 0.55:
                    continue
                if s == "shape":
                    k[s] = rng.choice(O.SUBTYPES + O.CATEGORIES)
                else:
                    k[s] = rng.choice({"size": O.SIZES, "color": O.COLORS, "material": O.MATERIALS}[s])
        if k or allow_empty:
            return k


# ----------------------------------------------------------------------------------------------------------------
# Words


def pick(rng, xs):
    return rng.choice(xs)


def an(word):
    w = word.lower()
    return "an" if (w[:1] in "aeio" or w.startswith("suv") or w.startswith("sport")) else "a"


def plural(noun, style):
    last = noun.split()[-1]
    head = noun[: len(noun) - len(last)]
    if last in PLURAL_EXC:
        lp = PLURAL_EXC[last]
        if last == "bus" and style.quirk:
            lp = "buss"
    elif last.endswith(("s", "x", "ch", "sh")):
        lp = last + "es"
    else:
        lp = last + "s"
    return head + lp


def noun_word(key, rng, style):
    s = key.get("shape")
    if s is None:
        return pick(rng, THING_W_EXT if style.ext else (THING_W if rng.random() < 0.93 else THING_W + ["vehicle"]))
    if s in O.CATEGORIES:
        return pick(rng, (CAT_W_EXT if style.ext else CAT_W)[s])
    return pick(rng, (SUBTYPE_W_EXT if style.ext else SUBTYPE_W).get(s, SUBTYPE_W[s]))


def adj_words(key, rng, style):
    out = []
    if "size" in key:
        out.append(pick(rng, (SIZE_W_EXT if style.ext else SIZE_W)[key["size"]]))
    if "color" in key:
        c = key["color"]
        out.append(pick(rng, COLOR_W_EXT.get(c, [c])) if style.ext else c)
    if "material" in key:
        out.append(pick(rng, (MAT_W_EXT if style.ext else MAT_W)[key["material"]]))
    return out


def np_(key, rng, style=BASE, det="the", plural_=False):
    """Noun phrase of a key: 'the big red metal car'."""
    noun = noun_word(key, rng, style)
    adjs = adj_words(key, rng, style)
    if style.extra and len(adjs) >= 2 and rng.random() < 0.25 and "material" in key:
        # "the large red car made of metal": redundant descriptions often come out as relative clauses
        adjs = [a for a in adjs if a not in sum(MAT_W_EXT.values(), [])]
        tail = " " + pick(rng, ["made of ", "that is made of ", "which is made of "]) + key["material"]
    else:
        tail = ""
    words = " ".join(adjs + [plural(noun, style) if plural_ else noun]) + tail
    if det == "a":
        return f"{an(words)} {words}"
    if det:
        return f"{det} {words}"
    return words


def part_words(value, rng, style=BASE):
    """Words for a part-name value (canonical raw or super name), with spaced and joined variants."""
    words = O.readable_name(value) if value in O.RAW_PART_NAMES else value.replace("_", " ")
    variants = [words]
    for a, b in (("tail light", "taillight"), ("head light", "headlight"), ("rearlight", "rear light"),
                 ("side stand", "sidestand"), ("windscreen", "wind screen"), ("footrest", "foot rest"),
                 ("tailplane", "tail plane"), ("license plate", "licence plate")):
        if a in words:
            variants.append(words.replace(a, b))
        elif b in words and a == "rearlight":
            variants.append(words.replace(b, a))
    if style.ext:
        for a, b in (("back ", "rear "), ("license plate", "number plate"), ("side stand", "kickstand"),
                     ("windscreen", "windshield"), ("saddle", "seat"), ("tailplane", "horizontal stabilizer")):
            if a in words and not (a == "saddle" and "seat" in words):
                variants.append(words.replace(a, b))
    # mostly the canonical words; spaced/joined variants a third of the time
    if len(variants) > 1 and rng.random() < 0.4:
        return pick(rng, variants[1:])
    return words


def part_plural(words):
    return words + ("es" if words.endswith("s") else "s")


# ----------------------------------------------------------------------------------------------------------------
# Programs (pipeline syntax)


def filt(key, base="scene()"):
    out = base
    if "pose" in key:
        out += f" | filter_pose[{key['pose']}]"
    for s in SLOTS:
        if s in key:
            out += f" | filter_{s}[{key[s]}]"
    return out


def pfilt(pkey, base):
    out = base
    for s in ("size", "color", "material", "partname"):
        if s in pkey:
            out += f" | partfilter_{s}[{pkey[s]}]"
    return out


def uniq(key, base="scene()"):
    return filt(key, base) + " | unique"


# ----------------------------------------------------------------------------------------------------------------
# Families. Each takes (w, rng, style) and returns (question, program, family, notes) or None.

ATTRS = ("color", "material", "size", "shape")


class LongPossessive(Exception):
    """A possessive of a long noun phrase ("the car facing left's color") reads badly: the question is dropped."""

Q_ATTR = {
    "color": ["What color is {X}?", "What is the color of {X}?", "{X_} is what color?", "Which color is {X}?",
              "What color does {X} have?", "Tell me the color of {X}.", "What's the color of {X}?",
              "Can you tell me what color {X} is?", "There is {A}; what color is it?", "What is {X}'s color?",
              "{X_} has what color?", "Which color does {X} have?",
              "Look at {X}. What color is it?", "I see {A}. What color is it?"],
    "material": ["What material is {X}?", "What is {X} made of?", "What is the material of {X}?",
                 "What is {X} made out of?", "Which material is {X} made of?", "{X_} is made of what material?",
                 "There is {A}; what is it made of?", "Is {X} made of metal or rubber?", "Is {X} metal or rubber?",
                 "What's {X} made from?", "What material does {X} consist of?", "Is {X} rubber or metal?",
                 "Which material does {X} have?", "What kind of material is {X} made of?"],
    "size": ["What size is {X}?", "How big is {X}?", "What is the size of {X}?", "Is {X} large or small?",
             "Is {X} big or small?", "{X_} is what size?", "There is {A}; how big is it?",
             "Is {X} small or large?", "What's the size of {X}?", "How large is {X}?",
             "Tell me the size of {X}.", "What size does {X} have?", "Is {X} a big one or a small one?"],
    "shape": ["What shape is {X}?", "What type of vehicle is {X}?", "What kind of object is {X}?",
              "What is {X}?", "What is the shape of {X}?", "Which vehicle is {X}?", "What is the name of {X}?",
              "What sort of vehicle is {X}?", "{X_} is what kind of vehicle?", "There is {A}; what is it?",
              "What type of thing is {X}?", "Can you name {X}?", "What kind of vehicle is {X}?",
              "Identify {X}.", "What exactly is {X}?"],
}


def fill(t, **kw):
    for k, v in kw.items():
        if "{" + k + "}'s" in t and len(v.split()) > 4:
            raise LongPossessive
    out = t
    for k, v in kw.items():
        out = out.replace("{" + k + "_}", v[:1].upper() + v[1:])
        out = out.replace("{" + k + "}", v)
    return out[:1].upper() + out[1:]


def q_zero_hop_query(w, rng, st):
    attr = pick(rng, ATTRS)
    i = rng.randrange(w.n)
    key = describe(w, i, w.all, rng, st, exclude=(attr,), shape_bias=0.45 if attr == "shape" else 0.7)
    if key is None:
        return None
    if attr == "shape" and key.get("shape") in O.SUBTYPES:
        return None
    t = pick(rng, Q_ATTR[attr])
    q = fill(t, X=np_(key, rng, st), A=np_(key, rng, st, det="a"))
    return q, uniq(key) + f" | query_{attr}", f"zero_hop_query_{attr}", None


def rel_text(r, rng, st):
    return pick(rng, (REL_W_EXT if st.ext else REL_W)[r])


def chain(w, rng, st, hops, final_exclude=()):
    """A chain of `hops` relations: returns (objects, keys, rels) with objects[0] the anchor."""
    i = rng.randrange(w.n)
    k0 = describe(w, i, w.all, rng, st)
    if k0 is None:
        return None
    objs, keys, rels = [i], [k0], []
    for h in range(hops):
        r = pick(rng, O.RELATIONS)
        pool = w.rel(objs[-1], r)
        if not pool:
            return None
        j = rng.choice(sorted(pool))
        last = h == hops - 1
        k = describe(w, j, pool, rng, st, exclude=final_exclude if last else (), shape_bias=0.5)
        if k is None:
            return None
        objs.append(j), keys.append(k), rels.append(r)
    return objs, keys, rels


def chain_prog(keys, rels):
    p = uniq(keys[0])
    for k, r in zip(keys[1:], rels):
        p = uniq(k, p + f" | relate[{r}]")
    return p


def chain_np(keys, rels, rng, st):
    """'the red thing left of the cube behind the sphere' (innermost last)."""
    text = np_(keys[0], rng, st)
    for k, r in zip(keys[1:], rels):
        conn = pick(rng, ["", "that is ", "which is ", "", "that is "])
        text = f"{np_(k, rng, st)} {conn}{rel_text(r, rng, st)} {text}"
    return text


def q_hop_query(w, rng, st, hops):
    attr = pick(rng, ATTRS)
    c = chain(w, rng, st, hops, final_exclude=(attr,))
    if c is None:
        return None
    objs, keys, rels = c
    if attr == "shape" and keys[-1].get("shape") in O.SUBTYPES:
        return None
    form = rng.random()
    if hops >= 2 and form < 0.45:
        # CLEVR: "There is a X [rel] the Y; what color is the Z [rel] it?"
        inner = chain_np(keys[:-1], rels[:-1], rng, st)
        inner_a = re.sub(r"^the ", "", inner, count=1)
        inner_a = f"{an(inner_a)} {inner_a}"
        last = np_(keys[-1], rng, st)
        rit = pick(rng, REL_IT[rels[-1]])
        t = {"color": ["There is {I}; what color is {L} {R}?", "There is {I}; what is the color of {L} {R}?"],
             "material": ["There is {I}; what material is {L} {R}?", "There is {I}; what is {L} {R} made of?"],
             "size": ["There is {I}; what size is {L} {R}?", "There is {I}; how big is {L} {R}?"],
             "shape": ["There is {I}; what shape is {L} {R}?", "There is {I}; what kind of vehicle is {L} {R}?"]}
        q = fill(pick(rng, t[attr]), I=inner_a, L=last, R=rit)
    elif hops == 1 and form < 0.35:
        anchor = np_(keys[0], rng, st, det="a")
        last = np_(keys[-1], rng, st)
        rit = pick(rng, REL_IT[rels[-1]])
        t = {"color": ["There is {I}; what color is {L} {R}?", "Look at {I}. What color is {L} {R}?"],
             "material": ["There is {I}; what is {L} {R} made of?", "There is {I}; what material is {L} {R}?"],
             "size": ["There is {I}; what size is {L} {R}?", "There is {I}; is {L} {R} big or small?"],
             "shape": ["There is {I}; what is {L} {R}?", "There is {I}; what type of vehicle is {L} {R}?"]}
        q = fill(pick(rng, t[attr]), I=anchor, L=last, R=rit)
    else:
        x = chain_np(keys, rels, rng, st)
        q = fill(pick(rng, Q_ATTR[attr]), X=x, A=x)
        if "{A}" in q or q.count(" it?") and "There is" in q:
            return None
        if "There is the" in q or "I see the" in q:
            return None
    return q, chain_prog(keys, rels) + f" | query_{attr}", f"{['', 'one', 'two', 'three'][hops]}_hop_query_{attr}", None


COUNT_T = ["How many {P} are there?", "What number of {P} are there?", "How many {P} are in the scene?",
           "Count the {P}.", "How many {P} can you see?", "What is the number of {P}?", "How many {P} are present?",
           "How many {P} are visible?", "Tell me how many {P} there are.", "How many {P} are in the picture?",
           "How many {P} does the image contain?", "What's the total number of {P}?", "Number of {P}?",
           "How many {P} do you see?", "Give the number of {P}."]
EXIST_T = ["Are there any {P}?", "Is there {A}?", "Is there any {S}?", "Do you see any {P}?",
           "Does the scene contain {A}?", "Are any {P} present?", "Is there at least one {S}?",
           "Can you see {A}?", "Are there {P}?", "Does the image have any {P}?", "Is {A} visible?",
           "Is there {A} in the scene?", "Are there any {P} in the picture?", "Do any {P} exist?"]


def key_words_for_count(key, rng, st, pl=True):
    return np_(key, rng, st, det=None, plural_=pl)


def q_zero_hop_count(w, rng, st):
    key = random_key(w, rng)
    return (fill(pick(rng, COUNT_T), P=key_words_for_count(key, rng, st)), f"count({filt(key)})",
            "zero_hop_count", None)


def q_zero_hop_exist(w, rng, st):
    key = random_key(w, rng, nonempty_prob=0.6)
    t = pick(rng, EXIST_T)
    q = fill(t, P=np_(key, rng, st, det=None, plural_=True), A=np_(key, rng, st, det="a"),
             S=np_(key, rng, st, det=None))
    return q, f"exist({filt(key)})", "zero_hop_exist", None


def q_count_union(w, rng, st):
    k1, k2 = random_key(w, rng), random_key(w, rng)
    if k1 == k2:
        return None
    p1, p2 = (np_(k, rng, st, det=None, plural_=True) for k in (k1, k2))
    s1, s2 = (np_(k, rng, st, det="a") for k in (k1, k2))
    t = pick(rng, ["How many things are {A1} or {A2}?", "How many {P1} or {P2} are there?",
                   "How many objects are either {A1} or {A2}?", "What number of things are {P1} or {P2}?",
                   "How many {P1} and {P2} are there?", "What is the total number of {P1} and {P2}?",
                   "Count the {P1} and the {P2}.", "How many vehicles are either {P1} or {P2}?",
                   "How many things are {P1} or {P2}?", "Add up the {P1} and the {P2}: how many are there?"])
    q = fill(t, P1=p1, P2=p2, A1=s1, A2=s2)
    return q, f"count(union({filt(k1)}, {filt(k2)}))", "count_or", None


def q_exist_union(w, rng, st):
    k1, k2 = random_key(w, rng, nonempty_prob=0.5), random_key(w, rng, nonempty_prob=0.5)
    if k1 == k2:
        return None
    s1, s2 = (np_(k, rng, st, det="a") for k in (k1, k2))
    p1, p2 = (np_(k, rng, st, det=None, plural_=True) for k in (k1, k2))
    t = pick(rng, ["Is there {A1} or {A2}?", "Are there any {P1} or {P2}?", "Is there anything that is {A1} or {A2}?",
                   "Does the scene contain {A1} or {A2}?", "Can you see either {A1} or {A2}?"])
    q = fill(t, A1=s1, A2=s2, P1=p1, P2=p2)
    return q, f"exist(union({filt(k1)}, {filt(k2)}))", "exist_or", None


def two_anchors(w, rng, st):
    i, j = rng.sample(range(w.n), 2)
    ki, kj = describe(w, i, w.all, rng, st), describe(w, j, w.all, rng, st)
    if ki is None or kj is None:
        return None
    return i, j, ki, kj


def q_count_and(w, rng, st, exist=False):
    a = two_anchors(w, rng, st)
    if a is None:
        return None
    i, j, ki, kj = a
    r1, r2 = pick(rng, O.RELATIONS), pick(rng, O.RELATIONS)
    pool = w.rel(i, r1) & w.rel(j, r2)
    key = random_key(w, rng, allow_empty=True) if rng.random() < 0.6 else {}
    if pool and rng.random() < 0.7:
        o = w.obj[rng.choice(sorted(pool))]
        key = rng.choice(keys_of(o))
    xi, xj = np_(ki, rng, st), np_(kj, rng, st)
    ri, rj = rel_text(r1, rng, st), rel_text(r2, rng, st)
    p = np_(key, rng, st, det=None, plural_=True)
    prog_in = f"intersect({uniq(ki)} | relate[{r1}], {uniq(kj)} | relate[{r2}])"
    prog = filt(key, prog_in)
    if exist:
        s = np_(key, rng, st, det="a")
        t = pick(rng, ["Is there {S} that is {R1} {X1} and {R2} {X2}?", "Are there any {P} {R1} {X1} and {R2} {X2}?",
                       "Is there {S} both {R1} {X1} and {R2} {X2}?",
                       "Is anything {R1} {X1} and also {R2} {X2}?" if not key else "Is there {S} {R1} {X1} and {R2} {X2}?"])
        return fill(t, S=s, P=p, R1=ri, R2=rj, X1=xi, X2=xj), f"exist({prog})", "exist_and", None
    t = pick(rng, ["How many {P} are {R1} {X1} and {R2} {X2}?", "How many {P} are both {R1} {X1} and {R2} {X2}?",
                   "What number of {P} are {R1} {X1} and {R2} {X2}?",
                   "How many {P} are {R1} {X1} and also {R2} {X2}?",
                   "Count the {P} that are {R1} {X1} and {R2} {X2}."])
    return fill(t, P=p, R1=ri, R2=rj, X1=xi, X2=xj), f"count({prog})", "count_and", None


# --- core spatial: relational counts / exists, CLEVR "There is X; how many Y are behind it?"

def q_spatial_count(w, rng, st):
    i = rng.randrange(w.n)
    ki = describe(w, i, w.all, rng, st)
    if ki is None:
        return None
    r = pick(rng, O.RELATIONS)
    pool = sorted(w.rel(i, r))
    if pool and rng.random() < 0.75:
        key = rng.choice(keys_of(w.obj[rng.choice(pool)]))
    else:
        key = random_key(w, rng, allow_empty=True)
    p = np_(key, rng, st, det=None, plural_=True)
    prog = f"count({filt(key, uniq(ki) + f' | relate[{r}]')})"
    if rng.random() < 0.5:
        t = pick(rng, ["There is {A}; how many {P} are {RI}?", "There is {A}; what number of {P} are {RI}?",
                       "Look at {A}: how many {P} are {RI}?", "There is {A}. How many {P} are {RI}?",
                       "I see {A}. How many {P} are {RI}?"])
        q = fill(t, A=np_(ki, rng, st, det="a"), P=p, RI=pick(rng, REL_IT[r]))
    else:
        t = pick(rng, ["How many {P} are {R} {X}?", "What number of {P} are {R} {X}?", "How many {P} are there {R} {X}?",
                       "Count the {P} {R} {X}.", "What is the number of {P} {R} {X}?",
                       "How many {P} can be seen {R} {X}?", "How many {P} {R} {X} are there?"])
        q = fill(t, P=p, R=rel_text(r, rng, st), X=np_(ki, rng, st))
    return q, prog, "one_hop_count", None


def q_spatial_exist(w, rng, st):
    i = rng.randrange(w.n)
    ki = describe(w, i, w.all, rng, st)
    if ki is None:
        return None
    r = pick(rng, O.RELATIONS)
    pool = sorted(w.rel(i, r))
    if pool and rng.random() < 0.5:
        key = rng.choice(keys_of(w.obj[rng.choice(pool)]))
    else:
        key = random_key(w, rng, allow_empty=True)
    prog = f"exist({filt(key, uniq(ki) + f' | relate[{r}]')})"
    if rng.random() < 0.4:
        t = pick(rng, ["There is {A}; are there any {P} {RI}?", "There is {A}; is there {S} {RI}?",
                       "There is {A}. Is there anything {RI}?" if not key else "There is {A}. Is there {S} {RI}?"])
        q = fill(t, A=np_(ki, rng, st, det="a"), P=np_(key, rng, st, det=None, plural_=True),
                 S=np_(key, rng, st, det="a"), RI=pick(rng, REL_IT[r]))
    else:
        t = pick(rng, ["Are there any {P} {R} {X}?", "Is there {S} {R} {X}?", "Is there any {S1} {R} {X}?",
                       "Is there anything {R} {X}?" if not key else "Is there {S} {R} {X}?",
                       "Does {X} have {S} {R} it?", "Are any {P} {R} {X}?", "Can you see {S} {R} {X}?"])
        q = fill(t, P=np_(key, rng, st, det=None, plural_=True), S=np_(key, rng, st, det="a"),
                 S1=np_(key, rng, st, det=None), R=rel_text(r, rng, st), X=np_(ki, rng, st))
        q = q.replace("have a", "have a", 1)
    return q, prog, "one_hop_exist", None


def q_two_hop_count(w, rng, st, exist=False):
    c = chain(w, rng, st, 1)
    if c is None:
        return None
    objs, keys, rels = c
    r = pick(rng, O.RELATIONS)
    pool = sorted(w.rel(objs[-1], r))
    key = rng.choice(keys_of(w.obj[rng.choice(pool)])) if pool and rng.random() < 0.7 else random_key(w, rng, allow_empty=True)
    prog_in = filt(key, chain_prog(keys, rels) + f" | relate[{r}]")
    inner = chain_np(keys, rels, rng, st)
    inner_a = f"{an(inner[4:])} {inner[4:]}"
    if exist:
        t = pick(rng, ["Is there {S} {R} {X}?", "There is {IA}; is there {S} {RI}?", "Are there any {P} {R} {X}?"])
        fam, prog = "two_hop_exist", f"exist({prog_in})"
    else:
        t = pick(rng, ["How many {P} are {R} {X}?", "There is {IA}; how many {P} are {RI}?",
                       "What number of {P} are {R} {X}?", "There is {IA}; what number of {P} are {RI}?"])
        fam, prog = "two_hop_count", f"count({prog_in})"
    q = fill(t, S=np_(key, rng, st, det="a"), P=np_(key, rng, st, det=None, plural_=True), R=rel_text(r, rng, st),
             X=inner, IA=inner_a, RI=pick(rng, REL_IT[r]))
    return q, prog, fam, None


# --- compare attribute

CMP_T = {
    "size": ["Do {X} and {Y} have the same size?", "Is {X} the same size as {Y}?", "Are {X} and {Y} the same size?",
             "Does {X} have the same size as {Y}?", "Is {X} as big as {Y}?", "Are {X} and {Y} of the same size?",
             "Is the size of {X} the same as the size of {Y}?", "Is {X} the same size as {Y} is?",
             "Do {X} and {Y} share the same size?", "Is {X} equal in size to {Y}?"],
    "color": ["Is {X} the same color as {Y}?", "Do {X} and {Y} have the same color?", "Are {X} and {Y} the same color?",
              "Does {X} have the same color as {Y}?", "Is the color of {X} the same as {Y}?",
              "Is {X} colored the same as {Y}?", "Do {X} and {Y} share a color?", "Are {X} and {Y} of the same color?",
              "Is the color of {X} the same as the color of {Y}?", "Does {X} match {Y} in color?"],
    "material": ["Is {X} made of the same material as {Y}?", "Do {X} and {Y} have the same material?",
                 "Are {X} and {Y} made of the same material?", "Is {X} the same material as {Y}?",
                 "Does {X} have the same material as {Y}?", "Is the material of {X} the same as that of {Y}?",
                 "Are {X} and {Y} of the same material?", "Do {X} and {Y} share the same material?",
                 "Is {X} made of the same stuff as {Y}?"],
    "shape": ["Is {X} the same shape as {Y}?", "Do {X} and {Y} have the same shape?", "Are {X} and {Y} the same shape?",
              "Is {X} the same kind of vehicle as {Y}?", "Are {X} and {Y} the same type of vehicle?",
              "Does {X} have the same shape as {Y}?", "Are {X} and {Y} the same type of object?",
              "Is {X} the same type of thing as {Y}?"],
}


def q_compare_attr(w, rng, st, relational=False):
    attr = pick(rng, ATTRS)
    if relational:
        c = chain(w, rng, st, 1, final_exclude=(attr,))
        if c is None:
            return None
        objs, keys, rels = c
        j = rng.choice([k for k in range(w.n) if k != objs[-1]])
        kj = describe(w, j, w.all, rng, st, exclude=(attr,))
        if kj is None:
            return None
        xa, pa = chain_np(keys, rels, rng, st), chain_prog(keys, rels)
    else:
        i, j = rng.sample(range(w.n), 2)
        ki = describe(w, i, w.all, rng, st, exclude=(attr,))
        kj = describe(w, j, w.all, rng, st, exclude=(attr,))
        if ki is None or kj is None:
            return None
        keys = [ki]
        xa, pa = np_(ki, rng, st), uniq(ki)
    if attr == "shape" and (keys[-1].get("shape") in O.SUBTYPES or kj.get("shape") in O.SUBTYPES):
        return None
    xb, pb = np_(kj, rng, st), uniq(kj)
    if rng.random() < 0.5:
        xa, xb, pa, pb = xb, xa, pb, pa
    q = fill(pick(rng, CMP_T[attr]), X=xa, Y=xb)
    return (q, f"equal_{attr}({pa} | query_{attr}, {pb} | query_{attr})",
            f"compare_{attr}" + ("_relate" if relational else ""), None)


# --- compare integer

def q_compare_int(w, rng, st):
    k1, k2 = random_key(w, rng), random_key(w, rng)
    if k1 == k2:
        return None
    op = pick(rng, ["greater_than", "less_than", "equal_integer"])
    a, b = (np_(k, rng, st, det=None, plural_=True) for k in (k1, k2))
    T = {
        "greater_than": ["Are there more {A} than {B}?", "Is the number of {A} greater than the number of {B}?",
                         "Is the number of {A} larger than the number of {B}?", "Are there more {A} than there are {B}?",
                         "Do {A} outnumber {B}?", "Is the count of {A} bigger than the count of {B}?",
                         "Are {A} more numerous than {B}?", "Is the number of {A} bigger than that of {B}?",
                         "Are there a greater number of {A} than {B}?", "Does the scene have more {A} than {B}?",
                         "Is the number of {A} higher than the number of {B}?"],
        "less_than": ["Are there fewer {A} than {B}?", "Is the number of {A} less than the number of {B}?",
                      "Is the number of {A} smaller than the number of {B}?", "Are there less {A} than {B}?",
                      "Are there fewer {A} than there are {B}?", "Is the count of {A} lower than the count of {B}?",
                      "Are {A} less numerous than {B}?", "Are there a smaller number of {A} than {B}?",
                      "Are {A} outnumbered by {B}?", "Does the scene have fewer {A} than {B}?"],
        "equal_integer": ["Are there the same number of {A} and {B}?", "Is the number of {A} the same as the number of {B}?",
                          "Are there as many {A} as {B}?", "Are there an equal number of {A} and {B}?",
                          "Is the number of {A} equal to the number of {B}?", "Do {A} and {B} occur equally often?",
                          "Are there equally many {A} and {B}?", "Is the count of {A} the same as the count of {B}?",
                          "Are there exactly as many {A} as {B}?"],
    }
    q = fill(pick(rng, T[op]), A=a, B=b)
    fam = {"greater_than": "compare_more", "less_than": "compare_fewer", "equal_integer": "compare_equal_count"}[op]
    return q, f"{op}(count({filt(k1)}), count({filt(k2)}))", fam, None


def q_compare_int_relate(w, rng, st):
    i = rng.randrange(w.n)
    ki = describe(w, i, w.all, rng, st)
    if ki is None:
        return None
    r1, r2 = rng.sample(O.RELATIONS, 2)
    k1 = random_key(w, rng, allow_empty=True) if rng.random() < 0.5 else {}
    k2 = dict(k1) if rng.random() < 0.6 else random_key(w, rng, allow_empty=True)
    op = pick(rng, ["greater_than", "less_than", "equal_integer"])
    x = np_(ki, rng, st)
    a = np_(k1, rng, st, det=None, plural_=True)
    b = np_(k2, rng, st, det=None, plural_=True)
    ra, rb = rel_text(r1, rng, st), rel_text(r2, rng, st)
    if k1 == k2:
        T = {"greater_than": ["Are there more {A} {RA} {X} than {RB} it?", "Are there more {A} {RA} {X} than {RB} it?"],
             "less_than": ["Are there fewer {A} {RA} {X} than {RB} it?", "Are there less {A} {RA} {X} than {RB} it?"],
             "equal_integer": ["Are there as many {A} {RA} {X} as {RB} it?",
                               "Is the number of {A} {RA} {X} the same as the number {RB} it?"]}
    else:
        T = {"greater_than": ["Are there more {A} {RA} {X} than {B} {RB} it?",
                              "Is the number of {A} {RA} {X} greater than the number of {B} {RB} it?"],
             "less_than": ["Are there fewer {A} {RA} {X} than {B} {RB} it?",
                           "Is the number of {A} {RA} {X} less than the number of {B} {RB} it?"],
             "equal_integer": ["Are there as many {A} {RA} {X} as {B} {RB} it?",
                               "Is the number of {A} {RA} {X} equal to the number of {B} {RB} it?"]}
    q = fill(pick(rng, T[op]), A=a, B=b, RA=ra, RB=rb, X=x)
    pa = filt(k1, uniq(ki) + f" | relate[{r1}]")
    pb = filt(k2, uniq(ki) + f" | relate[{r2}]")
    return q, f"{op}(count({pa}), count({pb}))", "compare_count_relate", None


# --- same-relate

SAME_ATTR_W = {"size": ["size"], "color": ["color"], "material": ["material"], "shape": ["shape"]}


def q_same_relate(w, rng, st):
    attr = pick(rng, ATTRS)
    i = rng.randrange(w.n)
    ki = describe(w, i, w.all, rng, st, exclude=(attr,))
    if ki is None:
        return None
    if attr == "shape" and ki.get("shape") in O.SUBTYPES:
        return None
    same = sorted(i2 for i2 in w.all if i2 != i and (w.obj[i2][attr if attr != "shape" else "subtype"]
                                                       == w.obj[i][attr if attr != "shape" else "subtype"]))
    kind = pick(rng, ["exist", "count", "query", "query"])
    x = np_(ki, rng, st)
    a = pick(rng, SAME_ATTR_W[attr])
    base = uniq(ki) + f" | same_{attr}"
    if kind == "query":
        if not same:
            return None
        j = rng.choice(same)
        qattr = pick(rng, [q for q in ATTRS if q != attr])
        kj = describe(w, j, frozenset(same), rng, st, exclude=(qattr, attr), shape_bias=0.3)
        if kj is None or (qattr == "shape" and kj.get("shape") in O.SUBTYPES):
            return None
        y = np_(kj, rng, st, det=None)
        qw = {"color": ["What color is the other {Y} that", "What is the color of the other {Y} that",
                        "The other {Y} that {V} what color?"],
              "material": ["What is the other {Y} that", "What material is the other {Y} that"],
              "size": ["What size is the other {Y} that", "How big is the other {Y} that"],
              "shape": ["What shape is the other {Y} that", "What kind of vehicle is the other {Y} that"]}[qattr]
        head = pick(rng, qw)
        rel = pick(rng, ["is the same {a} as {X}", "has the same {a} as {X}", "is the same {a} as {X}"])
        rel = rel.replace("{a}", a)
        if head.endswith("what color?"):
            q = fill(head.replace("{V}", rel.replace("is the same", "is the same", 1)), Y=y, X=x)
            q = fill(f"The other {{Y}} that {rel} is what color?", Y=y, X=x)
        else:
            q = fill(head + " " + rel + ("; what is it made of?" if False else "?"), Y=y, X=x)
            if qattr == "material" and head.startswith("What is the other"):
                q = q[:-1] + " made of?"
        return q, filt(kj, base) + f" | unique | query_{qattr}", f"same_{attr}_query", None
    key = random_key(w, rng, exclude=(attr,), allow_empty=True) if rng.random() < 0.45 else {}
    if same and rng.random() < 0.5:
        key = rng.choice(keys_of(w.obj[rng.choice(same)], exclude=(attr,)))
    p = np_(key, rng, st, det=None, plural_=True) if key else pick(rng, ["things", "objects"])
    s = np_(key, rng, st, det=None) if key else pick(rng, ["thing", "object"])
    if kind == "exist":
        t = pick(rng, ["Are there any other {P} that have the same {a} as {X}?", "Is there anything else that is the same {a} as {X}?"
                       if not key else "Is there another {S} that is the same {a} as {X}?",
                       "Is there another {S} that has the same {a} as {X}?", "Are there other {P} of the same {a} as {X}?",
                       "Is there any other {S} with the same {a} as {X}?", "Does anything else have the same {a} as {X}?"
                       if not key else "Does any other {S} have the same {a} as {X}?",
                       "Are there any other {P} with the same {a} as {X}?", "Is there another {S} of the same {a} as {X}?",
                       "Are there any {P} besides {X} that have the same {a}?" if True else ""])
        q = fill(t.replace("{a}", a), P=p, S=s, X=x)
        return q, f"exist({filt(key, base)})", f"same_{attr}_exist", None
    t = pick(rng, ["How many other {P} are the same {a} as {X}?", "How many other {P} have the same {a} as {X}?",
                   "What number of other {P} are the same {a} as {X}?", "How many other {P} are there of the same {a} as {X}?",
                   "How many {P} besides {X} have the same {a}?", "How many other {P} share the {a} of {X}?",
                   "Count the other {P} with the same {a} as {X}.", "What number of other {P} have the same {a} as {X}?"])
    q = fill(t.replace("{a}", a), P=p, X=x)
    return q, f"count({filt(key, base)})", f"same_{attr}_count", None


# --- parts

PQ = {"color": ["What color is the {P} of {X}?", "What is the color of the {P} of {X}?", "What color is {X}'s {P}?",
                "Which color is the {P} of {X}?", "What's the color of {X}'s {P}?", "The {P} of {X} is what color?",
                "What color does the {P} of {X} have?", "What is the colour of the {P} on {X}?" if False else
                "What color is the {P} on {X}?", "There is {A}; what color is its {P}?"],
      "material": ["What material is the {P} of {X}?", "What is the {P} of {X} made of?", "What is {X}'s {P} made of?",
                   "What is the material of the {P} of {X}?", "Is the {P} of {X} metal or rubber?",
                   "Which material is the {P} on {X} made of?", "There is {A}; what is its {P} made of?",
                   "The {P} of {X} is made of what material?"]}


def part_key(w, part, pool, rng, st, exclude=(), loose_super=False):
    """Shortest description of a part among ``pool`` (parts): partname (full or super) plus colour/material.

    A bare super-part name ("the wheel of the car") is used only when the object has one part of that kind at
    all, unless ``loose_super`` ("the car whose wheel is occluded" reads fine with any wheel)."""
    raw = w.pname(part)
    full, sup = O.canonical_part_name(raw), O.super_part_name(raw)
    style = w.pstyle(part)
    names = [full] + ([sup] if sup != full else [])
    n_sup = sum(O.super_part_name(r) == sup for r in O.PARTS[w.obj[part[0]]["subtype"]])
    cands = []
    for nm in names:
        for c in ([None] if "color" in exclude or style is None else [None, style.color]):
            for m in ([None] if "material" in exclude or style is None else [None, style.material]):
                k = {"partname": nm}
                if c:
                    k["color"] = c
                if m:
                    k["material"] = m
                sel = [p for p in pool if O.partname_matches(w.pname(p), nm) and
                       (c is None or (w.pstyle(p) and w.pstyle(p).color == c)) and
                       (m is None or (w.pstyle(p) and w.pstyle(p).material == m))]
                if sel == [part] and not (nm == sup != full and len(k) == 1 and n_sup > 1 and not loose_super):
                    cands.append(k)
    if not cands:
        return None
    mn = min(len(k) for k in cands)
    add = st.extra if any(len(k) == mn + st.extra for k in cands) else 0
    if add:
        st.used_extra += 1
    best = [k for k in cands if len(k) == mn + add]
    # prefer the full name most of the time; the super name when it is enough
    sup_only = [k for k in best if k["partname"] == sup and sup != full]
    if sup_only and rng.random() < 0.35:
        return dict(rng.choice(sup_only))
    fulls = [k for k in best if k["partname"] == full] or best
    return dict(rng.choice(fulls))


def owners_with(w, name, objs):
    """Objects among ``objs`` that have a part called ``name`` at all (recoloured or not)."""
    return [j for j in objs if any(O.partname_matches(raw, name) for raw in O.PARTS[w.obj[j]["subtype"]])]


def part_np(pkey, rng, st, det="the"):
    words = []
    if "color" in pkey:
        words.append(pkey["color"])
    if "material" in pkey:
        words.append(pick(rng, (MAT_W_EXT if st.ext else MAT_W)[pkey["material"]]))
    words.append(part_words(pkey["partname"], rng, st))
    t = " ".join(words)
    if det == "a":
        return f"{an(t)} {t}"
    return f"{det} {t}" if det else t


def q_part_query(w, rng, st):
    i = rng.randrange(w.n)
    parts = w.parts_rec(i)
    if not parts:
        return None
    part = rng.choice(parts)
    attr = pick(rng, ["color", "material", "color", "material", "partname"])
    ki = describe(w, i, w.all, rng, st)
    if ki is None:
        return None
    prog_obj = uniq(ki) + " | object2part"
    if attr == "partname":
        pk = part_key(w, part, parts, rng, st)
        if pk is None:
            return None
        st_ = w.pstyle(part)
        pk = {"color": st_.color} if rng.random() < 0.6 else {"material": st_.material, "color": st_.color}
        sel = [p for p in parts if w.pstyle(p).color == st_.color and ("material" not in pk or w.pstyle(p).material == st_.material)]
        if sel != [part]:
            return None
        desc = " ".join([pk["color"]] + ([pick(rng, MAT_W[pk["material"]])] if "material" in pk else []))
        x = np_(ki, rng, st)
        t = pick(rng, ["Which part of {X} is {D}?", "What is the name of the {D} part of {X}?", "What is the {D} part of {X}?",
                       "Which part of {X} is {D} colored?" if "material" not in pk else "Which part of {X} is {D}?",
                       "Name the {D} part of {X}.", "The {D} part of {X} is which part?", "What part of {X} is {D}?"])
        q = fill(t, X=x, D=desc)
        return q, pfilt(pk, prog_obj) + " | unique | partquery_partname", "part_query_name", None
    pk = part_key(w, part, parts, rng, st, exclude=(attr,))
    if pk is None:
        return None
    q = fill(pick(rng, PQ[attr]), P=part_np(pk, rng, st, det=None), X=np_(ki, rng, st), A=np_(ki, rng, st, det="a"))
    return q, pfilt(pk, prog_obj) + f" | unique | partquery_{attr}", f"part_query_{attr}", None


def q_object_with_part(w, rng, st):
    """Super-CLEVR part 3-5: the object that has a <part> / whose <part> is <color>."""
    allparts = [p for i in range(w.n) for p in w.parts_rec(i)]
    if not allparts:
        return None
    part = rng.choice(allparts)
    i = part[0]
    attr = pick(rng, ["color", "shape", "material", "shape"])
    # object filter (may be empty) then the part must be unique among those objects' recoloured parts
    ki = {}
    if rng.random() < 0.4:
        ki = rng.choice(keys_of(w.obj[i], exclude=(attr,)))
        if attr == "shape" and ki.get("shape") in O.SUBTYPES:
            ki = {}
    objs = denote(w, ki, w.all)
    pool = [p for j in sorted(objs) for p in w.parts_rec(j)]
    pk = part_key(w, part, pool, rng, st)
    if pk is None:
        return None
    if "color" not in pk and (rng.random() < 0.7 or len(owners_with(w, pk["partname"], objs)) > 1):
        pk["color"] = w.pstyle(part).color
    sel = [p for p in pool if O.partname_matches(w.pname(p), pk["partname"]) and
           all(getattr(w.pstyle(p), a) == pk[a] for a in ("color", "material") if a in pk)]
    if sel != [part]:
        return None
    x = np_(ki, rng, st, det=None)
    pw = part_words(pk["partname"], rng, st)
    col = pk.get("color")
    mat = pick(rng, MAT_W[pk["material"]]) if "material" in pk else None
    adj = " ".join(a for a in (col, mat) if a)
    head = {"color": ["What color is the {X}", "What is the color of the {X}"],
            "shape": ["What is the {X}", "What type of vehicle is the {X}", "What shape is the {X}", "What is the name of the {X}"],
            "material": ["What material is the {X}", "What is the {X}"]}[attr]
    h = pick(rng, head)
    if col and rng.random() < 0.5:
        desc = pick(rng, [f"whose {pw} is {adj}", f"with {an(adj)} {adj} {pw}", f"that has {an(adj)} {adj} {pw}",
                          f"whose {pw} is colored {col}" if not mat else f"whose {pw} is {adj}"])
    else:
        p2 = f"{adj} {pw}".strip()
        desc = pick(rng, [f"that has {an(p2)} {p2}", f"with {an(p2)} {p2}", f"which has {an(p2)} {p2}"])
    q = fill(h + " " + desc, X=x)
    if h.startswith("What is the {X}") and attr == "material":
        q += " made of?"
    else:
        q += "?"
    return q, pfilt(pk, filt(ki) + " | object2part") + f" | unique | part2object | unique | query_{attr}", \
        f"object_with_part_query_{attr}", None


def q_part_same_object(w, rng, st):
    """Super-CLEVR part 6-8: the <part1> that belongs to the same object as the <part2>."""
    objs = [i for i in range(w.n) if len(w.parts_rec(i)) >= 2]
    if not objs:
        return None
    i = rng.choice(objs)
    p1, p2 = rng.sample(w.parts_rec(i), 2)
    allparts = [p for j in range(w.n) for p in w.parts_rec(j)]
    k2 = part_key(w, p2, allparts, rng, st)
    if k2 is None:
        return None
    if "color" not in k2 and (rng.random() < 0.5 or len(owners_with(w, k2["partname"], w.all)) > 1):
        k2["color"] = w.pstyle(p2).color
        if [p for p in allparts if O.partname_matches(w.pname(p), k2["partname"]) and w.pstyle(p).color == k2["color"]] != [p2]:
            return None
    attr = pick(rng, ["color", "material", "partname"])
    if attr == "partname":
        s1 = w.pstyle(p1)
        k1 = {"color": s1.color}
        if [p for p in w.parts_rec(i) if p != p2 and w.pstyle(p).color == s1.color] != [p1]:
            return None
        one = f"{s1.color} part"
    else:
        k1 = part_key(w, p1, w.parts_rec(i), rng, st, exclude=(attr,))
        if k1 is None:
            return None
        one = part_np(k1, rng, st, det=None)
    two = part_np(k2, rng, st, det=None)
    head = {"color": ["What color is the {A}", "What is the color of the {A}"],
            "material": ["What material is the {A}", "What is the material of the {A}"],
            "partname": ["Which part is the {A}", "What is the name of the {A}", "What is the {A}"]}[attr]
    tail = pick(rng, ["that belongs to the same object as the {B}", "on the same vehicle as the {B}",
                      "of the same object as the {B}", "that is on the same object as the {B}",
                      "belonging to the object that also has the {B}"])
    q = fill(pick(rng, head) + " " + tail + "?", A=one, B=two)
    prog = pfilt(k1, pfilt(k2, "scene() | object2part") + " | unique | part2object | object2part")
    return q, prog + f" | unique | partquery_{attr}", f"part_same_object_query_{attr}", None


def q_part_count_exist(w, rng, st):
    i = rng.randrange(w.n)
    ki = describe(w, i, w.all, rng, st)
    if ki is None:
        return None
    o = w.obj[i]
    kind = pick(rng, ["count_color", "exist_color", "exist_part_color", "count_scene", "exist_scene"])
    x = np_(ki, rng, st)
    if kind in ("count_color", "exist_color"):
        c = pick(rng, [c for c in O.COLORS if c != o["color"]])
        if w.parts_rec(i) and rng.random() < 0.6:
            c = w.pstyle(rng.choice(w.parts_rec(i))).color
            if c == o["color"]:
                return None
        prog_in = uniq(ki) + f" | object2part | partfilter_color[{c}]"
        if kind == "count_color":
            t = pick(rng, ["How many {C} parts does {X} have?", "How many parts of {X} are {C}?",
                           "What number of {C} parts does {X} have?", "Count the {C} parts of {X}.",
                           "How many of {X}'s parts are {C}?", "How many {C} parts are on {X}?"])
            return fill(t, C=c, X=x), f"count({prog_in})", "part_count_color", None
        t = pick(rng, ["Does {X} have a {C} part?", "Is any part of {X} {C}?", "Does {X} have any {C} parts?",
                       "Is there a {C} part on {X}?", "Are any of {X}'s parts {C}?"])
        return fill(t, C=c, X=x), f"exist({prog_in})", "part_exist_color", None
    if kind == "exist_part_color":
        names = O.PARTS[o["subtype"]]
        raw = rng.choice(names)
        if w.parts_rec(i) and rng.random() < 0.6:
            raw = w.pname(rng.choice(w.parts_rec(i)))
        c = pick(rng, [c for c in O.COLORS if c != o["color"]])
        rec = {w.pname(p): w.pstyle(p) for p in w.parts_rec(i)}
        if raw in rec and rng.random() < 0.6:
            c = rec[raw].color
        if c == o["color"]:
            return None
        nm = O.canonical_part_name(raw)
        pw = part_words(nm, rng, st)
        t = pick(rng, ["Is the {P} of {X} {C}?", "Does {X} have a {C} {P}?", "Is {X}'s {P} {C}?",
                       "Is there a {C} {P} on {X}?", "Is the {P} on {X} colored {C}?"])
        prog = f"exist({uniq(ki)} | object2part | partfilter_color[{c}] | partfilter_partname[{nm}])"
        return fill(t, P=pw, X=x, C=c), prog, "part_exist_named_color", "a part with the object's own colour is not a recoloured part; only other colours are asked"
    # scene-wide: "How many vehicles have a green wheel?"
    allparts = [p for j in range(w.n) for p in w.parts_rec(j)]
    if not allparts:
        return None
    part = rng.choice(allparts)
    sup = O.super_part_name(w.pname(part))
    c = w.pstyle(part).color if rng.random() < 0.7 else pick(rng, O.COLORS)
    key = {}
    if rng.random() < 0.5:
        key = rng.choice(keys_of(w.obj[part[0]], exclude=("color",)))
    pw = part_words(sup, rng, st)
    if any(w.obj[j]["color"] == c for j in denote(w, key, w.all) if any(O.partname_matches(w.pname(p), sup) for p in [(j, q) for q in range(len(O.PARTS[w.obj[j]["subtype"]]))])):
        return None  # an object of that colour with such a part would make the question's meaning unclear
    prog_in = filt(key) + f" | object2part | partfilter_color[{c}] | partfilter_partname[{sup}] | part2object"
    p = np_(key, rng, st, det=None, plural_=True)
    s = np_(key, rng, st, det="a")
    if kind == "count_scene":
        t = pick(rng, ["How many {P} have a {C} {W}?", "How many {P} have {C} {WS}?", "What number of {P} have a {C} {W}?",
                       "Count the {P} with a {C} {W}."])
        return fill(t, P=p, C=c, W=pw, WS=part_plural(pw)), f"count({prog_in})", "part_count_objects_with_part", None
    t = pick(rng, ["Is there {S} with a {C} {W}?", "Is there {S} that has a {C} {W}?", "Does any {S1} have a {C} {W}?",
                   "Are there any {P} with {C} {WS}?"])
    return (fill(t, S=s, S1=np_(key, rng, st, det=None), P=p, C=c, W=pw, WS=part_plural(pw)), f"exist({prog_in})",
            "part_exist_objects_with_part", None)


# --- pose

POSE_Q = ["Which direction is {X} facing?", "What direction is {X} facing?", "Which way is {X} facing?",
          "Which direction does {X} face?", "In which direction is {X} facing?", "Which direction {X} is facing?",
          "What is the pose of {X}?", "Which way does {X} point?", "What direction does {X} face?",
          "Where is {X} facing?", "Which way is {X} pointing?", "What is the orientation of {X}?",
          "Tell me which direction {X} faces.", "Which direction is {X} heading?", "Is {X} facing left, right, forward or backward?"]


def pose_ok(w, i):
    return w.obj[i]["pose"] != O.NO_POSE


def q_pose_query(w, rng, st):
    i = rng.randrange(w.n)
    if not pose_ok(w, i):
        return None
    ki = describe(w, i, w.all, rng, st)
    if ki is None:
        return None
    return fill(pick(rng, POSE_Q), X=np_(ki, rng, st)), uniq(ki) + " | query_pose", "pose_query", None


def pose_clause(pose, rng):
    if rng.random() < 0.5:
        return pick(rng, ["that ", "which ", "that ", ""]) .replace("", "") + pick(rng, POSE_FACE[pose]) if False else \
            pick(rng, ["that ", "which "]) + pick(rng, POSE_FACE[pose])
    return pick(rng, POSE_PART[pose])


def q_pose_filter_query(w, rng, st):
    i = rng.randrange(w.n)
    if not pose_ok(w, i):
        return None
    o = w.obj[i]
    attr = pick(rng, ATTRS)
    # need the pose: the key without pose must not be unique, the key with pose must be
    for _ in range(6):
        k = rng.choice(keys_of(o, exclude=(attr,)))
        if attr == "shape" and k.get("shape") in O.SUBTYPES:
            continue
        if len(denote(w, k, w.all)) > 1 and denote(w, dict(k, pose=o["pose"]), w.all) == {i}:
            break
    else:
        return None
    k["pose"] = o["pose"]
    base = {s: v for s, v in k.items() if s != "pose"}
    x = f"the {np_(base, rng, st, det=None)} {pose_clause(o['pose'], rng)}"
    q = fill(pick(rng, Q_ATTR[attr]), X=x, A="x")
    if "x;" in q or "I see x" in q or q.startswith("Look at x"):
        return None
    return q, uniq(k) + f" | query_{attr}", f"pose_filter_query_{attr}", None


def q_pose_filter_count(w, rng, st):
    pose = pick(rng, O.POSE_LABELS)
    key = random_key(w, rng, allow_empty=True)
    p = np_(key, rng, st, det=None, plural_=True) if key else pick(rng, ["things", "objects", "vehicles"])
    s = np_(key, rng, st, det="a") if key else pick(rng, ["anything", "something"])
    verb_pl = pick(rng, POSE_FACE[pose]).replace("faces", "face").replace("is ", "are ").replace("points", "point").replace("are heading", "are heading")
    if rng.random() < 0.6:
        t = pick(rng, ["How many {P} {V}?", "How many {P} are {G}?", "What number of {P} are {G}?", "Count the {P} {G}.",
                       "How many {P} that {V} are there?"])
        q = fill(t, P=p, V=verb_pl, G=pick(rng, POSE_PART[pose]))
        return q, f"count({filt(dict(key, pose=pose))})", "pose_filter_count", None
    t = pick(rng, ["Is there {S} {G}?", "Are there any {P} {G}?", "Are there any {P} that {V}?", "Does any {S1} {V1}?"])
    s1 = np_(key, rng, st, det=None) if key else "object"
    v1 = verb_pl.replace("are facing", "face")
    q = fill(t, S=s, P=p, V=verb_pl, G=pick(rng, POSE_PART[pose]), S1=s1, V1=v1)
    q = q.replace("Is there anything facing", "Is anything facing") if rng.random() < 0.3 else q
    return q, f"exist({filt(dict(key, pose=pose))})", "pose_filter_exist", None


POSE_REL = {
    "same": ["faces the same direction as {X}", "is facing the same direction as {X}", "points the same way as {X}",
             "has the same orientation as {X}", "faces the same way as {X}", "is parallel to {X}",
             "is facing in the same direction as {X}"],
    "opposite": ["faces the opposite direction as {X}", "faces the opposite direction to {X}",
                 "is facing the opposite direction of {X}", "points the opposite way from {X}",
                 "faces away from the direction of {X}", "has the opposite orientation to {X}",
                 "faces opposite to {X}"],
    "vertical": ["faces the vertical direction as {X}", "is perpendicular to {X}", "faces perpendicular to {X}",
                 "is facing at a right angle to {X}", "faces a direction perpendicular to {X}",
                 "is oriented at 90 degrees to {X}", "faces sideways relative to {X}"],
}


def q_pose_relate(w, rng, st):
    i = rng.randrange(w.n)
    if not pose_ok(w, i):
        return None
    ki = describe(w, i, w.all, rng, st)
    if ki is None:
        return None
    rel = pick(rng, ["same", "opposite", "vertical"])
    d = w.obj[i]["deg"]
    pool = sorted(j for j in w.all if j != i and O.pose_relation(d, w.obj[i]["pose"], w.obj[j]["deg"]) == rel)
    x = np_(ki, rng, st)
    clause = pick(rng, POSE_REL[rel]).replace("{X}", x)
    base = uniq(ki) + f" | {rel}_pose"
    kind = pick(rng, ["query", "query", "count", "exist"])
    if kind == "query":
        if not pool:
            return None
        j = rng.choice(pool)
        attr = pick(rng, ATTRS)
        kj = describe(w, j, frozenset(pool), rng, st, exclude=(attr,), shape_bias=0.5)
        if kj is None or (attr == "shape" and kj.get("shape") in O.SUBTYPES):
            return None
        y = f"the {np_(kj, rng, st, det=None)} that {clause}"
        q = fill(pick(rng, [t for t in Q_ATTR[attr] if "{A}" not in t]), X=y)
        return q, filt(kj, base) + f" | unique | query_{attr}", f"pose_{rel}_query_{attr}", None
    key = random_key(w, rng, allow_empty=True) if rng.random() < 0.5 else {}
    p = np_(key, rng, st, det=None, plural_=True) if key else pick(rng, ["things", "objects", "vehicles"])
    clause_pl = clause.replace("faces", "face").replace("is facing", "are facing").replace("points", "point") \
        .replace("has the", "have the").replace("is perpendicular", "are perpendicular").replace("is parallel", "are parallel") \
        .replace("is oriented", "are oriented")
    if kind == "count":
        t = pick(rng, ["How many {P} {C}?", "What number of {P} {C}?", "How many other {P} {C}?", "Count the {P} that {C}."])
        return fill(t, P=p, C=clause_pl), f"count({filt(key, base)})", f"pose_{rel}_count", None
    s = np_(key, rng, st, det="a") if key else "anything"
    t = pick(rng, ["Is there {S} that {C}?", "Are there any {P} that {C}?", "Does anything else {C2}?" if not key else "Is there {S} that {C}?"])
    return fill(t, S=s, P=p, C=clause if True else clause, C2=clause_pl), f"exist({filt(key, base)})", f"pose_{rel}_exist", None


# --- occlusion (objects)

OCC_ADJ = ["occluded", "occluded", "hidden", "partly hidden", "partially occluded", "blocked from view", "obscured",
           "partially hidden", "covered"]
OCC_BY = ["occluded by", "occluded by", "hidden by", "blocked by", "partly hidden by", "obscured by", "covered by",
          "partially occluded by"]
OCCLUDES = ["occludes", "occludes", "hides", "blocks", "is occluding", "partially hides", "obscures", "covers"]


def q_occ_query(w, rng, st):
    occ = sorted(i for i in w.all if w.occluded(i))
    if not occ:
        return None
    i = rng.choice(occ)
    attr = pick(rng, ATTRS)
    k = describe(w, i, frozenset(occ), rng, st, exclude=(attr,), shape_bias=0.5)
    if k is None or (attr == "shape" and k.get("shape") in O.SUBTYPES):
        return None
    # the occlusion must be needed
    if denote(w, k, w.all) == {i}:
        return None
    adj = pick(rng, OCC_ADJ)
    x = pick(rng, [f"the {np_(k, rng, st, det=None)} that is {adj}", f"the {adj} {np_(k, rng, st, det=None)}",
                   f"the {np_(k, rng, st, det=None)} which is {adj}"])
    q = fill(pick(rng, [t for t in Q_ATTR[attr] if "{A}" not in t]), X=x)
    return q, filt(k, "scene() | filter_occludee") + f" | unique | query_{attr}", f"occluded_query_{attr}", None


def q_occ_by_query(w, rng, st):
    rel = pick(rng, ["occluded_by", "occludes"])
    pairs = [(i, j) for i in w.all for j in w.occluders(i)]  # j occludes i
    if not pairs:
        return None
    i, j = rng.choice(pairs)
    attr = pick(rng, ATTRS)
    if rel == "occluded_by":   # target i, anchor j: relate_occluding(j) = objects j occludes
        target, anchor, pool, op = i, j, w.occludees(j), "relate_occluding"
    else:                      # target j, anchor i: relate_occluded(i) = objects occluding i
        target, anchor, pool, op = j, i, w.occluders(i), "relate_occluded"
    ka = describe(w, anchor, w.all, rng, st)
    kt = describe(w, target, frozenset(pool), rng, st, exclude=(attr,), shape_bias=0.5)
    if ka is None or kt is None or (attr == "shape" and kt.get("shape") in O.SUBTYPES):
        return None
    a = np_(ka, rng, st)
    verb = pick(rng, OCC_BY) if rel == "occluded_by" else pick(rng, OCCLUDES)
    conn = pick(rng, ['that ', 'which ', '']) if rel == 'occluded_by' else pick(rng, ['that ', 'which '])
    y = f"the {np_(kt, rng, st, det=None)} {conn}{'is ' if rel == 'occluded_by' else ''}{verb} {a}"
    y = y.replace(" that is occluded", " that is occluded").replace("  ", " ")
    if rel == "occluded_by" and y.split()[-len(verb.split()) - len(a.split()) - 2] not in ("that", "which"):
        y = y.replace(" is " + verb, " " + verb, 1)
    q = fill(pick(rng, [t for t in Q_ATTR[attr] if "{A}" not in t]), X=y)
    return q, filt(kt, uniq(ka) + f" | {op}") + f" | unique | query_{attr}", f"{rel}_query_{attr}", None


def q_occ_bool(w, rng, st):
    kind = pick(rng, ["is_occluded", "occluded_by", "occludes_any", "count_occluded", "count_occludees", "count_occluders"])
    i = rng.randrange(w.n)
    ki = describe(w, i, w.all, rng, st)
    if ki is None:
        return None
    x = np_(ki, rng, st)
    if kind == "is_occluded":
        t = pick(rng, ["Is {X} occluded?", "Is {X} partly hidden?", "Is {X} hidden behind something?",
                       "Is {X} occluded by anything?", "Is {X} blocked from view by another object?",
                       "Is {X} partially occluded?", "Is any of {X} hidden by other objects?", "Is {X} obscured?"])
        return (fill(t, X=x), f"exist({filt(ki, 'scene() | filter_occludee')})", "object_is_occluded",
                "no object-level occlusion query exists: written as exist over the occluded objects matching the description")
    if kind == "occluded_by":
        others = [j for j in range(w.n) if j != i]
        j = rng.choice(list(w.occluders(i)) if w.occluders(i) and rng.random() < 0.6 else others)
        kj = describe(w, j, w.all, rng, st)
        if kj is None:
            return None
        y = np_(kj, rng, st)
        if rng.random() < 0.5:
            t = pick(rng, ["Is {X} occluded by {Y}?", "Is {X} hidden by {Y}?", "Is {X} partly blocked by {Y}?",
                           "Is {X} behind {Y} from the camera's view, so that it is occluded by it?" if False else "Is {X} obscured by {Y}?"])
            return fill(t, X=x, Y=y), f"exist({filt(kj, uniq(ki) + ' | relate_occluded')})", "is_occluded_by", None
        t = pick(rng, ["Does {Y} occlude {X}?", "Does {Y} hide {X}?", "Does {Y} block {X}?", "Does {Y} partially hide {X}?"])
        return fill(t, X=x, Y=y), f"exist({filt(kj, uniq(ki) + ' | relate_occluded')})", "does_occlude", None
    if kind == "occludes_any":
        t = pick(rng, ["Does {X} occlude anything?", "Does {X} hide any other object?", "Is {X} blocking anything from view?",
                       "Does {X} occlude any objects?", "Is anything occluded by {X}?"])
        return fill(t, X=x), f"exist({uniq(ki)} | relate_occluding)", "occludes_anything", None
    if kind == "count_occludees":
        t = pick(rng, ["How many objects does {X} occlude?", "How many things are occluded by {X}?",
                       "How many things does {X} hide?", "What number of objects are hidden by {X}?"])
        return fill(t, X=x), f"count({uniq(ki)} | relate_occluding)", "count_occluded_by", None
    if kind == "count_occluders":
        t = pick(rng, ["How many objects occlude {X}?", "How many things are hiding {X}?", "By how many objects is {X} occluded?",
                       "How many things block {X} from view?"])
        return fill(t, X=x), f"count({uniq(ki)} | relate_occluded)", "count_occluders", None
    key = random_key(w, rng, allow_empty=True) if rng.random() < 0.6 else {}
    p = np_(key, rng, st, det=None, plural_=True) if key else pick(rng, ["things", "objects", "vehicles"])
    adj = pick(rng, ["occluded", "hidden", "partially occluded", "partly hidden", "occluded by something"])
    t = pick(rng, ["How many {P} are {O}?", "How many {O2} {P} are there?", "What number of {P} are {O}?",
                   "Count the {P} that are {O}."])
    adj2 = adj if " by " not in adj else "occluded"
    return (fill(t, P=p, O=adj, O2=adj2), f"count({filt(key, 'scene() | filter_occludee')})", "count_occluded", None)


# --- part occlusion

def q_part_occ(w, rng, st):
    kind = pick(rng, ["is_occluded", "is_occluded", "which_part", "count", "whose", "whose", "part_of_occluded",
                      "is_occluded_by", "whose_by", "count_hidden_by"])
    i = rng.randrange(w.n)
    ki = describe(w, i, w.all, rng, st)
    if ki is None:
        return None
    x = np_(ki, rng, st)
    allp = w.parts_all(i)
    occp = [p for p in allp if p in w.ctx.occluded_parts]
    if kind == "is_occluded":
        if not allp:
            return None
        part = rng.choice(occp if occp and rng.random() < 0.5 else allp)
        pk = part_key(w, part, allp, rng, st)
        if pk is None or len(pk) > 1:
            return None
        pw = part_words(pk["partname"], rng, st)
        t = pick(rng, ["Is the {P} of {X} occluded?", "Is {X}'s {P} occluded?", "Is the {P} of {X} hidden?",
                       "Is the {P} on {X} blocked from view?", "Is the {P} of {X} covered by something?",
                       "Can the {P} of {X} be fully seen?" if False else "Is the {P} of {X} partially hidden?",
                       "Is the {P} of {X} obscured?"])
        return (fill(t, P=pw, X=x), f"{pfilt(pk, uniq(ki) + ' | object2part_all')} | unique | partquery_occlusion",
                "part_is_occluded", None)
    if kind == "which_part":
        if len(occp) != 1:
            return None
        t = pick(rng, ["Which part of {X} is occluded?", "What part of {X} is hidden?", "Which part of {X} is blocked from view?",
                       "Name the occluded part of {X}.", "Which of {X}'s parts is occluded?"])
        return fill(t, X=x), f"{uniq(ki)} | object2part_all | partfilter_occludee | unique | partquery_partname", "which_part_occluded", None
    if kind == "count":
        t = pick(rng, ["How many parts of {X} are occluded?", "How many of {X}'s parts are hidden?",
                       "What number of parts of {X} are occluded?", "How many occluded parts does {X} have?"])
        return fill(t, X=x), f"count({uniq(ki)} | object2part_all | partfilter_occludee)", "count_occluded_parts", None
    if kind == "is_occluded_by":
        if not allp:
            return None
        part = rng.choice(allp)
        pk = part_key(w, part, allp, rng, st)
        if pk is None or len(pk) > 1:
            return None
        occs = w.ctx.part_occluders.get(part, ())
        j = rng.choice(list(occs)) if occs and rng.random() < 0.6 else rng.choice([j for j in range(w.n) if j != i])
        kj = describe(w, j, w.all, rng, st)
        if kj is None:
            return None
        pw = part_words(pk["partname"], rng, st)
        t = pick(rng, ["Is the {P} of {X} occluded by {Y}?", "Is {X}'s {P} hidden by {Y}?", "Does {Y} occlude the {P} of {X}?",
                       "Is the {P} of {X} blocked by {Y}?", "Does {Y} hide the {P} of {X}?"])
        prog = f"exist({filt(kj, pfilt(pk, uniq(ki) + ' | object2part_all') + ' | unique | relate_part_occluded')})"
        return fill(t, P=pw, X=x, Y=np_(kj, rng, st)), prog, "part_is_occluded_by", None
    if kind == "count_hidden_by":
        t = pick(rng, ["How many parts does {X} occlude?", "How many parts of other objects are hidden by {X}?",
                       "What number of parts are occluded by {X}?"])
        return fill(t, X=x), f"count({uniq(ki)} | relate_occluding_part)", "count_parts_occluded_by", None
    if kind == "whose":
        # "What color is the car whose front wheel is occluded?"  (occlusion 6-9)
        allocc = sorted(w.ctx.occluded_parts)
        if not allocc:
            return None
        part = rng.choice(allocc)
        j = part[0]
        attr = pick(rng, ATTRS)
        kj = {}
        if rng.random() < 0.5:
            kj = rng.choice(keys_of(w.obj[j], exclude=(attr,)))
            if attr == "shape" and kj.get("shape") in O.SUBTYPES:
                kj = {}
        pool = [p for p in allocc if p[0] in denote(w, kj, w.all)]
        pk = part_key(w, part, pool, rng, st, exclude=("color", "material"), loose_super=True)
        if pk is None:
            return None
        pw = part_words(pk["partname"], rng, st)
        y = f"the {np_(kj, rng, st, det=None)} whose {pw} is {pick(rng, ['occluded', 'hidden', 'occluded', 'blocked from view', 'partly hidden'])}"
        q = fill(pick(rng, [t for t in Q_ATTR[attr] if "{A}" not in t]), X=y)
        prog = pfilt(pk, filt(kj) + " | object2part_all | partfilter_occludee") + f" | part2object | unique | query_{attr}"
        return q, prog, f"whose_part_occluded_query_{attr}", None
    if kind == "whose_by":
        # "What color is the object whose wheel is occluded by the bus?" (occlusion_by 9-12)
        j = rng.randrange(w.n)
        hidden = sorted(w.ctx.parts_occluded_by[j])
        if not hidden:
            return None
        kj = describe(w, j, w.all, rng, st)
        if kj is None:
            return None
        part = rng.choice(hidden)
        pk = part_key(w, part, hidden, rng, st, exclude=("color", "material"), loose_super=True)
        if pk is None:
            return None
        attr = pick(rng, ATTRS)
        owners = frozenset(p[0] for p in hidden if O.partname_matches(w.pname(p), pk["partname"]))
        kt = describe(w, part[0], owners, rng, st, exclude=(attr,), shape_bias=0.4)
        if kt is None or (attr == "shape" and kt.get("shape") in O.SUBTYPES):
            return None
        pw = part_words(pk["partname"], rng, st)
        y = f"the {np_(kt, rng, st, det=None)} whose {pw} is {pick(rng, OCC_BY)} {np_(kj, rng, st)}"
        q = fill(pick(rng, [t for t in Q_ATTR[attr] if "{A}" not in t]), X=y)
        prog = filt(kt, pfilt(pk, uniq(kj) + " | relate_occluding_part") + " | unique | part2object") + f" | unique | query_{attr}"
        return q, prog, f"whose_part_occluded_by_query_{attr}", None
    # part_of_occluded: "What color is the wheel which belongs to the occluded car?" (occlusion 10-12)
    occ = sorted(o for o in w.all if w.occluded(o))
    if not occ:
        return None
    j = rng.choice(occ)
    kj = describe(w, j, frozenset(occ), rng, st)
    if kj is None or not kj or denote(w, kj, w.all) == {j}:
        return None
    parts = w.parts_rec(j)
    if not parts:
        return None
    part = rng.choice(parts)
    attr = pick(rng, ["color", "material"])
    pk = part_key(w, part, parts, rng, st, exclude=(attr,))
    if pk is None:
        return None
    y = pick(rng, [f"the occluded {np_(kj, rng, st, det=None)}", f"the {np_(kj, rng, st, det=None)} that is occluded",
                   f"the hidden {np_(kj, rng, st, det=None)}"])
    t = pick(rng, ["What color is the {P} which belongs to {Y}?", "What color is the {P} of {Y}?"] if attr == "color" else
             ["What material is the {P} of {Y}?", "What is the {P} of {Y} made of?"])
    q = fill(t, P=part_np(pk, rng, st, det=None), Y=y)
    prog = pfilt(pk, filt(kj, "scene() | filter_occludee") + " | unique | object2part") + f" | unique | partquery_{attr}"
    return q, prog, f"part_of_occluded_query_{attr}", None


# ----------------------------------------------------------------------------------------------------------------
# Typos: one edit (deletion, insertion, substitution) in one content word of length >= 5


PROTECT = {"there", "what", "which", "many", "color", "same", "other", "that", "does", "have", "than"}


def typo(q, rng):
    words = q.split(" ")
    idx = [k for k, t in enumerate(words) if len(re.sub(r"\W", "", t)) >= 5]
    if not idx:
        return None
    k = rng.choice(idx)
    wd = words[k]
    core = re.sub(r"[^A-Za-z]", "", wd)
    pos = rng.randrange(1, len(core) - 1)
    op = rng.choice(["del", "ins", "sub"])
    letters = "abcdefghijklmnopqrstuvwxyz"
    if op == "del":
        new = core[:pos] + core[pos + 1:]
    elif op == "ins":
        new = core[:pos] + rng.choice(letters) + core[pos:]
    else:
        new = core[:pos] + rng.choice([c for c in letters if c != core[pos]]) + core[pos + 1:]
    words[k] = wd.replace(core, new)
    return " ".join(words), f"typo: {core} -> {new}"


# ----------------------------------------------------------------------------------------------------------------

GROUPS = {
    "core_query": [(lambda w, r, s: q_zero_hop_query(w, r, s), 4), (lambda w, r, s: q_hop_query(w, r, s, 1), 3),
                   (lambda w, r, s: q_hop_query(w, r, s, 2), 2), (lambda w, r, s: q_hop_query(w, r, s, 3), 1)],
    "core_count": [(q_zero_hop_count, 4), (q_count_union, 2), (lambda w, r, s: q_count_and(w, r, s), 2),
                   (lambda w, r, s: q_two_hop_count(w, r, s), 1)],
    "core_exist": [(q_zero_hop_exist, 4), (q_exist_union, 1), (lambda w, r, s: q_count_and(w, r, s, exist=True), 2),
                   (lambda w, r, s: q_two_hop_count(w, r, s, exist=True), 1)],
    "core_compare_attribute": [(q_compare_attr, 4), (lambda w, r, s: q_compare_attr(w, r, s, relational=True), 1)],
    "core_compare_integer": [(q_compare_int, 4), (q_compare_int_relate, 1)],
    "core_same_relate": [(q_same_relate, 1)],
    "core_spatial": [(q_spatial_count, 3), (q_spatial_exist, 2), (lambda w, r, s: q_hop_query(w, r, s, 1), 1)],
    "parts": [(q_part_query, 4), (q_object_with_part, 3), (q_part_same_object, 2), (q_part_count_exist, 3)],
    "pose": [(q_pose_query, 2), (q_pose_filter_query, 2), (q_pose_filter_count, 1), (q_pose_relate, 3)],
    "occlusion": [(q_occ_query, 2), (q_occ_by_query, 3), (q_occ_bool, 3)],
    "part_occlusion": [(q_part_occ, 1)],
}
ALL_FAMS = [f for g in GROUPS.values() for f in g]


def to_jsonable(v):
    if isinstance(v, (frozenset, set)):
        return sorted(v)
    if isinstance(v, tuple):
        return list(v)
    return v


def run_one(w, q, prog):
    p = parse_program(prog)
    check_program(p)
    r = execute(w.scene, p)
    return r


def build(per_group, seed):
    rng = random.Random(seed)
    worlds = [World(p) for p in SCENES]
    records, seen = [], set()
    answers = defaultdict(Counter)

    def accept(group, fam, ans):
        c = answers[(group, fam)]
        tot = sum(c.values())
        if isinstance(ans, bool) or (isinstance(ans, int) and not isinstance(ans, bool)):
            if tot >= 4 and c[ans] > 0.6 * tot + 1:
                return False
        if isinstance(ans, int) and not isinstance(ans, bool) and ans == 0 and c[0] > 0.25 * tot + 1:
            return False
        return True

    plan = [(g, BASE) for g in GROUPS] + [("redundant", Style(extra=1)), ("redundant", Style(extra=2)),
                                          ("synonyms_quirks_typos", Style(ext=True)),
                                          ("synonyms_quirks_typos", Style(quirk=True)),
                                          ("synonyms_quirks_typos", Style(ext=False, quirk=False))]
    share = Counter(g for g, _ in plan)
    for group, style in plan:
        target = per_group // share[group]
        fams = GROUPS.get(group, ALL_FAMS)
        weights = [wt for _, wt in fams]
        got, tries = 0, 0
        typos = group == "synonyms_quirks_typos" and not style.ext and not style.quirk
        while got < target and tries < target * 400:
            tries += 1
            w = worlds[rng.randrange(len(worlds))]
            fn = rng.choices([f for f, _ in fams], weights)[0]
            style.used_extra = 0
            try:
                out = fn(w, rng, style)
            except LongPossessive:
                continue
            if out is None:
                continue
            q, prog, fam, notes = out
            if style.quirk and "buss" not in q:
                continue
            r = run_one(w, q, prog)
            if not r.valid:
                continue
            if group == "redundant" and not style.used_extra:
                continue
            if typos:
                t = typo(q, rng)
                if t is None:
                    continue
                q, notes = t
            ans = to_jsonable(r.answer)
            if (w.path.name, q) in seen or not accept(group, fam, ans):
                continue
            seen.add((w.path.name, q))
            answers[(group, fam)][ans if not isinstance(ans, list) else str(ans)] += 1
            if style.ext:
                notes = "wider synonyms" + (f"; {notes}" if notes else "")
            if style.quirk:
                notes = "public plural quirk 'buss'" + (f"; {notes}" if notes else "")
            if group == "redundant":
                notes = f"{style.extra} redundant attribute(s) per description where possible" + (f"; {notes}" if notes else "")
            records.append({"id": f"g{len(records):05d}", "question": q, "program": prog, "family_group": group,
                            "family": fam, "scene": f"scenes/{w.path.name}", "answer": ans,
                            **({"phrasing_notes": notes} if notes else {})})
            got += 1
        print(f"{group:26s} {got:4d} ({tries} tries)", file=sys.stderr)
    return records


def redundant_ok(w, prog):
    """A redundant question must contain at least one description with more attributes than needed: some
    filter chain that still selects the same set after dropping one of its attribute filters."""
    return prog.count("| filter_") + prog.count("| partfilter_") >= 3


def fill_hand():
    path = HERE / "hand_written.jsonl"
    worlds = {}
    out = []
    for line in path.read_text().splitlines():
        if not line.strip():
            continue
        rec = json.loads(line)
        sc = rec["scene"]
        if sc not in worlds:
            worlds[sc] = World(HERE / sc)
        r = run_one(worlds[sc], rec["question"], rec["program"])
        if not r.valid:
            print(f"INVALID {rec['id']}: {rec['question']} :: {r.reason}", file=sys.stderr)
            continue
        rec["answer"] = to_jsonable(r.answer)
        out.append(rec)
    path.write_text("".join(json.dumps(r) + "\n" for r in out))
    print(f"{len(out)} hand-written records", file=sys.stderr)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--per-group", type=int, default=118)
    ap.add_argument("--seed", type=int, default=20240)
    ap.add_argument("--hand", action="store_true")
    a = ap.parse_args()
    if a.hand:
        fill_hand()
        return
    recs = build(a.per_group, a.seed)
    (HERE / "generated.jsonl").write_text("".join(json.dumps(r) + "\n" for r in recs))
    c = Counter(r["family_group"] for r in recs)
    print(dict(c), len(recs), file=sys.stderr)


if __name__ == "__main__":
    main()

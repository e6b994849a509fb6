"""Build the second independent question set (v2) for the question parser: questions with programs, grounded in
the stored scenes of this folder, answered by the reference executor.

    python tests/data/independent_questions_v2/make_set.py            # writes generated.jsonl
    python tests/data/independent_questions_v2/make_set.py --hand     # fills the answers of hand_written.jsonl

Everything is deterministic from ``--seed``. The phrase lists below are this set's own: they were written without
looking at the project's templates, realiser, verbaliser, lexicon or any question file. Evaluation only: never
train, tune or select a model on the output (see README.md).

How a question is made: pick a scene and a family, pick real referents of that scene, describe each with the
shortest description that singles it out among the objects it is chosen from (``Style.key``; the ``redundant``
group adds one or two more true attributes), write the text from the phrase lists, write the program in the public
Super-CLEVR-3D / CLEVR form (v1 README conventions), run the reference executor and keep the question only if the
program is valid. Per family, a pool of candidates is drawn and the kept questions are picked answer by answer
(round robin over the answers present), so yes/no and counts are roughly balanced.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import sys
from collections import Counter, defaultdict
from dataclasses import dataclass, field
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

from po3d_ppl import ontology
from po3d_ppl.language import check_program, parse_program
from po3d_ppl.questions.context import SceneContext
from po3d_ppl.questions.executor import execute
from po3d_ppl.world import load_scene

HERE = Path(__file__).resolve().parent
GROUPS = ("core_query", "core_count", "core_exist", "core_compare_attribute", "core_compare_integer",
          "core_same_relate", "core_spatial", "parts", "pose", "occlusion", "part_occlusion", "redundant",
          "synonyms_quirks_typos")
ATTRS = ("size", "color", "material", "shape")
SLOTS = ("pose", "size", "color", "material", "shape")


# ----------------------------------------------------------------------------------------------------------------
# scenes


@dataclass
class Obj:
    i: int
    subtype: str
    category: str
    size: str
    color: str
    material: str
    pose: str | None  # front/back/left/right or None (dead zone)
    degree: float
    occluded: bool


class World:
    """One stored scene with the facts the generator needs (read from the executor's own SceneContext)."""

    def __init__(self, path: Path):
        self.path = path
        self.name = f"scenes/{path.name}"
        self.ctx = ctx = SceneContext(load_scene(path))
        self.objs: list[Obj] = []
        for i, o in enumerate(ctx.objects):
            label = ontology.pose_label(o.pose_degree)
            self.objs.append(Obj(i, o.subtype, ontology.category_of(o.subtype), o.size, o.color, o.material,
                                 None if label == ontology.NO_POSE else label[:-5], o.pose_degree,
                                 bool(o.annotation.occlusion.occluded)))
        self.all = frozenset(range(len(self.objs)))

    # relations
    def rel(self, i: int, r: str) -> frozenset[int]:
        return frozenset(self.ctx.related(i, r))

    def same(self, i: int, attr: str) -> frozenset[int]:
        a = "subtype" if attr == "shape" else attr
        v = getattr(self.objs[i], a)
        return frozenset(j for j in self.all if j != i and getattr(self.objs[j], a) == v)

    def pose_rel(self, i: int, kind: str) -> frozenset[int]:
        o = self.objs[i]
        if o.pose is None:
            return frozenset()
        return frozenset(j for j in self.all if j != i and ontology.pose_relation(
            o.degree, o.pose + "_pose", self.objs[j].degree) == kind)

    def occluded(self) -> frozenset[int]:
        return frozenset(o.i for o in self.objs if o.occluded)

    def occluders_of(self, i: int) -> frozenset[int]:  # relate_occluded
        return frozenset(self.ctx.objects[i].occluded_by)

    def occludees_of(self, j: int) -> frozenset[int]:  # relate_occluding
        return self.ctx.occludees_of[j]

    # parts: (object, part id)
    def recoloured(self, i: int) -> list[tuple[int, int]]:
        return sorted(self.ctx.recoloured_of[i])

    def parts_all(self, i: int) -> list[tuple[int, int]]:
        return sorted(self.ctx.parts_all_of[i])

    def part_raw(self, p) -> str:
        return self.ctx.part_names[p]

    def part_style(self, p):
        return self.ctx.part_style(p)

    def part_occluded(self, p) -> bool:
        return p in self.ctx.occluded_parts

    def part_occluders(self, p) -> frozenset[int]:
        return frozenset(self.ctx.part_occluders.get(p, ()))

    def parts_hidden_by(self, j: int) -> frozenset:
        return self.ctx.parts_occluded_by[j]


# ----------------------------------------------------------------------------------------------------------------
# words

PLAIN_THING = ["thing", "object", "thing", "object", "thing"]
WIDE_THING = ["vehicle", "item", "vehicle", "object"]
PLAIN_SIZE = {"large": ["large", "big", "large"], "small": ["small", "tiny", "small"]}
WIDE_SIZE = {"large": ["big", "huge", "large-sized"], "small": ["little", "tiny", "small-sized"]}
PLAIN_MAT = {"metal": ["metal", "metallic", "shiny", "metal"], "rubber": ["rubber", "matte", "rubber"]}
WIDE_MAT = {"metal": ["metallic", "shiny", "steel"], "rubber": ["rubbery", "matte", "rubber"]}
POST_MAT = {"metal": ["made of metal"], "rubber": ["made of rubber"]}
WIDE_COLOR = {"gray": ["grey"], "purple": ["violet", "purple"], "cyan": ["turquoise", "cyan"],
              "brown": ["brown"], "red": ["red"], "blue": ["blue"], "green": ["green"], "yellow": ["yellow"]}
PLAIN_SHAPE = {
    "suv": ["SUV"], "wagon": ["wagon"], "minivan": ["minivan"], "sedan": ["sedan"], "truck": ["truck"],
    "articulated": ["articulated bus"], "regular": ["regular bus"], "double": ["double bus"],
    "school": ["school bus"], "chopper": ["chopper"], "dirtbike": ["dirtbike"], "scooter": ["scooter"],
    "cruiser": ["cruiser"], "jet": ["jet"], "fighter": ["fighter"], "biplane": ["biplane"],
    "airliner": ["airliner"], "road": ["road bike"], "utility": ["utility bike"], "mountain": ["mountain bike"],
    "tandem": ["tandem bike"],
    "car": ["car"], "bus": ["bus"], "motorbike": ["motorbike"], "aeroplane": ["aeroplane"], "bicycle": ["bicycle"],
}
WIDE_SHAPE = {
    "suv": ["sport utility vehicle", "SUV"], "wagon": ["station wagon", "estate car"], "minivan": ["mini van", "minivan"],
    "sedan": ["sedan car", "saloon"], "truck": ["pickup truck", "pickup"],
    "articulated": ["bendy bus", "articulated coach"], "regular": ["ordinary bus", "normal bus", "standard bus"],
    "double": ["double-decker bus", "double decker", "double-decker"], "school": ["schoolbus", "yellow-style school bus"],
    "chopper": ["chopper motorcycle", "chopper bike"], "dirtbike": ["dirt bike", "dirt bike"],
    "scooter": ["motor scooter", "moped"], "cruiser": ["cruiser motorcycle", "cruiser bike"],
    "jet": ["jet plane", "private jet"], "fighter": ["fighter jet", "fighter plane"], "biplane": ["bi-plane", "biplane"],
    "airliner": ["passenger jet", "passenger plane", "jetliner"], "road": ["racing bike", "road bicycle"],
    "utility": ["utility bicycle", "city bike"], "mountain": ["mountain bicycle", "MTB"],
    "tandem": ["tandem", "tandem bicycle"],
    "car": ["automobile", "auto", "car"], "bus": ["bus", "coach"], "motorbike": ["motorcycle", "motor bike"],
    "aeroplane": ["plane", "airplane", "aircraft"], "bicycle": ["bike", "cycle", "push bike"],
}
# not every wide word is a safe synonym; these are kept out of questions (ambiguous or wrong)
for _k, _bad in (("school", "yellow-style school bus"), ("bus", "coach"), ("scooter", "moped"),
                 ("articulated", "articulated coach"), ("jet", "private jet"), ("sedan", "saloon")):
    WIDE_SHAPE[_k] = [w for w in WIDE_SHAPE[_k] if w != _bad]

POSE_WORDS = {
    "front": ["facing the camera", "facing us", "facing toward the camera", "facing forward", "facing the viewer",
              "pointing toward the camera"],
    "back": ["facing away from the camera", "facing away", "facing away from us", "pointing away from the camera",
             "turned away from the camera"],
    "left": ["facing left", "facing to the left", "pointing left", "heading left", "turned to the left"],
    "right": ["facing right", "facing to the right", "pointing right", "heading right", "turned to the right"],
}
REL_WORDS = {
    "left": ["left of", "to the left of", "on the left side of", "to the left of"],
    "right": ["right of", "to the right of", "on the right side of", "to the right of"],
    "behind": ["behind", "behind", "in back of"],
    "front": ["in front of", "in front of", "in front of"],
}
REL_PLAIN_ONLY = {"in back of"}  # wider relation words, only in the synonyms group
REL_OPPOSITE = {"left": "right", "right": "left", "behind": "front", "front": "behind"}

PART_TEXT_VARIANTS = {  # word-level spelling variants used in ordinary questions (spaced / joined)
    "head light": ["head light", "headlight"],
    "headlight": ["headlight", "head light"],
    "tail light": ["tail light", "taillight"],
    "taillight": ["taillight", "tail light"],
    "rearlight": ["rearlight", "rear light"],
    "tailplane": ["tailplane", "tail plane"],
    "windscreen": ["windscreen", "wind screen"],
    "footrest": ["footrest", "foot rest"],
    "gas tank": ["gas tank", "gastank"],
    "side stand": ["side stand", "sidestand", "side-stand"],
    "license plate": ["license plate", "license plate", "licence plate"],
    "drive chain": ["drive chain", "drivechain"],
}
PART_WIDE = {  # wider synonyms of part words (synonyms group)
    "hood": ["bonnet"], "trunk": ["boot"], "windscreen": ["windshield"], "side stand": ["kickstand"],
    "license plate": ["number plate", "licence plate"], "handle": ["handlebar"], "fender": ["mudguard"],
    "gas tank": ["fuel tank", "petrol tank"], "footrest": ["foot peg"], "fin": ["tail fin"],
    "rearlight": ["rear reflector light", "back light"], "saddle": ["bike seat"], "drive chain": ["chain"],
    "crank arm": ["crank"], "tailplane": ["horizontal stabilizer"], "propeller": ["prop"],
}
PART_WIDE["rearlight"] = ["rear light"]


def cap(s: str) -> str:
    return s[:1].upper() + s[1:]


def indef(np: str) -> str:
    w = np.split()[0].lower()
    vowel = w[0] in "aeiou" and not w.startswith(("uti", "uni", "use", "one"))
    if w in ("suv", "mtb", "sport"):  # "an SUV", "an MTB"
        vowel = w != "sport"
    return ("an " if vowel else "a ") + np


def plural_word(w: str) -> str:
    if w in ("SUV", "MTB"):
        return w + "s"
    if w.endswith(("s", "x", "ch", "sh")):
        return w + "es"
    if w.endswith("y") and w[-2:-1] not in "aeiou":
        return w[:-1] + "ies"
    return w + "s"


def pluralise(np: str) -> str:
    words = np.split(" ")
    # a post-modifier ("made of metal") follows the noun: find the noun as the last word before it
    for k, w in enumerate(words):
        if w in ("made", "that", "facing", "pointing", "heading", "turned"):
            head = k - 1
            break
    else:
        head = len(words) - 1
    words[head] = plural_word(words[head])
    rest = " ".join(words)
    return rest.replace(" that is metallic", " that are metallic").replace(" that is rubber", " that are rubber")


def part_words(raw_or_super: str) -> str:
    if raw_or_super in ontology.RAW_PART_NAMES:
        return ontology.readable_name(raw_or_super)
    return raw_or_super.replace("_", " ")


# ----------------------------------------------------------------------------------------------------------------
# styles: how referents are described and named


Key = tuple  # ((slot, value), ...) in SLOTS order


class Style:
    """Word choices for one question. ``wide``: wider synonyms (synonyms group); ``redundant``: descriptions get
    one or two extra true attributes (redundant group)."""

    def __init__(self, rng: random.Random, wide: bool = False, redundant: bool = False):
        self.rng = rng
        self.wide = wide
        self.redundant = redundant
        self.notes: list[str] = []
        self.used_redundancy = False
        self.used_wide = False
        self.allow_post = False  # a redundant material may follow the noun ("made of metal") where unambiguous

    def pick(self, xs):
        return self.rng.choice(xs)

    # -- words
    def size_w(self, v):
        if self.wide and self.rng.random() < 0.5:
            w = self.pick(WIDE_SIZE[v])
            if w not in PLAIN_SIZE[v]:
                self.note_wide(w)
            return w
        return self.pick(PLAIN_SIZE[v])

    def mat_w(self, v):
        if self.wide and self.rng.random() < 0.5:
            w = self.pick(WIDE_MAT[v])
            if w not in PLAIN_MAT[v]:
                self.note_wide(w)
            return w
        return self.pick(PLAIN_MAT[v])

    def color_w(self, v):
        if self.wide and v in ("gray", "purple", "cyan") and self.rng.random() < 0.6:
            w = self.pick(WIDE_COLOR[v])
            if w != v:
                self.note_wide(w)
            return w
        return v

    def shape_w(self, v):
        if self.wide and self.rng.random() < 0.75:
            w = self.pick(WIDE_SHAPE[v])
            if w not in PLAIN_SHAPE[v]:
                self.note_wide(w)
            return w
        return self.pick(PLAIN_SHAPE[v])

    def thing_w(self):
        if self.wide and self.rng.random() < 0.6:
            w = self.pick(WIDE_THING)
            if w not in PLAIN_THING:
                self.note_wide(w)
            return w
        return self.pick(PLAIN_THING)

    def rel_w(self, r):
        ws = REL_WORDS[r]
        if not self.wide:
            ws = [w for w in ws if w not in REL_PLAIN_ONLY]
        w = self.pick(ws)
        if w in REL_PLAIN_ONLY:
            self.note_wide(w)
        return w

    def pose_w(self, p):
        return self.pick(POSE_WORDS[p])

    def note_wide(self, w):
        self.used_wide = True
        n = f"wider synonym '{w}'"
        if n not in self.notes:
            self.notes.append(n)

    def part_w(self, name: str) -> str:
        """Words for a part-name value (raw, canonical or super), with spelling variants."""
        text = part_words(name)
        if self.wide and self.rng.random() < 0.6:
            for k, vs in PART_WIDE.items():
                if k in text:
                    w = self.pick(vs)
                    self.note_wide(w)
                    return text.replace(k, w)
        for k, vs in PART_TEXT_VARIANTS.items():
            if k in text:
                w = self.pick(vs)
                if w != k and not (k == "head light" and w == "headlight") and not (
                        k == "tail light" and w == "taillight"):
                    n = f"part spelling '{w}'"
                    if n not in self.notes:
                        self.notes.append(n)
                return text.replace(k, w, 1)
        return text

    # -- descriptions
    def np(self, key: Key, post_pose: bool = True) -> str:
        """Noun phrase (no article) for a key: 'small red metal car', 'thing facing left'."""
        d = dict(key)
        words = []
        if "size" in d:
            words.append(self.size_w(d["size"]))
        if "color" in d:
            words.append(self.color_w(d["color"]))
        post = ""
        if "material" in d:
            if self.redundant and self.allow_post and self.rng.random() < 0.35:
                post = " " + self.pick(POST_MAT[d["material"]])
            else:
                words.append(self.mat_w(d["material"]))
        words.append(self.shape_w(d["shape"]) if "shape" in d else self.thing_w())
        text = " ".join(words) + post
        if "pose" in d:
            text += " " + self.pose_w(d["pose"])
        return text

    def key(self, w: World, target: int, among, exclude=(), pose: bool = False, shape_mode: str = "any",
            require_pose: bool = False) -> Key | None:
        """The shortest key selecting exactly ``target`` among ``among`` (None if there is none).

        ``exclude``: slots that must stay empty (the queried attribute); ``pose``: the pose slot may be used;
        ``require_pose``: it must be used (and be needed); ``shape_mode``: 'any', 'category' (no subtype), 'none'.
        In redundant style, one or two extra true attributes are added.
        """
        o = w.objs[target]
        among = sorted(among)
        options = []
        for slot in SLOTS:
            if slot in exclude:
                opts = [None]
            elif slot == "pose":
                opts = [None, o.pose] if (pose and o.pose) else [None]
                if require_pose:
                    opts = [o.pose] if o.pose else []
            elif slot == "shape":
                opts = {"any": [None, o.subtype, o.category], "category": [None, o.category],
                        "none": [None]}[shape_mode]
            else:
                opts = [None, getattr(o, slot)]
            options.append(opts)
        keys = []

        def rec(k, acc):
            if k == len(SLOTS):
                keys.append(tuple((s, v) for s, v in zip(SLOTS, acc, strict=True) if v is not None))
                return
            for v in options[k]:
                rec(k + 1, acc + [v])

        rec(0, [])
        good = [k for k in keys if select(w, among, k) == {target}]
        if not good:
            return None
        if require_pose:  # the pose must be needed: dropping it must not still single out the target
            good = [k for k in good if select(w, among, tuple(x for x in k if x[0] != "pose")) != {target}]
            if not good:
                return None
        n = min(len(k) for k in good)
        best = [k for k in good if len(k) == n]
        k = self.rng.choice(best)
        if self.redundant and len(k) < 4:
            k = self.add_redundancy(w, target, k, exclude, shape_mode)
        return k

    def add_redundancy(self, w, target, k, exclude, shape_mode):
        o = w.objs[target]
        d = dict(k)
        free = [s for s in ("size", "color", "material", "shape") if s not in d and s not in exclude]
        if shape_mode == "none" and "shape" in free:
            free.remove("shape")
        if not free or self.rng.random() < 0.25:
            return k
        extra = self.rng.sample(free, min(len(free), self.rng.choice([1, 1, 2])))
        for s in extra:
            if s == "shape":
                d[s] = o.subtype if (shape_mode == "any" and self.rng.random() < 0.6) else o.category
            else:
                d[s] = getattr(o, s)
        self.used_redundancy = True
        return tuple((s, d[s]) for s in SLOTS if s in d)


def matches(o: Obj, slot: str, v) -> bool:
    if slot == "shape":
        return v in (o.subtype, o.category)
    if slot == "pose":
        return o.pose == v
    return getattr(o, slot) == v


def select(w: World, among, key: Key) -> set[int]:
    return {i for i in among if all(matches(w.objs[i], s, v) for s, v in key)}


FILTER_OP = {"pose": "filter_pose", "size": "filter_size", "color": "filter_color", "material": "filter_material",
             "shape": "filter_shape"}


def chain(key: Key) -> str:
    out = ""
    for s, v in key:
        out += f" | {FILTER_OP[s]}[{v}_pose]" if s == "pose" else f" | {FILTER_OP[s]}[{v}]"
    return out


def ref(key: Key) -> str:
    return f"scene(){chain(key)} | unique"


def setp(key: Key) -> str:
    return f"scene(){chain(key)}"


def random_set_key(rng: random.Random, w: World, n_slots=None, shape_ok=True, base=None, p_random=0.2) -> Key:
    """A description of a set (for counts/exists): 1-2 slots, values mostly taken from a real object."""
    o = w.objs[rng.randrange(len(w.objs))] if base is None else w.objs[base]
    slots = ["size", "color", "material"] + (["shape"] if shape_ok else [])
    n = n_slots or rng.choice([1, 1, 2, 2, 3])
    chosen = rng.sample(slots, min(n, len(slots)))
    d = {}
    for s in chosen:
        if s == "shape":
            d[s] = rng.choice([o.subtype, o.category, o.category])
            if rng.random() < p_random / 2:
                d[s] = rng.choice(ontology.SHAPE_VALUES)
        elif rng.random() < p_random:  # a value no object may have
            d[s] = rng.choice({"size": ontology.SIZES, "color": ontology.COLORS, "material": ontology.MATERIALS}[s])
        else:
            d[s] = getattr(o, s)
    return tuple((s, d[s]) for s in SLOTS if s in d)


# ----------------------------------------------------------------------------------------------------------------
# question heads

Q_HEADS = {
    "color": ["What color is {np}?", "What colour is {np}?", "What is the color of {np}?", "What's the colour of {np}?",
              "Which color is {np}?", "{Np} is what color?", "Tell me the color of {np}.", "What color does {np} have?",
              "Can you tell me the colour of {np}?", "What color would you say {np} is?", "Which colour is {np} painted?",
              "What is {np}'s color?"],
    "material": ["What material is {np}?", "What is {np} made of?", "What is the material of {np}?",
                 "{Np} is made of what material?", "What's {np} made out of?", "Which material is {np} made of?",
                 "Is {np} metal or rubber?", "What kind of material is {np}?", "Tell me what {np} is made of.",
                 "Is {np} made of rubber or metal?", "What material does {np} seem to be made of?"],
    "size": ["What size is {np}?", "How big is {np}?", "What is the size of {np}?", "Is {np} large or small?",
             "Is {np} big or small?", "{Np} is what size?", "How large is {np}?", "Is {np} small or large?",
             "What's the size of {np}?", "Would you call {np} big or small?"],
    "shape": ["What shape is {np}?", "What type of vehicle is {np}?", "What kind of vehicle is {np}?", "What is {np}?",
              "What is the shape of {np}?", "What sort of object is {np}?", "What is the name of {np}?",
              "{Np} is what kind of vehicle?", "Which type of vehicle is {np}?", "Identify {np}.",
              "What exactly is {np}?"],
}
# heads with a pronoun after a "There is a X;" style opener
Q_PRON = {
    "color": ["what color is it?", "what is its color?", "what colour is it?", "which color does it have?",
              "what is its colour?"],
    "material": ["what is it made of?", "what material is it?", "what is its material?", "is it rubber or metal?"],
    "size": ["what size is it?", "how big is it?", "is it large or small?", "what is its size?"],
    "shape": ["what shape is it?", "what kind of vehicle is it?", "what is it?", "what type of vehicle is it?"],
}
OPENERS = ["There is {a}; ", "There is {a}. ", "Look at the {x}. ", "Find the {x}; ", "I see {a}. ",
           "Consider the {x}: ", "You can see {a}; "]


def ask(st: Style, attr: str, np_: str) -> str:
    """A question querying ``attr`` of the object the full noun phrase ``np_`` (with article) names."""
    heads = Q_HEADS[attr]
    if len(np_.split()) > 3:  # no possessive of a long noun phrase
        heads = [h for h in heads if "'s" not in h]
    if len(np_.split()) > 5:  # a verb after a long noun phrase reads badly
        heads = [h for h in heads if not h.endswith(("painted?", "is?", "have?", "made of?", "out of?"))]
    h = st.pick(heads)
    return cap(h.format(np=np_, Np=cap(np_)))


def ask_with_opener(st: Style, attr: str, x: str, inner: str | None) -> str:
    """'There is a red car; what color is the thing behind it?' (inner uses 'it'), or with inner None 'There is
    a red car; what color is it?'."""
    op = st.pick(OPENERS).format(a=indef(x), x=x)
    if inner is None:
        tail = st.pick(Q_PRON[attr])
    else:
        tail = ask(st, attr, inner)
        tail = tail[0].lower() + tail[1:]
    if op.endswith((". ", ": ")):
        tail = cap(tail) if op.endswith(". ") else tail
    return op + tail


COUNT_BARE = ["How many {ps} are there?", "How many {ps} are in the picture?", "How many {ps} can you see?",
              "What number of {ps} are there?", "Count the {ps}.", "How many {ps} do you see?",
              "What is the number of {ps}?", "How many {ps} are in the scene?", "Can you count the {ps}?",
              "Tell me how many {ps} there are.", "How many {ps} are in the image?", "Number of {ps}?",
              "How many {ps} are shown?", "What's the total number of {ps}?"]
COUNT_PRED = ["How many {ps} are {p}?", "What number of {ps} are {p}?", "Count the {ps} that are {p}.",
              "How many {ps} that are {p} are there?", "Tell me the number of {ps} that are {p}.",
              "How many of the {ps} are {p}?", "How many {ps} would you say are {p}?"]
COUNT_POST = ["How many {ps} {p} are there?", "How many {ps} {p} can you see?", "What is the number of {ps} {p}?",
              "Count the {ps} {p}.", "How many {ps} do you see {p}?", "How many {ps} are there {p}?"]
EXIST_BARE = ["Are there any {ps}?", "Is there {a}?", "Is there any {s} in the picture?", "Do you see {a}?",
              "Does the scene contain {a}?", "Is {a} present?", "Can you see any {ps}?", "Is there at least one {s}?",
              "Does the image have any {ps} in it?", "Are any {ps} visible in the scene?", "Is there {a} anywhere?",
              "Are there {ps} in the picture?"]
EXIST_PRED = ["Is there {a} that is {p}?", "Are any {ps} {p}?", "Is any {s} {p}?", "Are there any {ps} that are {p}?",
              "Is at least one {s} {p}?", "Do any {ps} happen to be {p}?"]
EXIST_POST = ["Is there {a} {p}?", "Are there any {ps} {p}?", "Do you see any {ps} {p}?", "Is there any {s} {p}?",
              "Can you see {a} {p}?", "Does the scene contain {a} {p}?", "Are there {ps} {p}?"]
EXIST_THING = ["Is anything {p}?", "Is there anything {p}?", "Is there something {p}?", "Does anything sit {p}?"]


def count_q(st: Style, ps: str, pred: str | None = None, post: bool = True) -> str:
    if pred is None:
        return st.pick(COUNT_BARE).format(ps=ps)
    heads = COUNT_PRED + (COUNT_POST if post else [])
    return st.pick(heads).format(ps=ps, p=pred)


def exist_q(st: Style, s: str, pred: str | None = None, post: bool = True, bare_thing: bool = False,
            rel_pred: bool = False) -> str:
    ps = pluralise(s)
    if pred is None:
        return st.pick(EXIST_BARE).format(ps=ps, s=s, a=indef(s))
    heads = EXIST_PRED + (EXIST_POST if post else [])
    if bare_thing:
        heads = heads + [h for h in EXIST_THING if rel_pred or "sit" not in h]
    return st.pick(heads).format(ps=ps, s=s, a=indef(s), p=pred)


# ----------------------------------------------------------------------------------------------------------------
# candidates


@dataclass
class Cand:
    question: str
    program: str
    family: str
    notes: list[str] = field(default_factory=list)
    expect: object = None  # an answer the generator expects (checked when given)


def keyed(st: Style, key: Key) -> str:
    return "the " + st.np(key)


def q_attr(rng, exclude=()):
    return rng.choice([a for a in ATTRS if a not in exclude])


def shape_mode_for(attr):
    return "none" if attr == "shape" else "any"


# ---------------------------------------------------------------- core_query

def g_zero_hop_query(rng, w, st):
    attr = q_attr(rng)
    st.allow_post = attr in ("color", "size")
    t = rng.randrange(len(w.objs))
    k = st.key(w, t, w.all, exclude=(attr,), shape_mode=shape_mode_for(attr))
    if k is None:
        return None
    x = st.np(k)
    if rng.random() < 0.25:
        q = ask_with_opener(st, attr, x, None)
    else:
        q = ask(st, attr, "the " + x)
    return Cand(q, f"{ref(k)} | query_{attr}", f"zero_hop_query_{attr}")


def g_query_subtype(rng, w, st):
    """'What kind of car is the red car?': the category in the description, the subtype asked."""
    t = rng.randrange(len(w.objs))
    o = w.objs[t]
    among = {j for j in w.all if w.objs[j].category == o.category}
    k = st.key(w, t, among, exclude=("shape",))
    if not k:
        return None
    k = tuple(sorted(k + (("shape", o.category),), key=lambda kv: SLOTS.index(kv[0])))
    cat = st.shape_w(o.category)
    adj = " ".join(st.np(tuple(x for x in k if x[0] != "shape")).split()[:-1])
    forms = [f"What kind of {cat} is the {adj} {cat}?", f"What type of {cat} is the {adj} one?",
             f"Which kind of {cat} is the {adj} {cat}?", f"The {adj} {cat} is what type of {cat}?",
             f"What sort of {cat} is the {adj} one?", f"Which {cat} model is the {adj} {cat}?"]
    q = cap(rng.choice(forms))
    return Cand(q, f"{ref(k)} | query_shape", "zero_hop_query_subtype")


def related_target(rng, w, st, exclude=(), shape_mode="any", need_hop=True):
    """Pick X (unique in the scene), relation r and Y (unique among objects r of X)."""
    x = rng.randrange(len(w.objs))
    r = rng.choice(ontology.RELATIONS)
    rel = w.rel(x, r)
    if not rel:
        return None
    y = rng.choice(sorted(rel))
    kx = st.key(w, x, w.all)
    ky = st.key(w, y, rel, exclude=exclude, shape_mode=shape_mode)
    if kx is None or ky is None:
        return None
    if need_hop and select(w, w.all, ky) == {y} and rng.random() < 0.85:
        return None  # the relation would not be needed
    return x, r, y, kx, ky


def g_one_hop_query(rng, w, st):
    attr = q_attr(rng)
    got = related_target(rng, w, st, exclude=(attr,), shape_mode=shape_mode_for(attr))
    if not got:
        return None
    _x, r, _y, kx, ky = got
    rw = st.rel_w(r)
    X, Y = st.np(kx), st.np(ky)
    form = rng.random()
    if form < 0.3:
        q = ask_with_opener(st, attr, X, f"the {Y} {rw} it")
    elif form < 0.55:
        mid = rng.choice(["that is", "which is", "located", "sitting", "that sits", "placed"])
        q = ask(st, attr, f"the {Y} {mid} {rw} the {X}")
    else:
        q = ask(st, attr, f"the {Y} {rw} the {X}")
    prog = f"{ref(kx)} | relate[{r}]{chain(ky)} | unique | query_{attr}"
    return Cand(q, prog, f"one_hop_query_{attr}")


def g_two_hop_query(rng, w, st):
    attr = q_attr(rng)
    got = related_target(rng, w, st)
    if not got:
        return None
    x, r1, y, kx, ky = got
    r2 = rng.choice(ontology.RELATIONS)
    rel2 = w.rel(y, r2)
    if not rel2:
        return None
    z = rng.choice(sorted(rel2))
    if z == x:
        return None  # no loop back to the first referent
    kz = st.key(w, z, rel2, exclude=(attr,), shape_mode=shape_mode_for(attr))
    if kz is None:
        return None
    X, Y, Z = st.np(kx), st.np(ky), st.np(kz)
    a1, a2 = st.rel_w(r1), st.rel_w(r2)
    form = rng.random()
    if form < 0.35:
        q = ask_with_opener(st, attr, f"{Y} {a1} the {X}", f"the {Z} {a2} it")
    elif form < 0.6:
        q = ask(st, attr, f"the {Z} that is {a2} the {Y} that is {a1} the {X}")
    else:
        q = ask(st, attr, f"the {Z} {a2} the {Y} {a1} the {X}")
    prog = f"{ref(kx)} | relate[{r1}]{chain(ky)} | unique | relate[{r2}]{chain(kz)} | unique | query_{attr}"
    return Cand(q, prog, f"two_hop_query_{attr}")


# ---------------------------------------------------------------- core_count / core_exist

def adj_pred(st, key):
    """'red and metallic' for an attribute-only key (no shape)."""
    d = dict(key)
    ws = []
    if "size" in d:
        ws.append(st.size_w(d["size"]))
    if "color" in d:
        ws.append(st.color_w(d["color"]))
    if "material" in d:
        ws.append(st.mat_w(d["material"]) if st.rng.random() < 0.6 else "made of " + d["material"])
    return ws[0] if len(ws) == 1 else ", ".join(ws[:-1]) + " and " + ws[-1]


def g_count_scene(rng, w, st):
    forms = ["How many objects are there?", "How many things are in the picture?", "How many vehicles are there?",
             "How many objects can you see in total?", "Count all the objects.", "What is the total number of things?",
             "How many items are in the scene?", "How many vehicles are shown in the image?",
             "How many things are there altogether?", "What number of objects is in the scene?",
             "In total, how many objects do you see?"]
    return Cand(rng.choice(forms), "count(scene())", "count_all")


def g_zero_hop_count(rng, w, st):
    kind = rng.choice(["category", "subtype", "attributes", "attributes", "mixed"])
    if kind == "category":
        o = rng.choice(w.objs) if rng.random() < 0.8 else None
        cat = o.category if o else rng.choice(ontology.CATEGORIES)
        k = (("shape", cat),)
    elif kind == "subtype":
        o = rng.choice(w.objs) if rng.random() < 0.75 else None
        sub = o.subtype if o else rng.choice(ontology.SUBTYPES)
        k = (("shape", sub),)
    elif kind == "attributes":
        k = random_set_key(rng, w, n_slots=rng.choice([1, 1, 2]), shape_ok=False)
    else:
        k = random_set_key(rng, w, n_slots=rng.choice([2, 2, 3]))
        if not any(s == "shape" for s, _ in k):
            return None
    fam = {"category": "zero_hop_count_category", "subtype": "zero_hop_count_subtype",
           "attributes": "zero_hop_count_attributes", "mixed": "zero_hop_count_mixed"}[kind]
    if kind == "attributes" and rng.random() < 0.45:
        thing = pluralise(st.thing_w())
        forms = [f"How many {thing} are {{p}}?", f"How many of the {thing} are {{p}}?",
                 f"What number of {thing} are {{p}}?", f"Count the {thing} that are {{p}}."]
        q = rng.choice(forms).format(p=adj_pred(st, k))
    else:
        q = count_q(st, pluralise(st.np(k)))
    return Cand(q, f"count({setp(k)})", fam)


def pred_or_np(st, key):
    """'red' / 'small and metallic' for an attribute-only key, else the plural noun phrase ('small cars')."""
    return adj_pred(st, key) if "shape" not in dict(key) else pluralise(st.np(key))


def g_count_or(rng, w, st):
    ka = random_set_key(rng, w, n_slots=rng.choice([1, 2]))
    kb = random_set_key(rng, w, n_slots=rng.choice([1, 2]))
    if ka == kb or select(w, w.all, ka) <= select(w, w.all, kb) or select(w, w.all, kb) <= select(w, w.all, ka):
        return None
    thing = pluralise(st.thing_w())
    if rng.random() < 0.5:
        A, B = pred_or_np(st, ka), pred_or_np(st, kb)
        forms = [f"How many {thing} are {A} or {B}?", f"How many {thing} are either {A} or {B}?",
                 f"What number of {thing} are {A} or {B}?", f"Count the {thing} that are {A} or {B}."]
    else:
        A, B = pluralise(st.np(ka)), pluralise(st.np(kb))
        forms = [f"What is the total number of {A} and {B}?", f"How many {A} or {B} are there?",
                 f"Count the {A} together with the {B}.", f"How many {A} plus {B} are there?",
                 f"Taken together, how many {A} and {B} are there?", f"How many {A} and {B} are there in all?"]
    q = rng.choice(forms)
    prog = f"count(union({setp(ka)}, {setp(kb)}))"
    return Cand(q, prog, "count_or")


def two_relations(rng, w, st, need_nonempty=False):
    a, b = rng.sample(range(len(w.objs)), 2)
    ra, rb = rng.choice(ontology.RELATIONS), rng.choice(ontology.RELATIONS)
    ka, kb = st.key(w, a, w.all), st.key(w, b, w.all)
    if ka is None or kb is None:
        return None
    both = w.rel(a, ra) & w.rel(b, rb)
    if need_nonempty and not both:
        return None
    return a, ra, b, rb, ka, kb, both


def g_count_and(rng, w, st):
    got = two_relations(rng, w, st)
    if not got:
        return None
    _a, ra, _b, rb, ka, kb, _both = got
    kf = ()
    if rng.random() < 0.4:
        kf = random_set_key(rng, w, n_slots=1)
    F = pluralise(st.np(kf)) if kf else pluralise(st.thing_w())
    A, B = st.np(ka), st.np(kb)
    w1, w2 = st.rel_w(ra), st.rel_w(rb)
    forms = [f"How many {F} are both {w1} the {A} and {w2} the {B}?",
             f"How many {F} are {w1} the {A} and {w2} the {B}?",
             f"What number of {F} are {w1} the {A} and also {w2} the {B}?",
             f"Count the {F} that are {w1} the {A} and {w2} the {B}.",
             f"How many {F} are there that are both {w1} the {A} and {w2} the {B}?"]
    q = rng.choice(forms)
    inner = f"intersect({ref(ka)} | relate[{ra}], {ref(kb)} | relate[{rb}])"
    prog = f"count({inner}{chain(kf)})"
    return Cand(q, prog, "count_and")


def g_zero_hop_exist(rng, w, st):
    kind = rng.choice(["shape", "attributes", "mixed", "mixed"])
    if kind == "shape":
        o = rng.choice(w.objs)
        v = rng.choice([o.subtype, o.category]) if rng.random() < 0.55 else rng.choice(ontology.SHAPE_VALUES)
        k = (("shape", v),)
    elif kind == "attributes":
        k = random_set_key(rng, w, n_slots=rng.choice([1, 2, 2, 3]), shape_ok=False)
    else:
        k = random_set_key(rng, w, n_slots=rng.choice([2, 2, 3]))
        if not any(s == "shape" for s, _ in k):
            return None
    if kind == "attributes" and rng.random() < 0.5:
        thing = st.thing_w()
        forms = ["Is anything {p}?", f"Are any of the {pluralise(thing)} {{p}}?", f"Is there {indef(thing)} that is {{p}}?",
                 f"Is any {thing} {{p}}?", f"Are there {pluralise(thing)} that are {{p}}?"]
        q = rng.choice(forms).format(p=adj_pred(st, k))
    else:
        q = exist_q(st, st.np(k))
    fam = {"shape": "zero_hop_exist_shape", "attributes": "zero_hop_exist_attributes",
           "mixed": "zero_hop_exist_mixed"}[kind]
    return Cand(q, f"exist({setp(k)})", fam)


def g_category_count_exist(rng, w, st):
    """Counts and exists over a category (hypernym), with or without one more attribute."""
    o = rng.choice(w.objs)
    cat = o.category if rng.random() < 0.8 else rng.choice(ontology.CATEGORIES)
    k = (("shape", cat),)
    if rng.random() < 0.4:
        s = rng.choice(["size", "color", "material"])
        k = ((s, getattr(o, s)),) + k
    if rng.random() < 0.5:
        return Cand(count_q(st, pluralise(st.np(k))), f"count({setp(k)})", "category_count")
    return Cand(exist_q(st, st.np(k)), f"exist({setp(k)})", "category_exist")


def g_exist_or(rng, w, st):
    ka = random_set_key(rng, w, n_slots=rng.choice([2, 2, 3]), p_random=0.6)
    kb = random_set_key(rng, w, n_slots=rng.choice([1, 2, 2]), p_random=0.6)
    if set(ka) <= set(kb) or set(kb) <= set(ka):
        return None
    A, B = st.np(ka), st.np(kb)
    forms = [f"Is there {indef(A)} or {indef(B)}?", f"Are there any {pluralise(A)} or {pluralise(B)}?",
             f"Can you see either {indef(A)} or {indef(B)}?", f"Does the picture contain {indef(A)} or {indef(B)}?",
             f"Is there at least one {A} or {B}?", f"Is {indef(A)} or {indef(B)} present?",
             f"Do you see any {pluralise(A)} or any {pluralise(B)}?"]
    prog = f"exist(union({setp(ka)}, {setp(kb)}))"
    return Cand(rng.choice(forms), prog, "exist_or")


def g_exist_and(rng, w, st):
    got = two_relations(rng, w, st)
    if not got:
        return None
    _a, ra, _b, rb, ka, kb, _both = got
    kf = ()
    if rng.random() < 0.4:
        kf = random_set_key(rng, w, n_slots=1)
    A, B = st.np(ka), st.np(kb)
    w1, w2 = st.rel_w(ra), st.rel_w(rb)
    if kf:
        F = st.np(kf)
        forms = [f"Is there {indef(F)} that is both {w1} the {A} and {w2} the {B}?",
                 f"Are there any {pluralise(F)} {w1} the {A} and {w2} the {B}?",
                 f"Is any {F} both {w1} the {A} and {w2} the {B}?",
                 f"Do you see {indef(F)} that is {w1} the {A} and also {w2} the {B}?"]
    else:
        forms = [f"Is there anything both {w1} the {A} and {w2} the {B}?",
                 f"Is anything {w1} the {A} and {w2} the {B}?",
                 f"Is there an object that is {w1} the {A} and {w2} the {B}?",
                 f"Does any object lie {w1} the {A} and {w2} the {B}?",
                 f"Is there something that is both {w1} the {A} and {w2} the {B}?"]
    inner = f"intersect({ref(ka)} | relate[{ra}], {ref(kb)} | relate[{rb}])"
    return Cand(rng.choice(forms), f"exist({inner}{chain(kf)})", "exist_and")


# ---------------------------------------------------------------- core_compare_attribute

CMP_FORMS = {
    "color": ["Is the {A} the same color as the {B}?", "Does the {A} have the same colour as the {B}?",
              "Are the {A} and the {B} the same color?", "Do the {A} and the {B} share a color?",
              "Is the color of the {A} the same as that of the {B}?", "Are the {A} and the {B} painted the same colour?",
              "Does the {A} match the {B} in color?", "Is the {A} colored like the {B}?",
              "Do the {A} and the {B} have the same color?", "Is the {A} the same colour as the {B}?"],
    "material": ["Is the {A} made of the same material as the {B}?", "Are the {A} and the {B} made of the same material?",
                 "Do the {A} and the {B} have the same material?", "Is the {A} the same material as the {B}?",
                 "Are the {A} and the {B} made of the same stuff?", "Is the material of the {A} the same as the {B}'s?",
                 "Does the {A} have the same material as the {B}?", "Do the {A} and the {B} share a material?"],
    "size": ["Is the {A} the same size as the {B}?", "Are the {A} and the {B} the same size?",
             "Do the {A} and the {B} have the same size?", "Are the {A} and the {B} equally sized?",
             "Is the {A} as big as the {B}?", "Does the {A} have the same size as the {B}?",
             "Is the size of the {A} equal to that of the {B}?", "Are the {A} and the {B} of equal size?"],
    "shape": ["Is the {A} the same shape as the {B}?", "Are the {A} and the {B} the same type of vehicle?",
              "Are the {A} and the {B} the same kind of vehicle?", "Is the {A} the same model as the {B}?",
              "Do the {A} and the {B} have the same shape?", "Is the {A} the same type of vehicle as the {B}?",
              "Are the {A} and the {B} the same shape?", "Is the {A} the same kind of thing as the {B}?"],
}


def cmp_text(st, attr, A, B):
    forms = CMP_FORMS[attr]
    if len(B.split()) > 2:
        forms = [f for f in forms if "{B}'s" not in f]
    return st.pick(forms).format(A=A, B=B)


def g_compare_attribute(rng, w, st):
    attr = q_attr(rng)
    st.allow_post = attr != "material"
    a, b = rng.sample(range(len(w.objs)), 2)
    if rng.random() < 0.5:  # prefer pairs that agree, for balance
        same = [j for j in w.same(a, attr)]
        if same:
            b = rng.choice(same)
    mode = "category" if attr == "shape" else "any"
    ka = st.key(w, a, w.all, exclude=(attr,), shape_mode=mode)
    kb = st.key(w, b, w.all, exclude=(attr,), shape_mode=mode)
    if ka is None or kb is None or ka == kb:
        return None
    q = cmp_text(st, attr, st.np(ka), st.np(kb))
    prog = f"equal_{attr}(query_{attr}({ref(ka)}), query_{attr}({ref(kb)}))"
    return Cand(q, prog, f"compare_{attr}")


def g_compare_attribute_hop(rng, w, st):
    attr = q_attr(rng)
    mode = "category" if attr == "shape" else "any"
    got = related_target(rng, w, st, exclude=(attr,), shape_mode=mode)
    if not got:
        return None
    x, r, y, kx, ky = got
    others = [j for j in w.all if j not in (x, y)]
    if not others:
        return None
    b = rng.choice(others)
    same = [j for j in w.same(y, attr) if j != x]
    if rng.random() < 0.5 and same:
        b = rng.choice(same)
    kb = st.key(w, b, w.all, exclude=(attr,), shape_mode=mode)
    if kb is None:
        return None
    A = f"{st.np(ky)} {st.rel_w(r)} the {st.np(kx)}"
    B = st.np(kb)
    if rng.random() < 0.5:
        q = cmp_text(st, attr, A, B)
        prog = f"equal_{attr}(query_{attr}({ref(kx)} | relate[{r}]{chain(ky)} | unique), query_{attr}({ref(kb)}))"
    else:
        q = cmp_text(st, attr, B, A)
        prog = f"equal_{attr}(query_{attr}({ref(kb)}), query_{attr}({ref(kx)} | relate[{r}]{chain(ky)} | unique))"
    return Cand(q, prog, f"compare_{attr}_one_hop")


# ---------------------------------------------------------------- core_compare_integer

def set_pair(rng, w, st, n=None):
    ka = random_set_key(rng, w, n_slots=n or rng.choice([1, 1, 2]))
    kb = random_set_key(rng, w, n_slots=n or rng.choice([1, 1, 2]))
    if ka == kb:
        return None
    ca, cb = len(select(w, w.all, ka)), len(select(w, w.all, kb))
    if ca == 0 and cb == 0:
        return None
    return ka, kb, ca, cb


MORE_FORMS = ["Are there more {A} than {B}?", "Are there more {A} than there are {B}?", "Do the {A} outnumber the {B}?",
              "Is the number of {A} greater than the number of {B}?", "Is the number of {A} larger than that of {B}?",
              "Are the {A} more numerous than the {B}?", "Does the scene have more {A} than {B}?",
              "Are {A} more common than {B} here?", "Is the count of {A} higher than the count of {B}?",
              "Do you see more {A} than {B}?"]
FEWER_FORMS = ["Are there fewer {A} than {B}?", "Are there less {A} than {B}?",
               "Is the number of {A} less than the number of {B}?", "Is the number of {A} smaller than that of {B}?",
               "Are the {A} fewer in number than the {B}?", "Does the picture have fewer {A} than {B}?",
               "Do the {B} outnumber the {A}?", "Are there fewer {A} than there are {B}?",
               "Is the count of {A} lower than the count of {B}?", "Do you see less {A} than {B}?"]
EQUAL_FORMS = ["Are there the same number of {A} and {B}?", "Are there as many {A} as {B}?",
               "Is the number of {A} the same as the number of {B}?", "Are there an equal number of {A} and {B}?",
               "Is the number of {A} equal to the number of {B}?", "Do the {A} and the {B} have the same count?",
               "Are there exactly as many {A} as there are {B}?", "Does the number of {A} match the number of {B}?",
               "Is there the same number of {A} as {B}?", "Are the {A} and the {B} equal in number?"]


def cmp_int(rng, kind, a_prog, b_prog):
    """Program for 'more' / 'fewer' / 'equal' (the 'B outnumber A' fewer form flips the arguments in text only;
    the program is written in the order the text compares)."""
    op = {"more": "greater_than", "fewer": "less_than", "equal": "equal_integer"}[kind]
    return f"{op}(count({a_prog}), count({b_prog}))"


def pick_cmp(st, kind):
    forms = {"more": MORE_FORMS, "fewer": FEWER_FORMS, "equal": EQUAL_FORMS}[kind]
    return st.pick(forms)


def cmp_program_for_form(form, kind, a_prog, b_prog):
    if form == "Do the {B} outnumber the {A}?":
        return f"greater_than(count({b_prog}), count({a_prog}))"
    return cmp_int(None, kind, a_prog, b_prog)


def g_compare_sets(rng, w, st):
    got = set_pair(rng, w, st)
    if not got:
        return None
    ka, kb, ca, cb = got
    kind = rng.choice(["more", "fewer", "equal"])
    if kind == "equal" and ca != cb and rng.random() < 0.5:
        return None
    form = pick_cmp(st, kind)
    A, B = pluralise(st.np(ka)), pluralise(st.np(kb))
    q = form.format(A=A, B=B)
    prog = cmp_program_for_form(form, kind, setp(ka), setp(kb))
    fam = {"more": "compare_count_more", "fewer": "compare_count_fewer", "equal": "compare_count_equal"}[kind]
    if "outnumber" in form:
        fam = "compare_count_outnumber"
    return Cand(q, prog, fam)


def g_compare_related(rng, w, st):
    """Counts of objects related to two different referents."""
    a, b = rng.sample(range(len(w.objs)), 2)
    ra, rb = rng.choice(ontology.RELATIONS), rng.choice(ontology.RELATIONS)
    ka, kb = st.key(w, a, w.all), st.key(w, b, w.all)
    if ka is None or kb is None:
        return None
    kf = random_set_key(rng, w, n_slots=1) if rng.random() < 0.45 else ()
    kg = kf if (kf and rng.random() < 0.6) else (random_set_key(rng, w, n_slots=1) if rng.random() < 0.3 else ())
    ca = len(select(w, w.rel(a, ra), kf))
    cb = len(select(w, w.rel(b, rb), kg))
    if ca == 0 and cb == 0:
        return None
    kind = rng.choice(["more", "fewer", "equal"])
    if kind == "equal" and ca != cb and rng.random() < 0.6:
        return None
    F = pluralise(st.np(kf)) if kf else pluralise(st.thing_w())
    G = pluralise(st.np(kg)) if kg else pluralise(st.thing_w())
    A = f"{F} {st.rel_w(ra)} the {st.np(ka)}"
    B = f"{G} {st.rel_w(rb)} the {st.np(kb)}"
    form = pick_cmp(st, kind)
    while "common" in form:
        form = pick_cmp(st, kind)
    q = form.format(A=A, B=B)
    pa = f"{ref(ka)} | relate[{ra}]{chain(kf)}"
    pb = f"{ref(kb)} | relate[{rb}]{chain(kg)}"
    prog = cmp_program_for_form(form, kind, pa, pb)
    return Cand(q, prog, f"compare_related_count_{kind}")


SAME_REF_FORMS = {
    "more": ["Are there more {F} {r1} the {X} than {r2} it?", "Are there more {F} {r1} the {X} than there are {r2} it?",
             "Is the number of {F} {r1} the {X} greater than the number {r2} it?",
             "Are more {F} {r1} the {X} than {r2} it?", "Does the {X} have more {F} {r1s} than {r2s}?",
             "Do the {F} {r1} the {X} outnumber those {r2} it?"],
    "fewer": ["Are there fewer {F} {r1} the {X} than {r2} it?", "Are there less {F} {r1} the {X} than {r2} it?",
              "Is the number of {F} {r1} the {X} smaller than the number {r2} it?",
              "Are fewer {F} {r1} the {X} than {r2} it?", "Does the {X} have fewer {F} {r1s} than {r2s}?"],
    "equal": ["Are there as many {F} {r1} the {X} as {r2} it?",
              "Is the number of {F} {r1} the {X} the same as the number {r2} it?",
              "Are there the same number of {F} {r1} the {X} and {r2} it?",
              "Does the {X} have as many {F} {r1s} as {r2s}?",
              "Are there equally many {F} {r1} the {X} and {r2} it?"],
}
REL_SIDE = {"left": ["on its left", "to its left"], "right": ["on its right", "to its right"],
            "behind": ["behind it"], "front": ["in front of it"]}


def g_compare_same_referent(rng, w, st):
    x = rng.randrange(len(w.objs))
    r1, r2 = rng.sample(list(ontology.RELATIONS), 2)
    if rng.random() < 0.6:
        r2 = REL_OPPOSITE[r1]
    kx = st.key(w, x, w.all)
    if kx is None:
        return None
    kf = random_set_key(rng, w, n_slots=1) if rng.random() < 0.5 else ()
    c1, c2 = len(select(w, w.rel(x, r1), kf)), len(select(w, w.rel(x, r2), kf))
    if c1 == 0 and c2 == 0:
        return None
    kind = rng.choice(["more", "fewer", "equal"])
    if kind == "equal" and c1 != c2 and rng.random() < 0.6:
        return None
    F = pluralise(st.np(kf)) if kf else pluralise(st.thing_w())
    form = st.pick(SAME_REF_FORMS[kind])
    q = form.format(F=F, X=st.np(kx), r1=st.rel_w(r1), r2=st.rel_w(r2), r1s=st.pick(REL_SIDE[r1]),
                    r2s=st.pick(REL_SIDE[r2]))
    pa = f"{ref(kx)} | relate[{r1}]{chain(kf)}"
    pb = f"{ref(kx)} | relate[{r2}]{chain(kf)}"
    return Cand(q, cmp_int(rng, kind, pa, pb), f"compare_same_referent_{kind}", ["pronoun 'it' for the referent"])


OCC_ADJ = ["occluded", "partly hidden", "partially hidden", "partially occluded", "partly covered", "obscured",
           "partly blocked from view"]


def g_compare_occluded(rng, w, st):
    occ = w.occluded()
    if not occ:
        return None
    ka = random_set_key(rng, w, n_slots=1, base=rng.choice(sorted(occ)))
    mode = rng.choice(["both_occluded", "occluded_vs_all", "both_occluded"])
    kb = random_set_key(rng, w, n_slots=1)
    if mode == "both_occluded" and ka == kb:
        return None
    kind = rng.choice(["more", "fewer", "equal"])
    adj = st.pick([a for a in OCC_ADJ if len(a.split()) <= 2])  # used before the noun
    A = pluralise(st.np(ka))
    if mode == "both_occluded":
        B = pluralise(st.np(kb))
        pb = f"scene() | filter_occludee{chain(kb)}"
        cb = len(select(w, occ, kb))
    else:
        B = pluralise(st.np(kb))
        pb = setp(kb)
        cb = len(select(w, w.all, kb))
    ca = len(select(w, occ, ka))
    if kind == "equal" and ca != cb and rng.random() < 0.6:
        return None
    pa = f"scene() | filter_occludee{chain(ka)}"
    if mode == "both_occluded":
        forms = {"more": [f"Are there more {adj} {A} than {adj} {B}?", f"Are more {A} than {B} {adj}?",
                          f"Is the number of {adj} {A} greater than the number of {adj} {B}?",
                          f"Do {adj} {A} outnumber {adj} {B}?"],
                 "fewer": [f"Are there fewer {adj} {A} than {adj} {B}?", f"Are fewer {A} than {B} {adj}?",
                           f"Is the number of {adj} {A} smaller than the number of {adj} {B}?",
                           f"Are there less {adj} {A} than {adj} {B}?"],
                 "equal": [f"Are there as many {adj} {A} as {adj} {B}?",
                           f"Is the number of {adj} {A} the same as the number of {adj} {B}?",
                           f"Are equally many {A} and {B} {adj}?",
                           f"Are there the same number of {adj} {A} and {adj} {B}?"]}[kind]
    else:
        forms = {"more": [f"Are there more {adj} {A} than {B} in total?", f"Do the {adj} {A} outnumber all the {B}?",
                          f"Is the number of {adj} {A} larger than the total number of {B}?"],
                 "fewer": [f"Are there fewer {adj} {A} than {B} in total?", f"Are there less {adj} {A} than {B} overall?",
                           f"Is the number of {adj} {A} less than the total number of {B}?"],
                 "equal": [f"Are there as many {adj} {A} as there are {B} in total?",
                           f"Is the number of {adj} {A} equal to the total number of {B}, hidden or not?",
                           f"Are there the same number of {adj} {A} as {B} overall?"]}[kind]
    q = cap(rng.choice(forms))
    return Cand(q, cmp_int(rng, kind, pa, pb), f"compare_occluded_count_{kind}")


# ---------------------------------------------------------------- core_same_relate

SAME_WORDS = {
    "color": ["the same color as", "the same colour as", "of the same color as"],
    "material": ["made of the same material as", "the same material as", "of the same material as"],
    "size": ["the same size as", "of the same size as", "as big as"],
    "shape": ["the same shape as", "the same type of vehicle as", "the same kind of vehicle as", "the same model as"],
}
SHARE_WORDS = {"color": ["color", "colour"], "material": ["material"], "size": ["size"],
               "shape": ["shape", "vehicle type", "model"]}


def g_same_count(rng, w, st):
    attr = q_attr(rng)
    x = rng.randrange(len(w.objs))
    kx = st.key(w, x, w.all, exclude=(attr,), shape_mode="category" if attr == "shape" else "any")
    if kx is None:
        return None
    kf = ()
    if rng.random() < 0.4:
        kf = random_set_key(rng, w, n_slots=1, shape_ok=attr != "shape")
        if attr in dict(kf):
            return None
    X = st.np(kx)
    F = pluralise(st.np(kf)) if kf else pluralise(st.thing_w())
    same = st.pick(SAME_WORDS[attr])
    share = st.pick(SHARE_WORDS[attr])
    forms = [f"How many other {F} are {same} the {X}?", f"How many {F} are {same} the {X}?",
             f"What number of other {F} are {same} the {X}?", f"How many other {F} have the same {share} as the {X}?",
             f"How many {F} share the {X}'s {share}?" if len(X.split()) <= 2 else f"How many {F} share a {share} with the {X}?",
             f"Besides the {X}, how many {F} are there with that {share}?",
             f"The {X} has the same {share} as how many other {F}?",
             f"Count the other {F} that have the same {share} as the {X}."]
    q = rng.choice(forms)
    return Cand(q, f"count({ref(kx)} | same_{attr}{chain(kf)})", f"same_{attr}_count")


def g_same_exist(rng, w, st):
    attr = q_attr(rng)
    x = rng.randrange(len(w.objs))
    kx = st.key(w, x, w.all, exclude=(attr,), shape_mode="category" if attr == "shape" else "any")
    if kx is None:
        return None
    kf = ()
    if rng.random() < 0.45:
        kf = random_set_key(rng, w, n_slots=1, shape_ok=attr != "shape")
        if attr in dict(kf):
            return None
    X = st.np(kx)
    same = st.pick(SAME_WORDS[attr])
    share = st.pick(SHARE_WORDS[attr])
    if kf:
        F = st.np(kf)
        forms = [f"Is there another {F} that is {same} the {X}?", f"Are there any other {pluralise(F)} {same} the {X}?",
                 f"Is there {indef(F)} that has the same {share} as the {X}?",
                 f"Does any other {F} have the same {share} as the {X}?",
                 f"Are any {pluralise(F)} {same} the {X}?"]
    else:
        forms = [f"Is there anything else that is {same} the {X}?", f"Is anything else {same} the {X}?",
                 f"Does any other object have the same {share} as the {X}?",
                 f"Are there other things {same} the {X}?", f"Is there another object with the same {share} as the {X}?",
                 f"Does the {X} share its {share} with any other object?", f"Is there something else {same} the {X}?"]
    q = rng.choice(forms)
    return Cand(q, f"exist({ref(kx)} | same_{attr}{chain(kf)})", f"same_{attr}_exist")


def g_same_query(rng, w, st):
    attr = q_attr(rng)
    qa = q_attr(rng, exclude=(attr,))
    x = rng.randrange(len(w.objs))
    rel = w.same(x, attr)
    if not rel:
        return None
    y = rng.choice(sorted(rel))
    kx = st.key(w, x, w.all, exclude=(attr,), shape_mode="category" if attr == "shape" else "any")
    excl = (qa, attr)
    ky = st.key(w, y, rel, exclude=excl, shape_mode="none" if "shape" in excl else "any")
    if kx is None or ky is None:
        return None
    X, Y = st.np(kx), st.np(ky)
    same = st.pick(SAME_WORDS[attr])
    if rng.random() < 0.3:
        opener = rng.choice([f"There is another {Y} that is {same} the {X}; ",
                             f"Some other {Y} is {same} the {X}. "])
        tail = st.pick(Q_PRON[qa])
        q = opener + (cap(tail) if opener.endswith(". ") else tail)
    else:
        mid = rng.choice(["that is ", "", "which is "])
        q = ask(st, qa, f"the other {Y} {mid}{same} the {X}" if rng.random() < 0.5 else f"the {Y} {mid}{same} the {X}")
    return Cand(q, f"{ref(kx)} | same_{attr}{chain(ky)} | unique | query_{qa}", f"same_{attr}_query_{qa}")


# ---------------------------------------------------------------- core_spatial

def g_one_hop_count(rng, w, st):
    x = rng.randrange(len(w.objs))
    r = rng.choice(ontology.RELATIONS)
    kx = st.key(w, x, w.all)
    if kx is None:
        return None
    kf = random_set_key(rng, w, n_slots=rng.choice([1, 1, 2])) if rng.random() < 0.6 else ()
    X = st.np(kx)
    F = pluralise(st.np(kf)) if kf else pluralise(st.thing_w())
    rw = st.rel_w(r)
    if rng.random() < 0.25:
        op = rng.choice([f"There is {indef(X)}; how many {F} are {rw} it?", f"Look at the {X}. How many {F} are {rw} it?",
                         f"{cap(rw)} the {X}, how many {F} are there?", f"Consider the {X}: how many {F} are {rw} it?"])
        q = op
    else:
        q = count_q(st, F, f"{rw} the {X}")
    return Cand(q, f"count({ref(kx)} | relate[{r}]{chain(kf)})", "one_hop_count")


def g_one_hop_exist(rng, w, st):
    x = rng.randrange(len(w.objs))
    r = rng.choice(ontology.RELATIONS)
    kx = st.key(w, x, w.all)
    if kx is None:
        return None
    kf = random_set_key(rng, w, n_slots=rng.choice([1, 1, 2])) if rng.random() < 0.7 else ()
    X = st.np(kx)
    rw = st.rel_w(r)
    if rng.random() < 0.2:
        F = st.np(kf) if kf else "anything"
        q = rng.choice([f"There is {indef(X)}; is there {indef(F) if kf else F} {rw} it?",
                        f"Look at the {X}. Is there {indef(F) if kf else F} {rw} it?"])
    else:
        F = st.np(kf) if kf else st.thing_w()
        q = exist_q(st, F, f"{rw} the {X}", bare_thing=not kf, rel_pred=True)
    return Cand(q, f"exist({ref(kx)} | relate[{r}]{chain(kf)})", "one_hop_exist")


def g_two_hop_count(rng, w, st):
    got = related_target(rng, w, st)
    if not got:
        return None
    _x, r1, _y, kx, ky = got
    r2 = rng.choice(ontology.RELATIONS)
    kf = random_set_key(rng, w, n_slots=1) if rng.random() < 0.5 else ()
    F = pluralise(st.np(kf)) if kf else pluralise(st.thing_w())
    X, Y = st.np(kx), st.np(ky)
    a1, a2 = st.rel_w(r1), st.rel_w(r2)
    if rng.random() < 0.35:
        q = rng.choice([f"There is {indef(Y)} {a1} the {X}; how many {F} are {a2} it?",
                        f"Find the {Y} {a1} the {X}. How many {F} are {a2} it?"])
    else:
        q = count_q(st, F, f"{a2} the {Y} {a1} the {X}")
    prog = f"count({ref(kx)} | relate[{r1}]{chain(ky)} | unique | relate[{r2}]{chain(kf)})"
    return Cand(q, prog, "two_hop_count")


def g_two_hop_exist(rng, w, st):
    got = related_target(rng, w, st)
    if not got:
        return None
    _x, r1, _y, kx, ky = got
    r2 = rng.choice(ontology.RELATIONS)
    kf = random_set_key(rng, w, n_slots=1) if rng.random() < 0.6 else ()
    X, Y = st.np(kx), st.np(ky)
    a1, a2 = st.rel_w(r1), st.rel_w(r2)
    F = st.np(kf) if kf else st.thing_w()
    if rng.random() < 0.35:
        q = rng.choice([f"There is {indef(Y)} {a1} the {X}; is there {indef(F)} {a2} it?",
                        f"Look at the {Y} {a1} the {X}. Are there any {pluralise(F)} {a2} it?"])
    else:
        q = exist_q(st, F, f"{a2} the {Y} that is {a1} the {X}" if rng.random() < 0.4 else f"{a2} the {Y} {a1} the {X}",
                    bare_thing=not kf, rel_pred=True)
    prog = f"exist({ref(kx)} | relate[{r1}]{chain(ky)} | unique | relate[{r2}]{chain(kf)})"
    return Cand(q, prog, "two_hop_exist")


def g_three_hop_query(rng, w, st):
    attr = rng.choice(["shape", "color", "shape", "material", "size"])
    got = related_target(rng, w, st, need_hop=False)
    if not got:
        return None
    x, r1, y, kx, ky = got
    r2, r3 = rng.choice(ontology.RELATIONS), rng.choice(ontology.RELATIONS)
    rel2 = w.rel(y, r2)
    if not rel2:
        return None
    z = rng.choice(sorted(rel2))
    kz = st.key(w, z, rel2)
    if z == x:
        return None  # no loop back to the first referent
    rel3 = w.rel(z, r3)
    if kz is None or not rel3:
        return None
    t = rng.choice(sorted(rel3))
    if t in (x, y):
        return None
    kt = st.key(w, t, rel3, exclude=(attr,), shape_mode=shape_mode_for(attr))
    if kt is None:
        return None
    X, Y, Z, T = st.np(kx), st.np(ky), st.np(kz), st.np(kt)
    a1, a2, a3 = st.rel_w(r1), st.rel_w(r2), st.rel_w(r3)
    if rng.random() < 0.5:
        q = ask_with_opener(st, attr, f"{Z} {a2} the {Y} {a1} the {X}", f"the {T} {a3} it")
    else:
        q = ask(st, attr, f"the {T} {a3} the {Z} {a2} the {Y} {a1} the {X}")
    prog = (f"{ref(kx)} | relate[{r1}]{chain(ky)} | unique | relate[{r2}]{chain(kz)} | unique"
            f" | relate[{r3}]{chain(kt)} | unique | query_{attr}")
    return Cand(q, prog, f"three_hop_query_{attr}")


def g_three_hop_count(rng, w, st):
    got = related_target(rng, w, st, need_hop=False)
    if not got:
        return None
    x, r1, y, kx, ky = got
    r2, r3 = rng.choice(ontology.RELATIONS), rng.choice(ontology.RELATIONS)
    rel2 = w.rel(y, r2)
    if not rel2:
        return None
    z = rng.choice(sorted(rel2))
    if z == x:
        return None  # no loop back to the first referent
    kz = st.key(w, z, rel2)
    if kz is None:
        return None
    kf = random_set_key(rng, w, n_slots=1) if rng.random() < 0.4 else ()
    F = pluralise(st.np(kf)) if kf else pluralise(st.thing_w())
    X, Y, Z = st.np(kx), st.np(ky), st.np(kz)
    a1, a2, a3 = st.rel_w(r1), st.rel_w(r2), st.rel_w(r3)
    q = rng.choice([f"There is {indef(Z)} {a2} the {Y} {a1} the {X}; how many {F} are {a3} it?",
                    f"How many {F} are {a3} the {Z} {a2} the {Y} {a1} the {X}?",
                    f"What number of {F} are {a3} the {Z} that is {a2} the {Y} {a1} the {X}?"])
    prog = (f"count({ref(kx)} | relate[{r1}]{chain(ky)} | unique | relate[{r2}]{chain(kz)} | unique"
            f" | relate[{r3}]{chain(kf)})")
    return Cand(q, prog, "three_hop_count")


def g_relate_query_shape(rng, w, st):
    """'What is the thing behind the red car?' with a bare 'thing' (the related object is alone there)."""
    x = rng.randrange(len(w.objs))
    r = rng.choice(ontology.RELATIONS)
    rel = w.rel(x, r)
    if len(rel) != 1:
        return None
    kx = st.key(w, x, w.all)
    if kx is None:
        return None
    X = st.np(kx)
    rw = st.rel_w(r)
    q = rng.choice([f"What is {rw} the {X}?", f"Which object is {rw} the {X}?", f"What kind of vehicle is {rw} the {X}?",
                    f"What is the thing {rw} the {X}?", f"Name the object {rw} the {X}.",
                    f"What vehicle can be seen {rw} the {X}?", f"What shape is the object {rw} the {X}?"])
    return Cand(cap(q), f"{ref(kx)} | relate[{r}] | unique | query_shape", "one_hop_query_shape_bare")


# ---------------------------------------------------------------- parts

def part_name_options(w, p, allow_super=True):
    """Part-name values that name part ``p`` unambiguously on its own: the canonical raw name, and the super-part
    name when the subtype has only one part of that kind."""
    raw = w.part_raw(p)
    canon = ontology.canonical_part_name(raw)
    sup = ontology.super_part_name(raw)
    sub = w.objs[p[0]].subtype
    out = [canon]
    if allow_super and sup != canon and sum(ontology.super_part_name(n) == sup for n in ontology.PARTS[sub]) == 1:
        out.append(sup)
    return out


def part_key(w, p, among, rng, exclude=(), by_name=True, prefer_super=0.5, need_color=False):
    """A part description selecting exactly ``p`` among the parts ``among``.

    ``by_name``: a name that is unambiguous on its object (canonical raw name or a super-part name the subtype has
    only once), or the super-part name plus the part's colour (plus material if needed); never a bare super-part
    name of a subtype with several such parts. Without ``by_name`` (the part name is asked): colour, plus material
    if needed.
    """
    raw = w.part_raw(p)
    style = w.part_style(p)
    sup = ontology.super_part_name(raw)
    opts = []
    if by_name:
        for name in part_name_options(w, p):
            opts.append((("name", name),))
        if style is not None and "color" not in exclude:
            opts.append((("color", style.color), ("name", sup)))
            if "material" not in exclude:
                opts.append((("color", style.color), ("material", style.material), ("name", sup)))
    elif style is not None:
        opts.append((("color", style.color),))
        opts.append((("color", style.color), ("material", style.material)))
    if need_color and style is not None:  # a part named across the whole scene: its colour singles it out
        opts = [(("color", style.color), ("name", n)) for n in dict.fromkeys([sup] + part_name_options(w, p))]
        opts.append((("color", style.color), ("material", style.material), ("name", sup)))
    good = [k for k in opts if part_select(w, among, k) == {p}]
    if not good:
        return None
    n = min(len(k) for k in good)
    best = [k for k in good if len(k) == n]
    if len(best) > 1 and rng.random() < prefer_super:
        sup_keys = [k for k in best if dict(k).get("name") == sup]
        if sup_keys:
            return sup_keys[0]
    return rng.choice(best)


def part_select(w, among, key):
    out = set()
    for p in among:
        raw = w.part_raw(p)
        ok = True
        for s, v in key:
            if s == "name":
                ok = ok and ontology.partname_matches(raw, v)
            else:
                style = w.part_style(p)
                ok = ok and style is not None and getattr(style, s) == v
        if ok:
            out.add(p)
    return out


PART_OPS = {"color": "partfilter_color", "material": "partfilter_material", "name": "partfilter_partname"}


def pchain(key):
    order = {"size": 0, "color": 1, "material": 2, "name": 3}
    return "".join(f" | {PART_OPS[s]}[{v}]" for s, v in sorted(key, key=lambda kv: order[kv[0]]))


def part_np(st, key):
    d = dict(key)
    ws = []
    if "color" in d:
        ws.append(st.color_w(d["color"]))
    if "material" in d:
        ws.append(st.mat_w(d["material"]))
    ws.append(st.part_w(d["name"]) if "name" in d else "part")
    return " ".join(ws)


P_ATTR_HEADS = {
    "color": ["What color is the {P} of the {X}?", "What colour is the {X}'s {P}?", "What is the color of the {P} of the {X}?",
              "The {P} of the {X} is what color?", "Which colour does the {P} of the {X} have?",
              "What color is the {P} on the {X}?", "Tell me the color of the {X}'s {P}.",
              "What colour has the {P} of the {X} been painted?", "On the {X}, what color is the {P}?"],
    "material": ["What material is the {P} of the {X}?", "What is the {X}'s {P} made of?",
                 "What is the material of the {P} of the {X}?", "Is the {P} of the {X} metal or rubber?",
                 "The {P} on the {X} is made of what?", "What is the {P} on the {X} made of?",
                 "Which material is the {X}'s {P} made of?", "What's the {P} of the {X} made out of?"],
}


def possessive_ok(X):
    return len(X.split()) <= 2


def fmt_part_q(st, forms, **kw):
    X = kw.get("X", "")
    if not possessive_ok(X):
        forms = [f for f in forms if "{X}'s" not in f]
    return cap(st.pick(forms).format(**kw))


def objects_with_recoloured(w):
    return [o.i for o in w.objs if w.recoloured(o.i)]


def g_part_query(rng, w, st):
    attr = rng.choice(["color", "material", "color"])
    objs = objects_with_recoloured(w)
    if not objs:
        return None
    x = rng.choice(objs)
    p = rng.choice(w.recoloured(x))
    kx = st.key(w, x, w.all)
    kp = part_key(w, p, w.recoloured(x), rng, exclude=(attr,))
    if kx is None or kp is None:
        return None
    X, P = st.np(kx), part_np(st, kp)
    q = fmt_part_q(st, P_ATTR_HEADS[attr], X=X, P=P)
    prog = f"{ref(kx)} | object2part{pchain(kp)} | unique | partquery_{attr}"
    return Cand(q, prog, f"part_query_{attr}")


def g_part_query_name(rng, w, st):
    objs = objects_with_recoloured(w)
    if not objs:
        return None
    x = rng.choice(objs)
    p = rng.choice(w.recoloured(x))
    kx = st.key(w, x, w.all)
    kp = part_key(w, p, w.recoloured(x), rng, by_name=False)
    if kx is None or kp is None:
        return None
    d = dict(kp)
    X = st.np(kx)
    c = st.color_w(d["color"])
    desc = c if "material" not in d else f"{c} and {st.mat_w(d['material'])}"
    pre = c if "material" not in d else f"{c} {st.mat_w(d['material'])}"
    forms = [f"Which part of the {X} is {desc}?", f"What is the name of the {pre} part of the {X}?",
             f"The {X} has a {pre} part; which part is it?", f"What {pre} part does the {X} have?",
             f"Name the {pre} part of the {X}.", f"What part of the {X} is {desc}?",
             f"Which of the {X}'s parts is {desc}?" if possessive_ok(X) else f"Which of the parts of the {X} is {desc}?"]
    q = cap(rng.choice(forms))
    return Cand(q, f"{ref(kx)} | object2part{pchain(kp)} | unique | partquery_partname", "part_query_partname")


def g_object_with_part(rng, w, st):
    attr = rng.choice(["color", "shape", "material", "shape"])
    objs = objects_with_recoloured(w)
    if not objs:
        return None
    t = rng.choice(objs)
    p = rng.choice(w.recoloured(t))
    style = w.part_style(p)
    raw = w.part_raw(p)
    names = part_name_options(w, p) + [ontology.super_part_name(raw)]
    name = rng.choice(names)
    # description of the object: fewest slots such that exactly one object of that description has the part
    base = [(("color", style.color), ("name", name)), (("color", style.color), ("material", style.material), ("name", name))]
    o = w.objs[t]
    mode = shape_mode_for(attr)
    found = None
    for pk in base:
        # minimal object key among owners (may be empty)
        if len(part_select(w, [q for q in w.recoloured(t)], pk)) != 1:
            continue
        cands = []
        for ok in keys_upto(o, exclude=(attr,), mode=mode):
            sel = select(w, w.all, ok)
            parts = part_select(w, [q for i in sel for q in w.recoloured(i)], pk)
            if len(parts) == 1 and next(iter(parts))[0] == t:
                cands.append(ok)
        if cands:
            n = min(len(k) for k in cands)
            found = (pk, rng.choice([k for k in cands if len(k) == n]))
            break
    if not found:
        return None
    pk, kx = found
    if st.redundant:
        kx = st.add_redundancy(w, t, kx, (attr,), mode)
    X = st.np(kx)
    d = dict(pk)
    pn = st.part_w(d["name"])
    col = st.color_w(d["color"])
    mat = st.mat_w(d["material"]) if "material" in d else None
    P = f"{col} {mat} {pn}" if mat else f"{col} {pn}"
    forms = [f"the {X} that has {indef(P)}", f"the {X} with {indef(P)}", f"the {X} which has {indef(P)}"]
    if not mat:
        forms += [f"the {X} whose {pn} is {col}", f"the {X} whose {pn} is painted {col}"]
    np_ = rng.choice(forms)
    if "whose" in np_:
        notes = ["whose"]
    else:
        notes = []
    q = ask(st, attr, np_)
    prog = f"scene(){chain(kx)} | object2part{pchain(pk)} | unique | part2object | unique | query_{attr}"
    return Cand(q, prog, f"object_with_part_query_{attr}", notes)


def keys_upto(o: Obj, exclude=(), mode="any"):
    """All keys describing object ``o`` (no pose), shortest first."""
    opts = []
    for s in ("size", "color", "material", "shape"):
        if s in exclude:
            opts.append([None])
        elif s == "shape":
            opts.append({"any": [None, o.subtype, o.category], "category": [None, o.category], "none": [None]}[mode])
        else:
            opts.append([None, getattr(o, s)])
    out = [()]
    for k, s in enumerate(("size", "color", "material", "shape")):
        out = [acc + ((s, v),) if v is not None else acc for acc in out for v in opts[k]]
    return sorted(set(out), key=lambda k: (len(k), k))


def g_same_object_part(rng, w, st):
    attr = rng.choice(["color", "material", "partname"])
    allparts = [q for i in w.all for q in w.recoloured(i)]
    if not allparts:
        return None
    p2 = rng.choice(allparts)
    others = [q for q in w.recoloured(p2[0]) if q != p2]
    if not others:
        return None
    p1 = rng.choice(others)
    k2 = part_key(w, p2, allparts, rng, need_color=True)
    if k2 is None:
        return None
    if attr == "partname":
        k1 = part_key(w, p1, w.recoloured(p1[0]), rng, by_name=False)
        if k1 is None:
            return None
    else:
        k1 = part_key(w, p1, w.recoloured(p1[0]), rng, exclude=(attr,))
        if k1 is None:
            return None
    # the queried part must not be picked out by the first part's description
    if p2 in part_select(w, w.recoloured(p1[0]), k1):
        return None
    P2 = part_np(st, k2)
    thing = st.thing_w()
    if attr == "partname":
        d = dict(k1)
        c = st.color_w(d["color"])
        pre = c if "material" not in d else f"{c} {st.mat_w(d['material'])}"
        q = cap(rng.choice([f"Which part of the {thing} with the {P2} is {pre}?",
                            f"What is the name of the {pre} part that belongs to the same object as the {P2}?",
                            f"The {thing} that has the {P2} also has a {pre} part; what is it called?",
                            f"What {pre} part is on the same {thing} as the {P2}?",
                            f"Name the {pre} part of the {thing} that has the {P2}."]))
    else:
        P1 = part_np(st, k1)
        forms = {"color": [f"What color is the {P1} that belongs to the same object as the {P2}?",
                           f"What colour is the {P1} of the {thing} that has the {P2}?",
                           f"There is a {P2}; what color is the {P1} on the same {thing}?",
                           f"The {thing} with the {P2} has a {P1}. What color is it?",
                           f"What is the color of the {P1} on the {thing} with the {P2}?"],
                 "material": [f"What material is the {P1} that belongs to the same object as the {P2}?",
                              f"What is the {P1} of the {thing} with the {P2} made of?",
                              f"There is a {P2}; what is the {P1} of the same {thing} made of?",
                              f"Is the {P1} on the {thing} that has the {P2} rubber or metal?",
                              f"What is the material of the {P1} on the same {thing} as the {P2}?"]}[attr]
        q = cap(rng.choice(forms))
    prog = (f"scene() | object2part{pchain(k2)} | unique | part2object | object2part{pchain(k1)} | unique"
            f" | partquery_{attr}")
    return Cand(q, prog, f"same_object_part_query_{attr}")


def g_part_count(rng, w, st):
    objs = objects_with_recoloured(w)
    if not objs:
        return None
    x = rng.choice(objs)
    o = w.objs[x]
    colors = [w.part_style(p).color for p in w.recoloured(x)]
    c = rng.choice(colors) if rng.random() < 0.75 else rng.choice([c for c in ontology.COLORS if c != o.color])
    if c == o.color:
        return None
    kx = st.key(w, x, w.all, exclude=("color",))
    if kx is None:
        return None
    X = st.np(kx)
    cw = st.color_w(c)
    forms = [f"How many {cw} parts does the {X} have?", f"How many parts of the {X} are {cw}?",
             f"What number of {cw} parts are on the {X}?", f"Count the {cw} parts of the {X}.",
             f"How many of the {X}'s parts are {cw}?" if possessive_ok(X) else f"How many of the parts of the {X} are {cw}?",
             f"The {X} has how many {cw} parts?"]
    q = rng.choice(forms)
    return Cand(q, f"count({ref(kx)} | object2part | partfilter_color[{c}])", "part_count_color")


def g_part_exist(rng, w, st):
    objs = objects_with_recoloured(w)
    if not objs:
        return None
    x = rng.choice(objs)
    o = w.objs[x]
    kx = st.key(w, x, w.all, exclude=("color",))
    if kx is None:
        return None
    if rng.random() < 0.5:
        p = rng.choice(w.recoloured(x))
        c = w.part_style(p).color
        name = ontology.super_part_name(w.part_raw(p)) if rng.random() < 0.6 else ontology.canonical_part_name(w.part_raw(p))
        if rng.random() < 0.5:  # ask another colour for a "no"
            c = rng.choice([k for k in ontology.COLORS if k != o.color])
    else:
        c = rng.choice([k for k in ontology.COLORS if k != o.color])
        raw = rng.choice(ontology.PARTS[o.subtype])
        name = ontology.super_part_name(raw) if rng.random() < 0.6 else ontology.canonical_part_name(raw)
    X = st.np(kx)
    cw, pn = st.color_w(c), st.part_w(name)
    forms = [f"Does the {X} have {indef(cw + ' ' + pn)}?", f"Is there {indef(cw + ' ' + pn)} on the {X}?",
             f"Does the {X} have any {cw} {pluralise(pn)}?" if name == ontology.super_part_name(name) else
             f"Is the {pn} of the {X} {cw}?",
             f"Has the {X} got {indef(cw + ' ' + pn)}?", f"Is any {pn} of the {X} {cw}?"
             if name == ontology.super_part_name(name) else f"Is the {X}'s {pn} {cw}?"]
    q = rng.choice(forms)
    if "'s" in q and not possessive_ok(X):
        return None
    prog = f"exist({ref(kx)} | object2part | partfilter_color[{c}] | partfilter_partname[{name}])"
    return Cand(q, prog, "part_exist")


def g_objects_with_part_count(rng, w, st):
    allparts = [q for i in w.all for q in w.recoloured(i)]
    if not allparts:
        return None
    p = rng.choice(allparts)
    c = w.part_style(p).color if rng.random() < 0.8 else rng.choice(ontology.COLORS)
    name = ontology.super_part_name(w.part_raw(p))
    kf = ()
    if rng.random() < 0.4:
        o = w.objs[p[0]]
        kf = (("shape", rng.choice([o.category, o.category, o.subtype])),)
    if any(w.objs[i].color == c for i in select(w, w.all, kf)):
        return None  # a body part of that colour would count visually but is not a recoloured part
    F = pluralise(st.np(kf)) if kf else pluralise(st.thing_w())
    cw, pn = st.color_w(c), st.part_w(name)
    forms = [f"How many {F} have {indef(cw + ' ' + pn)}?", f"How many {F} have a {pn} that is {cw}?",
             f"What number of {F} have {cw} {pluralise(pn)}?", f"Count the {F} with {indef(cw + ' ' + pn)}.",
             f"How many {F} are there whose {pn} is {cw}?", f"On how many {F} is there {indef(cw + ' ' + pn)}?"]
    q = rng.choice(forms)
    prog = f"count(scene(){chain(kf)} | object2part | partfilter_color[{c}] | partfilter_partname[{name}] | part2object)"
    notes = ["whose"] if "whose" in q else []
    return Cand(q, prog, "objects_with_part_count", notes)


# ---------------------------------------------------------------- pose

POSE_Q = ["Which direction is the {X} facing?", "Which way is the {X} facing?", "What direction does the {X} face?",
          "What is the pose of the {X}?", "In which direction is the {X} pointing?", "Where is the {X} facing?",
          "Which way does the {X} point?", "What's the orientation of the {X}?", "Which direction does the {X} point in?",
          "Which way is the front of the {X} pointing?", "What direction is the {X} heading?",
          "Is the {X} facing left, right, toward us or away from us?", "How is the {X} oriented?",
          "What is the facing direction of the {X}?", "Which direction is the {X}'s front pointing?"]


def g_query_pose(rng, w, st):
    st.allow_post = True
    objs = [o.i for o in w.objs if o.pose]
    if not objs:
        return None
    t = rng.choice(objs)
    k = st.key(w, t, w.all)
    if k is None:
        return None
    X = st.np(k)
    forms = POSE_Q if possessive_ok(X) else [f for f in POSE_Q if "'s" not in f]
    q = st.pick(forms).format(X=X)
    if rng.random() < 0.15:
        q = f"There is {indef(X)}. " + rng.choice(["Which way is it facing?", "What direction does it face?",
                                                     "Which direction is it pointing?", "What is its pose?"])
    return Cand(q, f"{ref(k)} | query_pose", "query_pose")


def g_pose_filter_query(rng, w, st):
    attr = q_attr(rng)
    objs = [o.i for o in w.objs if o.pose]
    if not objs:
        return None
    t = rng.choice(objs)
    k = st.key(w, t, w.all, exclude=(attr,), pose=True, require_pose=True, shape_mode=shape_mode_for(attr))
    if k is None:
        return None
    d = dict(k)
    kk = tuple(x for x in k if x[0] != "pose")
    core = st.np(kk)
    pw = st.pose_w(d["pose"])
    np_ = rng.choice([f"the {core} {pw}", f"the {core} that is {pw}", f"the {core} which is {pw}"])
    if pw.startswith("facing") and rng.random() < 0.4:
        np_ = f"the {core} that faces {pw[len('facing '):]}"
    q = ask(st, attr, np_)
    return Cand(q, f"{ref(k)} | query_{attr}", f"pose_filter_query_{attr}")


PREL_WORDS = {
    "same": ["that faces the same direction as", "facing the same way as", "with the same pose as",
             "pointing in the same direction as", "that is oriented the same way as", "that has the same orientation as",
             "which faces the same direction as", "parallel in direction to"],
    "opposite": ["that faces the opposite direction to", "facing the other way from", "facing opposite to",
                 "pointing the opposite way from", "that faces the opposite direction as", "with the opposite pose to",
                 "which is turned the opposite way from", "facing away from the direction of"],
    "vertical": ["that faces perpendicular to", "at a right angle to", "facing at 90 degrees to",
                 "that faces the vertical direction as", "whose direction is perpendicular to that of",
                 "that is oriented perpendicular to", "facing sideways relative to", "that faces crosswise to"],
}
PREL_WORDS["same"].remove("parallel in direction to")
PREL_WORDS["opposite"].remove("facing away from the direction of")


def pose_related(rng, w, st, kind, exclude=(), mode="any"):
    refs = [o.i for o in w.objs if o.pose]
    if not refs:
        return None
    x = rng.choice(refs)
    rel = w.pose_rel(x, kind)
    if not rel:
        return None
    y = rng.choice(sorted(rel))
    kx = st.key(w, x, w.all)
    ky = st.key(w, y, rel, exclude=exclude, shape_mode=mode)
    if kx is None or ky is None:
        return None
    return x, y, kx, ky, rel


def g_pose_rel_query(rng, w, st):
    kind = rng.choice(["same", "opposite", "vertical"])
    attr = q_attr(rng)
    got = pose_related(rng, w, st, kind, exclude=(attr,), mode=shape_mode_for(attr))
    if not got:
        return None
    _x, y, kx, ky, _rel = got
    if select(w, w.all, ky) == {y} and rng.random() < 0.8:
        return None
    X, Y = st.np(kx), st.np(ky)
    rw = st.pick(PREL_WORDS[kind])
    notes = ["whose"] if "whose" in rw else []
    q = ask(st, attr, f"the {Y} {rw} the {X}")
    prog = f"{ref(kx)} | {kind}_pose{chain(ky)} | unique | query_{attr}"
    return Cand(q, prog, f"{kind}_pose_query_{attr}", notes)


def g_pose_rel_count_exist(rng, w, st):
    kind = rng.choice(["same", "opposite", "vertical"])
    refs = [o.i for o in w.objs if o.pose]
    if not refs:
        return None
    x = rng.choice(refs)
    kx = st.key(w, x, w.all)
    if kx is None:
        return None
    kf = random_set_key(rng, w, n_slots=1) if rng.random() < 0.45 else ()
    X = st.np(kx)
    rw = st.pick(PREL_WORDS[kind])
    pred = rw.replace("that faces", "facing").replace("which faces", "facing").replace("that is oriented", "oriented") \
        .replace("that has", "having").replace("which is turned", "turned").replace("whose direction is", "with a direction")
    what = rng.choice(["count", "exist"])
    if what == "count":
        F = pluralise(st.np(kf)) if kf else pluralise(st.thing_w())
        are = "are there" if pred.startswith(("with", "having", "at a")) else "are"
        forms = [f"How many {F} {are} {pred} the {X}?", f"How many {F} face the same way as the {X}?" if kind == "same"
                 else f"How many {F} {are} {pred} the {X}?", f"What number of {F} {are} {pred} the {X}?",
                 f"Count the {F} {pred} the {X}."]
        if kind == "vertical":
            forms += [f"How many {F} face perpendicular to the {X}?"]
        if kind == "opposite":
            forms += [f"How many {F} face the opposite way to the {X}?"]
        q = rng.choice(forms)
        prog = f"count({ref(kx)} | {kind}_pose{chain(kf)})"
    else:
        F = st.np(kf) if kf else st.thing_w()
        forms = [f"Is there {indef(F)} {pred} the {X}?", f"Are there any {pluralise(F)} {pred} the {X}?",
                 f"Does any {F} face the same direction as the {X}?" if kind == "same" else
                 f"Is any {F} {pred} the {X}?", f"Is there another {F} {pred} the {X}?"]
        q = rng.choice(forms)
        prog = f"exist({ref(kx)} | {kind}_pose{chain(kf)})"
    return Cand(cap(q), prog, f"{kind}_pose_{what}")


def g_pose_filter_count_exist(rng, w, st):
    pose = rng.choice(ontology.POSES)
    kf = random_set_key(rng, w, n_slots=1) if rng.random() < 0.7 else ()
    pw = st.pose_w(pose)
    what = rng.choice(["count", "exist"])
    key = (("pose", pose),) + kf
    if what == "count":
        F = pluralise(st.np(kf)) if kf else pluralise(st.thing_w())
        forms = [f"How many {F} are {pw}?", f"How many {F} {pw} are there?", f"What number of {F} are {pw}?",
                 f"Count the {F} that are {pw}.", f"How many of the {F} are {pw}?"]
        if pw.startswith("facing"):
            forms.append(f"How many {F} face {pw[7:]}?")
        q = rng.choice(forms)
        prog = f"count({setp(key)})"
    else:
        F = st.np(kf) if kf else st.thing_w()
        forms = [f"Is there {indef(F)} {pw}?", f"Are any {pluralise(F)} {pw}?", f"Is any {F} {pw}?",
                 f"Do you see {indef(F)} {pw}?", f"Are there any {pluralise(F)} {pw}?"]
        if pw.startswith("facing"):
            forms.append(f"Does any {F} face {pw[7:]}?")
        q = rng.choice(forms)
        prog = f"exist({setp(key)})"
    return Cand(q, prog, f"pose_filter_{what}")


# ---------------------------------------------------------------- occlusion

OCC_PRED = ["occluded", "partly hidden", "partially hidden", "partially occluded", "partly covered",
            "partially blocked from view", "obscured", "hidden in part"]
OCC_BY = ["occluded by", "hidden by", "partly hidden by", "blocked by", "obscured by", "partially covered by",
          "partly hidden behind", "partially occluded by"]
OCC_ING = ["occludes", "hides", "blocks the view of", "obscures", "partly covers", "is hiding", "partially hides",
           "is in front of and hiding"]
OCC_ING_SHORT = OCC_ING[:-1]
OCC_ING_PL = {"occludes": "occlude", "hides": "hide", "blocks the view of": "block the view of", "obscures": "obscure",
              "partly covers": "partly cover", "is hiding": "are hiding", "partially hides": "partially hide",
              "is in front of and hiding": "are in front of and hiding"}


def g_occluded_query(rng, w, st):
    occ = w.occluded()
    if not occ:
        return None
    attr = q_attr(rng)
    t = rng.choice(sorted(occ))
    k = st.key(w, t, occ, exclude=(attr,), shape_mode=shape_mode_for(attr))
    if k is None:
        return None
    if select(w, w.all, k) == {t} and rng.random() < 0.85:
        return None  # occlusion not needed
    Y = st.np(k)
    adj = st.pick(OCC_PRED)
    np_ = rng.choice([f"the {Y} that is {adj}", f"the {adj} {Y}" if len(adj.split()) <= 2 else f"the {Y} that is {adj}",
                      f"the {Y} which is {adj}"])
    q = ask(st, attr, np_)
    return Cand(q, f"scene() | filter_occludee{chain(k)} | unique | query_{attr}", f"occluded_query_{attr}")


def g_occluded_by_query(rng, w, st):
    attr = q_attr(rng)
    pairs = [(y, x) for y in w.all for x in w.occludees_of(y)]  # y occludes x
    if not pairs:
        return None
    y, x = rng.choice(pairs)
    rev = rng.random() < 0.5  # ask about the occluder instead
    if not rev:
        rel = w.occludees_of(y)
        ky = st.key(w, y, w.all)
        kx = st.key(w, x, rel, exclude=(attr,), shape_mode=shape_mode_for(attr))
        if ky is None or kx is None:
            return None
        Y, X = st.np(ky), st.np(kx)
        byw = st.pick(OCC_BY)
        np_ = rng.choice([f"the {X} that is {byw} the {Y}", f"the {X} {byw} the {Y}"])
        q = ask(st, attr, np_)
        prog = f"{ref(ky)} | relate_occluding{chain(kx)} | unique | query_{attr}"
        return Cand(q, prog, f"occluded_by_query_{attr}")
    rel = w.occluders_of(x)
    kx = st.key(w, x, w.all)
    ky = st.key(w, y, rel, exclude=(attr,), shape_mode=shape_mode_for(attr))
    if kx is None or ky is None:
        return None
    X, Y = st.np(kx), st.np(ky)
    ing = st.pick(OCC_ING)
    np_ = rng.choice([f"the {Y} that {ing} the {X}", f"the {Y} which {ing} the {X}"])
    q = ask(st, attr, np_)
    prog = f"{ref(kx)} | relate_occluded{chain(ky)} | unique | query_{attr}"
    return Cand(q, prog, f"occluding_query_{attr}")


IS_OCC = ["Is the {X} occluded?", "Is the {X} partly hidden?", "Is the {X} partially hidden by something?",
          "Is any part of the {X} hidden from view?", "Is the {X} blocked from view by another object?",
          "Is something in front of the {X}, hiding part of it?", "Is the {X} obscured?",
          "Is the {X} partially occluded?", "Can we see all of the {X}, or is it occluded?",
          "Is the view of the {X} blocked by anything?"]


def g_is_occluded(rng, w, st):
    st.allow_post = True
    t = rng.randrange(len(w.objs))
    k = st.key(w, t, w.all)
    if k is None:
        return None
    q = st.pick(IS_OCC).format(X=st.np(k))
    return Cand(q, f"exist(scene() | filter_occludee{chain(k)})", "is_occluded")


def g_is_occluded_by(rng, w, st):
    x, y = rng.sample(range(len(w.objs)), 2)
    if rng.random() < 0.5:
        pairs = [(a, b) for b in w.all for a in w.occludees_of(b)]
        if pairs:
            x, y = rng.choice(pairs)
    kx, ky = st.key(w, x, w.all), st.key(w, y, w.all)
    if kx is None or ky is None:
        return None
    X, Y = st.np(kx), st.np(ky)
    forms = [f"Is the {X} occluded by the {Y}?", f"Is the {X} partly hidden by the {Y}?",
             f"Does the {Y} occlude the {X}?", f"Does the {Y} hide part of the {X}?",
             f"Is the {X} blocked from view by the {Y}?", f"Does the {Y} block the view of the {X}?",
             f"Is the {Y} in front of the {X}, hiding part of it?", f"Is part of the {X} hidden behind the {Y}?",
             f"Is the {X} obscured by the {Y}?"]
    q = rng.choice(forms)
    return Cand(q, f"exist({ref(ky)} | relate_occluding{chain(kx)})", "is_occluded_by")


def g_occlusion_count(rng, w, st):
    kind = rng.choice(["occluded", "occluded", "occludes", "occluders"])
    if kind == "occluded":
        kf = random_set_key(rng, w, n_slots=1) if rng.random() < 0.6 else ()
        F = pluralise(st.np(kf)) if kf else pluralise(st.thing_w())
        adj = st.pick(OCC_PRED)
        forms = [f"How many {F} are {adj}?", f"How many {adj} {F} are there?" if len(adj.split()) == 1 else
                 f"How many {F} are {adj}?", f"What number of {F} are {adj}?", f"Count the {F} that are {adj}.",
                 f"How many of the {F} are {adj}?"]
        return Cand(rng.choice(forms), f"count(scene() | filter_occludee{chain(kf)})", "occluded_count")
    t = rng.randrange(len(w.objs))
    k = st.key(w, t, w.all)
    if k is None:
        return None
    X = st.np(k)
    thing = pluralise(st.thing_w())
    if kind == "occludes":
        ing = st.pick(OCC_ING_SHORT)
        forms = [f"How many {thing} does the {X} occlude?", f"How many {thing} are {st.pick(OCC_BY)} the {X}?",
                 f"How many {thing} does the {X} partly hide?", f"The {X} {ing} how many {thing}?",
                 f"What number of {thing} are hidden by the {X}?"]
        return Cand(rng.choice(forms), f"count({ref(k)} | relate_occluding)", "occluded_by_count")
    forms = [f"How many {thing} occlude the {X}?", f"By how many {thing} is the {X} occluded?",
             f"How many {thing} are hiding part of the {X}?", f"How many {thing} {OCC_ING_PL[st.pick(OCC_ING_SHORT)]} the {X}?",
             f"What number of {thing} block the view of the {X}?"]
    return Cand(rng.choice(forms), f"count({ref(k)} | relate_occluded)", "occluder_count")


def g_occluded_exist(rng, w, st):
    kf = random_set_key(rng, w, n_slots=rng.choice([1, 1, 2]))
    if len(select(w, w.all, kf)) < 2 and rng.random() < 0.7:
        return None  # plural description
    F = st.np(kf)
    adj = st.pick(OCC_PRED)
    forms = [f"Are any {pluralise(F)} {adj}?", f"Is any {F} {adj}?", f"Is there {indef(F)} that is {adj}?",
             f"Are any of the {pluralise(F)} {adj}?", f"Is at least one {F} {adj}?",
             f"Is there {indef(adj + ' ' + F)}?" if len(adj.split()) == 1 else f"Are there {pluralise(F)} that are {adj}?"]
    return Cand(rng.choice(forms), f"exist(scene() | filter_occludee{chain(kf)})", "occluded_exist")


# ---------------------------------------------------------------- part occlusion

def g_part_occluded_yesno(rng, w, st):
    x = rng.randrange(len(w.objs))
    parts = w.parts_all(x)
    if not parts:
        return None
    p = rng.choice(parts)
    names = part_name_options(w, p)
    name = rng.choice(names)
    if part_select(w, parts, (("name", name),)) != {p}:
        return None
    kx = st.key(w, x, w.all)
    if kx is None:
        return None
    X, P = st.np(kx), st.part_w(name)
    forms = ["Is the {P} of the {X} occluded?", "Is the {X}'s {P} occluded?", "Is the {P} of the {X} hidden?",
             "Is the {P} on the {X} partly hidden?", "Is the {X}'s {P} blocked from view?",
             "Can the whole {P} of the {X} be seen, or is it occluded?", "Is the {P} of the {X} partially hidden?",
             "Is the {X}'s {P} obscured by something?", "Is anything hiding the {P} of the {X}?"]
    q = fmt_part_q(st, forms, X=X, P=P)
    prog = f"{ref(kx)} | object2part_all | partfilter_partname[{name}] | unique | partquery_occlusion"
    return Cand(q, prog, "part_occluded_yesno")


def g_which_part_occluded(rng, w, st):
    objs = [i for i in w.all if len([p for p in w.parts_all(i) if w.part_occluded(p)]) == 1]
    if not objs:
        return None
    x = rng.choice(objs)
    kx = st.key(w, x, w.all)
    if kx is None:
        return None
    X = st.np(kx)
    forms = ["Which part of the {X} is occluded?", "What part of the {X} is hidden?",
             "Which part of the {X} is partly hidden?", "Which of the {X}'s parts is occluded?",
             "Name the occluded part of the {X}.", "What part of the {X} is blocked from view?",
             "Which part of the {X} can't be fully seen?", "The {X} has one part hidden; which one?",
             "What is the name of the occluded part of the {X}?"]
    q = fmt_part_q(st, forms, X=X)
    prog = f"{ref(kx)} | object2part_all | partfilter_occludee | unique | partquery_partname"
    return Cand(q, prog, "which_part_occluded")


def g_whose_part_occluded_query(rng, w, st):
    attr = q_attr(rng)
    cands = [(i, p) for i in w.all for p in w.parts_all(i) if w.part_occluded(p)]
    if not cands:
        return None
    t, p = rng.choice(cands)
    raw = w.part_raw(p)
    name = rng.choice([ontology.super_part_name(raw), ontology.canonical_part_name(raw)])
    o = w.objs[t]
    mode = shape_mode_for(attr)
    found = []
    for k in keys_upto(o, exclude=(attr,), mode=mode):
        sel = select(w, w.all, k)
        owners = {q[0] for i in sel for q in w.parts_all(i) if w.part_occluded(q) and ontology.partname_matches(
            w.part_raw(q), name)}
        if owners == {t}:
            found.append(k)
    if not found:
        return None
    n = min(len(k) for k in found)
    k = rng.choice([k for k in found if len(k) == n])
    if st.redundant:
        k = st.add_redundancy(w, t, k, (attr,), mode)
    X, P = st.np(k), st.part_w(name)
    adj = st.pick(["occluded", "hidden", "partly hidden", "blocked from view", "obscured", "partially occluded"])
    q = ask(st, attr, f"the {X} whose {P} is {adj}")
    prog = (f"scene(){chain(k)} | object2part_all | partfilter_occludee | partfilter_partname[{name}] | part2object"
            f" | unique | query_{attr}")
    return Cand(q, prog, f"whose_part_occluded_query_{attr}", ["whose"])


def g_part_of_occluded_object(rng, w, st):
    attr = rng.choice(["color", "material", "partname"])
    occ = [i for i in w.occluded() if w.recoloured(i)]
    if not occ:
        return None
    t = rng.choice(occ)
    k = st.key(w, t, w.occluded())
    if k is None:
        return None
    p = rng.choice(w.recoloured(t))
    if attr == "partname":
        kp = part_key(w, p, w.recoloured(t), rng, by_name=False)
        if kp is None:
            return None
    else:
        kp = part_key(w, p, w.recoloured(t), rng, exclude=(attr,))
        if kp is None:
            return None
    X = st.np(k)
    adj = st.pick(OCC_PRED)
    obj = rng.choice([f"the {X} that is {adj}", f"the {adj} {X}" if len(adj.split()) == 1 else f"the {X} that is {adj}",
                      f"the {X} which is {adj}"])
    if attr == "partname":
        d = dict(kp)
        c = st.color_w(d["color"])
        m = st.mat_w(d["material"]) if "material" in d else None
        pre = c if not m else f"{c} {m}"
        q = cap(rng.choice([f"Which part of {obj} is {c if not m else c + ' and ' + m}?", f"What is the name of the {pre} part of {obj}?",
                            f"Name the {pre} part of {obj}.", f"What {pre} part does {obj} have?"]))
    else:
        P = part_np(st, kp)
        q = ask(st, attr, f"the {P} of {obj}")
    prog = f"scene() | filter_occludee{chain(k)} | object2part{pchain(kp)} | unique | partquery_{attr}"
    return Cand(q, prog, f"part_of_occluded_object_query_{attr}")


def g_part_occluded_by_yesno(rng, w, st):
    x = rng.randrange(len(w.objs))
    parts = [p for p in w.parts_all(x)]
    if not parts:
        return None
    occ = [p for p in parts if w.part_occluders(p)]
    p = rng.choice(occ) if (occ and rng.random() < 0.7) else rng.choice(parts)
    name = rng.choice(part_name_options(w, p))
    if part_select(w, parts, (("name", name),)) != {p}:
        return None
    occs = sorted(w.part_occluders(p))
    others = [j for j in w.all if j != x]
    y = rng.choice(occs) if (occs and rng.random() < 0.6) else rng.choice(others)
    kx, ky = st.key(w, x, w.all), st.key(w, y, w.all)
    if kx is None or ky is None:
        return None
    X, Y, P = st.np(kx), st.np(ky), st.part_w(name)
    forms = ["Is the {P} of the {X} occluded by the {Y}?", "Does the {Y} hide the {X}'s {P}?",
             "Is the {X}'s {P} hidden by the {Y}?", "Does the {Y} occlude the {P} of the {X}?",
             "Is the {P} of the {X} partly hidden behind the {Y}?", "Is the {Y} blocking the view of the {X}'s {P}?",
             "Is the {P} on the {X} obscured by the {Y}?"]
    q = fmt_part_q(st, forms, X=X, Y=Y, P=P)
    prog = f"exist({ref(kx)} | object2part_all | partfilter_partname[{name}] | unique | relate_part_occluded{chain(ky)})"
    return Cand(q, prog, "part_occluded_by_yesno")


def g_whose_part_occluded_by_query(rng, w, st):
    attr = q_attr(rng)
    ys = [j for j in w.all if w.parts_hidden_by(j)]
    if not ys:
        return None
    y = rng.choice(ys)
    hidden = sorted(w.parts_hidden_by(y))
    p = rng.choice(hidden)
    raw = w.part_raw(p)
    name = None
    for nm in rng.sample([ontology.super_part_name(raw), ontology.canonical_part_name(raw)], 2):
        if part_select(w, hidden, (("name", nm),)) == {p}:
            name = nm
            break
    if name is None:
        return None
    t = p[0]
    ky = st.key(w, y, w.all)
    kx = st.key(w, t, {t}, exclude=(attr,), shape_mode=shape_mode_for(attr))
    if ky is None or kx is None:
        return None
    if not kx and rng.random() < 0.5:  # allow one naming attribute sometimes (the minimal one is empty)
        pass
    X, Y, P = st.np(kx), st.np(ky), st.part_w(name)
    byw = st.pick(OCC_BY)
    q = ask(st, attr, f"the {X} whose {P} is {byw} the {Y}")
    prog = (f"{ref(ky)} | relate_occluding_part | partfilter_partname[{name}] | unique | part2object{chain(kx)}"
            f" | unique | query_{attr}")
    return Cand(q, prog, f"whose_part_occluded_by_query_{attr}", ["whose"])


def g_occluded_part_count_exist(rng, w, st):
    what = rng.choice(["count", "count", "exist", "hidden_by_count"])
    t = rng.randrange(len(w.objs))
    k = st.key(w, t, w.all)
    if k is None:
        return None
    X = st.np(k)
    if what == "count":
        forms = ["How many parts of the {X} are occluded?", "How many of the {X}'s parts are hidden?",
                 "How many parts of the {X} are partly hidden?", "What number of the {X}'s parts are occluded?",
                 "Count the occluded parts of the {X}.", "How many parts of the {X} are blocked from view?"]
        q = fmt_part_q(st, forms, X=X)
        return Cand(q, f"count({ref(k)} | object2part_all | partfilter_occludee)", "occluded_part_count")
    if what == "hidden_by_count":
        forms = ["How many parts of other objects does the {X} occlude?", "How many parts does the {X} hide?",
                 "The {X} hides how many parts of other vehicles?", "How many object parts are occluded by the {X}?",
                 "What number of parts are hidden by the {X}?"]
        q = fmt_part_q(st, forms, X=X)
        return Cand(q, f"count({ref(k)} | relate_occluding_part)", "parts_occluded_by_count")
    o = w.objs[t]
    raw = rng.choice(ontology.PARTS[o.subtype])
    if rng.random() < 0.6:
        occ = [p for p in w.parts_all(t) if w.part_occluded(p)]
        if occ:
            raw = w.part_raw(rng.choice(occ))
    name = ontology.super_part_name(raw) if rng.random() < 0.6 else ontology.canonical_part_name(raw)
    P = st.part_w(name)
    plural_ok = name == ontology.super_part_name(raw) and sum(
        ontology.super_part_name(n) == name for n in ontology.PARTS[o.subtype]) > 1
    forms = ["Does the {X} have an occluded {P}?", "Does the {X} have a {P} that is partly hidden?",
             "Is there a hidden {P} on the {X}?"]
    if plural_ok:
        forms += ["Are any of the {X}'s {Ps} occluded?", "Is any {P} of the {X} hidden?",
                  "Are any {Ps} of the {X} partly hidden?"]
    q = fmt_part_q(st, forms, X=X, P=P, Ps=pluralise(P))
    return Cand(q, f"exist({ref(k)} | object2part_all | partfilter_occludee | partfilter_partname[{name}])",
                "occluded_part_exist")


def g_whose_part_occluded_part_query(rng, w, st):
    """'What color is the P1 of the X whose P2 is occluded?' (public occlusion 13-15)."""
    attr = rng.choice(["color", "material", "partname"])
    cands = [(i, p) for i in w.all for p in w.parts_all(i) if w.part_occluded(p) and w.recoloured(i)]
    if not cands:
        return None
    t, p2 = rng.choice(cands)
    raw = w.part_raw(p2)
    name2 = rng.choice([ontology.super_part_name(raw), ontology.canonical_part_name(raw)])
    o = w.objs[t]
    found = []
    for k in keys_upto(o):
        sel = select(w, w.all, k)
        owners = {q[0] for i in sel for q in w.parts_all(i) if w.part_occluded(q) and ontology.partname_matches(
            w.part_raw(q), name2)}
        if owners == {t}:
            found.append(k)
    if not found:
        return None
    n = min(len(k) for k in found)
    k = rng.choice([k for k in found if len(k) == n])
    p1 = rng.choice(w.recoloured(t))
    if p1 == p2:
        return None
    if attr == "partname":
        kp = part_key(w, p1, w.recoloured(t), rng, by_name=False)
        if kp is None:
            return None
    else:
        kp = part_key(w, p1, w.recoloured(t), rng, exclude=(attr,))
        if kp is None:
            return None
    if p2 in part_select(w, w.recoloured(t), kp):
        return None
    X, P2 = st.np(k), st.part_w(name2)
    adj = st.pick(["occluded", "hidden", "partly hidden", "obscured"])
    obj = f"the {X} whose {P2} is {adj}"
    if attr == "partname":
        d = dict(kp)
        c = st.color_w(d["color"])
        m = st.mat_w(d["material"]) if "material" in d else None
        pre = c if not m else f"{c} {m}"
        q = cap(rng.choice([f"Which part of {obj} is {c if not m else c + ' and ' + m}?",
                            f"What is the name of the {pre} part of {obj}?"]))
    else:
        q = ask(st, attr, f"the {part_np(st, kp)} of {obj}")
    prog = (f"scene() | object2part_all | partfilter_occludee | partfilter_partname[{name2}] | part2object{chain(k)}"
            f" | object2part{pchain(kp)} | unique | partquery_{attr}")
    return Cand(q, prog, f"whose_part_occluded_part_query_{attr}", ["whose"])


# ----------------------------------------------------------------------------------------------------------------
# groups

BASE = {
    "core_query": [(g_zero_hop_query, 4), (g_one_hop_query, 4), (g_two_hop_query, 2), (g_query_subtype, 1)],
    "core_count": [(g_count_scene, 0.5), (g_zero_hop_count, 4), (g_count_or, 1.5), (g_count_and, 1.5)],
    "core_exist": [(g_zero_hop_exist, 4), (g_exist_or, 1.5), (g_exist_and, 1.5)],
    "core_compare_attribute": [(g_compare_attribute, 3), (g_compare_attribute_hop, 1.5)],
    "core_compare_integer": [(g_compare_sets, 4), (g_compare_related, 2), (g_compare_same_referent, 3),
                             (g_compare_occluded, 2)],
    "core_same_relate": [(g_same_count, 2), (g_same_exist, 2), (g_same_query, 2)],
    "core_spatial": [(g_one_hop_count, 2), (g_one_hop_exist, 2), (g_two_hop_count, 1.5), (g_two_hop_exist, 1.5),
                     (g_three_hop_query, 1), (g_three_hop_count, 0.7), (g_relate_query_shape, 0.8)],
    "parts": [(g_part_query, 2.5), (g_part_query_name, 1.5), (g_object_with_part, 2.5), (g_same_object_part, 2),
              (g_part_count, 1.2), (g_part_exist, 1.2), (g_objects_with_part_count, 1)],
    "pose": [(g_query_pose, 2), (g_pose_filter_query, 2), (g_pose_rel_query, 3), (g_pose_rel_count_exist, 2),
             (g_pose_filter_count_exist, 1.5)],
    "occlusion": [(g_occluded_query, 2), (g_occluded_by_query, 3), (g_is_occluded, 1.5), (g_is_occluded_by, 1.5),
                  (g_occlusion_count, 1.5), (g_occluded_exist, 1)],
    "part_occlusion": [(g_part_occluded_yesno, 2), (g_which_part_occluded, 1.2), (g_whose_part_occluded_query, 2),
                       (g_part_of_occluded_object, 1.5), (g_part_occluded_by_yesno, 1.5),
                       (g_whose_part_occluded_by_query, 1.5), (g_occluded_part_count_exist, 1.5),
                       (g_whose_part_occluded_part_query, 1)],
}
# the redundant group re-uses families whose referents are described (prefix redundant_)
REDUNDANT = [(g_zero_hop_query, 2), (g_one_hop_query, 1.5), (g_compare_attribute, 1.2), (g_one_hop_count, 1),
             (g_same_count, 0.8), (g_same_query, 0.7), (g_part_query, 1.2), (g_object_with_part, 0.6),
             (g_query_pose, 1), (g_pose_rel_query, 1), (g_occluded_by_query, 1), (g_is_occluded, 0.6),
             (g_part_occluded_yesno, 0.8), (g_compare_same_referent, 0.6)]
# the synonyms group: wider synonyms, the public plural quirk, typos (prefix synonym_ / plural_quirk_ / typo_)
SYNONYM = [(g_category_count_exist, 1.5), (g_zero_hop_query, 1.5), (g_zero_hop_count, 1.2), (g_zero_hop_exist, 1), (g_one_hop_count, 1),
           (g_compare_sets, 1), (g_part_query, 1.2), (g_query_pose, 0.7), (g_pose_rel_query, 0.6),
           (g_occluded_by_query, 0.6), (g_part_occluded_yesno, 0.6), (g_same_exist, 0.5), (g_one_hop_query, 0.8)]
PLURAL_QUIRK = [(g_zero_hop_count, 2), (g_compare_sets, 1.5), (g_one_hop_count, 1), (g_zero_hop_exist, 0.6),
                (g_pose_filter_count_exist, 0.5), (g_occlusion_count, 0.5), (g_objects_with_part_count, 0.4)]
TYPO = [(g_zero_hop_query, 1.5), (g_zero_hop_count, 1), (g_one_hop_query, 1), (g_part_query, 1), (g_zero_hop_exist, 1),
        (g_compare_attribute, 0.8), (g_query_pose, 0.6), (g_occluded_query, 0.6), (g_same_count, 0.5),
        (g_whose_part_occluded_query, 0.5), (g_one_hop_count, 0.8)]

# vocabulary words that may receive a typo (any word of the program's value vocabulary, as written in text)
TYPO_WORDS = sorted({w for v in list(PLAIN_SHAPE.values()) for x in v for w in x.split() if len(w) >= 4} |
                    {c for c in ontology.COLORS if len(c) >= 4} | {"metal", "metallic", "rubber", "shiny", "matte",
                                                                    "large", "small", "tiny"} |
                    {w for n in ontology.RAW_PART_NAMES for w in part_words(n).split() if len(w) >= 4
                     and w not in ("left", "right", "front", "back", "center")})
KEYBOARD = {c: n for c, n in zip("qwertyuiopasdfghjklzxcvbnm",
                                 ["wa", "qes", "wrd", "etf", "rgy", "tuh", "yij", "uok", "ipl", "ol", "qsz", "awdx",
                                  "sefc", "drgv", "fthb", "gyjn", "hukm", "jilm", "kop", "xas", "zsdc", "xdfv",
                                  "cfgb", "vghn", "bhjm", "njk"], strict=True)}
# real English words one edit away from a vocabulary word (a "typo" must not be another word)
ENGLISH = set(TYPO_WORDS) | {
    "meal", "tin", "tine", "tint", "tidy", "smell", "mall", "shall", "stall", "bed", "read", "rad", "lack", "bus",
    "busy", "cat", "cart", "bluer", "blur", "clue", "glue", "greed", "greet", "preen", "mat", "mate", "matter",
    "matted", "rubbed", "rubble", "robber", "shine", "shin", "shinny", "whiny", "spiny", "lager", "larger", "barge",
    "lard", "forks", "form", "work", "fort", "cork", "pork", "seal", "seam", "sear", "sea", "set", "sat", "seas",
    "beat", "heat", "meat", "neat", "fiber", "gay", "grey", "gravy", "grab", "pray", "tray", "fray", "grays", "crown",
    "brow", "drown", "frown", "grown", "fellow", "bellow", "hello", "meta", "petal", "medal", "mental", "metals",
    "heel", "wheels", "doom", "odor", "boor", "poor", "dour", "rook", "room", "goof", "proof", "hoof", "good", "hold",
    "food", "mood", "wood", "hook", "drunk", "trunks", "track", "trick", "tuck", "trucks", "struck", "pane", "panes",
    "panels", "win", "wind", "wine", "king", "ring", "sing", "ding", "wig", "wink", "engines", "mirrors", "bender",
    "fonder", "tender", "render", "sender", "lender", "clover", "coven", "lover", "over", "hover", "covet", "covers",
    "task", "thank", "tan", "rank", "bank", "tack", "talk", "chin", "chair", "candle", "handled", "handler",
    "paddle", "waddle", "sadder", "addle", "barrier", "farrier", "stan", "strand", "stank", "break", "brave", "bake",
    "rake", "place", "slate", "plat", "pate", "plates", "lights", "fight", "sight", "night", "might", "tight",
    "bumpers", "jumper", "dumper", "bumped", "crack", "crane", "cranky", "frank", "dive", "drove", "driver", "drives",
    "sedans", "wagons", "lighter", "righter", "tighter", "fighters", "load", "toad", "rod", "roads", "rood", "like",
    "hike", "mike", "bikes", "bile", "fountain", "choppers", "hopper", "shopper", "shooter", "scooted", "bruiser",
    "schools", "doubles", "doublet", "doubled", "aeroplanes", "cyans", "reds", "blues", "greens", "browns", "purples",
    "yellows", "smalls", "larges", "tiny", "tinny", "metall", "rubbers", "roofs", "hoods", "doors", "wings", "seats",
    "tanks", "chains", "pedals", "handles", "saddles", "stands", "brakes", "exhausts",
    "fenders", "saddled", "whee", "can", "chan", "clan", "scan",
    "cyst", "sal", "sail", "gree", "tanden", "sean"
}


def make_typo(rng: random.Random, q: str):
    words = q.split()
    def vocab(t):
        c = t.strip("?.,;:").lower()
        c = c.removesuffix("'s")
        return c in TYPO_WORDS or (c.endswith("s") and c[:-1] in TYPO_WORDS) or (c.endswith("es") and c[:-2] in TYPO_WORDS)

    idx = [k for k, t in enumerate(words) if vocab(t) and "or" not in words[max(0, k - 1):k + 2]
           and (k == 0 or words[k - 1].lower() != "how")]  # not the head words of "How large ...", "metal or rubber"
    if not idx:
        return None
    k = rng.choice(idx)
    tok = words[k]
    core = tok.strip("?.,;:")
    core = core.removesuffix("'s")
    lead = tok[: tok.index(core)]
    trail = tok[tok.index(core) + len(core):]
    base = core
    for _ in range(20):
        op = rng.choice(["delete", "double", "swap_key", "insert"])
        pos = rng.randrange(1, len(base))  # keep the first letter
        if op == "delete":
            new = base[:pos] + base[pos + 1:]
        elif op == "double":
            new = base[:pos] + base[pos] + base[pos:]
        elif op == "swap_key":
            c = base[pos].lower()
            if c not in KEYBOARD:
                continue
            new = base[:pos] + rng.choice(KEYBOARD[c]) + base[pos + 1:]
        else:
            c = base[pos - 1].lower()
            if c not in KEYBOARD:
                continue
            new = base[:pos] + rng.choice(KEYBOARD[c]) + base[pos:]
        if new.lower() != base.lower() and new.lower() not in ENGLISH and new.lower().rstrip("s") not in ENGLISH:
            words[k] = lead + new + trail
            return " ".join(words), f"typo: {base} -> {new}"
    return None


# ----------------------------------------------------------------------------------------------------------------
# driver


def run_program(ctx, program: str):
    typed = check_program(parse_program(program))
    return execute(ctx, typed)


def plain(value):
    if isinstance(value, (frozenset, set)):
        return sorted(value)
    if isinstance(value, tuple):
        return list(value)
    return value


def draw_pool(rng, worlds, gen, group, variant, n_target, max_tries):
    """Candidates of one generator (a list of records with answers), deduplicated by (scene, question)."""
    pool, seen, seen_prog = [], set(), Counter()
    stats = Counter()
    for _ in range(max_tries):
        if len(pool) >= n_target:
            break
        w = rng.choice(worlds)
        st = Style(rng, wide=variant in ("synonym", "plural_quirk"), redundant=variant == "redundant")
        c = gen(rng, w, st)
        if c is None:
            stats["none"] += 1
            continue
        notes = list(st.notes) + list(c.notes)
        fam = c.family
        q = c.question
        if variant == "redundant":
            if not st.used_redundancy:
                stats["no_redundancy"] += 1
                continue
            fam = "redundant_" + fam
            notes.append("redundant description")
        elif variant == "synonym":
            if not st.used_wide:
                stats["no_wide"] += 1
                continue
            fam = "synonym_" + fam
            if "buses" in q and rng.random() < 0.5:
                q = q.replace("buses", "busses")
                notes.append("spelling 'busses'")
        elif variant == "plural_quirk":
            if "buses" not in q:
                stats["no_buses"] += 1
                continue
            q = q.replace("buses", "buss")
            fam = "plural_quirk_" + fam
            notes = [n for n in notes] + ["public plural quirk 'buss'"]
        elif variant == "typo":
            t = make_typo(rng, q)
            if t is None:
                stats["no_typo"] += 1
                continue
            q, note = t
            fam = "typo_" + fam
            notes.append(note)
        q = " ".join(q.split()).replace(" any thing ", " anything ").replace("Is any thing ", "Is anything ")
        if (w.name, q) in seen:
            stats["dup"] += 1
            continue
        if seen_prog[(w.name, c.program)] >= 1:
            stats["dup_prog"] += 1
            continue
        res = run_program(w.ctx, c.program)
        if not res.valid:
            stats["invalid"] += 1
            if os.environ.get("MAKE_SET_DEBUG"):
                print("INVALID", gen.__name__, q, c.program, res.reason, file=sys.stderr)
            continue
        seen.add((w.name, q))
        seen_prog[(w.name, c.program)] += 1
        rec = {"question": q, "program": c.program, "family_group": group, "family": fam, "scene": w.name,
               "answer": plain(res.answer)}
        if notes:
            rec["phrasing_notes"] = "; ".join(dict.fromkeys(notes))
        pool.append(rec)
    return pool, stats


def balanced_pick(rng, pool, n, taken):
    """Pick up to n records: round robin over the families of the pool and, within a family, over its answers
    (the answer picked least so far first), so yes/no and counts are balanced per family."""
    fams: dict = defaultdict(lambda: defaultdict(list))
    for r in pool:
        if (r["scene"], r["question"]) not in taken:
            fams[r["family"]][json.dumps(r["answer"])].append(r)
    for buckets in fams.values():
        for v in buckets.values():
            rng.shuffle(v)
    order = sorted(fams)
    rng.shuffle(order)
    picked: Counter = Counter()
    out = []
    progress = True
    while len(out) < n and progress:
        progress = False
        for f in order:
            if len(out) >= n:
                break
            buckets = fams[f]
            avail = [a for a in sorted(buckets) if buckets[a]]
            if not avail:
                continue
            m = min(picked[(f, a)] for a in avail)
            a = rng.choice([a for a in avail if picked[(f, a)] == m])
            r = buckets[a].pop()
            progress = True
            if (r["scene"], r["question"]) in taken:
                continue
            taken.add((r["scene"], r["question"]))
            picked[(f, a)] += 1
            out.append(r)
    return out


def build(seed: int, per_group: int, verbose: bool = True):
    rng = random.Random(seed)
    worlds = [World(p) for p in sorted((HERE / "scenes").glob("scene_*.json"))]
    plan = {g: [(gen, wt, None) for gen, wt in BASE[g]] for g in BASE}
    plan["redundant"] = [(gen, wt, "redundant") for gen, wt in REDUNDANT]
    plan["synonyms_quirks_typos"] = ([(gen, wt * 0.45, "synonym") for gen, wt in SYNONYM]
                                     + [(gen, wt * 0.35, "plural_quirk") for gen, wt in PLURAL_QUIRK]
                                     + [(gen, wt * 0.4, "typo") for gen, wt in TYPO])
    records = []
    taken: set = set()
    for group in GROUPS:
        entries = plan[group]
        total_w = sum(wt for _, wt, _ in entries)
        quotas = [max(1, round(per_group * wt / total_w)) for _, wt, _ in entries]
        while sum(quotas) > per_group:
            quotas[quotas.index(max(quotas))] -= 1
        while sum(quotas) < per_group:
            quotas[quotas.index(min(quotas))] += 1
        chosen = []
        leftovers = []
        for (gen, _, variant), quota in zip(entries, quotas, strict=True):
            pool, stats = draw_pool(rng, worlds, gen, group, variant, n_target=quota * 12, max_tries=quota * 600)
            got = balanced_pick(rng, pool, quota, taken)
            chosen += got
            leftovers += pool
            if verbose:
                print(f"  {group:24s} {gen.__name__:32s} {variant or '':12s} quota {quota:3d} pool {len(pool):4d}"
                      f" picked {len(got):3d} {dict(stats)}", file=sys.stderr)
        if len(chosen) < per_group:  # fill from the other families' pools
            chosen += balanced_pick(rng, leftovers, per_group - len(chosen), taken)
        records += chosen
    for k, r in enumerate(records):
        r_id = f"v2g{k:05d}"
        records[k] = {"id": r_id, **r}
    return records


def hand(path: Path) -> None:
    """Fill (or check) the answers of the hand-written records with the reference executor."""
    worlds: dict[str, SceneContext] = {}
    out = []
    bad = 0
    for n, line in enumerate(path.read_text().splitlines(), 1):
        if not line.strip():
            continue
        r = json.loads(line)
        ctx = worlds.get(r["scene"])
        if ctx is None:
            ctx = worlds[r["scene"]] = SceneContext(load_scene(HERE / r["scene"]))
        res = run_program(ctx, r["program"])
        if not res.valid:
            bad += 1
            print(f"{path.name}:{n} INVALID {r['id']}: {r['question']} | {r['program']} | {res.reason}", file=sys.stderr)
            continue
        r["answer"] = plain(res.answer)
        keys = ["id", "question", "program", "family_group", "family", "scene", "answer", "phrasing_notes"]
        out.append({k: r[k] for k in keys if k in r})
    if bad:
        raise SystemExit(f"{bad} invalid hand-written programs; nothing written")
    path.write_text("".join(json.dumps(r) + "\n" for r in out))
    print(f"{path.name}: {len(out)} answers filled", file=sys.stderr)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=2024)
    ap.add_argument("--per-group", type=int, default=114)
    ap.add_argument("--out", type=Path, default=HERE / "generated.jsonl")
    ap.add_argument("--hand", action="store_true", help="fill the answers of hand_written.jsonl instead")
    ap.add_argument("--quiet", action="store_true")
    args = ap.parse_args(argv)
    if args.hand:
        hand(HERE / "hand_written.jsonl")
        return
    records = build(args.seed, args.per_group, verbose=not args.quiet)
    args.out.write_text("".join(json.dumps(r) + "\n" for r in records))
    groups = Counter(r["family_group"] for r in records)
    print(f"{args.out.name}: {len(records)} questions, {len({r['family'] for r in records})} families; "
          + ", ".join(f"{g} {groups[g]}" for g in GROUPS), file=sys.stderr)


if __name__ == "__main__":
    main()

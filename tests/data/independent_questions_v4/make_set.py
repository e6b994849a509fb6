"""Build the fourth independent question set (evaluation only; see README.md).

    python tests/data/independent_questions_v4/make_set.py            # writes generated.jsonl (seed 7400)
    python tests/data/independent_questions_v4/make_set.py --hand     # fills / checks hand_written.jsonl answers
    python tests/data/independent_questions_v4/make_set.py --show 7403 7410   # prints what a scene holds

Written from scratch, with its own phrase lists. Every program is run with the reference executor on its scene and
kept only if valid; answers are the executor's raw answers.
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
SEEDS = range(7400, 7464)
PER_GROUP = 110
GROUPS = ("core_query", "core_count", "core_exist", "core_compare_attribute", "core_compare_integer",
          "core_same_relate", "core_spatial", "parts", "pose", "occlusion", "part_occlusion", "redundant",
          "synonyms_quirks_typos")
SLOTS = ("size", "color", "material", "shape")


def plain(value):
    if isinstance(value, (frozenset, set)):
        return sorted(value)
    if isinstance(value, tuple):
        return list(value)
    return value


# ----------------------------------------------------------------------------------------------------------------
# scenes


class S:
    """One scene with the facts the generators read."""

    def __init__(self, seed: int):
        self.seed = seed
        self.rel = f"scenes/scene_{seed}.json"
        self.scene = load_scene(HERE / self.rel)
        self.ctx = SceneContext(self.scene)
        self.objs = self.scene.objects
        self.n = len(self.objs)
        self.all = frozenset(range(self.n))

    def val(self, i: int, slot: str) -> str:
        o = self.objs[i]
        return {"size": o.size, "color": o.color, "material": o.material, "shape": o.subtype,
                "category": o.category}[slot]

    def match(self, i: int, desc: dict) -> bool:
        o = self.objs[i]
        for k, v in desc.items():
            if k == "shape":
                if not ontology.shape_matches(o.subtype, v):
                    return False
            elif k == "pose":
                if o.pose != v:
                    return False
            elif self.val(i, k) != v:
                return False
        return True

    def sel(self, dom, desc: dict) -> frozenset:
        return frozenset(i for i in dom if self.match(i, desc))

    def rel_of(self, i: int, r: str) -> frozenset:
        return self.ctx.related(i, r)

    def run(self, program: str):
        typed = check_program(parse_program(program))
        res = execute(self.ctx, typed)
        return (res.valid, plain(res.answer) if res.valid else res.reason)


_SCENES: dict[int, S] = {}


def scene(seed: int) -> S:
    if seed not in _SCENES:
        _SCENES[seed] = S(seed)
    return _SCENES[seed]


# ----------------------------------------------------------------------------------------------------------------
# descriptions (minimal, or with extra true attributes)


def _options(s: S, t: int, banned: set):
    """Slot dicts (true for t) in order of size; shape may be the subtype or the category."""
    free = [k for k in SLOTS if k not in banned]
    for n in range(len(free) + 1):
        found = []
        for combo in itertools.combinations(free, n):
            base = {k: s.val(t, k) for k in combo if k != "shape"}
            if "shape" in combo:
                found.append(dict(base, shape=s.objs[t].category))
                found.append(dict(base, shape=s.objs[t].subtype))
            else:
                found.append(base)
        yield n, found


def minimal(rng, s: S, t: int, dom, banned=(), nonempty=False, redundant=False):
    """Fewest-slot description of t that singles it out in dom; None if impossible."""
    banned = set(banned)
    dom = frozenset(dom)
    for n, found in _options(s, t, banned):
        if nonempty and n == 0:
            continue
        good = [d for d in found if s.sel(dom, d) == {t}]
        if good:
            d = dict(rng.choice(good))
            if redundant:
                d = add_redundant(rng, s, t, d, banned)
            return d
    return None


def add_redundant(rng, s: S, t: int, d: dict, banned: set):
    extra = [k for k in SLOTS if k not in banned and k not in d]
    if not extra:
        if d.get("shape") == s.objs[t].category and s.objs[t].category != s.objs[t].subtype:
            return dict(d, shape=s.objs[t].subtype)
        return None
    k = rng.sample(extra, min(len(extra), rng.choice((1, 1, 2))))
    out = dict(d)
    for key in k:
        out[key] = s.objs[t].subtype if key == "shape" and rng.random() < 0.6 else (
            s.objs[t].category if key == "shape" else s.val(t, key))
    return out


def set_desc(rng, s: S, dom, max_slots=2, min_slots=0):
    """A true description of some object(s) in dom (for counting / exist), from a random object's attributes."""
    dom = list(dom)
    if not dom:
        return {}
    t = rng.choice(dom)
    n = rng.randint(min_slots, max_slots)
    keys = rng.sample(SLOTS, n)
    d = {}
    for k in keys:
        d[k] = (s.objs[t].subtype if rng.random() < 0.4 else s.objs[t].category) if k == "shape" else s.val(t, k)
    return d


def any_desc(rng, s: S, n_slots=1):
    """A description that may match nothing (values drawn from the vocabulary)."""
    d = {}
    for k in rng.sample(SLOTS, n_slots):
        if k == "shape":
            d[k] = rng.choice(ontology.CATEGORIES + ontology.SUBTYPES)
        else:
            d[k] = rng.choice({"size": ontology.SIZES, "color": ontology.COLORS, "material": ontology.MATERIALS}[k])
    return d


def filters(d: dict) -> str:
    out = []
    if "pose" in d:
        out.append(f"filter_pose[{d['pose']}]")
    for k in SLOTS:
        if k in d:
            out.append(f"filter_{k}[{d[k]}]")
    return "".join(" | " + f for f in out)


def obj(d: dict, start="scene()") -> str:
    return f"{start}{filters(d)} | unique"


def pfilters(pd: dict) -> str:
    out = []
    for k in ("color", "material"):
        if k in pd:
            out.append(f"partfilter_{k}[{pd[k]}]")
    if "name" in pd:
        out.append(f"partfilter_partname[{pd['name']}]")
    return "".join(" | " + f for f in out)


# ----------------------------------------------------------------------------------------------------------------
# words (this set's own lists)

SIZE_W = {"large": ["large", "big"], "small": ["small", "little"]}
SIZE_WIDE = {"large": ["hefty", "oversized", "jumbo", "sizeable", "bulky", "full-size"],
             "small": ["mini", "petite", "compact", "wee", "undersized", "pint-sized"]}
COLOR_W = {c: [c] for c in ontology.COLORS}
COLOR_WIDE = {"gray": ["charcoal", "ashen", "slate", "dove-grey"], "red": ["crimson", "scarlet", "ruby", "cherry-red"],
              "blue": ["navy", "cobalt", "azure", "royal-blue"], "green": ["emerald", "lime", "grass-green"],
              "brown": ["chocolate", "coffee-coloured", "chestnut", "tan"],
              "purple": ["lilac", "plum", "mauve", "lavender"], "cyan": ["aquamarine", "blue-green", "cyan-coloured"],
              "yellow": ["golden", "lemon", "mustard", "canary-yellow"]}
MAT_W = {"metal": ["metal", "metallic"], "rubber": ["rubber"]}
MAT_POST = {"metal": ["made of metal", "that is metal"], "rubber": ["made of rubber", "that is rubber"]}
MAT_WIDE = {"metal": ["glossy", "gleaming", "metal-made", "iron", "tin"],
            "rubber": ["rubberised", "non-shiny", "dull-finish", "flat-finish", "rubber-made"]}
THING_W = ["thing", "object"]
THING_WIDE = ["toy", "model", "piece", "figure", "entity"]
CAT_W = {"car": ["car"], "bus": ["bus"], "motorbike": ["motorbike"], "aeroplane": ["aeroplane", "airplane"],
         "bicycle": ["bicycle", "bike"]}
CAT_WIDE = {"car": ["motorcar", "motor car", "passenger car"], "bus": ["omnibus", "transit bus", "shuttle bus"],
            "motorbike": ["motorcycle", "moto", "motor-bike"], "aeroplane": ["flying machine", "air-plane"],
            "bicycle": ["pedal bike", "pedal cycle", "two-wheeler"]}
SUB_W = {s: [ontology.SUBTYPE_WORDS[s]] for s in ontology.SUBTYPES}
SUB_W.update({"suv": ["SUV", "suv"], "dirtbike": ["dirtbike", "dirt bike"], "double": ["double bus"]})
SUB_WIDE = {"suv": ["sport-utility", "crossover"], "wagon": ["shooting brake", "family wagon", "estate wagon"],
            "minivan": ["MPV", "people mover", "mini-van"], "sedan": ["four-door sedan", "sedan car"],
            "truck": ["pick-up truck", "ute"], "articulated": ["accordion bus", "jointed bus", "two-section bus"],
            "regular": ["standard bus", "ordinary bus", "normal bus"],
            "double": ["double-deck bus", "two-storey bus", "decker bus"],
            "school": ["student bus", "school coach", "pupil bus"],
            "chopper": ["custom chopper", "chopper motorcycle"],
            "dirtbike": ["motocross bike", "off-road motorbike", "enduro bike"],
            "scooter": ["motor scooter", "vespa"], "cruiser": ["cruiser motorcycle", "cruising motorbike"],
            "jet": ["jet airplane", "jet-plane"], "fighter": ["combat jet", "military jet", "warbird"],
            "biplane": ["two-winged plane", "double-winged plane"],
            "airliner": ["passenger plane", "commercial plane", "airbus"],
            "road": ["road bicycle", "racer bike"], "utility": ["utility bicycle", "town bike", "commuter bike"],
            "mountain": ["mountain bicycle", "all-terrain bike", "ATB"],
            "tandem": ["tandem bicycle", "bicycle built for two", "two-seater bike"]}
PART_WIDE = {"wheel": ["tire", "rim"], "hood": ["engine lid"], "trunk": ["rear hatch", "luggage compartment"],
             "mirror": ["side mirror", "rear-view mirror"],
             "license_plate": ["licence plate", "registration plate", "reg plate"],
             "head_light": ["front lamp", "front light"], "headlight": ["front lamp", "front light"],
             "tail_light": ["brake light", "rear lamp"], "taillight": ["brake light", "rear lamp"],
             "bumper": ["bumper bar"], "roof": ["rooftop"], "windscreen": ["front screen"],
             "fender": ["mud flap", "splash guard"], "handle": ["grip", "hand grip"], "seat": ["rider seat"],
             "saddle": ["bike seat"], "pedal": ["foot pedal"], "drive_chain": ["bike chain", "chain drive"],
             "crank_arm": ["pedal arm", "crankarm"], "wing": ["aerofoil", "airfoil"],
             "fin": ["vertical stabiliser", "tail fin"], "tailplane": ["horizontal stabiliser", "elevator"],
             "propeller": ["airscrew", "rotor"], "engine": ["power unit"], "gas_tank": ["fuel tank", "petrol tank"],
             "exhaust": ["exhaust pipe", "tailpipe", "muffler"], "footrest": ["foot peg", "footpeg"],
             "side_stand": ["prop stand", "side-stand"], "carrier": ["luggage rack", "rack"],
             "brake_system": ["brakes", "brake set"], "cover": ["fairing"], "panel": ["side panel"],
             "rearlight": ["rear reflector", "back light"], "door": ["entry door"], "fork": ["front forks"]}
PART_BASE_FIX = {"head light": "headlight", "tail light": "taillight", "drive chain": "chain", "gas tank": "fuel tank",
                 "side stand": "side stand", "crank arm": "crank arm", "brake system": "brake system",
                 "license plate": "license plate"}
REL_W = {"left": ["left of", "to the left of", "on the left side of", "on the left of"],
         "right": ["right of", "to the right of", "on the right side of", "on the right of"],
         "behind": ["behind"], "front": ["in front of"]}
REL_WIDE = {"left": ["further left than", "more to the left than", "off to the left of"],
            "right": ["further right than", "more to the right than", "off to the right of"],
            "behind": ["to the rear of", "at the rear of"], "front": ["before", "out in front of", "to the fore of"]}
POSE_W = {"front_pose": ["facing front", "facing toward us", "facing the viewer", "pointing at the camera"],
          "back_pose": ["facing away", "facing away from us", "pointing away from the viewer", "facing backward"],
          "left_pose": ["facing left", "pointing left", "heading left", "oriented to the left"],
          "right_pose": ["facing right", "pointing right", "heading right", "oriented to the right"]}
ATTR_NOUN = {"color": ["colour", "color"], "material": ["material"], "size": ["size"], "shape": ["shape", "type"]}
ATTR_WIDE = {"color": ["tint", "paint colour", "paint"], "material": ["substance", "make-up", "fabric"],
             "size": ["dimensions", "bigness", "scale"], "shape": ["model", "sort", "variety"]}
OPENERS = ["Hey,", "So,", "Question:", "In this image,", "In the scene,", "Hmm,", "Right,", "Could you tell me:",
           "I'd like to know:", "Help me out:", "One more:", "Alright,", "Look at the scene:", "From the image:",
           "Pardon,", "Sorry,", "Next one:", "Please answer:", "Curious:", "Let me ask:"]

# single typos, each checked by hand to be a non-word at edit distance 1 that keeps the first letter
TYPOS = {
    'sedan': ['sedam', 'sdan', 'seddan'],
    'truck': ['truk', 'truckk', 'trunck'],
    'minivan': ['minvan', 'minivam', 'minivann'],
    'wagon': ['wagin', 'wagn', 'wahon'],
    'scooter': ['scoter', 'scooder', 'scoooter'],
    'chopper': ['choper', 'chopprr', 'chlpper'],
    'cruiser': ['cruser', 'cruisr', 'cruisser'],
    'dirtbike': ['dirtbik', 'dirbike', 'dirtbyke'],
    'airliner': ['airliber', 'airlner', 'airlinner'],
    'biplane': ['biplan', 'bilane', 'biiplane'],
    'fighter': ['fighrer', 'fihter', 'fightter'],
    'jet': ['jjet', 'jwt', 'jrt'],
    'bicycle': ['bicyle', 'bicicle', 'biycle'],
    'bike': ['bke', 'biike', 'bikr'],
    'motorbike': ['motorbke', 'motorbik', 'mortorbike'],
    'aeroplane': ['aeroplan', 'aeroplanne', 'aeroplabe'],
    'airplane': ['airplne', 'airpane', 'airplame'],
    'car': ['caar', 'cqr'],
    'bus': ['buus', 'bua'],
    'buses': ['busess', 'bues', 'busrs'],
    'cars': ['carss', 'czrs'],
    'things': ['thngs', 'thimgs', 'thiings'],
    'thing': ['thng', 'thimg', 'thiing'],
    'object': ['objct', 'obkect', 'onject'],
    'objects': ['objcts', 'objeccts', 'onjects'],
    'color': ['colr', 'coolor', 'colot'],
    'colour': ['colur', 'coulour', 'colout'],
    'material': ['materal', 'matrial', 'materiall'],
    'purple': ['puple', 'purrple', 'pureple'],
    'yellow': ['yelow', 'yelloww', 'yeklow'],
    'green': ['gren', 'greeen', 'grren'],
    'brown': ['brwn', 'browwn', 'brpwn'],
    'cyan': ['cyann', 'cyam', 'cian'],
    'gray': ['grqy', 'grayy', 'grsy'],
    'red': ['rred', 'rdd', 'rwd'],
    'blue': ['blie', 'bluue', 'blye'],
    'metal': ['metl', 'mettal', 'metak'],
    'metallic': ['metalic', 'metallick', 'metallc'],
    'rubber': ['ruber', 'rubbr', 'rubbet'],
    'large': ['lage', 'larrge', 'latge'],
    'small': ['smal', 'smalll', 'snall'],
    'wheel': ['wheell', 'wjeel', 'wheeel'],
    'occluded': ['ocluded', 'occludded', 'occlued'],
    'hidden': ['hiden', 'hiddden', 'hidfen'],
    'behind': ['behnd', 'behimd', 'beehind'],
    'front': ['fromt', 'frontt', 'frnt'],
    'facing': ['facng', 'faccing', 'fasing'],
    'direction': ['directon', 'diretion', 'directiom'],
    'same': ['saame', 'sme', 'samee'],
    'many': ['mny', 'manny', 'mant'],
    'there': ['thre', 'theere', 'thwre'],
    'left': ['lef', 'leftt', 'lrft'],
    'right': ['rght', 'riight', 'rigjt'],
    'door': ['doorr', 'dpor'],
    'mirror': ['miror', 'mirrror', 'mirrir'],
    'roof': ['rooof', 'roog', 'rpof'],
    'hood': ['hoood', 'hoid', 'hlod'],
    'trunk': ['trnk', 'truunk', 'trumk'],
    'bumper': ['bumpr', 'bummper', 'bunper'],
    'engine': ['engne', 'enginne', 'emgine'],
    'propeller': ['propeler', 'proppeller', 'propellr'],
    'wing': ['wng', 'wiing', 'wimg'],
    'windscreen': ['windscren', 'windsceen', 'windscreem'],
    'seat': ['seatt', 'seqt', 'sewt'],
    'fork': ['forkk', 'fprk', 'forj'],
    'pedal': ['pedl', 'pedall', 'pwdal'],
    'saddle': ['sadle', 'saddlle', 'sqddle'],
    'occludes': ['ocludes', 'occlludes', 'occludez'],
    'shape': ['shpe', 'shappe', 'shaoe'],
    'size': ['sze', 'sizze', 'sixe'],
    'school': ['scool', 'schoool', 'schiol'],
    'articulated': ['articlated', 'articulatted', 'artculated'],
    'double': ['duble', 'doublle', 'dpuble'],
    'regular': ['regulr', 'reguler', 'reggular'],
    'mountain': ['montain', 'mountan', 'mounntain'],
    'tandem': ['tanden', 'tandm', 'tanddem'],
    'utility': ['utlity', 'utiliity', 'utiluty'],
    'road': ['roadd', 'rpad', 'roaf'],
}
TYPO_FUNCTION_WORDS = {"many", "there", "same", "left", "right", "front", "behind"}


def plural(word: str, quirk=False) -> str:
    if " for two" in word:
        head, _, rest = word.partition(" ")
        return plural(head) + " " + rest
    if word.endswith("bus"):
        return word + ("s" if quirk else "es")
    if word in ("SUV", "MPV", "ATB"):
        return word + "s"
    if word.endswith(("s", "x", "ch", "sh")):
        return word + "es"
    if word.endswith("y") and word[-2] not in "aeiou":
        return word[:-1] + "ies"
    return word + "s"


class Talk:
    """Word choices for one question: plain, or with wider synonyms (recorded)."""

    def __init__(self, rng: random.Random, wide=False, quirk=False):
        self.rng = rng
        self.wide = wide
        self.quirk = quirk
        self.wide_used: list[str] = []
        self.quirk_used = False

    def pick(self, base, wide=None):
        if self.wide and wide and self.rng.random() < 0.55:
            w = self.rng.choice(wide)
            self.wide_used.append(w)
            return w
        return self.rng.choice(base)

    def size(self, v):
        return self.pick(SIZE_W[v], SIZE_WIDE[v])

    def color(self, v):
        return self.pick(COLOR_W[v], COLOR_WIDE[v])

    def mat(self, v):
        return self.pick(MAT_W[v], MAT_WIDE[v])

    def attr(self, a):
        return self.pick(ATTR_NOUN[a], ATTR_WIDE[a])

    def rel(self, r):
        return self.pick(REL_W[r], REL_WIDE[r])

    def pose(self, p):
        return self.rng.choice(POSE_W[p])

    def noun(self, shape=None, pl=False):
        if shape is None:
            w = self.pick(THING_W, THING_WIDE)
        elif shape in ontology.CATEGORIES:
            w = self.pick(CAT_W[shape], CAT_WIDE[shape])
        else:
            w = self.pick(SUB_W[shape], SUB_WIDE[shape])
        if pl:
            if self.quirk and w.endswith("bus"):
                self.quirk_used = True
                return plural(w, quirk=True)
            return plural(w)
        return w

    def np(self, d: dict, art="the", pl=False, post_ok=True):
        """Noun phrase for a description (size colour material noun, pose and sometimes material postposed)."""
        adj = []
        post = []
        if "size" in d:
            adj.append(self.size(d["size"]))
        if "color" in d:
            adj.append(self.color(d["color"]))
        if "material" in d:
            if post_ok and self.rng.random() < 0.2 and not self.wide:
                m = self.rng.choice(MAT_POST[d["material"]])
                post.append(m.replace("that is", "that are") if pl else m)
            else:
                adj.append(self.mat(d["material"]))
        noun = self.noun(d.get("shape"), pl)
        if "pose" in d:
            post.insert(0, self.pose(d["pose"]))
        text = " ".join(adj + [noun] + post)
        if art == "a":
            art = "an" if text[0].lower() in "aeiou" and not text.startswith(("ute", "utility", "one")) else "a"
        return (art + " " + text) if art else text

    def part(self, raw_or_super: str, super_only=False):
        """Words for a part: its readable name (or super-part name); wide words swap the super-part word."""
        sup = ontology.super_part_name(raw_or_super)
        if super_only or raw_or_super == sup:
            words = ontology.readable_name(sup)
            lead = ""
        else:
            words = ontology.readable_name(raw_or_super)
            head = ontology.readable_name(sup)
            lead = words[: len(words) - len(head)].strip() if words.endswith(head) else ""
            if not words.endswith(head):
                lead, head = "", words
            words = head
        words = PART_BASE_FIX.get(words, words)
        if self.wide and sup in PART_WIDE and self.rng.random() < 0.6:
            w = self.rng.choice(PART_WIDE[sup])
            self.wide_used.append(w)
            words = w
        if lead:
            if self.wide and "back" in lead.split() and self.rng.random() < 0.5:
                lead = lead.replace("back", "rear")
                self.wide_used.append("rear")
            if lead == "center":
                lead = self.rng.choice(["center", "centre", "middle"])
            if lead.startswith("mid "):
                lead = lead.replace("mid ", "middle ")
            return lead + " " + words
        return words


def lower_first(q: str) -> str:
    if q[:3] in ("SUV", "MPV", "ATB") or q.startswith("I "):
        return q
    return q[0].lower() + q[1:]


def upper_first(q: str) -> str:
    return q[0].upper() + q[1:]


def voice(rng, q: str) -> str:
    """Vary the register: openers, lowercase, a missing question mark."""
    q = upper_first(q)
    r = rng.random()
    if r < 0.16:
        q = rng.choice(OPENERS) + " " + lower_first(q)
    elif r < 0.22:
        q = q.rstrip("?") + ", please?" if q.endswith("?") else q + ", please"
    if rng.random() < 0.18:
        q = q.lower()
    if q.endswith("?") and rng.random() < 0.14:
        q = q[:-1]
    return q


# ----------------------------------------------------------------------------------------------------------------
# generator helpers

QUERY_ATTRS = ("color", "material", "size", "shape")


class Skip(Exception):
    pass


def need(x):
    if x is None or x is False:
        raise Skip
    return x


def D(g, t, dom, banned=(), nonempty=False):
    """Description of t (minimal, or redundant in the redundant group)."""
    d = minimal(g.rng, g.s, t, dom, banned, nonempty, redundant=False)
    need(d is not None)
    if g.red:
        d2 = add_redundant(g.rng, g.s, t, d, set(banned))
        if d2 is not None and d2 != d:
            g.red_done = True
            return d2
    return d


class G:
    """Context of one candidate: rng, scene, talk, redundant flag."""

    def __init__(self, rng, s, talk, red=False):
        self.rng, self.s, self.T, self.red = rng, s, talk, red
        self.red_done = False
        self.notes: list[str] = []

    def ch(self, seq):
        seq = list(seq)
        if not seq:
            raise Skip
        return self.rng.choice(seq)


def qword(g, attr):
    return g.T.attr(attr)


def ask_attr(g, attr, np_text):
    """A question asking attribute `attr` of the thing `np_text`."""
    T = g.T
    a = qword(g, attr)
    frames = {
        "color": [f"What {a} is {np_text}?", f"{np_text}: what {a} is it?", f"Which {a} does {np_text} have?",
                  f"Tell me the {a} of {np_text}.", f"What's the {a} of {np_text}?", f"Name the {a} of {np_text}.",
                  f"what {a} has {np_text}", f"Can you say what {a} {np_text} is?", f"{np_text} is what {a}?",
                  f"Which {a} is {np_text} painted?"],
        "material": [f"What is {np_text} made of?", f"What {a} is {np_text}?", f"Is {np_text} metal or rubber?",
                     f"Which {a} is {np_text} made from?", f"{np_text}: metal or rubber?",
                     f"Tell me what {np_text} is made of.", f"What's the {a} of {np_text}?",
                     f"what is {np_text} made from", f"Is {np_text} rubber or metal?"],
        "size": [f"How big is {np_text}?", f"What {a} is {np_text}?", f"Is {np_text} large or small?",
                 f"Is {np_text} big or small?", f"Tell me the {a} of {np_text}.", f"{np_text}: big or little?",
                 f"What is the {a} of {np_text}?", f"Is {np_text} small or large?"],
        "shape": [f"What kind of thing is {np_text}?", f"What is {np_text}?", f"What type of vehicle is {np_text}?",
                  f"Which {a} of object is {np_text}?", f"Identify {np_text}.", f"What exactly is {np_text}?",
                  f"What {a} is {np_text}?", f"{np_text} is what kind of object?",
                  f"What sort of vehicle is {np_text}?"],
    }
    return g.ch(frames[attr])


def ask_attr_it(g, attr):
    """The question part of 'There is X; <question about it>'."""
    a = qword(g, attr)
    return g.ch({"color": [f"what {a} is it?", f"what is its {a}?", f"which {a} does it have?"],
                 "material": ["what is it made of?", f"what {a} is it?", "is it metal or rubber?"],
                 "size": ["how big is it?", "is it large or small?", f"what {a} is it?"],
                 "shape": ["what is it?", "what kind of thing is it?", f"what {a} is it?"]}[attr])


def it_frame(g, np_a, np_the, rest):
    return g.ch([f"There is {np_a}; {rest}", f"There's {np_a}. {upper_first(rest)}", f"Look at {np_the}. {upper_first(rest)}",
                 f"See {np_the}? {upper_first(rest)}", f"I can see {np_a}, {rest}", f"Consider {np_the}: {rest}"])


def q_prog(chain, attr):
    return f"{chain} | query_{attr}"


def ref(g, t, dom=None, banned=(), nonempty=False):
    """(description, noun phrase with 'the') of object t singled out in dom (default: the scene)."""
    d = D(g, t, g.s.all if dom is None else dom, banned, nonempty)
    return d, g.T.np(d)


def all_parts(s, i):
    return ontology.PARTS[s.objs[i].subtype]


def part_label(s, i, raw):
    """(program value, text name source): the super-part name when the subtype has only one such part."""
    sup = ontology.super_part_name(raw)
    same = [p for p in all_parts(s, i) if ontology.super_part_name(p) == sup]
    if len(same) == 1:
        return sup, sup
    return ontology.canonical_part_name(raw), raw


def part_text(g, name_src, raw):
    return g.T.part(name_src if name_src == ontology.super_part_name(raw) else raw)


def bad_part_color(s, i, c):
    return c == s.objs[i].color or c == "gray"


def pose_safe(s, i, margin=6.0):
    o = s.objs[i]
    if o.pose == ontology.NO_POSE:
        return False
    d = o.pose_degree % 360.0
    return min(min(abs(d - b), 360 - abs(d - b)) for b in (30, 60, 120, 150, 210, 240, 300, 330)) >= margin


def pose_rel_safe(s, i, margin=6.0):
    if not pose_safe(s, i):
        return False
    a = s.objs[i].pose_degree
    for j in s.all - {i}:
        diff = abs(a - s.objs[j].pose_degree) % 360.0
        diff = min(diff, 360 - diff)
        if min(abs(diff - 45), abs(diff - 135)) < margin:
            return False
    return True


# ----------------------------------------------------------------------------------------------------------------
# families: core

def f_zero_query(g):
    s, T = g.s, g.T
    t = g.ch(range(s.n))
    attr = g.ch(QUERY_ATTRS)
    d, np_ = ref(g, t, banned={attr})
    chain = obj(d)
    if g.rng.random() < 0.3:
        q = it_frame(g, T.np(d, "a"), np_, ask_attr_it(g, attr))
        fam = f"zero_hop_query_{attr}_pronoun"
    else:
        q = ask_attr(g, attr, np_)
        fam = f"zero_hop_query_{attr}"
    return q, q_prog(chain, attr), fam


def f_category_query(g):
    s, T = g.s, g.T
    t = g.ch(range(s.n))
    cat = s.objs[t].category
    dom = s.sel(s.all, {"shape": cat})
    d = D(g, t, dom, banned={"shape"})
    full = dict(d, shape=cat)
    cw = T.noun(cat)
    if not d:
        q = g.ch([f"What kind of {cw} is in the picture?", f"Which type of {cw} is there?",
                  f"There is one {cw}; which kind is it?"])
    else:
        adj = T.np(d, art="").rsplit(" ", 1)[0]
        q = g.ch([f"What kind of {cw} is the {adj} one?", f"Which type of {cw} is the {adj} one?",
                  f"The {adj} {cw} - which kind is it?", f"What sort of {cw} is the {adj} one?"])
    return q, q_prog(obj(full), "shape"), "zero_hop_query_subtype_of_category"


def count_frames(g, npl):
    return g.ch([f"How many {npl} are there?", f"How many {npl} are in the picture?", f"Count the {npl}.",
                 f"What number of {npl} can you see?", f"Number of {npl}?", f"how many {npl} is there",
                 f"Tell me how many {npl} there are.", f"How many {npl} do you see?", f"{npl}: how many?",
                 f"What's the total number of {npl}?", f"How many {npl} can be seen?"])


def f_count_attr(g):
    s, T = g.s, g.T
    n = g.ch((1, 1, 2, 2, 3))
    d = set_desc(g.rng, s, s.all, n, n) if g.rng.random() < 0.8 else any_desc(g.rng, s, min(n, 2))
    need(d)
    if g.T.quirk and "shape" not in d:
        raise Skip
    if g.red:
        members = s.sel(s.all, d)
        need(members)
        extra = [k for k in SLOTS if k not in d and len({s.val(i, k) for i in members}) == 1]
        need(extra)
        k = g.ch(extra)
        d = dict(d, **{k: s.val(next(iter(members)), k)})
        g.red_done = True
    npl = T.np(d, art="", pl=True)
    return count_frames(g, npl), f"count(scene(){filters(d)})", f"count_{len(d)}_attr"


def f_count_all(g):
    T = g.T
    w = T.noun(None, pl=True)
    q = g.ch([f"How many {w} are there in total?", f"How many {w} are there?", f"Count all the {w}.",
              f"What is the total number of {w}?", f"How many {w} are in the scene altogether?",
              "How many vehicles are there?", f"how many {w} do you see in all"])
    return q, "count(scene())", "count_all"


def union_pair(g):
    s = g.s
    a = set_desc(g.rng, s, s.all, 1, 1) if g.rng.random() < 0.8 else any_desc(g.rng, s, 1)
    b = set_desc(g.rng, s, s.all, 1, 1) if g.rng.random() < 0.7 else any_desc(g.rng, s, 1)
    need(a and b and a != b and list(a) != list(b) or (a and b and a != b))
    return a, b


def f_count_union(g):
    T = g.T
    a, b = union_pair(g)
    pa, pb = T.np(a, "", pl=True), T.np(b, "", pl=True)
    q = g.ch([f"How many {pa} or {pb} are there?", f"How many are {pa} or {pb}?",
              f"Count the {pa} and the {pb} together.", f"What is the number of {pa} plus {pb}?",
              f"How many {pa} or {pb} can you see?", f"Total number of {pa} or {pb}?"])
    return q, f"count(union(scene(){filters(a)}, scene(){filters(b)}))", "count_union"


def exist_frames(g, d, pl_ok=True):
    T = g.T
    npa, npl = T.np(d, "a"), T.np(d, "", pl=True)
    fr = [f"Is there {npa}?", f"Do you see {npa}?", f"Is there at least one {T.np(d, '')}?",
          f"Can you find {npa} in the picture?", f"Is {npa} present?", f"Is there {npa} anywhere?"]
    if pl_ok:
        fr += [f"Are there any {npl}?", f"Does the scene contain any {npl}?", f"Any {npl}?",
               f"Are any {npl} visible?", f"are there {npl} in the image"]
    return g.ch(fr)


def f_exist_attr(g):
    s = g.s
    n = g.ch((1, 2, 2, 3))
    d = set_desc(g.rng, s, s.all, n, n) if g.rng.random() < 0.5 else any_desc(g.rng, s, min(n, 3))
    need(d)
    if g.red:
        members = s.sel(s.all, d)
        need(members)
        extra = [k for k in SLOTS if k not in d and len({s.val(i, k) for i in members}) == 1]
        need(extra)
        k = g.ch(extra)
        d = dict(d, **{k: s.val(next(iter(members)), k)})
        g.red_done = True
    return exist_frames(g, d), f"exist(scene(){filters(d)})", f"exist_{len(d)}_attr"


def f_exist_union(g):
    T = g.T
    a, b = union_pair(g)
    q = g.ch([f"Is there {T.np(a, 'a')} or {T.np(b, 'a')}?", f"Are there any {T.np(a, '', pl=True)} or "
              f"{T.np(b, '', pl=True)}?", f"Can you see either {T.np(a, 'a')} or {T.np(b, 'a')}?",
              f"Does the picture have {T.np(a, 'a')} or {T.np(b, 'a')} in it?"])
    return q, f"exist(union(scene(){filters(a)}, scene(){filters(b)}))", "exist_union"


def cmp_attr_text(g, attr, x, y):
    a = qword(g, attr)
    return g.ch({
        "color": [f"Is {x} the same {a} as {y}?", f"Do {x} and {y} have the same {a}?",
                  f"Are {x} and {y} the same {a}?", f"Does {x} match {y} in {a}?", f"{x} and {y}: same {a}?",
                  f"Is {x} coloured like {y}?", f"Do {x} and {y} share a {a}?",
                  f"Is the {a} of {x} equal to the {a} of {y}?"],
        "material": [f"Are {x} and {y} made of the same {a}?", f"Is {x} made of the same stuff as {y}?",
                     f"Do {x} and {y} share a {a}?", f"Same {a} for {x} and {y}?",
                     f"Is {x} the same {a} as {y}?", f"Are {x} and {y} made of the same thing?"],
        "size": [f"Is {x} the same {a} as {y}?", f"Are {x} and {y} equally big?", f"Is {x} as big as {y}?",
                 f"Do {x} and {y} have the same {a}?", f"{x} and {y}: same {a}?", f"Are {x} and {y} the same {a}?"],
        "shape": [f"Are {x} and {y} the same kind of thing?", f"Is {x} the same type as {y}?",
                  f"Do {x} and {y} have the same {a}?", f"Are {x} and {y} the same model?",
                  f"Is {x} the same sort of vehicle as {y}?"],
    }[attr])


def f_compare_attr(g):
    s = g.s
    attr = g.ch(QUERY_ATTRS)
    x = g.ch(range(s.n))
    others = [j for j in s.all - {x}]
    need(others)
    want = g.rng.random() < 0.5
    pool = [j for j in others if (s.val(j, attr) == s.val(x, attr)) == want] or others
    y = g.ch(pool)
    dx, nx = ref(g, x, banned={attr})
    dy, ny = ref(g, y, banned={attr})
    q = cmp_attr_text(g, attr, nx, ny)
    return q, f"equal_{attr}({q_prog(obj(dx), attr)}, {q_prog(obj(dy), attr)})", f"compare_{attr}"


def f_compare_attr_related(g):
    s, T = g.s, g.T
    attr = g.ch(QUERY_ATTRS)
    x = g.ch(range(s.n))
    r = g.ch(ontology.RELATIONS)
    dx, nx = ref(g, x, banned={attr})
    rs = s.rel_of(x, r)
    need(rs)
    y = g.ch(sorted(rs))
    dy = D(g, y, rs, banned={attr})
    ny = T.np(dy) + " " + T.rel(r) + " " + nx
    z = g.ch(sorted(s.all - {y}))
    dz, nz = ref(g, z, banned={attr})
    q = cmp_attr_text(g, attr, ny, nz) if g.rng.random() < 0.5 else cmp_attr_text(g, attr, nz, ny)
    py = q_prog(f"{obj(dx)} | relate[{r}]{filters(dy)} | unique", attr)
    pz = q_prog(obj(dz), attr)
    prog = f"equal_{attr}({py}, {pz})" if q.find(ny) < q.find(nz) else f"equal_{attr}({pz}, {py})"
    return q, prog, f"compare_{attr}_related"


def count_pair(g):
    s = g.s
    a = set_desc(g.rng, s, s.all, 2, 1)
    if g.T.quirk and g.rng.random() < 0.7:
        buses = [i for i in s.all if s.objs[i].category == "bus"]
        need(buses)
        a = {"shape": "bus"} if g.rng.random() < 0.6 else {"color": s.objs[g.ch(buses)].color, "shape": "bus"}
    b = set_desc(g.rng, s, s.all, 2, 1)
    need(a and b and a != b)
    return a, b


def f_compare_counts(g):
    s, T = g.s, g.T
    a, b = count_pair(g)
    if g.red:
        for d in (a, b):
            members = s.sel(s.all, d)
            extra = [k for k in SLOTS if k not in d and members and len({s.val(i, k) for i in members}) == 1]
            if extra:
                k = g.ch(extra)
                d[k] = s.val(next(iter(members)), k)
                g.red_done = True
    pa, pb = T.np(a, "", pl=True), T.np(b, "", pl=True)
    kind = g.ch(("gt", "lt", "eq"))
    ca, cb = f"count(scene(){filters(a)})", f"count(scene(){filters(b)})"
    if kind == "gt":
        q, prog = g.ch([(f"Are there more {pa} than {pb}?", 0), (f"Do the {pa} outnumber the {pb}?", 0),
                        (f"Is the number of {pa} greater than the number of {pb}?", 0),
                        (f"More {pa} than {pb}?", 0), (f"Are {pa} more numerous than {pb}?", 0)]), None
        prog = f"greater_than({ca}, {cb})"
    elif kind == "lt":
        q = g.ch([f"Are there fewer {pa} than {pb}?", f"Are there less {pa} than {pb}?",
                  f"Is the number of {pa} smaller than that of {pb}?", f"Fewer {pa} than {pb}?",
                  f"Are the {pa} outnumbered by the {pb}?"])
        prog = f"less_than({ca}, {cb})"
    else:
        q = g.ch([f"Are there as many {pa} as {pb}?", f"Is the number of {pa} the same as the number of {pb}?",
                  f"Are there equally many {pa} and {pb}?", f"Same number of {pa} and {pb}?",
                  f"Do the {pa} and the {pb} come in equal numbers?", f"Is there an equal count of {pa} and {pb}?"])
        prog = f"equal_integer({ca}, {cb})"
    if isinstance(q, tuple):
        q = q[0]
    return q, prog, f"compare_count_{kind}"


REL_PAIRS = (("left", "right"), ("right", "left"), ("behind", "front"), ("front", "behind"))


def f_compare_counts_around(g):
    s, T = g.s, g.T
    x = g.ch(range(s.n))
    dx, nx = ref(g, x)
    r1, r2 = g.ch(REL_PAIRS)
    f = set_desc(g.rng, s, s.all - {x}, 1, 0)
    npl = T.np(f, "", pl=True)
    it2 = {"left": "to its left", "right": "to its right", "behind": "behind it", "front": "in front of it"}
    kind = g.ch(("gt", "lt", "eq"))
    w1 = T.rel(r1)
    if kind == "gt":
        q = g.ch([f"Are there more {npl} {w1} {nx} than {it2[r2]}?",
                  f"Are more {npl} {w1} {nx} than {it2[r2]}?"])
        op = "greater_than"
    elif kind == "lt":
        q = g.ch([f"Are there fewer {npl} {w1} {nx} than {it2[r2]}?",
                  f"Are there less {npl} {w1} {nx} than {it2[r2]}?"])
        op = "less_than"
    else:
        q = g.ch([f"Are there as many {npl} {w1} {nx} as {it2[r2]}?",
                  f"Is the number of {npl} {w1} {nx} the same as the number {it2[r2]}?"])
        op = "equal_integer"
    c1 = f"count({obj(dx)} | relate[{r1}]{filters(f)})"
    c2 = f"count({obj(dx)} | relate[{r2}]{filters(f)})"
    return q, f"{op}({c1}, {c2})", f"compare_count_around_{kind}"


SAME_TXT = {"color": ("colour", "color"), "material": ("material",), "size": ("size",), "shape": ("shape", "type")}


def same_phrase(g, attr, nx):
    w = g.ch(SAME_TXT[attr])
    if g.T.wide and g.rng.random() < 0.5:
        w = g.T.attr(attr)
    return g.ch([f"the same {w} as {nx}", f"of the same {w} as {nx}", f"with the same {w} as {nx}",
                 f"sharing the {w} of {nx}", f"matching {nx} in {w}"])


def f_same_count(g):
    s, T = g.s, g.T
    attr = g.ch(QUERY_ATTRS)
    x = g.ch(range(s.n))
    dx, nx = ref(g, x, banned={attr})
    same = s.sel(s.all - {x}, {attr: s.val(x, attr)} if attr != "shape" else {})
    if attr == "shape":
        same = frozenset(j for j in s.all - {x} if s.objs[j].subtype == s.objs[x].subtype)
    f = set_desc(g.rng, s, same, 1, 0) if same and g.rng.random() < 0.6 else {}
    f.pop(attr, None)
    if attr == "shape":
        f.pop("shape", None)
    npl = T.np(f, "", pl=True)
    sp = same_phrase(g, attr, nx)
    q = g.ch([f"How many other {npl} are {sp}?", f"How many other {npl} are there {sp}?",
              f"Count the other {npl} {sp}.", f"What number of other {npl} are {sp}?",
              f"Apart from {nx}, how many {npl} are there with the same {g.ch(SAME_TXT[attr])}?",
              f"Besides {nx}, how many {npl} have its {g.ch(SAME_TXT[attr])}?"])
    return q, f"count({obj(dx)} | same_{attr}{filters(f)})", f"same_{attr}_count"


def f_same_exist(g):
    s, T = g.s, g.T
    attr = g.ch(QUERY_ATTRS)
    x = g.ch(range(s.n))
    dx, nx = ref(g, x, banned={attr})
    f = any_desc(g.rng, s, 1) if g.rng.random() < 0.5 else {}
    f.pop(attr, None)
    sp = same_phrase(g, attr, nx)
    if f:
        q = g.ch([f"Is there another {T.np(f, '')} {sp}?", f"Are there other {T.np(f, '', pl=True)} {sp}?",
                  f"Is any other {T.np(f, '')} {sp}?"])
    else:
        q = g.ch([f"Is there anything else {sp}?", f"Is anything else {sp}?", f"Is there any other thing {sp}?",
                  f"Does anything else have the same {g.ch(SAME_TXT[attr])} as {nx}?",
                  f"Is there something else {sp}?"])
    return q, f"exist({obj(dx)} | same_{attr}{filters(f)})", f"same_{attr}_exist"


def f_same_query(g):
    s, T = g.s, g.T
    attr = g.ch(QUERY_ATTRS)
    qa = g.ch([a for a in QUERY_ATTRS if a != attr])
    x = g.ch(range(s.n))
    dx, nx = ref(g, x, banned={attr})
    if attr == "shape":
        same = frozenset(j for j in s.all - {x} if s.objs[j].subtype == s.objs[x].subtype)
    else:
        same = frozenset(j for j in s.all - {x} if s.val(j, attr) == s.val(x, attr))
    need(same)
    y = g.ch(sorted(same))
    dy = D(g, y, same, banned={attr, qa})
    sp = same_phrase(g, attr, nx)
    ny = T.np(dy, "the") + " " + sp if dy else g.ch(["the other thing", "the other object", "the thing"]) + " " + sp
    if g.rng.random() < 0.5:
        q = ask_attr(g, qa, ny)
    else:
        q = g.ch([f"There is another {T.np(dy, '')} {sp}; {ask_attr_it(g, qa)}",
                  f"Something else is {sp}: {ask_attr_it(g, qa)}"]) if not dy else \
            f"There is another {T.np(dy, '')} {sp}; {ask_attr_it(g, qa)}"
    return q, q_prog(f"{obj(dx)} | same_{attr}{filters(dy)} | unique", qa), f"same_{attr}_query_{qa}"


# ----------------------------------------------------------------------------------------------------------------
# families: spatial

def thing_np(g, d, art="the"):
    return g.T.np(d, art)


def f_one_hop_query(g):
    s, T = g.s, g.T
    x = g.ch(range(s.n))
    r = g.ch(ontology.RELATIONS)
    rs = s.rel_of(x, r)
    need(rs)
    y = g.ch(sorted(rs))
    qa = g.ch(QUERY_ATTRS)
    dx, nx = ref(g, x)
    dy = D(g, y, rs, banned={qa})
    w = T.rel(r)
    ny = f"{thing_np(g, dy)} {w} {nx}" if g.rng.random() < 0.6 else f"{thing_np(g, dy)} that is {w} {nx}"
    if g.rng.random() < 0.25:
        q = f"There is {thing_np(g, dy, 'a')} {w} {nx}; {ask_attr_it(g, qa)}"
    else:
        q = ask_attr(g, qa, ny)
    return q, q_prog(f"{obj(dx)} | relate[{r}]{filters(dy)} | unique", qa), f"one_hop_query_{qa}"


def f_bare_what(g):
    s, T = g.s, g.T
    x = g.ch(range(s.n))
    r = g.ch(ontology.RELATIONS)
    rs = s.rel_of(x, r)
    need(len(rs) == 1)
    dx, nx = ref(g, x)
    w = T.rel(r)
    q = g.ch([f"What is {w} {nx}?", f"What's {w} {nx}?", f"What can you see {w} {nx}?",
              f"What object is {w} {nx}?", f"Which thing is {w} {nx}?"])
    return q, q_prog(f"{obj(dx)} | relate[{r}] | unique", "shape"), "one_hop_bare_what"


def rel_count_q(g, npl, where):
    return g.ch([f"How many {npl} are {where}?", f"What number of {npl} are {where}?", f"Count the {npl} {where}.",
                 f"How many {npl} can be seen {where}?", f"how many {npl} is {where}",
                 f"Tell me the number of {npl} {where}."])


def rel_exist_q(g, d, where):
    T = g.T
    if not d:
        return g.ch([f"Is there anything {where}?", f"Is anything {where}?", f"Are there any objects {where}?",
                     f"Is there something {where}?"])
    return g.ch([f"Is there {T.np(d, 'a')} {where}?", f"Are there any {T.np(d, '', pl=True)} {where}?",
                 f"Can you see {T.np(d, 'a')} {where}?", f"Is {T.np(d, 'a')} {where}?"])


def f_one_hop_count(g, exist=False):
    s, T = g.s, g.T
    x = g.ch(range(s.n))
    r = g.ch(ontology.RELATIONS)
    rs = s.rel_of(x, r)
    dx, nx = ref(g, x)
    if exist:
        f = set_desc(g.rng, s, rs, 2, 0) if rs and g.rng.random() < 0.5 else any_desc(g.rng, s, g.ch((1, 1, 2)))
    else:
        f = set_desc(g.rng, s, rs, 2, 0) if rs and g.rng.random() < 0.75 else any_desc(g.rng, s, 1)
    if g.T.quirk:
        f = {"shape": "bus"}
    where = f"{T.rel(r)} {nx}"
    if exist:
        return rel_exist_q(g, f, where), f"exist({obj(dx)} | relate[{r}]{filters(f)})", "one_hop_exist"
    npl = T.np(f, "", pl=True)
    return rel_count_q(g, npl, where), f"count({obj(dx)} | relate[{r}]{filters(f)})", "one_hop_count"


def f_one_hop_exist(g):
    return f_one_hop_count(g, exist=True)


def hop_chain(g, hops):
    """(chain program ending in an Object, its noun phrase) after `hops` relate steps from a scene referent."""
    s, T = g.s, g.T
    x = g.ch(range(s.n))
    dx, nx = ref(g, x)
    prog, text, cur = obj(dx), nx, x
    for _ in range(hops):
        r = g.ch(ontology.RELATIONS)
        rs = s.rel_of(cur, r)
        need(rs)
        y = g.ch(sorted(rs))
        dy = D(g, y, rs)
        prog = f"{prog} | relate[{r}]{filters(dy)} | unique"
        text = f"{thing_np(g, dy)} {T.rel(r)} {text}" if g.rng.random() < 0.6 else \
            f"{thing_np(g, dy)} that is {T.rel(r)} {text}"
        cur = y
    return prog, text, cur


def f_two_hop_query(g, hops=2):
    s, T = g.s, g.T
    prog, text, cur = hop_chain(g, hops - 1)
    r = g.ch(ontology.RELATIONS)
    rs = s.rel_of(cur, r)
    need(rs)
    y = g.ch(sorted(rs))
    qa = g.ch(QUERY_ATTRS)
    dy = D(g, y, rs, banned={qa})
    ny = f"{thing_np(g, dy)} {T.rel(r)} {text}"
    return ask_attr(g, qa, ny), q_prog(f"{prog} | relate[{r}]{filters(dy)} | unique", qa), \
        f"{'two' if hops == 2 else 'three'}_hop_query_{qa}"


def f_three_hop_query(g):
    return f_two_hop_query(g, 3)


def f_two_hop_count(g, hops=2):
    s, T = g.s, g.T
    prog, text, cur = hop_chain(g, hops - 1)
    r = g.ch(ontology.RELATIONS)
    rs = s.rel_of(cur, r)
    f = set_desc(g.rng, s, rs, 1, 0) if rs else {}
    npl = T.np(f, "", pl=True)
    return rel_count_q(g, npl, f"{T.rel(r)} {text}"), f"count({prog} | relate[{r}]{filters(f)})", \
        f"{'two' if hops == 2 else 'three'}_hop_count"


def f_three_hop_count(g):
    return f_two_hop_count(g, 3)


def f_two_hop_exist(g):
    s, T = g.s, g.T
    prog, text, cur = hop_chain(g, 1)
    r = g.ch(ontology.RELATIONS)
    rs = s.rel_of(cur, r)
    f = set_desc(g.rng, s, rs, 1, 0) if rs and g.rng.random() < 0.5 else any_desc(g.rng, s, 1)
    return rel_exist_q(g, f, f"{T.rel(r)} {text}"), f"exist({prog} | relate[{r}]{filters(f)})", "two_hop_exist"


def f_and(g, exist=None):
    s, T = g.s, g.T
    x, y = g.rng.sample(range(s.n), 2)
    r1, r2 = g.ch(ontology.RELATIONS), g.ch(ontology.RELATIONS)
    dx, nx = ref(g, x)
    dy, ny = ref(g, y)
    both = (s.rel_of(x, r1) & s.rel_of(y, r2)) - {x, y}
    exist = g.rng.random() < 0.5 if exist is None else exist
    f = set_desc(g.rng, s, both, 1, 0) if both and g.rng.random() < 0.6 else (any_desc(g.rng, s, 1) if exist else {})
    w1, w2 = T.rel(r1), T.rel(r2)
    inner = f"intersect({obj(dx)} | relate[{r1}], {obj(dy)} | relate[{r2}]){filters(f)}"
    if exist:
        if f:
            q = g.ch([f"Is there {T.np(f, 'a')} that is {w1} {nx} and {w2} {ny}?",
                      f"Is there {T.np(f, 'a')} both {w1} {nx} and {w2} {ny}?",
                      f"Are there any {T.np(f, '', pl=True)} {w1} {nx} and also {w2} {ny}?"])
        else:
            q = g.ch([f"Is there anything {w1} {nx} and {w2} {ny}?",
                      f"Is anything both {w1} {nx} and {w2} {ny}?"])
        return q, f"exist({inner})", "and_exist"
    npl = T.np(f, "", pl=True)
    q = g.ch([f"How many {npl} are both {w1} {nx} and {w2} {ny}?", f"How many {npl} are {w1} {nx} and {w2} {ny}?",
              f"Count the {npl} that are {w1} {nx} and at the same time {w2} {ny}.",
              f"What number of {npl} are {w1} {nx} as well as {w2} {ny}?"])
    return q, f"count({inner})", "and_count"


def f_and_count(g):
    return f_and(g, False)


def f_and_exist(g):
    return f_and(g, True)


# ----------------------------------------------------------------------------------------------------------------
# families: parts

def poss(g, np_text, part):
    """'the part of the X' or, for short noun phrases, 'the X's part'."""
    if len(np_text.split()) <= 3 and g.rng.random() < 0.35 and not np_text.endswith("s"):
        return f"{np_text}'s {part}"
    return g.ch([f"the {part} of {np_text}", f"the {part} of {np_text}", f"the {part} on {np_text}"])


def recoloured(s, i):
    return list(s.objs[i].parts.items())


def f_part_query(g):
    s, T = g.s, g.T
    cands = [i for i in range(s.n) if s.objs[i].parts]
    need(cands)
    i = g.ch(cands)
    raw, style = g.ch(recoloured(s, i))
    label, src = part_label(s, i, raw)
    dx, nx = ref(g, i)
    pw = part_text(g, src, raw)
    qa = g.ch(("color", "color", "material"))
    pp = poss(g, nx, pw)
    q = ask_attr(g, qa, pp) if g.rng.random() < 0.7 else g.ch([
        f"{upper_first(nx)} has a {pw}; {ask_attr_it(g, qa)}", f"Look at {nx}. {upper_first(ask_attr(g, qa, 'its ' + pw))}"])
    return q, f"{obj(dx)} | object2part | partfilter_partname[{label}] | unique | partquery_{qa}", f"part_query_{qa}"


def f_part_name_by_color(g):
    s, T = g.s, g.T
    cands = [(i, raw, st) for i in range(s.n) for raw, st in recoloured(s, i)
             if not bad_part_color(s, i, st.color) and sum(x.color == st.color for x in s.objs[i].parts.values()) == 1]
    need(cands)
    i, raw, st = g.ch(cands)
    dx, nx = ref(g, i)
    c = T.color(st.color)
    q = g.ch([f"Which part of {nx} is {c}?", f"What part of {nx} is {c}?", f"Name the {c} part of {nx}.",
              f"{upper_first(nx)} has one {c} part; which one?", f"Which piece of {nx} is painted {c}?",
              f"what part is {c} on {nx}"])
    return q, f"{obj(dx)} | object2part | partfilter_color[{st.color}] | unique | partquery_partname", \
        "part_query_name_by_color"


def clean_part_color(s, raw, c, exclude):
    """No other object with such a part whose body has colour c (its unrecoloured part would look c)."""
    sup = ontology.super_part_name(raw)
    for j in s.all - {exclude}:
        if s.objs[j].color == c and any(ontology.super_part_name(p) == sup for p in all_parts(s, j)):
            return False
    return c != "gray"


def f_part_owner_query(g):
    s, T = g.s, g.T
    cands = [(i, raw, st) for i in range(s.n) for raw, st in recoloured(s, i)
             if clean_part_color(s, raw, st.color, i) and st.color != s.objs[i].color]
    need(cands)
    i, raw, st = g.ch(cands)
    qa = g.ch(QUERY_ATTRS)
    sup = ontology.super_part_name(raw)
    use_full = g.rng.random() < 0.3
    name = ontology.canonical_part_name(raw) if use_full else sup
    pd = {"color": st.color, "name": name}
    # fewest owner attributes (queried one banned) that make the part unique
    found = None
    for n, opts in _options(s, i, {qa}):
        for d in g.rng.sample(opts, len(opts)):
            owners = s.sel(s.all, d)
            parts = [(j, r) for j in owners for r, st2 in recoloured(s, j)
                     if st2.color == st.color and ontology.partname_matches(r, name)]
            if parts == [(i, raw)]:
                found = d
                break
        if found is not None:
            break
    need(found is not None)
    d = found
    if g.red:
        d2 = add_redundant(g.rng, s, i, d, {qa})
        need(d2 and d2 != d)
        d, g.red_done = d2, True
    pw = part_text(g, sup if not use_full else raw, raw)
    c = T.color(st.color)
    nx = T.np(d) if d else g.ch(["the thing", "the object", "the vehicle"])
    a = qword(g, qa)
    if g.rng.random() < 0.35:
        g.notes.append("whose")
        q = ask_attr(g, qa, f"{nx} whose {pw} is {c}")
    else:
        q = g.ch([ask_attr(g, qa, f"{nx} that has a {c} {pw}"), ask_attr(g, qa, f"{nx} with the {c} {pw}"),
                  ask_attr(g, qa, f"{nx} with a {c} {pw}")])
    if qa == "shape" and not d and g.rng.random() < 0.5:
        q = g.ch([f"What kind of vehicle has a {c} {pw}?", f"Which type of object has the {c} {pw}?",
                  f"What has a {c} {pw}?"])
    prog = (f"scene(){filters(d)} | object2part{pfilters(pd)} | unique | part2object | unique | query_{qa}")
    return q, prog, f"part_owner_query_{qa}"


def f_same_object_part(g):
    s, T = g.s, g.T
    cands = []
    for i in range(s.n):
        rc = recoloured(s, i)
        if len(rc) < 2:
            continue
        for raw2, st2 in rc:
            if not clean_part_color(s, raw2, st2.color, i):
                continue
            sup2 = ontology.super_part_name(raw2)
            same = [(j, r) for j in range(s.n) for r, x in recoloured(s, j)
                    if x.color == st2.color and ontology.super_part_name(r) == sup2]
            if same == [(i, raw2)]:
                for raw1, st1 in rc:
                    if raw1 != raw2:
                        cands.append((i, raw1, st1, raw2, st2))
    need(cands)
    i, raw1, st1, raw2, st2 = g.ch(cands)
    sup2 = ontology.super_part_name(raw2)
    label1, src1 = part_label(s, i, raw1)
    qa = g.ch(("color", "material", "partname"))
    p2 = f"{T.color(st2.color)} {part_text(g, sup2, raw2)}"
    head = f"scene() | object2part | partfilter_color[{st2.color}] | partfilter_partname[{sup2}] | unique | " \
           f"part2object | object2part"
    if qa == "partname":
        need(sum(x.color == st1.color for x in s.objs[i].parts.values()) == 1 and st1.color != st2.color)
        c1 = T.color(st1.color)
        q = g.ch([f"Which {c1} part is on the same object as the {p2}?",
                  f"What is the name of the {c1} part that belongs to the same object as the {p2}?",
                  f"On the vehicle with the {p2}, which part is {c1}?"])
        return q, f"{head} | partfilter_color[{st1.color}] | unique | partquery_partname", "same_object_part_name"
    p1 = part_text(g, src1, raw1)
    q = g.ch([ask_attr(g, qa, f"the {p1} that belongs to the same object as the {p2}"),
              ask_attr(g, qa, f"the {p1} on the same thing as the {p2}"),
              f"On the vehicle with the {p2}, {lower_first(ask_attr(g, qa, 'the ' + p1))}"])
    return q, f"{head} | partfilter_partname[{label1}] | unique | partquery_{qa}", f"same_object_part_{qa}"


def f_part_count(g, exist=False):
    s, T = g.s, g.T
    i = g.ch(range(s.n))
    dx, nx = ref(g, i)
    pcs = [st.color for st in s.objs[i].parts.values() if not bad_part_color(s, i, st.color)]
    if pcs and g.rng.random() < 0.6:
        c = g.ch(pcs)
    else:
        c = g.ch([x for x in ontology.COLORS if not bad_part_color(s, i, x)])
    cw = T.color(c)
    prog_in = f"{obj(dx)} | object2part | partfilter_color[{c}]"
    if exist:
        q = g.ch([f"Does {nx} have any {cw} parts?", f"Is any part of {nx} {cw}?", f"Has {nx} got a {cw} part?",
                  f"Does {nx} have a {cw} part?", f"Are any of the parts of {nx} {cw}?"])
        return q, f"exist({prog_in})", "part_color_exist"
    q = g.ch([f"How many {cw} parts does {nx} have?", f"How many parts of {nx} are {cw}?",
              f"Count the {cw} parts on {nx}.", f"What number of {cw} parts are there on {nx}?",
              f"how many {cw} parts {nx} has"])
    return q, f"count({prog_in})", "part_color_count"


def f_part_exist(g):
    return f_part_count(g, True)


def f_objects_with_part(g, exist=None):
    s, T = g.s, g.T
    exist = g.rng.random() < 0.5 if exist is None else exist
    pool = [(i, raw, st) for i in range(s.n) for raw, st in recoloured(s, i)]
    need(pool)
    i, raw, st = g.ch(pool)
    sup = ontology.super_part_name(raw)
    c = st.color if g.rng.random() < 0.7 else g.ch(ontology.COLORS)
    need(clean_part_color(s, raw, c, -1))
    f = {}
    if g.rng.random() < 0.4:
        f = {"shape": s.objs[i].category}
    nl = T.np(f, "", pl=True)
    ns = T.np(f, "a")
    pw = T.part(sup)
    cw = T.color(c)
    prog_in = f"scene(){filters(f)} | object2part | partfilter_color[{c}] | partfilter_partname[{sup}] | part2object"
    if exist:
        q = g.ch([f"Is there {ns} with a {cw} {pw}?", f"Does any of the {nl} have a {cw} {pw}?",
                  f"Is there {ns} that has a {cw} {pw}?", f"Can you see {ns} with a {cw} {pw}?"])
        return q, f"exist({prog_in})", "object_with_part_exist"
    q = g.ch([f"How many {nl} have a {cw} {pw}?", f"How many {nl} come with a {cw} {pw}?",
              f"Count the {nl} that have a {cw} {pw}.", f"What number of {nl} have a {cw} {pw}?"])
    return q, f"count({prog_in})", "object_with_part_count"


# ----------------------------------------------------------------------------------------------------------------
# families: pose

def f_pose_query(g):
    s, T = g.s, g.T
    cands = [i for i in range(s.n) if pose_safe(s, i)]
    need(cands)
    i = g.ch(cands)
    dx, nx = ref(g, i)
    q = g.ch([f"Which direction is {nx} facing?", f"What is the pose of {nx}?", f"Which way does {nx} point?",
              f"In which direction is {nx} heading?", f"What direction does {nx} face?", f"Which way is {nx} turned?",
              f"where is {nx} facing", f"Tell me which way {nx} faces.", f"What's the facing direction of {nx}?",
              f"{upper_first(nx)} faces which direction?"])
    return q, f"{obj(dx)} | query_pose", "pose_query"


def pose_desc(g, t, banned):
    s = g.s
    p = s.objs[t].pose
    for n, opts in _options(s, t, set(banned)):
        good = []
        for d in opts:
            base = s.sel(s.all, d)
            if len(base) > 1 and s.sel(base, {"pose": p}) == {t} and all(pose_safe(s, j) for j in base):
                good.append(d)
        if good:
            d = dict(g.ch(good))
            if g.red:
                d2 = add_redundant(g.rng, s, t, d, set(banned))
                need(d2 and d2 != d)
                d, g.red_done = d2, True
            return dict(d, pose=p)
    raise Skip


def f_pose_filter_query(g):
    s, T = g.s, g.T
    t = g.ch([i for i in range(s.n) if pose_safe(s, i)] or need(None))
    qa = g.ch(QUERY_ATTRS)
    d = pose_desc(g, t, {qa})
    npd = T.np(d)
    q = ask_attr(g, qa, npd) if g.rng.random() < 0.6 else ask_attr(g, qa, npd.replace(" facing", " that is facing")
                                                                   .replace(" pointing", " that is pointing")
                                                                   .replace(" heading", " that is heading")
                                                                   .replace(" oriented", " that is oriented"))
    return q, q_prog(obj(d), qa), f"pose_filter_query_{qa}"


def f_pose_filter_count(g, exist=False):
    s, T = g.s, g.T
    f = set_desc(g.rng, s, s.all, 1, 0)
    base = s.sel(s.all, f)
    need(base and all(pose_safe(s, j) for j in base))
    p = g.ch([s.objs[j].pose for j in base] + list(ontology.POSE_LABELS))
    pw = T.pose(p)
    if exist:
        q = g.ch([f"Is there {T.np(f, 'a')} {pw}?", f"Is any {T.np(f, '')} {pw}?",
                  f"Are there any {T.np(f, '', pl=True)} {pw}?", f"Do you see {T.np(f, 'a')} {pw}?"])
        return q, f"exist(scene() | filter_pose[{p}]{filters(f)})", "pose_filter_exist"
    q = g.ch([f"How many {T.np(f, '', pl=True)} are {pw}?", f"Count the {T.np(f, '', pl=True)} {pw}.",
              f"What number of {T.np(f, '', pl=True)} are {pw}?", f"how many {T.np(f, '', pl=True)} {pw} are there"])
    return q, f"count(scene() | filter_pose[{p}]{filters(f)})", "pose_filter_count"


def f_pose_filter_exist(g):
    return f_pose_filter_count(g, True)


POSE_REL = {"same": ["facing the same direction as", "pointing the same way as", "with the same heading as",
                     "oriented the same way as", "that faces the same way as"],
            "opposite": ["facing the opposite direction from", "pointing the other way from", "facing opposite to",
                         "with the reverse heading of", "that faces the opposite way to"],
            "vertical": ["facing perpendicular to", "at a right angle to", "turned at ninety degrees to",
                         "oriented perpendicular to", "that faces crosswise to"]}
POSE_OP = {"same": "same_pose", "opposite": "opposite_pose", "vertical": "vertical_pose"}


def pose_related(s, x, kind):
    o = s.objs[x]
    return frozenset(j for j in s.all - {x}
                     if ontology.pose_relation(o.pose_degree, o.pose, s.objs[j].pose_degree) == kind)


def f_pose_rel(g, mode=None):
    s, T = g.s, g.T
    cands = [i for i in range(s.n) if pose_rel_safe(s, i)]
    need(cands)
    x = g.ch(cands)
    kind = g.ch(tuple(POSE_REL))
    rs = pose_related(s, x, kind)
    dx, nx = ref(g, x)
    rw = g.ch(POSE_REL[kind])
    mode = mode or g.ch(("query", "count", "exist"))
    head = f"{obj(dx)} | {POSE_OP[kind]}"
    if mode == "query":
        need(rs)
        y = g.ch(sorted(rs))
        qa = g.ch(QUERY_ATTRS)
        dy = D(g, y, rs, banned={qa})
        ny = T.np(dy)
        q = ask_attr(g, qa, f"{ny} {rw} {nx}")
        return q, q_prog(f"{head}{filters(dy)} | unique", qa), f"pose_{kind}_query_{qa}"
    f = set_desc(g.rng, s, rs, 1, 0) if rs and g.rng.random() < 0.6 else (any_desc(g.rng, s, 1)
                                                                         if g.rng.random() < 0.5 else {})
    rw2 = rw.replace("that faces", "facing")
    if mode == "count":
        q = g.ch([f"How many {T.np(f, '', pl=True)} are {rw2} {nx}?", f"Count the {T.np(f, '', pl=True)} {rw2} {nx}.",
                  f"What number of {T.np(f, '', pl=True)} are {rw2} {nx}?"])
        return q, f"count({head}{filters(f)})", f"pose_{kind}_count"
    q = g.ch([f"Is there {T.np(f, 'a')} {rw2} {nx}?", f"Is any {T.np(f, '')} {rw2} {nx}?",
              f"Are there {T.np(f, '', pl=True)} {rw2} {nx}?"]) if f else \
        g.ch([f"Is anything {rw2} {nx}?", f"Is there anything {rw2} {nx}?", f"Does anything else face the same way "
              f"as {nx}?" if kind == "same" else f"Is there anything {rw2} {nx}?"])
    return q, f"exist({head}{filters(f)})", f"pose_{kind}_exist"


# ----------------------------------------------------------------------------------------------------------------
# families: occlusion

OCC_ADJ = ["occluded", "partly hidden", "partially hidden", "partly covered", "obscured"]
OCC_BY = ["occluded by", "hidden behind", "partly hidden by", "blocked by", "obscured by", "partly covered by"]
OCCLUDES = ["that occludes", "that hides", "that is blocking", "that partly covers", "that obscures",
            "in front of and hiding"]


def occ_np(g, d):
    T = g.T
    w = g.ch(OCC_ADJ)
    if g.rng.random() < 0.5:
        return f"the {w} {T.np(d, '')}"
    return f"{T.np(d)} that is {w}"


def f_occluded_query(g):
    s, T = g.s, g.T
    occ = frozenset(i for i in range(s.n) if s.objs[i].occluded)
    need(occ)
    t = g.ch(sorted(occ))
    qa = g.ch(QUERY_ATTRS)
    found = None
    for n, opts in _options(s, t, {qa}):
        good = [d for d in opts if s.sel(occ, d) == {t} and len(s.sel(s.all, d)) > 1]
        if good:
            found = dict(g.ch(good))
            break
    need(found is not None)
    d = found
    if g.red:
        d2 = add_redundant(g.rng, s, t, d, {qa})
        need(d2 and d2 != d)
        d, g.red_done = d2, True
    q = ask_attr(g, qa, occ_np(g, d))
    return q, q_prog(f"scene() | filter_occludee{filters(d)} | unique", qa), f"occluded_query_{qa}"


def f_occluded_by_query(g, occluding=False):
    s, T = g.s, g.T
    pairs = [(i, j) for i in range(s.n) for j in s.objs[i].occluded_by]  # j hides i
    need(pairs)
    i, j = g.ch(pairs)
    qa = g.ch(QUERY_ATTRS)
    if occluding:  # ask about j, the occluder of i
        dom = frozenset(s.objs[i].occluded_by)
        dr, nr = ref(g, i, nonempty=True)
        dt = D(g, j, dom, banned={qa})
        q = ask_attr(g, qa, f"{T.np(dt)} {g.ch(OCCLUDES)} {nr}")
        return q, q_prog(f"{obj(dr)} | relate_occluded{filters(dt)} | unique", qa), f"occluding_query_{qa}"
    dom = s.ctx.occludees_of[j]
    dr, nr = ref(g, j, nonempty=True)
    dt = D(g, i, dom, banned={qa})
    q = ask_attr(g, qa, f"{T.np(dt)} {'that is ' if g.rng.random() < 0.4 else ''}{g.ch(OCC_BY)} {nr}")
    return q, q_prog(f"{obj(dr)} | relate_occluding{filters(dt)} | unique", qa), f"occluded_by_query_{qa}"


def f_occluding_query(g):
    return f_occluded_by_query(g, True)


def f_occl_yesno(g):
    s, T = g.s, g.T
    want = g.rng.random() < 0.5
    cands = [i for i in range(s.n) if s.objs[i].occluded == want]
    need(cands)
    t = g.ch(cands)
    d, nx = ref(g, t)
    q = g.ch([f"Is {nx} occluded?", f"Is {nx} partly hidden?", f"Is {nx} blocked from view by anything?",
              f"Is part of {nx} hidden?", f"Is {nx} partially covered by another object?", f"is {nx} occluded",
              f"Does something hide part of {nx}?", f"Is {nx} obscured?"])
    return q, f"exist(scene() | filter_occludee{filters(d)})", "object_occluded_yesno"


def f_occl_by_yesno(g):
    s, T = g.s, g.T
    pairs = [(i, j) for i in range(s.n) for j in s.objs[i].occluded_by]
    if g.rng.random() < 0.5 and pairs:
        i, j = g.ch(pairs)
    else:
        i, j = g.rng.sample(range(s.n), 2)
    dx, nx = ref(g, i)
    dy, ny = ref(g, j, nonempty=True)
    q = g.ch([f"Is {nx} occluded by {ny}?", f"Does {ny} hide {nx}?", f"Is {nx} hidden behind {ny}?",
              f"Does {ny} block {nx}?", f"Is {nx} partly covered by {ny}?", f"Does {ny} occlude {nx}?"])
    return q, f"exist({obj(dy)} | relate_occluding{filters(dx)})", "occluded_by_yesno"


def f_occl_count(g):
    s, T = g.s, g.T
    k = g.ch(("occludee", "by", "of"))
    if k == "occludee":
        occ = [i for i in range(s.n) if s.objs[i].occluded]
        f = set_desc(g.rng, s, occ, 1, 0) if occ and g.rng.random() < 0.6 else set_desc(g.rng, s, s.all, 1, 0)
        npl = T.np(f, "", pl=True)
        q = g.ch([f"How many {npl} are occluded?", f"How many {npl} are partly hidden?",
                  f"Count the occluded {npl}.", f"How many {npl} are at least partly covered?",
                  f"What number of {npl} are obscured?"])
        return q, f"count(scene() | filter_occludee{filters(f)})", "occluded_count"
    y = g.ch(range(s.n))
    dy, ny = ref(g, y, nonempty=True)
    if k == "by":
        q = g.ch([f"How many things does {ny} occlude?", f"How many objects are hidden behind {ny}?",
                  f"How many objects does {ny} partly cover?", f"Count the things that {ny} hides."])
        return q, f"count({obj(dy)} | relate_occluding)", "occludees_of_count"
    q = g.ch([f"How many things occlude {ny}?", f"By how many objects is {ny} hidden?",
              f"How many objects are blocking {ny}?", f"Count the things in front of and hiding {ny}."])
    return q, f"count({obj(dy)} | relate_occluded)", "occluders_of_count"


# ----------------------------------------------------------------------------------------------------------------
# families: part occlusion

def occluded_parts(s, i):
    return [ontology.PARTS[s.objs[i].subtype][p] for (o, p) in s.ctx.occluded_parts if o == i]


def parts_all(s, i):
    return sorted({ontology.PARTS[s.objs[i].subtype][p] for (o, p) in s.ctx.parts_all_of[i]})


PART_OCC_Q = ["Is {pp} occluded?", "Is {pp} hidden?", "Is {pp} blocked from view?", "Is {pp} partly covered?",
              "Is {pp} obscured by something?", "is {pp} occluded", "Can something be seen in front of {pp}?"]


def f_part_occ_yesno(g):
    s, T = g.s, g.T
    want = g.rng.random() < 0.5
    cands = [(i, r) for i in range(s.n) for r in parts_all(s, i) if s.objs[i].part_occluded(r) == want]
    need(cands)
    i, raw = g.ch(cands)
    label, src = part_label(s, i, raw)
    dx, nx = ref(g, i)
    pp = poss(g, nx, part_text(g, src, raw))
    q = g.ch(PART_OCC_Q[:6]).format(pp=pp)
    return q, f"{obj(dx)} | object2part_all | partfilter_partname[{label}] | unique | partquery_occlusion", \
        "part_occluded_yesno"


def f_which_part_occ(g):
    s, T = g.s, g.T
    cands = [i for i in range(s.n) if len(occluded_parts(s, i)) == 1]
    need(cands)
    i = g.ch(cands)
    dx, nx = ref(g, i)
    q = g.ch([f"Which part of {nx} is occluded?", f"What part of {nx} is hidden?", f"Name the hidden part of {nx}.",
              f"Which part of {nx} is blocked from view?", f"One part of {nx} is covered; which one?",
              f"what part of {nx} is obscured"])
    return q, f"{obj(dx)} | object2part_all | partfilter_occludee | unique | partquery_partname", \
        "which_part_occluded"


def f_whose_part_occ(g):
    s, T = g.s, g.T
    cands = [(i, r) for i in range(s.n) for r in occluded_parts(s, i)]
    need(cands)
    i, raw = g.ch(cands)
    qa = g.ch(QUERY_ATTRS)
    sup = ontology.super_part_name(raw)
    name = sup if g.rng.random() < 0.6 else ontology.canonical_part_name(raw)
    found = None
    for n, opts in _options(s, i, {qa}):
        for d in g.rng.sample(opts, len(opts)):
            owners = {j for j in s.sel(s.all, d) for r in occluded_parts(s, j) if ontology.partname_matches(r, name)}
            if owners == {i}:
                found = d
                break
        if found is not None:
            break
    need(found is not None)
    d = found
    if g.red:
        d2 = add_redundant(g.rng, s, i, d, {qa})
        need(d2 and d2 != d)
        d, g.red_done = d2, True
    pw = part_text(g, sup if name == sup else raw, raw)
    nx = T.np(d) if d else g.ch(["the thing", "the object", "the vehicle"])
    g.notes.append("whose")
    ow = g.ch(["occluded", "hidden", "blocked from view", "partly hidden", "covered"])
    q = g.ch([ask_attr(g, qa, f"{nx} whose {pw} is {ow}"), ask_attr(g, qa, f"{nx} with a {ow} {pw}"),
              f"{upper_first(nx)} whose {pw} is {ow}: {ask_attr_it(g, qa)}"])
    return q, f"scene(){filters(d)} | object2part_all | partfilter_occludee | partfilter_partname[{name}] | " \
              f"part2object | unique | query_{qa}", f"whose_part_occluded_query_{qa}"


def f_part_of_occluded(g, by=False):
    s, T = g.s, g.T
    if by:
        pairs = [(i, j) for i in range(s.n) for j in s.objs[i].occluded_by if s.objs[i].parts]
        need(pairs)
        i, j = g.ch(pairs)
        dom = s.ctx.occludees_of[j]
    else:
        occ = frozenset(i for i in range(s.n) if s.objs[i].occluded)
        cands = [i for i in occ if s.objs[i].parts]
        need(cands)
        i = g.ch(cands)
        dom = occ
    raw, st = g.ch(recoloured(s, i))
    label, src = part_label(s, i, raw)
    qa = g.ch(("color", "material", "color"))
    d = D(g, i, dom, nonempty=True)
    pw = part_text(g, src, raw)
    if by:
        dy, ny = ref(g, j, nonempty=True)
        q = ask_attr(g, qa, g.ch([f"the {pw} of {T.np(d)} that is {g.ch(OCC_BY)} {ny}",
                                  f"the {pw} belonging to {T.np(d)} {g.ch(OCC_BY)} {ny}"]))
        return q, f"{obj(dy)} | relate_occluding{filters(d)} | object2part | partfilter_partname[{label}] | unique" \
                  f" | partquery_{qa}", f"part_of_occluded_by_query_{qa}"
    q = ask_attr(g, qa, g.ch([f"the {pw} of {occ_np(g, d)}", f"the {pw} that belongs to {occ_np(g, d)}"]))
    return q, f"scene() | filter_occludee{filters(d)} | object2part | partfilter_partname[{label}] | unique | " \
              f"partquery_{qa}", f"part_of_occluded_query_{qa}"


def f_part_of_occluded_by(g):
    return f_part_of_occluded(g, True)


def f_part_occ_by_yesno(g):
    s, T = g.s, g.T
    want = g.rng.random() < 0.5
    cands = []
    for i in range(s.n):
        for r in parts_all(s, i):
            by = s.objs[i].part_occluded_by(r)
            for j in s.all - {i}:
                if (j in by) == want:
                    cands.append((i, r, j))
    need(cands)
    i, raw, j = g.ch(cands)
    label, src = part_label(s, i, raw)
    dx, nx = ref(g, i)
    dy, ny = ref(g, j, nonempty=True)
    pw = part_text(g, src, raw)
    pp = poss(g, nx, pw)
    q = g.ch([f"Is {pp} occluded by {ny}?", f"Does {ny} hide {pp}?", f"Is {pp} hidden behind {ny}?",
              f"Is {pp} blocked by {ny}?", f"Does {ny} cover {pp}?"])
    return q, f"exist({obj(dx)} | object2part_all | partfilter_partname[{label}] | unique | relate_part_occluded" \
              f"{filters(dy)})", "part_occluded_by_yesno"


def f_whose_part_occ_by(g):
    s, T = g.s, g.T
    cands = [(j, part) for j in range(s.n) for part in s.ctx.parts_occluded_by[j]]
    need(cands)
    j, (i, pid) = g.ch(cands)
    raw = ontology.PARTS[s.objs[i].subtype][pid]
    sup = ontology.super_part_name(raw)
    hidden = s.ctx.parts_occluded_by[j]
    names = [sup, ontology.canonical_part_name(raw)]
    name = next((n for n in names if [p for p in hidden if ontology.partname_matches(s.ctx.part_names[p], n)]
                 == [(i, pid)]), None)
    need(name)
    qa = g.ch(QUERY_ATTRS)
    dy, ny = ref(g, j, nonempty=True)
    pw = part_text(g, sup if name == sup else raw, raw)
    g.notes.append("whose")
    dt = {}
    if g.red:
        dt = add_redundant(g.rng, s, i, {}, {qa})
        need(dt)
        g.red_done = True
    nt = T.np(dt) if dt else g.ch(["the thing", "the object", "the vehicle"])
    ow = g.ch(OCC_BY)
    q = ask_attr(g, qa, f"{nt} whose {pw} is {ow} {ny}")
    if qa == "shape" and not dt and g.rng.random() < 0.5:
        q = g.ch([f"Which vehicle has its {pw} {ow} {ny}?", f"What kind of object has a {pw} {ow} {ny}?"])
    return q, f"{obj(dy)} | relate_occluding_part | partfilter_partname[{name}] | unique | part2object" \
              f"{filters(dt)} | unique | query_{qa}", f"whose_part_occluded_by_query_{qa}"


def f_occ_part_count(g):
    s, T = g.s, g.T
    i = g.ch(range(s.n))
    dx, nx = ref(g, i)
    q = g.ch([f"How many parts of {nx} are occluded?", f"How many of the parts of {nx} are hidden?",
              f"Count the hidden parts of {nx}.", f"What number of parts of {nx} are blocked from view?",
              f"how many parts of {nx} is covered"])
    return q, f"count({obj(dx)} | object2part_all | partfilter_occludee)", "occluded_part_count"


# ----------------------------------------------------------------------------------------------------------------
# groups

GROUP_FAMILIES = {
    "core_query": [f_zero_query, f_zero_query, f_category_query],
    "core_count": [f_count_attr, f_count_attr, f_count_all, f_count_union],
    "core_exist": [f_exist_attr, f_exist_attr, f_exist_union],
    "core_compare_attribute": [f_compare_attr, f_compare_attr, f_compare_attr_related],
    "core_compare_integer": [f_compare_counts, f_compare_counts, f_compare_counts_around],
    "core_same_relate": [f_same_count, f_same_exist, f_same_query],
    "core_spatial": [f_one_hop_query, f_one_hop_count, f_one_hop_exist, f_bare_what, f_two_hop_query,
                     f_two_hop_count, f_two_hop_exist, f_three_hop_query, f_three_hop_count, f_and_count,
                     f_and_exist],
    "parts": [f_part_query, f_part_name_by_color, f_part_owner_query, f_same_object_part, f_part_count,
              f_part_exist, f_objects_with_part],
    "pose": [f_pose_query, f_pose_filter_query, f_pose_filter_count, f_pose_filter_exist, f_pose_rel, f_pose_rel],
    "occlusion": [f_occluded_query, f_occluded_by_query, f_occluding_query, f_occl_yesno, f_occl_by_yesno,
                  f_occl_count],
    "part_occlusion": [f_part_occ_yesno, f_which_part_occ, f_whose_part_occ, f_part_of_occluded,
                       f_part_of_occluded_by, f_part_occ_by_yesno, f_whose_part_occ_by, f_occ_part_count],
}
REDUNDANT_FAMILIES = [f_zero_query, f_count_attr, f_exist_attr, f_compare_attr, f_compare_counts, f_same_query,
                      f_one_hop_query, f_one_hop_count, f_part_query, f_part_owner_query, f_pose_filter_query,
                      f_pose_query, f_occluded_query, f_occluded_by_query, f_part_occ_yesno, f_whose_part_occ,
                      f_whose_part_occ_by]
WIDE_FAMILIES = [f_zero_query, f_count_attr, f_exist_attr, f_compare_attr, f_same_count, f_one_hop_query,
                 f_one_hop_count, f_two_hop_query, f_part_query, f_part_owner_query, f_part_count, f_pose_query,
                 f_pose_filter_query, f_occluded_by_query, f_part_occ_yesno, f_whose_part_occ]
QUIRK_FAMILIES = [f_count_attr, f_compare_counts, f_one_hop_count]
TYPO_FAMILIES = [f_zero_query, f_count_attr, f_exist_attr, f_compare_attr, f_compare_counts, f_same_exist,
                 f_one_hop_count, f_one_hop_query, f_part_query, f_pose_query, f_pose_filter_count, f_occl_yesno,
                 f_occluded_query, f_part_occ_yesno, f_which_part_occ]


def apply_typo(rng, q):
    words = [(m.start(), m.end(), m.group(0)) for m in re.finditer(r"[A-Za-z]+", q)]
    cands = [(a, b, w) for a, b, w in words if w.lower() in TYPOS]
    content = [c for c in cands if c[2].lower() not in TYPO_FUNCTION_WORDS]
    pool = content if content and (rng.random() < 0.85 or len(content) == len(cands)) else cands
    if not pool:
        return None, None
    a, b, w = rng.choice(pool)
    t = rng.choice(TYPOS[w.lower()])
    if w[0].isupper():
        t = t[0].upper() + t[1:]
    return q[:a] + t + q[b:], f"typo: {w.lower()} -> {t.lower()}"


def candidate(rng, seed, fn, kind):
    s = scene(seed)
    talk = Talk(rng, wide=(kind == "wide"), quirk=(kind == "quirk"))
    g = G(rng, s, talk, red=(kind == "red"))
    try:
        q, prog, fam = fn(g)
    except Skip:
        return None
    if kind == "red" and not g.red_done:
        return None
    notes = list(dict.fromkeys(g.notes))
    if kind == "red":
        fam = "redundant_" + fam
        notes.insert(0, "redundant description")
    elif kind == "wide":
        used = [w for w in dict.fromkeys(talk.wide_used) if re.search(r"\b" + re.escape(w.lower()), q.lower())]
        if not used:
            return None
        fam = "synonym_" + fam
        notes.insert(0, "wider synonyms " + ", ".join(f"'{w}'" for w in used))
    elif kind == "quirk":
        if not talk.quirk_used:
            return None
        fam = "plural_quirk_" + fam
        notes.insert(0, "public plural quirk 'buss'")
    q = re.sub(r"\s+", " ", q).strip()
    q = voice(rng, q)
    if kind == "typo":
        q, note = apply_typo(rng, q)
        if q is None:
            return None
        fam = "typo_" + fam
        notes.insert(0, note)
    ok, ans = s.run(prog)
    if not ok:
        return None
    return {"question": q, "program": prog, "family": fam, "scene": s.rel, "answer": ans,
            "phrasing_notes": "; ".join(notes)}


def spell(rng, prog):
    """Write the last stage as a call around the pipeline, sometimes (an equivalent spelling)."""
    m = re.fullmatch(r"(scene\(\).*) \| (query_\w+|partquery_\w+)", prog)
    if m and rng.random() < 0.3:
        return f"{m.group(2)}({m.group(1)})"
    return prog


def balanced_pick(cands, quota, taken):
    """Take up to quota candidates, least-picked answer first."""
    by_ans = defaultdict(list)
    for c in cands:
        by_ans[json.dumps(c["answer"])].append(c)
    used = Counter()
    out = []
    while len(out) < quota and any(by_ans.values()):
        key = min((k for k, v in by_ans.items() if v), key=lambda k: (used[k], k))
        c = by_ans[key].pop(0)
        sig = (c["scene"], c["question"])
        psig = (c["scene"], re.sub(r"\s", "", c["program"]))
        if sig in taken or psig in taken:
            continue
        taken.add(sig)
        taken.add(psig)
        used[key] += 1
        out.append(c)
    return out


def build(seed: int, skip_texts=frozenset()):
    rng = random.Random(seed)
    seeds = list(SEEDS)
    records = []
    taken = set(skip_texts)
    plan = {grp: [(fn, "plain") for fn in fns] for grp, fns in GROUP_FAMILIES.items()}
    plan["redundant"] = [(fn, "red") for fn in REDUNDANT_FAMILIES]
    plan["synonyms_quirks_typos"] = ([(fn, "wide") for fn in WIDE_FAMILIES] + [(fn, "quirk") for fn in QUIRK_FAMILIES]
                                     + [(fn, "typo") for fn in TYPO_FAMILIES])
    for grp in GROUPS:
        entries = plan[grp]
        pools = []
        for fn, kind in entries:
            want = (PER_GROUP // len(entries) + 2) * 5
            if kind == "quirk":
                want = 60
            pool, tries = [], 0
            while len(pool) < want and tries < want * 12:
                tries += 1
                c = candidate(rng, rng.choice(seeds), fn, kind)
                if c:
                    c["program"] = spell(rng, c["program"])
                    pool.append(c)
            pools.append(pool)
        # family-level balance: within an entry, candidates are grouped by family label
        fam_pools = defaultdict(list)
        for pool in pools:
            for c in pool:
                fam_pools[c["family"]].append(c)
        picked = []
        fams = sorted(fam_pools)
        rng.shuffle(fams)
        per_fam = {f: balanced_pick(fam_pools[f], PER_GROUP, set(taken)) for f in fams}
        # round-robin over the group's entries (base generators) then their families
        by_entry = defaultdict(list)
        for (fn, kind), pool in zip(entries, pools):
            for f in sorted({c["family"] for c in pool}):
                if f not in by_entry[fn.__name__ + kind]:
                    by_entry[fn.__name__ + kind].append(f)
        iters = {f: iter(v) for f, v in per_fam.items()}
        keys = list(by_entry)
        while len(picked) < PER_GROUP:
            progress = False
            for k in keys:
                for f in list(by_entry[k]):
                    c = next(iters[f], None)
                    if c is None:
                        by_entry[k].remove(f)
                        continue
                    sig = (c["scene"], c["question"])
                    psig = (c["scene"], re.sub(r"\s", "", c["program"]))
                    if sig in taken or psig in taken:
                        continue
                    taken.update((sig, psig))
                    picked.append(dict(c, family_group=grp))
                    progress = True
                    by_entry[k].append(by_entry[k].pop(by_entry[k].index(f)))
                    break
                if len(picked) >= PER_GROUP:
                    break
            if not progress:
                break
        records.extend(picked)
    out = []
    for n, r in enumerate(records):
        out.append({"id": f"v4g{n:05d}", "question": r["question"], "program": r["program"],
                    "family_group": r["family_group"], "family": r["family"], "scene": r["scene"],
                    "answer": r["answer"], **({"phrasing_notes": r["phrasing_notes"]} if r["phrasing_notes"] else {})})
    return out


# ----------------------------------------------------------------------------------------------------------------
# --show, --hand, main

def show(seed: int) -> str:
    s = scene(seed)
    lines = [f"scene {seed}: {s.n} objects"]
    for i, o in enumerate(s.objs):
        parts = ", ".join(f"{ontology.canonical_part_name(r)}={st.color}/{st.material}" for r, st in o.parts.items())
        occ_parts = ", ".join(f"{ontology.canonical_part_name(r)}<-{list(o.part_occluded_by(r))}"
                              for r in occluded_parts(s, i))
        lines.append(f"  [{i}] {o.size} {o.color} {o.material} {o.subtype} ({o.category}) pose={o.pose} "
                     f"{o.pose_degree:.0f}deg{'' if pose_safe(s, i) else ' (near edge)'} "
                     f"occluded={o.occluded} by={list(o.occluded_by)}")
        lines.append(f"       recoloured: {parts or '-'}")
        if occ_parts:
            lines.append(f"       occluded parts: {occ_parts}")
        lines.append("       " + "  ".join(f"{r}:{sorted(s.rel_of(i, r))}" for r in ontology.RELATIONS))
        rels = {k: sorted(pose_related(s, i, k)) for k in POSE_REL} if o.pose != ontology.NO_POSE else {}
        lines.append(f"       pose rel: {rels}")
    return "\n".join(lines)


def canonical_ok(program: str) -> list[str]:
    bad = []
    for v in re.findall(r"partfilter_partname\[([A-Za-z0-9_\-]+)\]", program):
        try:
            if ontology.canonical_part_name(v) != v:
                bad.append(v)
        except Exception:
            bad.append(v)
    return bad


def hand(path: Path) -> int:
    lines = [ln for ln in path.read_text().splitlines() if ln.strip()]
    out, errors = [], []
    for n, line in enumerate(lines):
        r = json.loads(line)
        seed = int(re.search(r"(\d+)\.json$", r["scene"]).group(1))
        s = scene(seed)
        bad = canonical_ok(r["program"])
        if bad:
            errors.append(f"line {n + 1}: non-canonical part name {bad}: {r['question']}")
            continue
        try:
            ok, ans = s.run(r["program"])
        except Exception as e:  # a malformed program is refused
            errors.append(f"line {n + 1}: {type(e).__name__}: {e}: {r['question']}")
            continue
        if not ok:
            errors.append(f"line {n + 1}: invalid: {ans}: {r['question']}")
            continue
        if "expect" in r and r["expect"] != ans:
            errors.append(f"line {n + 1}: expected {r['expect']!r}, executor says {ans!r}: {r['question']}")
        rec = {"id": f"v4h{len(out):03d}", "question": r["question"], "program": r["program"],
               "family_group": r["family_group"], "family": r["family"], "scene": r["scene"], "answer": ans}
        if r.get("phrasing_notes"):
            rec["phrasing_notes"] = r["phrasing_notes"]
        if "expect" in r:
            rec["expect"] = r["expect"]
        out.append(rec)
    if errors:
        print("\n".join(errors), file=sys.stderr)
        print(f"{len(errors)} problem(s); nothing written", file=sys.stderr)
        return 1
    path.write_text("".join(json.dumps(r) + "\n" for r in out))
    print(f"{len(out)} hand-written records checked and written")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seed", type=int, default=7400)
    ap.add_argument("--hand", action="store_true", help="fill/check answers of hand_written.jsonl")
    ap.add_argument("--show", type=int, nargs="+", metavar="SEED", help="print what a scene holds")
    ap.add_argument("--out", type=Path, default=HERE / "generated.jsonl")
    args = ap.parse_args(argv)
    if args.show:
        for sd in args.show:
            print(show(sd))
        return 0
    if args.hand:
        return hand(HERE / "hand_written.jsonl")
    skip = set()
    hw = HERE / "hand_written.jsonl"
    if hw.exists():
        for line in hw.read_text().splitlines():
            if line.strip():
                r = json.loads(line)
                skip.add((r["scene"], r["question"]))
    recs = build(args.seed, frozenset(skip))
    args.out.write_text("".join(json.dumps(r) + "\n" for r in recs))
    per = Counter(r["family_group"] for r in recs)
    print(f"{len(recs)} records -> {args.out}")
    for grp in GROUPS:
        print(f"  {grp}: {per[grp]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

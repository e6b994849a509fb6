"""Program -> English: many phrasings of one program, composed from the program's own structure.

The question parser learnt our template wording because every family had two or three fixed texts. This realiser
writes a question for any program built from the template operations, choosing at random among the ways people
(and the public CLEVR / Super-CLEVR files) say each step: query frames ("What is the colour of ...", "... is what
colour?"), noun phrases (adjectives before the noun, or "that is red and metal" after it), relative clauses
("that faces left", "facing to the left pose"), possessives ("the bus's left mirror"), "whose" constructions
("the car whose back wheel is occluded"), CLEVR's "There is a ...; how many ... are behind it?", comparisons
("more / fewer / as many", "greater / less than"), and every spelling of shapes and parts from
:mod:`po3d_ppl.language.lexicon`. Unsupported structures raise :class:`Unrealisable`, so the caller falls back to
the template text.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from po3d_ppl import ontology
from po3d_ppl.language import lexicon as lx
from po3d_ppl.language.ast import Node, Program


class Unrealisable(ValueError):
    """The realiser has no phrasing for this program structure."""


@dataclass
class _Obj:
    """A description of a set of objects (or of one object): what filters and relations say about it."""

    attrs: dict[str, str] = field(default_factory=dict)  # slot -> value
    shape: str | None = None
    posts: list[tuple[str, str]] = field(default_factory=list)  # (singular clause, plural clause)
    occluded: bool = False
    other: bool = False
    anchor: _Obj | None = None  # the object of the last relation (for "There is a ...; ... it")
    anchor_ref: str | None = None  # how the first post says the anchor
    union: tuple[_Obj, _Obj] | None = None
    hoist: bool = False
    #: How the set was reached from its anchor: "relate", "occluded_by" (relate_occluding: the anchor occludes
    #: them), "occluding" (relate_occluded: they occlude the anchor), "occluding_part" (relate_part_occluded),
    #: "pose"; None for plain filters.
    via: str | None = None
    #: Object filters applied after the relation (what the relation's result was narrowed to).
    narrowed: bool = False
    #: For the owner of a described part ("the thing that has a red wheel"): the part said alone ("the red
    #: wheel"), for "the door that belongs to the same object as the red wheel".
    owned_ref: str | None = None
    #: For the owner of a part another object occludes: (part noun, the occluder's reference), for "The bus
    #: occludes the front wheel of a thing; what colour is it?".
    part_statement: tuple[str, str] | None = None


@dataclass
class _Part:
    attrs: dict[str, str] = field(default_factory=dict)
    name: str | None = None
    occluded: bool = False
    owner: _Obj | None = None
    owner_unique: bool = False
    posts: list[tuple[str, str]] = field(default_factory=list)
    #: The occluder, for parts reached by relate_occluding_part ("How many parts does the bus occlude?").
    anchor_ref: str | None = None


_OBJECT_ATTR = {"filter_size": "size", "filter_color": "color", "filter_material": "material"}
_PART_ATTR = {"partfilter_size": "size", "partfilter_color": "color", "partfilter_material": "material"}
_ATTR_NAME = {"size": ("size",), "color": ("color", "colour"), "material": ("material",),
              "shape": ("shape",)}


class Realiser:
    """Writes questions for programs; one instance per random stream."""

    def __init__(self, rng: np.random.Generator, compare_around: bool = False, wording: bool = False,
                 wording3: bool = False):
        """``compare_around``: say two counts taken around one referent with the referent named once ("Are there
        more cars right of the bus than left of it?"); part of the opt-in ``compare_relate`` corpus families
        (:data:`po3d_ppl.questions.parser_corpus.OPT_IN_FAMILIES`), off by default so the default corpus is
        unchanged. ``wording``: the opt-in ``wording2`` phrasings (off by default, same reason): indirect
        questions ("Tell me whether the car is red.", "I'd like to know what colour the bus has."), counts and
        existence around a ``same_*`` referent said of the referent ("Does the car share its colour with any
        bus?", "The car has the same size as how many other things?", "How many buses besides the car have its
        colour?"), two counts around one referent introduced first ("Looking at the bus, are there more cars
        behind it than left of it?", "Does the bus have fewer cars behind it than left of it?"), "stand / sit /
        located" with spatial relations, and a few more everyday shape names. Every random draw it adds happens
        only when it is on, so the default stream is untouched. ``wording3``: the opt-in ``wording3`` frames
        (from reading dev 4's misses; off by default for the same reason): elliptical comparisons ("The bus and the
        car: same size?", "Same number of cars and buses?"), unions said with "or" or "plus" ("Does the picture
        have a car or a bus in it?", "What is the number of cars plus buses?"), "Is part of the car hidden?",
        "By how many things is the car hidden?", "Does the bus have a red part?"."""
        self.rng = rng
        self.compare_around = compare_around
        self.wording = wording
        self.wording3 = wording3
        self._said: list[str] = []

    # ----- choices ---------------------------------------------------------------------------------------------
    def more(self, *frames: str) -> tuple[str, ...]:
        """``frames`` where the ``wording3`` frames are on, else none (so the default stream is untouched)."""
        return frames if self.wording3 else ()

    def pick(self, options):
        return options[int(self.rng.integers(len(options)))] if len(options) > 1 else options[0]

    def chance(self, p: float) -> bool:
        return float(self.rng.random()) < p

    # ----- entry -----------------------------------------------------------------------------------------------
    def question(self, program: Program) -> str:
        self.program = program
        self._said = []
        text = self._top(program[len(program) - 1])
        if self.wording and self.chance(0.15):
            text = self._embedded(text) or text
        return _finish(text)

    # ----- indirect questions (wording2) -----------------------------------------------------------------------
    def _subject(self, rest: str) -> str | None:
        """The noun phrase (one this question said, or two joined by "and") that ``rest`` starts with."""
        said = sorted(set(self._said), key=len, reverse=True)
        m = re.match(r"the (?:total )?(?:number|count|amount|quantity|size|colou?r|material|shape|type) of ", rest)
        if m:  # "the number of cars", "the colour of the bus and the car"
            inner = self._subject(rest[m.end():])
            return None if inner is None else m.group(0) + inner
        for a in said:
            if rest.startswith(a + " and "):
                tail = rest[len(a) + 5:]
                for b in said:
                    if tail.startswith(b + " "):
                        return f"{a} and {b}"
        for a in said:
            if rest.startswith(a + " "):
                return a
        return None

    def _embedded(self, text: str) -> str | None:
        """``text`` (a direct question) as an indirect one: "Is the car red?" -> "Tell me whether the car is
        red.", "What colour does the bus have?" -> "I'd like to know what colour the bus has."; None where the
        subject cannot be found (the direct question is kept)."""
        t = re.sub(r"\s+", " ", text).strip()
        if not t.endswith("?") or "; " in t or ". " in t or ", " in t:
            return None
        body = t[:-1]
        first, _, rest = body.partition(" ")
        aux = first.lower()
        clause = None
        if aux in ("is", "are") and rest.startswith("there "):
            clause = f"there {aux} {rest[6:]}"
        elif aux in ("is", "are", "do", "does"):
            subject = self._subject(rest)
            if subject is None:
                return None
            tail = rest[len(subject):].strip()
            if aux in ("is", "are"):
                clause = f"{subject} {aux} {tail}"
            else:
                verb, _, obj = tail.partition(" ")
                clause = f"{subject} {_third_person(verb) if aux == 'does' else verb} {obj}".strip()
        elif aux == "can" and rest.startswith("you see "):
            clause = "you can " + rest[4:]
        if clause is not None:
            lead = self.pick(("Tell me if", "Tell me whether", "Tell me whether or not", "Can you tell me if",
                              "Can you tell me whether", "I want to know if", "I'd like to know whether",
                              "Let me know if", "Please tell me whether", "Check whether", "Say whether"))
            return f"{lead} {clause}{'?' if lead.startswith('Can') else '.'}"
        if body.lower().startswith(("can you tell", "tell me")):
            return None
        low = body[:1].lower() + body[1:]
        lead_wh = None
        m = re.match(r"(?:what is|what's|tell me|identify) (the \w+ of .+)$", low)
        if m:
            clause = m.group(1)
            lead_wh = self.pick(("I want to know", "I'd like to know", "Tell me", "Please tell me",
                                "Can you tell me", "Let me know", "I need to know"))
        elif low.startswith("how many ") and not re.search(r" (does|do|can|is|has) ", low):
            clause = re.sub(r" are there$", " there are", low)
        else:
            for s in sorted(set(self._said), key=len, reverse=True):
                for ending, replace in ((f" is {s}", f" {s} is"), (f" does {s} have", f" {s} has"),
                                        (f" is {s} made of", f" {s} is made of"),
                                        (f" is {s} made from", f" {s} is made from")):
                    head = low.removesuffix(ending)
                    if head != low and re.fullmatch(r"(what|which|how) ?\w*", head):
                        clause = head + replace
                        break
                if clause is not None:
                    break
        if clause is None:
            return None
        lead = lead_wh or self.pick(("I want to know", "I'd like to know", "Tell me", "Please tell me",
                                     "Can you tell me", "I wonder", "Let me know", "I need to know"))
        return f"{lead} {clause}{'?' if lead.startswith('Can') else '.'}"

    def _node(self, index: int) -> Node:
        return self.program[index]

    def _in(self, node: Node, k: int = 0) -> Node:
        return self.program[node.inputs[k]]

    # ----- object sets -----------------------------------------------------------------------------------------
    def obj(self, node: Node) -> _Obj:
        f = node.function
        if f == "scene":
            return _Obj()
        if f == "unique":
            return self.obj(self._in(node))
        if f in _OBJECT_ATTR:
            d = self.obj(self._in(node))
            d.attrs[_OBJECT_ATTR[f]] = node.value
            d.narrowed = True
            return d
        if f == "filter_shape":
            d = self.obj(self._in(node))
            d.shape = node.value
            d.narrowed = True
            return d
        if f == "filter_pose":
            d = self.obj(self._in(node))
            d.posts.append(self._pose_clause(node.value))
            return d
        if f == "filter_occludee":
            d = self.obj(self._in(node))
            if self.chance(0.5):
                d.occluded = True
            else:
                d.posts.append(self.pick(_OCCLUDED_CLAUSES))
            return d
        if f == "relate":
            anchor = self.obj(self._in(node))
            words = self.pick(lx.RELATION_FORMS[node.value])
            ref = self.np(anchor, "def")
            return _Obj(posts=[self._bare_or_clause(words, ref)], anchor=anchor, anchor_ref=ref, via="relate")
        if f.startswith("same_") and f != "same_pose":
            attr = f.removeprefix("same_")
            anchor = self.obj(self._in(node))
            name = self.pick(_ATTR_NAME[attr])
            ref = self.np(anchor, "def")
            if attr == "material" and self.chance(0.3):
                return _Obj(posts=[(f"made of the same material as {ref}", f"made of the same material as {ref}")],
                            other=self.chance(0.6), anchor=anchor, anchor_ref=ref)
            sing, plur = self.pick(((f"that has the same {name} as {ref}", f"that have the same {name} as {ref}"),
                                    (f"with the same {name} as {ref}",) * 2,
                                    (f"that is the same {name} as {ref}", f"that are the same {name} as {ref}"),
                                    (f"of the same {name} as {ref}",) * 2,
                                    (f"sharing the {name} of {ref}",) * 2,
                                    (f"that shares the {name} of {ref}", f"that share the {name} of {ref}"),
                                    *(((f"that shares {ref}'s {name}", f"that share {ref}'s {name}"),
                                       (f"sharing {ref}'s {name}",) * 2) if len(ref.split()) <= 4 and not _has_clause(ref) else ()),
                                    (f"which has the same {name} as {ref}", f"which have the same {name} as {ref}"),
                                    (f"that matches {ref} in {name}", f"that match {ref} in {name}")))
            return _Obj(posts=[(sing, plur)], other=self.chance(0.6), anchor=anchor, anchor_ref=ref)
        if f in ("same_pose", "opposite_pose", "vertical_pose"):
            anchor = self.obj(self._in(node))
            ref = self.np(anchor, "def")
            return _Obj(posts=[self.pick(_POSE_RELATIONS[f])(ref)], other=f == "same_pose" and self.chance(0.3),
                        anchor=anchor, anchor_ref=ref, via="pose")
        if f == "relate_occluding":  # objects the anchor occludes
            anchor = self.obj(self._in(node))
            ref = self.np(anchor, "def")
            return _Obj(posts=[self.pick(_OCCLUDED_BY)(ref)], anchor=anchor, anchor_ref=ref, via="occluded_by")
        if f == "relate_occluded":  # objects that occlude the anchor
            anchor = self.obj(self._in(node))
            ref = self.np(anchor, "def")
            return _Obj(posts=[self.pick(_OCCLUDING)(ref)], anchor=anchor, anchor_ref=ref, via="occluding")
        if f == "relate_part_occluded":
            part = self.part(self._in(node))
            ref = self.part_np(part, "def")
            return _Obj(posts=[self.pick(_OCCLUDING)(ref)], anchor_ref=ref, via="occluding_part")
        if f == "part2object":
            return self._owner_of(self._in(node))
        if f == "union":
            return _Obj(union=(self.obj(self._in(node, 0)), self.obj(self._in(node, 1))))
        if f == "intersect":
            a, b = self.obj(self._in(node, 0)), self.obj(self._in(node, 1))
            if a.attrs or a.shape or b.attrs or b.shape or a.union or b.union:
                raise Unrealisable("intersect of filtered sets")
            posts = a.posts + b.posts
            if len(posts) == 2 and self.chance(0.6):
                (s1, p1), (s2, p2) = posts
                both = self.pick(("both ", ""))
                posts = [(f"that is {both}{s1.removeprefix('that is ')} and {s2.removeprefix('that is ')}",
                          f"that are {both}{p1.removeprefix('that are ')} and {p2.removeprefix('that are ')}")]
                posts = [(_clean_is(posts[0][0]), _clean_are(posts[0][1]))]
            return _Obj(posts=posts, other=a.other or b.other)
        raise Unrealisable(f"no phrasing for {f} as an object set")

    def _bare_or_clause(self, words: str, ref: str) -> tuple[str, str]:
        if self.wording and self.chance(0.15):  # "that stands behind the car", "located left of the bus"
            verb = self.pick((("that stands", "that stand"), ("that sits", "that sit"), ("standing",) * 2,
                              ("sitting",) * 2, ("located",) * 2, ("positioned",) * 2, ("placed",) * 2,
                              ("that is located", "that are located"), ("that is standing", "that are standing")))
            return (f"{verb[0]} {words} {ref}", f"{verb[1]} {words} {ref}")
        if self.chance(0.7):
            return (f"{words} {ref}", f"{words} {ref}")
        return (f"that is {words} {ref}", f"that are {words} {ref}")

    def _pose_clause(self, pose: str) -> tuple[str, str]:
        words = self.pick(lx.POSE_FORMS[pose] + (_POSE_EXTRA[pose] if self.chance(0.25) else ()))
        bare = pose.removesuffix("_pose")
        return self.pick((
            (f"that is facing {words}", f"that are facing {words}"),
            (f"oriented {words}",) * 2,
            (f"that is pointing {words}", f"that are pointing {words}"),
            (f"that is turned {words}", f"that are turned {words}"),
            (f"heading {words}",) * 2,
            (f"whose direction is {bare}",) * 2,
            (f"in the {bare} pose",) * 2,
            (f"that points {words}", f"that point {words}"),
            (f"that heads {words}", f"that head {words}"),
            (f"which heads {words}", f"which head {words}"),
            (f"that is heading {words}", f"that are heading {words}"),
            (f"which is pointing {words}", f"which are pointing {words}"),
            (f"looking {words}",) * 2,
        ) if self.chance(0.35) else (
            (f"that faces {words}", f"that face {words}"),
            (f"facing {words}",) * 2,
            (f"which faces {words}", f"which face {words}"),
            (f"that is facing {words}", f"that are facing {words}"),
            (f"that faces to the {bare} pose", f"that face to the {bare} pose"),
            (f"with a {bare} pose", f"with a {bare} pose"),
            (f"whose pose is {bare}", f"whose pose is {bare}"),
            (f"that faces the {bare} direction", f"that face the {bare} direction"),
            (f"pointing {words}",) * 2,
        ))

    def _owner_of(self, partset: Node) -> _Obj:
        """Objects owning parts: "the car that has a red wheel" / "the car whose wheel is occluded"."""
        part = self.part(partset)
        owner = part.owner if part.owner is not None else _Obj()
        part.owner = None
        d = _Obj(attrs=dict(owner.attrs), shape=owner.shape, posts=list(owner.posts), occluded=owner.occluded)
        if not (owner.attrs or owner.shape or owner.posts or owner.occluded):
            d.owned_ref = self.part_np(part, "def")
        adjectives = self._part_adjectives(part)
        noun = self._part_noun(part, d.shape)
        if part.posts and not adjectives:  # "whose wheel is occluded by the bus"
            if part.anchor_ref and part.name:
                d.part_statement = (noun, part.anchor_ref)
            clause = part.posts[0][0].removeprefix("that ").removeprefix("which ")
            if clause.split()[0] in _PASSIVE_WORDS:
                clause = "is " + clause
            style = self.rng.random()
            if style < 0.6 or not clause.startswith("is "):
                d.posts.append((f"whose {noun} {clause}", f"whose {noun} {clause}"))
            elif style < 0.8:
                d.posts.append((f"with its {noun} {clause.removeprefix('is ')}",
                                f"with their {noun} {clause.removeprefix('is ')}"))
            else:
                verb = self.pick((("that has", "that have"), ("which has", "which have")))
                d.posts.append((f"{verb[0]} a {noun} {clause.removeprefix('is ')}",
                                f"{verb[1]} a {noun} {clause.removeprefix('is ')}"))
            return d
        if len(part.attrs) + part.occluded == 1 and part.name and self.chance(0.5):
            value = "occluded" if part.occluded else self._attr_words(next(iter(part.attrs.items())))
            if part.occluded:
                value = self.pick(("occluded", "hidden", "partially occluded", "blocked from view"))
            d.posts.append((f"whose {noun} is {value}", f"whose {noun} is {value}"))
            return d
        phrase = " ".join([*adjectives, noun])
        if part.posts:
            phrase += " " + part.posts[0][0]
        art = "a"
        verb = self.pick((("that has", "that have"), ("with", "with"), ("which has", "which have")))
        d.posts.append((f"{verb[0]} {art} {phrase}", f"{verb[1]} {art} {phrase}"))
        return d

    # ----- part sets -------------------------------------------------------------------------------------------
    def part(self, node: Node) -> _Part:
        f = node.function
        if f == "unique":
            return self.part(self._in(node))
        if f in ("object2part", "object2part_all"):
            source = self._in(node)
            owner = self.obj(source)
            return _Part(owner=owner, owner_unique=source.function == "unique")
        if f in _PART_ATTR:
            d = self.part(self._in(node))
            d.attrs[_PART_ATTR[f]] = node.value
            return d
        if f == "partfilter_partname":
            d = self.part(self._in(node))
            d.name = node.value
            return d
        if f == "partfilter_occludee":
            d = self.part(self._in(node))
            d.occluded = True
            return d
        if f == "relate_occluding_part":
            anchor = self.obj(self._in(node))
            ref = self.np(anchor, "def")
            return _Part(posts=[self.pick(_OCCLUDED_BY)(ref)], anchor_ref=ref)
        raise Unrealisable(f"no phrasing for {f} as a part set")

    # ----- noun phrases ----------------------------------------------------------------------------------------
    def _attr_words(self, item: tuple[str, str]) -> str:
        if item[1] in _ATTRIBUTE_EXTRA and self.chance(0.06):
            return self.pick(_ATTRIBUTE_EXTRA[item[1]])
        return self.pick(lx.ATTRIBUTE_FORMS[item[1]])

    def _adjectives(self, attrs: dict[str, str]) -> list[str]:
        words = [self._attr_words((k, attrs[k])) for k in ("size", "color", "material") if k in attrs]
        if len(words) > 1 and self.chance(0.08):  # people do not always keep CLEVR's size-colour-material order
            words = [words[i] for i in self.rng.permutation(len(words))]
        return words

    def _part_adjectives(self, part: _Part) -> list[str]:
        words = self._adjectives(part.attrs)
        if part.occluded:
            words.insert(0, self.pick(("occluded", "hidden", "partially occluded")))
        return words

    def _part_noun(self, part: _Part, owner_shape: str | None) -> str:
        if part.name is None:
            return "part"
        category = _category(owner_shape)
        forms = lx.part_forms_for_category(part.name, category) if category else lx.part_forms(part.name)
        shared = forms[len(lx.part_forms(part.name)):]  # spellings another category's value also has
        if shared and self.chance(0.3):  # "the SUV's headlight" is the car's head_light: the owner decides
            return self.pick(shared)
        return forms[0] if self.chance(0.5) else self.pick(forms)

    def _noun(self, d: _Obj, plural: bool) -> str:
        if d.shape is None:
            return self.pick(lx.THING_PLURALS if plural else lx.THING_FORMS)
        form = self.pick(lx.shape_forms(d.shape)) if self.chance(0.6) else lx.shape_forms(d.shape)[0]
        if d.shape in _SHAPE_EXTRA and self.chance(0.08):
            form = self.pick(_SHAPE_EXTRA[d.shape])
        if self.wording and d.shape in _SHAPE_EXTRA_2 and self.chance(0.1):
            form = self.pick(_SHAPE_EXTRA_2[d.shape])
        return self.pick(lx.plural_forms(form)) if plural else form

    def np(self, d: _Obj, kind: str) -> str:
        """``kind``: "def" (the ...), "indef" (a ...), "plural" (... things)."""
        said = self._np(d, kind)
        self._said.append(said)
        return said

    def _np(self, d: _Obj, kind: str) -> str:
        if d.hoist:
            return "it" if kind != "plural" else "them"
        plural = kind == "plural"
        attrs, said = dict(d.attrs), []
        if attrs and self.chance(0.16):  # "the thing whose colour is red", "the car which is big and made of metal"
            keys = [k for k in ("size", "color", "material") if k in attrs]
            chosen = [k for k in keys if self.chance(0.6)] or [self.pick(keys)]
            said = self._attribute_clauses({k: attrs.pop(k) for k in chosen}, plural)
        adjectives = self._adjectives(attrs)
        posts = said + [p[1] if plural else p[0] for p in d.posts]
        if d.occluded:
            if self.chance(0.5):
                adjectives.insert(0, self.pick(("occluded", "partially occluded", "hidden")))
            else:
                posts.insert(0, self.pick(_OCCLUDED_CLAUSES)[1 if plural else 0])
        noun = self._noun(d, plural)
        if len(adjectives) >= 1 and not posts and self.chance(0.12):  # "the car that is red and metal"
            verb = "are" if plural else "is"
            head = f"{noun} that {verb} {_and(adjectives)}"
        elif "material" in d.attrs and self.chance(0.1) and not posts:
            rest = [self._attr_words((k, d.attrs[k])) for k in ("size", "color") if k in d.attrs]
            head = " ".join([*rest, noun, "made of", d.attrs["material"]])  # "made of metal", not "of shiny"
        else:
            head = " ".join([*adjectives, noun])
        if d.other:
            head = "other " + head
        if posts:
            head = head + " " + " and ".join(posts) if len(posts) < 3 else head + " " + " ".join(posts)
        if kind == "def":
            return "the " + head
        if kind == "indef":
            return "a " + head
        return head

    def _attribute_clauses(self, attrs: dict[str, str], plural: bool) -> list[str]:
        """Attributes said after the noun: "whose colour is red", "which is big and made of metal"."""
        be, rel = ("are" if plural else "is"), self.pick(("that", "which", "that"))

        def predicate(k: str, v: str) -> str:
            if k == "material" and self.chance(0.5):
                return f"made of {v}"
            if k == "size" and self.chance(0.25):
                return f"{self._attr_words((k, v))} in size"
            if k == "color" and self.chance(0.2):
                return f"{self.pick(('colored', 'coloured', 'painted'))} {self._attr_words((k, v))}"
            return self._attr_words((k, v))

        style = self.rng.random()
        if style < 0.45:  # "whose colour is red", one clause per attribute
            out = []
            for k, v in attrs.items():
                name = self.pick(_ATTR_NAME[k])
                word = v if self.chance(0.6) else self._attr_words((k, v))
                out.append(f"whose {name} is {word}")
            return [", ".join(out) if len(out) > 1 and self.chance(0.5) else " and ".join(out)]
        if style < 0.85:  # "which is red and made of metal"
            return [f"{rel} {be} {_and([predicate(k, v) for k, v in attrs.items()])}"]
        out = []  # "with a red colour", "of small size"
        for k, v in attrs.items():
            name = self.pick(_ATTR_NAME[k])
            out.append(self.pick((f"with a {v} {name}", f"of {v} {name}")) if k != "material" else f"made of {v}")
        return [" and ".join(out)]

    def part_np(self, p: _Part, kind: str) -> str:
        said = self._part_np(p, kind)
        self._said.append(said)
        return said

    def _part_np(self, p: _Part, kind: str) -> str:
        adjectives = self._part_adjectives(p)
        owner_shape = p.owner.shape if p.owner is not None else None
        noun = self._part_noun(p, owner_shape)
        head = " ".join([*adjectives, noun])
        if p.posts:
            head += " " + p.posts[0][0]
        det = "the " if kind == "def" else "a "
        o = p.owner
        if (o is not None and o.owned_ref and len(o.posts) == 1 and not (o.attrs or o.shape or o.occluded)
                and self.chance(0.45)):
            thing = self.pick(("object", "object", "vehicle", "thing", "item"))
            return self.pick((f"{det}{head} that belongs to the same {thing} as {o.owned_ref}",
                              f"{det}{head} of the same {thing} as {o.owned_ref}",
                              f"{det}{head} on the same {thing} as {o.owned_ref}",
                              f"{det}{head} belonging to the same {thing} as {o.owned_ref}",
                              f"{det}{head} that is on the same {thing} as {o.owned_ref}",
                              f"{det}{head} that is part of the same {thing} as {o.owned_ref}"))
        if p.owner is None or (not p.owner.attrs and p.owner.shape is None and not p.owner.posts
                               and not p.owner.occluded):
            if p.owner is not None and self.chance(0.3):
                return f"{det}{head} of {self.pick(('a', 'some', 'any'))} {self._noun(p.owner, False)}"
            return det + head
        owner = self.np(p.owner, "def" if p.owner_unique or self.chance(0.7) else "indef")
        style = self.rng.random()
        if style < 0.55:
            return f"{det}{head} of {owner}"
        if style < 0.8 and owner.startswith("the ") and not p.owner.posts and not _has_clause(owner):
            return f"{owner}'s {head}"
        if style < 0.9:
            return f"{det}{head} on {owner}"
        return f"{det}{head} that belongs to {owner}"

    # ----- questions -------------------------------------------------------------------------------------------
    def _maybe_hoist(self, d: _Obj) -> str:
        """CLEVR's "There is a red car; ..." form: describe the relation's anchor first, then say "it"."""
        if (d.anchor is not None and d.anchor_ref and d.posts and self.chance(0.25)
                and d.posts[0][0].endswith(d.anchor_ref)):
            intro = self.np(d.anchor, "indef")
            d.posts[0] = tuple(p[: len(p) - len(d.anchor_ref)] + "it" for p in d.posts[0])
            return self.pick(("There is ", "There is ", "Look at ")) + intro + "; "
        return ""

    def _top(self, node: Node) -> str:
        f = node.function
        if f.startswith(("query_", "partquery_")):
            return self._query(node)
        if f in ("count", "exist"):
            return self._count_exist(node)
        if f.startswith("equal_") and f != "equal_integer":
            return self._compare_attribute(node)
        if f in ("greater_than", "less_than", "equal_integer"):
            return self._compare_counts(node)
        raise Unrealisable(f"no phrasing for a program ending in {f}")

    def _query(self, node: Node) -> str:
        f = node.function
        target = self._in(node)
        if f.startswith("partquery_"):
            part = self.part(target)
            attr = f.removeprefix("partquery_")
            if attr == "partname":
                return self._part_name_question(part)
            if attr == "occlusion":
                x = self.part_np(part, "def")
                word = self.pick(("occluded", "hidden", "partially occluded", "blocked", "covered",
                                  "occluded by something", "blocked from view"))
                owner = part.owner
                if (owner is not None and part.name and not part.posts and self.chance(0.2)
                        and (owner.attrs or owner.shape or owner.posts or owner.occluded)):
                    bare = " ".join([*self._part_adjectives(part), self._part_noun(part, owner.shape)])
                    return (self.pick(_INTROS) + self.np(owner, "indef") + "; "
                            + self.pick((f"is its {bare} {word}?", f"is the {bare} of it {word}?")))
                return f"Is {x} {word}?"
            owner = part.owner
            if (owner is not None and part.name and not part.posts and self.chance(0.2)
                    and (owner.attrs or owner.shape or owner.posts or owner.occluded)):
                # CLEVR's "There is a scooter; what colour is its panel?", "The red car has a trunk; what ..."
                bare = " ".join([*self._part_adjectives(part), self._part_noun(part, owner.shape)])
                if self.chance(0.3) and part.owner_unique:
                    return (f"{self.np(owner, 'def')} {self.pick(('has', 'has got', 'comes with'))} a {bare}; "
                            + self.pick(_IT_QUESTIONS[attr]))
                intro = self.pick(_INTROS) + self.np(owner, "indef")
                return intro + "; " + self._its_part_question(attr, bare)
            if (owner is not None and owner.owned_ref and len(owner.posts) == 1 and part.name is not None
                    and not (owner.attrs or owner.shape or owner.occluded) and self.chance(0.25)):
                head = self.part_np(_Part(attrs=part.attrs, name=part.name, occluded=part.occluded), "def")
                thing = self.pick(("object", "object", "vehicle", "thing"))
                together = self.pick((f"are on the same {thing}", f"belong to the same {thing}",
                                      f"are parts of the same {thing}", f"are on one {thing}"))
                return f"{owner.owned_ref} and {head} {together}; " + self._attribute_question(attr, head)
            x = self.part_np(part, "def")
            return self._attribute_question(attr, x)
        d = self.obj(target)
        attr = f.removeprefix("query_")
        if attr == "shape" and d.via in ("occluding", "occluded_by", "occluding_part") and not d.narrowed \
                and not d.other and self.chance(0.75):
            return self._what_occludes(d)
        if attr == "shape" and d.via in ("pose", "relate") and not d.narrowed and not d.other and len(d.posts) == 1 \
                and self.chance(0.4):
            what = self._what_relation(d)
            if what is not None:
                return what
        if (attr == "shape" and len(d.posts) == 1 and d.posts[0][0].startswith("whose ") and d.via is None
                and not d.posts[0][0].startswith(("whose pose", "whose direction")) and not d.attrs
                and d.shape is None and not d.occluded and not d.other and self.chance(0.3)):
            return f"{d.posts[0][0][:1].upper()}{d.posts[0][0][1:]}?"  # "Whose back wheel is occluded?"
        if attr == "shape" and d.posts and not d.other and self.chance(0.15):  # "Which bus has a red wheel?"
            sing = d.posts[-1][0]
            if sing.startswith(("that ", "which ")) and not sing.startswith(("that is ", "which is ")):
                rest = self.np(_strip_posts(d), "def").removeprefix("the ")
                return f"Which {rest} {sing.split(' ', 1)[1]}?"
        statement = self._occlusion_statement(d)
        if statement is not None:
            return statement + self.pick(_IT_QUESTIONS[attr])
        if self.chance(0.14):  # CLEVR's "There is a small red car; what is its size?"
            intro = self.pick(_INTROS) + self.np(d, "indef") + "; "
            return intro + self.pick(_IT_QUESTIONS[attr])
        intro = self._maybe_hoist(d)
        x = self.np(d, "def")
        if attr == "pose":
            if self.chance(0.12):  # "Is the bus facing left, right, towards the camera or away from it?"
                options = [self.pick(lx.POSE_FORMS[p]) for p in self.rng.permutation(sorted(lx.POSE_FORMS))]
                verb = self.pick(("facing", "pointing", "heading", "turned"))
                return intro + f"Is {x} {verb} {', '.join(options[:-1])} or {options[-1]}?"
            return intro + self.pick(_POSE_QUESTIONS)(x)
        question = self._attribute_question(attr, x)
        if attr == "shape" and not intro and self.chance(0.15):
            question = self.pick((f"What is {x}?", f"What is {x}?", f"What vehicle is {x}?", f"What's {x}?",
                                  f"What sort of thing is {x}?", f"Which kind of vehicle is {x}?",
                                  f"What kind of thing is {x}?", f"Which type of object is {x}?"))
        return intro + question

    def _its_part_question(self, attr: str, part: str) -> str:
        name = self.pick(_ATTR_NAME[attr])
        frames = [f"what {name} is its {part}?", f"what is the {name} of its {part}?", f"its {part} is what {name}?",
                  f"what {name} does its {part} have?", f"what is its {part}'s {name}?"]
        if attr == "material":
            frames += [f"what is its {part} made of?", f"what material is its {part} made of?",
                       f"is its {part} metal or rubber?"]
        if attr == "size":
            frames += [f"how big is its {part}?", f"is its {part} large or small?"]
        return self.pick(frames)

    def _occlusion_statement(self, d: _Obj) -> str | None:
        """"The bus is occluded by a thing; what colour is it?", "The car occludes the wheel of a thing; ..."."""
        if d.other or not self.chance(0.35 if d.part_statement is not None else 0.2):
            return None
        if d.part_statement is not None and not d.attrs and not d.shape and len(d.posts) == 1 and not d.occluded:
            noun, ref = d.part_statement
            thing = self.pick(("a thing", "an object", "a vehicle", "something", "an item"))
            verb = self.pick(("occludes", "is occluding", "hides", "is hiding", "blocks", "covers", "is blocking"))
            return f"{ref} {verb} the {noun} of {thing}; "
        if d.via not in ("occluded_by", "occluding") or not d.anchor_ref or len(d.posts) != 1 or d.occluded:
            return None
        rest = self.np(_strip_posts(d), "indef")
        if not (d.attrs or d.shape) and self.chance(0.25):
            rest = "something"
        ref = d.anchor_ref
        if d.via == "occluded_by":  # the anchor occludes it
            verb = self.pick(("occludes", "is occluding", "hides", "is hiding", "blocks", "is blocking",
                              "partially hides", "covers"))
            return f"{ref} {verb} {rest}; "
        verb = self.pick(("is occluded by", "is hidden by", "is blocked by", "is partially hidden by",
                          "is partly occluded by", "is covered by", "is obscured by"))
        if self.chance(0.3):
            return f"{rest} {self.pick(('occludes', 'hides', 'blocks', 'is occluding', 'is hiding'))} {ref}; "
        return f"{ref} {verb} {rest}; "

    def _what_relation(self, d: _Obj) -> str | None:
        """Shape queries on an unnarrowed relation: "What faces the same direction as the bus?", "What is behind
        the car?"."""
        sing = d.posts[0][0]
        words = sing.split()
        if words[0] in ("that", "which") and len(words) > 1:
            rest = " ".join(words[1:])
            thing = self.pick(("thing", "object", "vehicle", "item"))
            return self.pick((f"What {rest}?", f"Which {thing} {rest}?", f"What kind of {thing} {rest}?"))
        if d.via == "relate" or words[0] in _BARE_STARTS:
            thing = self.pick(("thing", "object", "vehicle"))
            return self.pick((f"What is {sing}?", f"Which {thing} is {sing}?", f"What kind of {thing} is {sing}?"))
        return None

    def _what_occludes(self, d: _Obj) -> str:
        """Shape queries on an occlusion relation: "What is occluding the bus?", "What does the car occlude?"."""
        ref = d.anchor_ref
        thing = self.pick(("thing", "object", "vehicle", "item"))
        if d.via in ("occluding", "occluding_part"):  # what occludes ref
            return self.pick((f"What is occluding {ref}?", f"What occludes {ref}?", f"What is {ref} occluded by?",
                              f"Which {thing} occludes {ref}?", f"What is blocking {ref}?", f"What blocks {ref}?",
                              f"What hides {ref}?", f"What is {ref} hidden by?", f"Which {thing} is occluding {ref}?",
                              f"What kind of {thing} occludes {ref}?", f"What type of {thing} is occluding {ref}?",
                              f"What shape is the {thing} that occludes {ref}?", f"What is {ref} blocked by?"))
        if self.chance(0.5):
            verb = self.pick(("occlude", "hide", "block", "cover", "obscure", "partially hide"))
            return self.pick((f"What does {ref} {verb}?", f"What does {ref} {verb}?", f"Which {thing} does {ref} {verb}?",
                              f"What kind of {thing} does {ref} {verb}?"))
        return self.pick((f"What is occluded by {ref}?", f"What does {ref} occlude?", f"What is {ref} occluding?",
                          f"Which {thing} is occluded by {ref}?", f"What is hidden by {ref}?",
                          f"What does {ref} block?", f"What kind of {thing} does {ref} occlude?",
                          f"Which {thing} is blocked by {ref}?", f"What is {ref} hiding?", f"What does {ref} hide?",
                          f"What is {ref} blocking?", f"What does {ref} cover?", f"Which {thing} does {ref} hide?"))

    def _attribute_question(self, attr: str, x: str) -> str:
        name = self.pick(_ATTR_NAME[attr])
        common = [f"What is the {name} of {x}?", f"What {name} is {x}?", f"{x} is what {name}?",
                  f"{x} has what {name}?", f"What {name} does {x} have?", f"Tell me the {name} of {x}.",
                  f"What's the {name} of {x}?", f"Can you tell me the {name} of {x}?", f"Which {name} is {x}?",
                  f"What is {x}'s {name}?" if len(x.split()) <= 4 and not _has_clause(x) else f"What is the {name} of {x}?",
                  f"Identify the {name} of {x}."]
        frames = {
            "color": [f"What color is {x} painted?" if len(x.split()) <= 4 else f"What color is {x}?", f"Of what {name} is {x}?", f"What is the {name} of {x}?",
                      f"What {name} is {x}?", f"Which {name} does {x} have?"],
            "size": [f"What size is {x}?", f"How big is {x}?", f"What is the size of {x}?", f"{x} is what size?",
                     f"Is {x} large or small?", f"What size does {x} have?", f"Tell me the size of {x}.",
                     f"How large is {x}?", f"Is {x} big or small?", f"Is {x} small or large?",
                     f"{x} is how big?", f"Is {x} little or big?", f"Is {x} a large one or a small one?",
                     f"Is {x} a small or a large one?", f"Is {x} a big thing or a small thing?",
                     f"Is {x} a large or a small vehicle?"],
            "material": [f"What material is {x}?", f"What is {x} made of?", f"What is the material of {x}?",
                         f"{x} is made of what material?", f"Is {x} metal or rubber?", f"Is {x} rubber or metal?",
                         f"What is {x} made from?", f"Which material is {x}?", f"What material is {x} made of?",
                         f"What is {x} made out of?", f"{x} is made of what?", f"What material was used for {x}?",
                         f"Is {x} shiny or matte?", f"Is {x} made of metal or rubber?",
                         f"What kind of material is {x}?", f"Of what material is {x}?",
                         f"Is {x} a metal one or a rubber one?", f"Is {x} a rubber or a metal one?"],
            "shape": [f"What shape is {x}?", f"What type of vehicle is {x}?", f"What kind of object is {x}?",
                      f"What is the shape of {x}?", f"What sort of vehicle is {x}?", f"{x} is what type of vehicle?",
                      f"What kind of vehicle is {x}?", f"What type of object is {x}?", f"{x} is what shape?",
                      f"{x} has what shape?", f"What shape does {x} have?", f"What kind of thing is {x}?",
                      f"Which type of vehicle is {x}?", f"What category of vehicle is {x}?",
                      f"Which vehicle is {x}?", f"What is the type of {x}?", f"What sort of object is {x}?"],
        }[attr]
        if attr in ("color", "size", "material") and self.chance(0.35):
            return self.pick(common)
        if attr == "shape" and self.chance(0.2):
            return self.pick(common)
        return self.pick(frames)

    def _part_name_question(self, part: _Part) -> str:
        owner = part.owner
        if (owner is not None and part.name is None and (part.attrs or part.occluded) and not part.posts
                and (owner.attrs or owner.shape or owner.posts) and self.chance(0.5)):
            o = self.np(owner, "def")
            occ = self.pick(("occluded", "occluded", "hidden", "blocked", "partially occluded", "not visible",
                             "blocked from view", "obscured", "covered"))
            state = _and([*(self._adjectives(part.attrs))] + ([occ] if part.occluded else []))
            adjs = " ".join(self._part_adjectives(part))
            frames = [f"Which part of {o} is {state}?", f"What part of {o} is {state}?",
                      f"Which of the parts of {o} is {state}?", f"Which part of {o} is {state}?",
                      f"What is the {adjs} part of {o}?", f"Which {adjs} part does {o} have?",
                      f"Which part on {o} is {state}?", f"What part of {o} is {state}?",
                      f"The {adjs} part of {o} is which part?", f"Which of {o}'s parts is {state}?"
                      if len(o.split()) <= 4 and not _has_clause(o) else f"Which of the parts of {o} is {state}?",
                      f"What is the {adjs} part of {o} called?", f"Tell me which part of {o} is {state}.",
                      f"Which is the {adjs} part of {o}?"]
            if "material" in part.attrs and not part.occluded and len(part.attrs) == 1:
                frames.append(f"Which part of {o} is made of {part.attrs['material']}?")
            if self.chance(0.2):  # "There is a red car; which of its parts is occluded?"
                intro = self.pick(_INTROS) + self.np(owner, "indef") + "; "
                return intro + self.pick((f"which of its parts is {state}?", f"which part of it is {state}?",
                                          f"what part of it is {state}?", f"which of its parts is {state}?",
                                          f"what is its {adjs} part?", f"which is its {adjs} part?"))
            if "color" in part.attrs and not part.occluded and len(part.attrs) == 1:
                frames.append(f"Which part of {o} is colored {self._attr_words(('color', part.attrs['color']))}?")
            return self.pick(frames)
        if (owner is not None and part.name is not None and (part.attrs or part.occluded) and not part.posts
                and (owner.attrs or owner.shape or owner.posts) and self.chance(0.6)):
            o = self.np(owner, "def")
            noun = self._part_noun(part, owner.shape)
            names = _pluralise_part(noun)
            state = self._part_state(part)
            short = len(o.split()) <= 4 and not _has_clause(o)
            if self.chance(0.2):
                intro = self.pick(_INTROS) + self.np(owner, "indef") + "; "
                return intro + self.pick((f"which of its {names} is {state}?", f"which {noun} of it is {state}?",
                                          f"which one of its {names} is {state}?"))
            return self.pick((f"Which {noun} of {o} is {state}?", f"Which {noun} of {o} is {state}?",
                              f"Which of the {names} of {o} is {state}?", f"Which {noun} on {o} is {state}?",
                              f"Which of {o}'s {names} is {state}?" if short else f"Which {noun} of {o} is {state}?",
                              f"What is the name of the {' '.join(self._part_adjectives(part))} {noun} of {o}?",
                              f"Which one of the {names} of {o} is {state}?", f"Tell me which {noun} of {o} is {state}."))
        x = self.part_np(part, "def")
        return self.pick((f"What is the name of {x}?", f"What is {x} called?", f"What do you call {x}?",
                          f"What is the name of {x}?", f"Name {x}.", f"Which part is {x}?",
                          f"What part is {x}?", f"What is {x}?", f"Identify {x}.", f"Which part is {x}?",
                          f"What kind of part is {x}?", f"What is the part name of {x}?"))

    def _count_exist(self, node: Node) -> str:
        target = self._in(node)
        count = node.function == "count"
        if target.function in ("partfilter_partname", "partfilter_color", "partfilter_material", "partfilter_size",
                               "partfilter_occludee", "object2part", "object2part_all", "relate_occluding_part"):
            return self._count_exist_parts(self.part(target), count)
        if self.wording and _same_below(self.program, target) is not None and self.chance(0.4):
            return self._same_count_exist(target, count)
        d = self.obj(target)
        if d.union is not None:
            a, b = d.union
            if d.attrs or d.shape is not None or d.posts or d.occluded:  # filters on the union
                if a.attrs or a.shape or b.attrs or b.shape or not a.posts or not b.posts:
                    raise Unrealisable("filters over a union of filtered sets")
                subject = self.np(_Obj(attrs=d.attrs, shape=d.shape), "plural")
                ra, rb = " and ".join(p[1] for p in a.posts), " and ".join(p[1] for p in b.posts)
                ra, rb = ra.removeprefix("that are "), rb.removeprefix("that are ")
                if count:
                    return self.pick((f"How many {subject} are either {ra} or {rb}?",
                                      f"How many {subject} are {ra} or {rb}?",
                                      f"What number of {subject} are either {ra} or {rb}?"))
                return self.pick((f"Are there any {subject} that are either {ra} or {rb}?",
                                  f"Are there any {subject} {ra} or {rb}?"))
            pa, pb = self.np(a, "plural"), self.np(b, "plural")
            if count:
                return self.pick((f"How many things are either {pa} or {pb}?", f"How many {pa} or {pb} are there?",
                                  f"What number of objects are {pa} or {pb}?",
                                  f"What is the total number of {pa} and {pb}?",
                                  f"How many {pa} and {pb} are there in total?",
                                  f"How many {pa} and {pb} are there altogether?",
                                  f"Count the {pa} and the {pb}.",
                                  f"How many objects are {pa} or {pb}?")
                             + self.more(f"What is the number of {pa} plus {pb}?", f"How many {pa} plus {pb} are there?",
                                         f"How many {pa} and {pb} are there combined?",
                                         f"Count the {pa} and the {pb} together."))
            frames = (f"Are there any {pa} or {pb}?", (f"Is there anything that is either a "
                      f"{self.np(a, 'indef').removeprefix('a ')} or a {self.np(b, 'indef').removeprefix('a ')}?"))
            if self.wording3:
                sa, sb = self.np(a, "indef"), self.np(b, "indef")
                where = self.pick(("image", "picture", "scene"))
                frames += (f"Is there {sa} or {sb}?", f"Is there either {sa} or {sb}?", f"Can you see {sa} or {sb}?",
                           f"Can you see either {sa} or {sb}?", f"Do you see {sa} or {sb}?",
                           f"Does the {where} have {sa} or {sb} in it?", f"Does the {where} contain {sa} or {sb}?",
                           f"Does the {where} show {sa} or {sb}?")
            return self.pick(frames)
        if not count and _occludee_chain(self.program, target) and self.chance(0.6):
            plain = _Obj(attrs=d.attrs, shape=d.shape, posts=[p for p in d.posts if p not in _OCCLUDED_CLAUSES],
                         other=d.other)
            x = self.np(plain, "def")
            word = self.pick(("occluded", "hidden", "partially hidden", "partly occluded", "blocked from view",
                              "occluded by another object", "covered by something"))
            frames = (f"Is {x} {word}?", f"Is {x} {word}?", f"Is {x} {word} in the picture?")
            if self.wording3:
                hidden = self.pick(("hidden", "occluded", "covered", "blocked"))
                frames += (f"Is part of {x} {hidden}?", f"Is some of {x} {hidden}?", f"Is {x} {hidden} by anything?",
                           f"Is {x} {hidden} by something?", f"Is {x} {hidden} by another object?")
            return self.pick(frames)
        if d.via is not None and d.posts and d.union is None and self.chance(0.7 if d.via == "occluding_part" else 0.35):
            direct = self._relation_yes_no(d) if not count else self._relation_count(d)
            if direct is not None:
                return direct
        if d.attrs and not d.posts and not d.occluded and not d.other and self.chance(0.2):
            # attributes said as the predicate: "Are any of the buses small and red?", "How many cars are metal?"
            keys = [k for k in ("size", "color", "material") if k in d.attrs]
            chosen = [k for k in keys if self.chance(0.5)] or [self.pick(keys)]
            subject_attrs = {k: v for k, v in d.attrs.items() if k not in chosen}
            subject = self.np(_Obj(attrs=subject_attrs, shape=d.shape), "plural")
            pred = _and([f"made of {d.attrs[k]}" if k == "material" and self.chance(0.3)
                         else self._attr_words((k, d.attrs[k])) for k in chosen])
            if count:
                return self.pick((f"How many {subject} are {pred}?", f"How many of the {subject} are {pred}?",
                                  f"What number of {subject} are {pred}?", f"How many of the {subject} are {pred}?"))
            return self.pick((f"Are any of the {subject} {pred}?", f"Are any {subject} {pred}?",
                              f"Is any of the {subject} {pred}?", f"Are there {subject} that are {pred}?",
                              f"Are any of the {subject} in the scene {pred}?"))
        if d.occluded and not d.posts and not d.other and self.chance(0.3):  # "How many of the red cars are hidden?"
            plain = self.np(_Obj(attrs=d.attrs, shape=d.shape), "plural")
            occ = self.pick(("occluded", "hidden", "partially hidden", "partly occluded", "blocked from view",
                             "obscured", "not fully visible", "covered"))
            if count:
                return self.pick((f"How many {plain} are {occ}?", f"How many of the {plain} are {occ}?",
                                  f"What number of {plain} are {occ}?", f"How many {plain} are {occ} in the image?"))
            return self.pick((f"Are any {plain} {occ}?", f"Are any of the {plain} {occ}?",
                              f"Is any of the {plain} {occ}?", f"Are there {plain} that are {occ}?"))
        intro = self._maybe_hoist(d)
        predicative = self._predicative(d)
        if count:
            if predicative is not None and self.chance(0.6):
                subject, pred = predicative
                return intro + self.pick((f"How many {subject} {pred}?", f"What number of {subject} {pred}?",
                                          f"How many of the {subject} {pred}?"))
            x = self.np(d, "plural")
            return intro + self.pick((f"How many {x} are there?", f"What number of {x} are there?",
                                      f"How many {x} are in the scene?", f"Count the {x}.",
                                      f"How many {x} are there in the image?", f"What is the number of {x}?",
                                      f"How many {x} can you see?", f"How many {x} do you see?",
                                      f"How many {x} are in the picture?", f"How many {x}?",
                                      f"How many {x} are visible?", f"Count the number of {x}.",
                                      f"How many {x} can be seen?", f"Tell me how many {x} there are.",
                                      f"What's the number of {x}?", f"How many {x} exist?",
                                      f"How many {x} are present?", f"What is the total number of {x}?",
                                      f"How many {x} are shown?", f"Give the number of {x}."))
        if (self.wording and predicative is not None and predicative[1].split()[0] in ("stand", "sit")
                and self.chance(0.6)):  # "Does anything stand behind the car?"
            rest = _strip_posts(d)
            some = (self.pick(("anything", "something", "any object", "any thing", "any vehicle"))
                    if not (rest.attrs or rest.shape or rest.posts or rest.occluded or rest.other)
                    else "any " + self.np(rest, "indef").removeprefix("a ").removeprefix("an "))
            return intro + f"Does {some} {predicative[1]}?"
        if predicative is not None and predicative[1].startswith("are ") and self.chance(0.5):
            subject, pred = predicative
            single = self.np(_strip_posts(d), "indef")
            pred = pred.removeprefix("are ")
            return intro + self.pick((f"Are there any {subject} {pred}?", f"Is there {single} {pred}?",
                                      f"Are any {subject} {pred}?"))
        if d.other and d.shape is None and not d.attrs and d.posts and self.chance(0.5):
            post = d.posts[0][0]
            return intro + self.pick((f"Is there anything else {post}?", f"Is there another thing {post}?",
                                      f"Is there any other thing {post}?",
                                      f"Are there any other things {d.posts[0][1]}?", f"Is there anything else {post}?"))
        x = self.np(d, "plural")
        single = self.np(d, "indef")
        return intro + self.pick((f"Are there any {x}?", f"Is there {single}?", f"Do you see any {x}?",
                                  f"Does the scene contain {single}?", f"Are any {x} visible?",
                                  f"Is there any {self.np(d, 'indef').removeprefix('a ')}?",
                                  f"Are there {x}?", f"Is there {single} in the scene?",
                                  f"Does {single} exist?", f"Can you see {single}?", f"Is {single} present?",
                                  f"Is there at least one {self.np(d, 'indef').removeprefix('a ')}?",
                                  f"Are there any {x} in the image?", f"Do any {x} exist?",
                                  f"Is there {single} in the image?", f"Are there any {x} in the picture?",
                                  f"Is {single} visible?", f"Is there {single} anywhere?",
                                  f"Does the {self.pick(('image', 'picture', 'scene', 'photo'))} "
                                  f"{self.pick(('show', 'contain', 'have', 'include'))} any {x}?",
                                  f"Does the {self.pick(('image', 'picture', 'scene'))} show {single}?",
                                  f"Are any {x} present?", f"Can you see any {x}?", f"Are there any {x} present?")
                                 + self.more(f"Do you see {single}?", f"Can you see {x}?", f"Do you see {x}?"))

    def _same_count_exist(self, target: Node, count: bool) -> str:
        """Counts and existence of objects sharing an attribute with a referent, said of the referent (wording2):
        "Does the car share its colour with any bus?", "The car has the same size as how many other things?",
        "How many buses besides the car have its colour?", "How many other buses are there besides the red
        one?"."""
        same = _same_below(self.program, target)
        attr = same.function.removeprefix("same_")
        anchor = self.obj(self._in(same))
        rest = _Obj()
        node = target
        while node is not same:
            if node.function == "filter_shape":
                rest.shape = node.value
            else:
                rest.attrs[_OBJECT_ATTR[node.function]] = node.value
            node = self._in(node)
        ref = self.np(anchor, "def")
        name = self.pick(_ATTR_NAME[attr])
        plain = not (rest.attrs or rest.shape)
        if count:
            ys = (self.pick(("other things", "other objects", "other vehicles", "other items", "others"))
                  if plain else ("other " if self.chance(0.4) else "") + self.np(rest, "plural"))
            besides = self.pick(("besides", "apart from", "other than", "except", "aside from"))
            frames = [f"{ref} has the same {name} as how many {ys}?", f"{ref} shares its {name} with how many {ys}?",
                      f"How many {ys} {besides} {ref} have its {name}?",
                      f"How many {ys} {besides} {ref} have the same {name}?",
                      f"{besides.capitalize()} {ref}, how many {ys} have the same {name}?",
                      f"With how many {ys} does {ref} share its {name}?",
                      f"{ref} is the same {name} as how many {ys}?"]
            if attr == "shape" and plain and anchor.shape is not None:
                kinds = self._noun(_Obj(shape=anchor.shape), True)
                frames += [f"How many other {kinds} are there {besides} {ref}?",
                           f"How many other {kinds} are there {besides} {ref}?",
                           f"{besides.capitalize()} {ref}, how many other {kinds} are there?"]
            return self.pick(frames)
        some = (self.pick(("anything else", "any other thing", "any other object", "another object",
                           "any other vehicle")) if plain
                else "any " + ("other " if self.chance(0.3) else "") + self.np(rest, "indef").removeprefix("a ")
                .removeprefix("an "))
        return self.pick((f"Does {ref} share its {name} with {some}?", f"Does {ref} have the same {name} as {some}?",
                          f"Is {ref} the same {name} as {some}?", f"Does {ref} match {some} in {name}?",
                          f"Does {some} have the same {name} as {ref}?", f"Does {some} share {ref}'s {name}?"
                          if len(ref.split()) <= 4 and not _has_clause(ref) else f"Does {some} share its {name} with {ref}?"))

    def _relation_yes_no(self, d: _Obj) -> str | None:
        """Exist over a relation, said of one object: "Is the car behind the bus?", "Does the truck occlude the
        bus?", "Is the front wheel of the car occluded by the bus?"."""
        rest = _strip_posts(d)
        sing, plur = d.posts[-1]
        ref = d.anchor_ref
        # Only for parts: "Is the bus occluded by the car?" is said of relate_occluding (the generic clause
        # below), "Does the car occlude the bus?" of relate_occluded; one wording, one program.
        if d.via == "occluding_part" and ref and self.chance(0.8):
            style = self.rng.random()
            some = (self.np(rest, "def") if style < 0.4 else self.np(rest, "indef") if style < 0.8
                    else "any " + self.np(rest, "plural"))
            word = self.pick(("occluded", "occluded", "hidden", "blocked", "partially occluded", "obscured",
                              "covered", "partly hidden"))
            return self.pick((f"Is {ref} {word} by {some}?", f"Is {ref} {word} by {some}?",
                              f"Is {ref} being {word} by {some}?"))
        subject = self.np(rest, "def" if self.chance(0.85) else "indef")
        for prefix in ("that is ", "which is "):
            if sing.startswith(prefix):
                return f"Is {subject} {sing.removeprefix(prefix)}?"
        words = plur.split()
        if words[0] in ("that", "which") and len(words) > 1 and words[1] in _VERBS:
            return f"Does {subject} {' '.join(words[1:])}?"
        if words[0] in _BARE_STARTS or sing.startswith(tuple(f for forms in lx.RELATION_FORMS.values()
                                                           for f in forms)):
            return f"Is {subject} {sing}?"
        return None

    def _relation_count(self, d: _Obj) -> str | None:
        rest = self.np(_strip_posts(d), "plural")
        ref = d.anchor_ref
        if d.via in ("occluding", "occluding_part") and ref:
            return self.pick((f"How many {rest} is {ref} occluded by?", f"By how many {rest} is {ref} occluded?",
                              f"How many {rest} are occluding {ref}?", f"How many {rest} is {ref} hidden by?",
                              f"What number of {rest} occlude {ref}?", f"How many {rest} block {ref}?")
                             + self.more(f"By how many {rest} is {ref} hidden?", f"By how many {rest} is {ref} blocked?"))
        if d.via == "occluded_by" and ref:
            return self.pick((f"How many {rest} does {ref} occlude?", f"How many {rest} is {ref} occluding?",
                              f"How many {rest} does {ref} block?", f"How many {rest} does {ref} hide?",
                              f"What number of {rest} does {ref} occlude?"))
        return None

    def _part_state(self, part: _Part) -> str | None:
        """The part's attributes said as a predicate ("red", "made of metal", "occluded"), or None."""
        if not (part.attrs or part.occluded):
            return None
        words = []
        for k in ("size", "color", "material"):
            if k in part.attrs:
                v = part.attrs[k]
                words.append(f"made of {v}" if k == "material" and self.chance(0.4) else self._attr_words((k, v)))
        if part.occluded:
            words.append(self.pick(("occluded", "occluded", "hidden", "partially occluded", "blocked from view",
                                    "obscured", "partly hidden", "not fully visible", "covered")))
        return _and(words)

    def _count_exist_parts(self, part: _Part, count: bool) -> str:
        owner = part.owner
        described = owner is not None and (owner.attrs or owner.shape or owner.posts or owner.occluded)
        state = self._part_state(part)
        if part.anchor_ref and not part.attrs and not part.occluded:  # relate_occluding_part
            ref = part.anchor_ref
            names = lx.plural(self._part_noun(part, None)) if part.name else "parts"
            verb = self.pick(("occlude", "hide", "block", "cover", "obscure"))
            done = {"occlude": "occluded", "hide": "hidden", "block": "blocked", "cover": "covered",
                    "obscure": "obscured"}[verb]
            if count:
                return self.pick((f"How many {names} does {ref} {verb}?", f"How many {names} are {done} by {ref}?",
                                  f"What number of {names} does {ref} {verb}?", f"How many {names} is {ref} {verb}ing?"
                                  if verb != "hide" else f"How many {names} is {ref} hiding?"))
            one = self._part_noun(part, None) if part.name else "part"
            return self.pick((f"Does {ref} {verb} any {names}?", f"Is any {one} {done} by {ref}?",
                              f"Does {ref} {verb} a {one}?"))
        if described and state is not None and not part.posts and self.chance(0.6):
            o = self.np(owner, "def" if part.owner_unique or self.chance(0.7) else "indef")
            short = len(o.split()) <= 4 and o.startswith("the ") and not _has_clause(o)
            if part.name is not None:
                noun = self._part_noun(part, owner.shape)
                names = _pluralise_part(noun)
                if count:
                    return self.pick((f"How many {names} of {o} are {state}?", f"How many of {o}'s {names} are {state}?"
                                      if short else f"How many of the {names} of {o} are {state}?",
                                      f"What number of {names} of {o} are {state}?"))
                frames = [f"Is any {noun} of {o} {state}?", f"Are any of the {names} of {o} {state}?"]
                if part.occluded:  # "Is the wheel of the car occluded?" asks partquery_occlusion
                    frames += [f"Does {o} have a {state} {noun}?" if " " not in state else
                               f"Does {o} have a {noun} that is {state}?", f"Is one of the {names} of {o} {state}?"]
                else:
                    frames += [f"Is the {noun} of {o} {state}?", f"Is the {noun} on {o} {state}?",
                               f"Is the {noun} of {o} {state}?"]
                if short:
                    frames += [f"Are any of {o}'s {names} {state}?"] + ([] if part.occluded else [f"Is {o}'s {noun} {state}?"])
                if "color" in part.attrs and not part.occluded and len(part.attrs) == 1:
                    frames += [f"Is the {noun} of {o} colored {part.attrs['color']}?",
                               f"Is the {noun} of {o} painted {part.attrs['color']}?"]
                return self.pick(frames)
            if count:
                return self.pick((f"How many parts of {o} are {state}?", f"How many of the parts of {o} are {state}?",
                                  f"How many of {o}'s parts are {state}?" if short else
                                  f"How many parts of {o} are {state}?", f"What number of parts of {o} are {state}?",
                                  f"How many parts are {state} on {o}?"))
            frames = [f"Is any part of {o} {state}?", f"Are any parts of {o} {state}?",
                      f"Are any of the parts of {o} {state}?", f"Does {o} have a part that is {state}?",
                      f"Does {o} have any parts that are {state}?", f"Is there a part of {o} that is {state}?",
                      f"Is some part of {o} {state}?"]
            if short:
                frames += [f"Are any of {o}'s parts {state}?", f"Is any of {o}'s parts {state}?"]
            if len(state.split()) == 1 and not part.occluded:  # "Does the bus have a red part?"
                frames += self.more(f"Does {o} have a {state} part?", f"Has {o} got a {state} part?",
                                    f"Does {o} have any {state} parts?")
            return self.pick(frames)
        if described:
            o = self.np(owner, "def" if part.owner_unique or self.chance(0.7) else "indef")
            bare = _Part(attrs=part.attrs, name=part.name, occluded=part.occluded, posts=part.posts)
            noun = self.part_np(bare, "indef").removeprefix("a ")
            plural = _pluralise_part(noun)
            if count:
                return self.pick((f"How many {plural} does {o} have?", f"How many {plural} are there on {o}?",
                                  f"How many {plural} of {o} are there?", f"What number of {plural} does {o} have?",
                                  f"How many {plural} has {o}?"))
            return self.pick((f"Does {o} have a {noun}?", f"Is there a {noun} on {o}?", f"Does {o} have any {plural}?",
                              f"Has {o} got a {noun}?", f"Is there a {noun} of {o}?"))
        noun = self.part_np(part, "indef").removeprefix("a ")
        if count:
            return self.pick((f"How many {_pluralise_part(noun)} are there?",
                              f"What number of {_pluralise_part(noun)} are there?"))
        return self.pick((f"Is there a {noun}?", f"Are there any {_pluralise_part(noun)}?"))

    def _predicative(self, d: _Obj) -> tuple[str, str] | None:
        """(plural subject, predicate with its verb) for "How many cars are behind the bus?" / "How many cars face
        left?", from the last post-modifier when it reads predicatively."""
        if not d.posts:
            return None
        sing, plur = d.posts[-1]
        rest = _Obj(attrs=d.attrs, shape=d.shape, posts=d.posts[:-1], occluded=d.occluded, other=d.other)
        if plur.startswith("that ") and not plur.startswith("that is "):
            if len(plur.split()) > 1 and plur.split()[1] in ("are", "face", "have", "occlude", "block", "hide", "share",
                                                             "head", "point", "match", "cover", "obscure", "stand",
                                                             "sit"):
                return self.np(rest, "plural"), plur.removeprefix("that ")
            return None
        if plur.startswith(("occluded by", "facing", "pointing")):
            return self.np(rest, "plural"), "are " + plur
        if plur == sing and not plur.startswith(("with", "of", "sharing", "whose", "made", "that", "which")):
            return self.np(rest, "plural"), "are " + plur
        return None

    def _compare_attribute(self, node: Node) -> str:
        attr = node.function.removeprefix("equal_")
        a, b = self._in(node, 0), self._in(node, 1)
        if not (a.function.startswith(("query_", "partquery_")) and b.function.startswith(("query_", "partquery_"))):
            raise Unrealisable("attribute comparison of non-queries")

        def said(q: Node) -> str:
            if q.function.startswith("partquery_"):
                return self.part_np(self.part(self._in(q)), "def")
            return self.np(self.obj(self._in(q)), "def")

        x, y = said(a), said(b)
        name = self.pick(_ATTR_NAME[attr])
        if a.function.startswith("query_") and self.chance(0.12):  # "There is a blue car; is it the same size as ...?"
            intro = self.pick(("There is ", "There is ", "Look at ")) + "a " + x.removeprefix("the ") + "; "
            frames = [f"is it the same {name} as {y}?", f"does it have the same {name} as {y}?",
                      f"is it of the same {name} as {y}?", f"does it share its {name} with {y}?",
                      f"is its {name} the same as {y}'s?" if len(y.split()) <= 4 and not _has_clause(y) else f"is it the same {name} as {y}?"]
            if attr == "material":
                frames += [f"is it made of the same material as {y}?"]
            if attr == "size":
                frames += [f"is it as big as {y}?"]
            return intro + self.pick(frames)
        frames = [f"Do {x} and {y} have the same {name}?", f"Is {x} the same {name} as {y}?",
                  f"Does {x} have the same {name} as {y}?", f"Are {x} and {y} the same {name}?",
                  f"Is the {name} of {x} the same as {y}?", f"Is the {name} of {x} the same as that of {y}?",
                  f"Do {x} and {y} share the same {name}?", f"Do {x} and {y} have an equal {name}?",
                  f"Is the {name} of {x} equal to the {name} of {y}?", f"Are {x} and {y} of the same {name}?",
                  f"Do {x} and {y} have matching {name}s?", f"Is {x} of the same {name} as {y}?",
                  f"Does {x} match {y} in {name}?", f"Is the {name} of {x} and {y} the same?",
                  f"Are {x} and {y} the same in {name}?",
                  f"Does {x} share its {name} with {y}?", f"Is {x}'s {name} the same as {y}'s?"
                  if len(x.split()) <= 4 and len(y.split()) <= 4 and not _has_clause(x + " " + y) else f"Is {x} the same {name} as {y}?"]
        frames += self.more(f"{x} and {y}: same {name}?", f"{x} and {y}: the same {name}?", f"{x} and {y}, same {name}?")
        if attr == "size":
            frames += [f"Is {x} as big as {y}?", f"Is {x} as large as {y}?", f"Are {x} and {y} equally big?"]
        if attr == "color":
            frames += [f"Is {x} colored the same as {y}?", f"Do {x} and {y} have the same colour?"]
        if attr == "material":
            frames += [f"Are {x} and {y} made of the same material?", f"Is {x} made of the same material as {y}?",
                       f"Are {x} and {y} made of the same stuff?", f"Is {x} made from the same material as {y}?"]
        if attr == "shape":
            frames += [f"Are {x} and {y} the same type of vehicle?", f"Is {x} the same kind of vehicle as {y}?",
                       f"Are {x} and {y} the same kind of object?", f"Is {x} the same type of object as {y}?",
                       f"Do {x} and {y} have the same type?", f"Are {x} and {y} the same vehicle type?"]
        return self.pick(frames)

    def _more_count_frames(self, f: str, x: str, y: str, n: str, m: str) -> list[str]:
        ns = {"quantity": "quantities", "total number": "numbers"}.get(n, n + "s")
        if f == "greater_than":
            big = self.pick(("greater", "larger", "bigger", "higher", "more"))
            return [f"Is there a {big} {n} of {x} than {y}?", f"Is the {n} of {x} {big} than the {m} of {y}?",
                    f"Are there more {x} than there are {y}?", f"Does the {n} of {x} exceed the {m} of {y}?",
                    f"Is the {n} of {x} {big} than that of {y}?", f"Are {x} more than {y}?",
                    f"Are there more {x} compared to {y}?", f"Is the {n} of {x} more than the {m} of {y}?",
                    f"Do {x} outnumber {y}?", f"Are the {x} more numerous than the {y}?",
                    f"Does the scene contain more {x} than {y}?", f"Do you see more {x} than {y}?",
                    f"Is it true that there are more {x} than {y}?", f"Is the {n} of {x} above the {m} of {y}?",
                    f"Are there more {x} in the scene than {y}?", f"Are there a greater number of {x} than {y}?",
                    f"Is there more {x} than {y}?", f"Is the {n} of {x} {big} than the {n} of {y}?",
                    f"Is the {n} of {x} higher than the {m} of {y}?", f"Is the {n} of {x} higher than that of {y}?"]
        if f == "less_than":
            small = self.pick(("less", "smaller", "fewer", "lower"))
            return [f"Is there a {self.pick(('smaller', 'lower', 'lesser'))} {n} of {x} than {y}?",
                    f"Is the {n} of {x} {small} than the {m} of {y}?", f"Are there fewer {x} than there are {y}?",
                    f"Is the {n} of {x} {small} than that of {y}?", f"Are {x} fewer than {y}?",
                    f"Are {x} less than {y}?", f"Are there less {x} than there are {y}?",
                    f"Are the {x} less numerous than the {y}?", f"Does the scene contain fewer {x} than {y}?",
                    f"Do you see fewer {x} than {y}?", f"Is it true that there are fewer {x} than {y}?",
                    f"Are there fewer {x} in the scene than {y}?", f"Is the {n} of {x} below the {m} of {y}?",
                    f"Are there a smaller number of {x} than {y}?", f"Are there fewer {x} compared to {y}?",
                    f"Is the {n} of {x} {small} than the {n} of {y}?",
                    f"Is the {n} of {x} lower than the {m} of {y}?", f"Is the {n} of {x} lower than that of {y}?",
                    f"Is there a lower {n} of {x} than {y}?"]
        return [f"Is there the same {n} of {x} and {y}?", f"Is there an equal {n} of {x} and {y}?",
                f"Are there as many {x} as there are {y}?", f"Is the {n} of {x} the same as the {m} of {y}?",
                f"Is the {n} of {x} equal to the {m} of {y}?", f"Are {x} and {y} equal in number?",
                f"Are the {ns} of {x} and {y} the same?", f"Are the {ns} of {x} and {y} equal?",
                f"Do {x} and {y} have the same {n}?", f"Is the {n} of {x} the same as that of {y}?",
                f"Does the {n} of {x} equal the {m} of {y}?", f"Does the scene contain as many {x} as {y}?",
                f"Are there exactly as many {x} as {y}?", f"Are there the same {n} of {x} as {y}?",
                f"Is the {n} of {x} and {y} the same?", f"Are there equally many {x} and {y}?",
                f"Is the {n} of {x} identical to the {m} of {y}?"]

    def _compare_counts(self, node: Node) -> str:
        a, b = self._in(node, 0), self._in(node, 1)
        if a.function != "count" or b.function != "count":
            raise Unrealisable("count comparison of non-counts")
        if self.compare_around and self._one_referent(self._in(a), self._in(b)) and self.chance(0.85):
            return self._compare_around(node.function, self._in(a), self._in(b))
        x, y = self.np(self.obj(self._in(a)), "plural"), self.np(self.obj(self._in(b)), "plural")
        f = node.function
        n = self.pick(("number", "number", "number", "count", "amount", "quantity", "total number"))
        m = self.pick(("number", "number", "count", "amount", "quantity"))
        if self.chance(0.45):
            return self.pick(self._more_count_frames(f, x, y, n, m))
        if f == "greater_than":
            more = self.pick(("more", "greater", "bigger", "larger", "higher", "higher"))
            frames = [f"Are there more {x} than {y}?", (f"Is the number of {x} {more if more != 'more' else 'greater'}"
                      f" than the number of {y}?"), f"Do {x} outnumber {y}?", f"Are there more {x} than {y}?",
                      f"Is the number of {x} larger than that of {y}?", f"Are {x} more numerous than {y}?",
                      f"Is the count of {x} greater than the count of {y}?"]
        elif f == "less_than":
            less = self.pick(("less", "smaller", "fewer", "lower", "lower"))
            frames = [f"Are there fewer {x} than {y}?", f"Are there less {x} than {y}?",
                      f"Is the number of {x} {less} than the number of {y}?",
                      f"Is the number of {x} smaller than that of {y}?", f"Are {x} fewer than {y}?",
                      f"Are there fewer {x} than {y}?",
                      f"Is the count of {x} less than the count of {y}?"]
        else:
            frames = [f"Are there the same number of {x} and {y}?", f"Are there as many {x} as {y}?",
                      f"Is the number of {x} the same as the number of {y}?",
                      f"Is the number of {x} equal to the number of {y}?", f"Are there an equal number of {x} and {y}?",
                      f"Is the number of {x} equal to that of {y}?", f"Do {x} and {y} have the same count?",
                      *self.more(f"Same number of {x} and {y}?", f"The same number of {x} and {y}?",
                                 f"Is there an equal count of {x} and {y}?", f"Equal numbers of {x} and {y}?")]
        return self.pick(frames)

    def _one_referent(self, a: Node, b: Node) -> bool:
        """Both sides are objects related to the same referent (the same chain), narrowed by attributes only."""
        ra, rb = _relate_below(self.program, a), _relate_below(self.program, b)
        return (ra is not None and rb is not None and ra.value != rb.value
                and _subtree(self.program, ra.inputs[0]) == _subtree(self.program, rb.inputs[0]))

    def _compare_around(self, f: str, a: Node, b: Node) -> str:
        """Two counts on two sides of one referent, named once: "Are there more cars right of the bus than left
        of it?", "Is the number of things behind the car the same as the number of buses in front of it?"."""
        first, second = self.obj(a), self.obj(b)
        ref = first.anchor_ref
        if (self.wording and ref and first.posts and first.posts[0][1].endswith(ref)
                and (second.attrs, second.shape) == (first.attrs, first.shape) and self.chance(0.5)):
            where = f"{self.pick(lx.RELATION_FORMS[_relate_below(self.program, b).value])} it"
            # the referent first: "Looking at the bus, are there more cars behind it than left of it?",
            # "Does the bus have fewer cars behind it than left of it?"
            first.posts[0] = tuple(p[: len(p) - len(ref)] + "it" for p in first.posts[0])
            rel = first.posts[0][1].removeprefix("that are ")
            bare = self.np(_Obj(attrs=first.attrs, shape=first.shape), "plural")
            if self.chance(0.35):
                more = {"greater_than": "more", "less_than": self.pick(("fewer", "less"))}.get(f)
                if more is not None:
                    return f"Does {ref} have {more} {bare} {rel} than {where}?"
                return self.pick((f"Does {ref} have as many {bare} {rel} as {where}?",
                                  f"Does {ref} have the same number of {bare} {rel} as {where}?"))
            lead = self.pick((f"Looking at {ref}, ", f"There is {self.np(first.anchor, 'indef')}; ",
                              f"Look at {ref}; ", f"Consider {ref}: ", f"As for {ref}, ", f"Focusing on {ref}, "))
            x = f"{bare} {rel}"
            frames = {"greater_than": [f"are there more {x} than {where}?", f"are there more {x} than there are {where}?",
                                       f"do {x} outnumber those {where}?"],
                      "less_than": [f"are there fewer {x} than {where}?", f"are there less {x} than {where}?",
                                    f"are there fewer {x} than there are {where}?"],
                      "equal_integer": [f"are there as many {x} as {where}?", f"are there the same number of {x} as {where}?",
                                        f"is the number of {x} the same as the number {where}?"]}[f]
            return lead + self.pick(frames)
        x = self.np(first, "plural")
        where = f"{self.pick(lx.RELATION_FORMS[_relate_below(self.program, b).value])} it"
        second.posts, second.other = [(where, where)], False
        if (second.attrs, second.shape) == (first.attrs, first.shape) and self.chance(0.7):  # "... than left of it"
            big = self.pick(("greater", "larger", "bigger", "higher"))
            small = self.pick(("less", "smaller", "lower"))
            frames = {
                "greater_than": [f"Are there more {x} than {where}?", f"Are there more {x} than there are {where}?",
                                 f"Is the number of {x} {big} than the number {where}?",
                                 f"Are there more {x} than {where} instead?"],
                "less_than": [f"Are there fewer {x} than {where}?", f"Are there less {x} than {where}?",
                              f"Is the number of {x} {small} than the number {where}?",
                              f"Are there fewer {x} than there are {where}?"],
                "equal_integer": [f"Are there as many {x} as {where}?", f"Are there as many {x} as there are {where}?",
                                  f"Is the number of {x} the same as the number {where}?",
                                  f"Is the number of {x} equal to the number {where}?",
                                  f"Are there the same number of {x} as {where}?"],
            }[f]
            return self.pick(frames)
        y = self.np(second, "plural")
        n = self.pick(("number", "number", "number", "count", "amount"))
        return self.pick(self._more_count_frames(f, x, y, n, n))


def _relate_below(program: Program, node: Node) -> Node | None:
    """The ``relate`` node under a chain of attribute filters, if that is what ``node`` is."""
    while node.function in ("filter_size", "filter_color", "filter_material", "filter_shape"):
        node = program[node.inputs[0]]
    return node if node.function == "relate" else None


def _same_below(program: Program, node: Node) -> Node | None:
    """The ``same_*`` node (not ``same_pose``) under a chain of attribute filters, if that is what ``node`` is."""
    while node.function in ("filter_size", "filter_color", "filter_material", "filter_shape"):
        node = program[node.inputs[0]]
    return node if node.function.startswith("same_") and node.function != "same_pose" else None


def _third_person(verb: str) -> str:
    """"have" -> "has", "match" -> "matches", "occlude" -> "occludes"."""
    if verb == "have":
        return "has"
    if verb.endswith(("s", "sh", "ch", "x", "z", "o")):
        return verb + "es"
    if verb.endswith("y") and verb[-2:-1] not in "aeiou":
        return verb[:-1] + "ies"
    return verb + "s"


def _subtree(program: Program, index: int) -> tuple:
    """A hashable description of the sub-program computing node ``index`` (equal for equal computations)."""
    node = program[index]
    return node.function, node.value, tuple(_subtree(program, i) for i in node.inputs)


def _has_clause(phrase: str) -> bool:
    """Whether a noun phrase has a post-modifier (no possessive "'s" after it)."""
    return any(w in phrase.split() for w in ("that", "which", "whose", "made", "with", "of", "in"))


def _and(words: list[str]) -> str:
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]


def _clean_is(text: str) -> str:
    return text.replace(" and that is ", " and ")


def _clean_are(text: str) -> str:
    return text.replace(" and that are ", " and ")


def _occludee_chain(program: Program, node: Node) -> bool:
    """Whether ``node`` is object filters over ``filter_occludee`` (an object-level "is it occluded?")."""
    while node.function in ("filter_size", "filter_color", "filter_material", "filter_shape", "filter_pose"):
        node = program[node.inputs[0]]
    return node.function == "filter_occludee"


def _strip_posts(d: _Obj) -> _Obj:
    return _Obj(attrs=d.attrs, shape=d.shape, posts=d.posts[:-1], occluded=d.occluded, other=d.other)


def _pluralise_part(phrase: str) -> str:
    head, sep, tail = phrase.partition(" of ")
    return lx.plural(head) + sep + tail


def _category(shape: str | None) -> str | None:
    if shape is None:
        return None
    return shape if shape in ontology.CATEGORIES else ontology.CATEGORY_OF.get(shape)


_OCCLUDED_CLAUSES = (("that is occluded", "that are occluded"), ("that is partially hidden", "that are partially hidden"),
                     ("that is blocked from view", "that are blocked from view"), ("which is occluded",
                                                                                   "which are occluded"),
                     ("that is partly occluded", "that are partly occluded"), ("that is hidden", "that are hidden"),
                     ("that is obscured", "that are obscured"), ("that is partially visible", "that are partially visible"),
                     ("that is covered", "that are covered"), ("that is not fully visible", "that are not fully visible"),
                     ("that is occluded by something", "that are occluded by something"),
                     ("that is partially occluded", "that are partially occluded"),
                     ("that is blocked", "that are blocked"), ("which is hidden", "which are hidden"))
_OCCLUDED_BY = (lambda r: (f"that is occluded by {r}", f"that are occluded by {r}"),
                lambda r: (f"occluded by {r}",) * 2,
                lambda r: (f"that is hidden by {r}", f"that are hidden by {r}"),
                lambda r: (f"that is blocked by {r}", f"that are blocked by {r}"),
                lambda r: (f"that {r} occludes", f"that {r} occludes"),
                lambda r: (f"that is partially hidden by {r}", f"that are partially hidden by {r}"),
                lambda r: (f"hidden by {r}",) * 2, lambda r: (f"blocked by {r}",) * 2,
                lambda r: (f"that is hidden behind {r}", f"that are hidden behind {r}"),
                lambda r: (f"that is obscured by {r}", f"that are obscured by {r}"),
                lambda r: (f"that is covered by {r}", f"that are covered by {r}"),
                lambda r: (f"which is occluded by {r}", f"which are occluded by {r}"),
                lambda r: (f"partially occluded by {r}",) * 2,
                lambda r: (f"that is partly blocked by {r}", f"that are partly blocked by {r}"))
_OCCLUDING = (lambda r: (f"that occludes {r}", f"that occlude {r}"),
              lambda r: (f"that is occluding {r}", f"that are occluding {r}"),
              lambda r: (f"that blocks {r}", f"that block {r}"),
              lambda r: (f"that hides {r}", f"that hide {r}"),
              lambda r: (f"occluding {r}",) * 2,
              lambda r: (f"that blocks the view of {r}", f"that block the view of {r}"),
              lambda r: (f"which occludes {r}", f"which occlude {r}"),
              lambda r: (f"that obscures {r}", f"that obscure {r}"),
              lambda r: (f"that covers {r}", f"that cover {r}"),
              lambda r: (f"that is blocking {r}", f"that are blocking {r}"),
              lambda r: (f"that is hiding {r}", f"that are hiding {r}"),
              lambda r: (f"that partially occludes {r}", f"that partially occlude {r}"),
              lambda r: (f"blocking {r}",) * 2, lambda r: (f"hiding {r}",) * 2)
_POSE_RELATIONS = {
    "same_pose": (lambda r: (f"that faces the same direction as {r}", f"that face the same direction as {r}"),
                  lambda r: (f"facing the same way as {r}",) * 2,
                  lambda r: (f"that has the same pose as {r}", f"that have the same pose as {r}"),
                  lambda r: (f"with the same direction as {r}",) * 2,
                  lambda r: (f"pointing in the same direction as {r}",) * 2,
                  lambda r: (f"that faces the same way as {r}", f"that face the same way as {r}"),
                  lambda r: (f"that is facing the same direction as {r}", f"that are facing the same direction as {r}"),
                  lambda r: (f"oriented the same way as {r}",) * 2,
                  lambda r: (f"with the same orientation as {r}",) * 2,
                  lambda r: (f"that is parallel to {r}", f"that are parallel to {r}"),
                  lambda r: (f"facing in the same direction as {r}",) * 2,
                  lambda r: (f"that points the same way as {r}", f"that point the same way as {r}"),
                  lambda r: (f"whose pose is the same as {r}",) * 2,
                  lambda r: (f"that has the same direction as {r}", f"that have the same direction as {r}")),
    "opposite_pose": (lambda r: (f"that faces the opposite direction to {r}", f"that face the opposite direction to {r}"),
                      lambda r: (f"facing the opposite way from {r}",) * 2,
                      lambda r: (f"that faces the opposite direction as {r}", f"that face the opposite direction as {r}"),
                      lambda r: (f"that has the opposite pose to {r}", f"that have the opposite pose to {r}"),
                      lambda r: (f"with the opposite direction of {r}",) * 2,
                      lambda r: (f"pointing the opposite way to {r}",) * 2,
                      lambda r: (f"that faces the opposite direction of {r}", f"that face the opposite direction of {r}"),
                      lambda r: (f"facing the opposite direction from {r}",) * 2,
                      lambda r: (f"that is facing opposite to {r}", f"that are facing opposite to {r}"),
                      lambda r: (f"that faces the other way from {r}", f"that face the other way from {r}"),
                      lambda r: (f"with the opposite orientation to {r}",) * 2,
                      lambda r: (f"whose direction is opposite to {r}",) * 2,
                      lambda r: (f"facing in the opposite direction to {r}",) * 2,
                      lambda r: (f"that has the opposite direction of {r}", f"that have the opposite direction of {r}")),
    "vertical_pose": (lambda r: (f"that faces perpendicular to {r}", f"that face perpendicular to {r}"),
                      lambda r: (f"facing at a right angle to {r}",) * 2,
                      lambda r: (f"that faces the vertical direction as {r}", f"that face the vertical direction as {r}"),
                      lambda r: (f"whose direction is perpendicular to {r}",) * 2,
                      lambda r: (f"that is perpendicular to {r}", f"that are perpendicular to {r}"),
                      lambda r: (f"with a pose perpendicular to {r}",) * 2,
                      lambda r: (f"facing perpendicular to {r}",) * 2,
                      lambda r: (f"that is orthogonal to {r}", f"that are orthogonal to {r}"),
                      lambda r: (f"that faces at a right angle to {r}", f"that face at a right angle to {r}"),
                      lambda r: (f"whose direction is vertical to {r}",) * 2,
                      lambda r: (f"that is facing perpendicular to {r}", f"that are facing perpendicular to {r}"),
                      lambda r: (f"facing a direction perpendicular to {r}",) * 2,
                      lambda r: (f"that faces a perpendicular direction to {r}", f"that face a perpendicular direction to {r}"),
                      lambda r: (f"that faces the vertical direction of {r}", f"that face the vertical direction of {r}"),
                      lambda r: (f"that is at a right angle to {r}", f"that are at a right angle to {r}"),
                      lambda r: (f"at right angles to {r}",) * 2),
}
_VERBS = ("face", "occlude", "block", "hide", "point", "obscure", "cover", "partially", "have")
_BARE_STARTS = ("occluded", "hidden", "blocked", "facing", "pointing", "oriented", "heading", "partially", "parallel",
                "perpendicular")
#: Rarer words for attribute values and shapes (the realiser's own; the lexicon keeps the public ones).
_ATTRIBUTE_EXTRA = {"large": ("giant", "enormous", "large-sized", "big-sized", "massive"),
                    "small": ("miniature", "small-sized", "mini", "little-sized"),
                    "metal": ("metallic", "glossy", "shiny metal", "chrome", "reflective", "metal-made"),
                    "rubber": ("matt", "rubbery", "matte rubber", "dull", "non-metallic", "non-metal", "non-shiny"),
                    "gray": ("grey", "silver"), "purple": ("violet",), "cyan": ("turquoise",)}
_SHAPE_EXTRA = {"truck": ("pickup",), "minivan": ("van",), "airliner": ("passenger airliner", "airliner plane"),
                "scooter": ("moped",), "fighter": ("fighter aircraft", "warplane", "military jet"),
                "car": ("auto", "motorcar"), "aeroplane": ("airplane", "aircraft"), "motorbike": ("motorcycle",),
                "bicycle": ("bike", "pushbike"), "bus": ("coach", "omnibus"), "wagon": ("estate",)}
#: Everyday shape names said only by the opt-in ``wording2`` phrasings.
_SHAPE_EXTRA_2 = {"mountain": ("MTB", "mtb", "mountain-bike"), "utility": ("city bike", "city bicycle", "commuter bike"),
                  "road": ("racing bike", "racing bicycle"), "bicycle": ("cycle", "push bike")}
_PASSIVE_WORDS = ("occluded", "hidden", "blocked", "partially", "partly", "obscured", "covered")
_POSE_EXTRA = {"front_pose": ("the camera", "towards us", "toward the viewer", "frontward", "forwards"),
               "back_pose": ("away", "away from us", "away from the viewer", "backwards", "rearward"),
               "left_pose": ("leftwards", "towards the left", "toward the left"),
               "right_pose": ("rightwards", "towards the right", "toward the right")}
_IT_QUESTIONS = {
    "color": ("what color is it?", "what is its color?", "what colour is it?", "what is its colour?",
              "what is the color of it?", "it is what color?", "what color does it have?", "which color is it?"),
    "size": ("what size is it?", "what is its size?", "how big is it?", "what is the size of it?", "it is what size?",
             "is it large or small?", "how large is it?", "is it big or small?"),
    "material": ("what material is it?", "what is its material?", "what is it made of?", "what is the material of it?",
                 "it is made of what material?", "is it metal or rubber?", "what is it made from?",
                 "which material is it made of?"),
    "shape": ("what shape is it?", "what is its shape?", "what type of vehicle is it?", "what kind of vehicle is it?",
              "what is it?", "what is the shape of it?", "what type of object is it?", "it is what shape?"),
    "pose": ("which direction is it facing?", "what is its pose?", "which way is it facing?",
             "what direction does it face?", "which way does it face?", "what is its orientation?",
             "where is it facing?", "what direction is it pointing?"),
}
_POSE_QUESTIONS = (lambda x: f"Which direction is {x} facing?", lambda x: f"What direction does {x} face?",
                   lambda x: f"Which way is {x} facing?", lambda x: f"What is the pose of {x}?",
                   lambda x: f"Which way does {x} point?", lambda x: f"Where is {x} facing?",
                   lambda x: f"In which direction is {x} pointing?", lambda x: f"What is the facing direction of {x}?",
                   lambda x: f"Which direction does {x} face?", lambda x: f"What pose is {x} in?",
                   lambda x: f"What direction is {x} facing?", lambda x: f"What is the orientation of {x}?",
                   lambda x: f"{x} is facing which direction?", lambda x: f"{x} faces which direction?",
                   lambda x: f"What direction is {x} pointing?", lambda x: f"What is the direction of {x}?",
                   lambda x: f"Which direction is {x} pointing in?", lambda x: f"How is {x} oriented?",
                   lambda x: f"What direction is {x} pointing towards?", lambda x: f"Which way is {x} pointing?",
                   lambda x: f"What is the facing of {x}?", lambda x: f"Is {x} facing left, right, front or back?",
                   lambda x: f"Which direction is {x} heading?", lambda x: f"In what direction is {x} facing?",
                   lambda x: f"Which direction does {x} point to?", lambda x: f"{x} is pointing in which direction?")

_INTROS = ("There is ", "There is ", "There is ", "Look at ", "Consider ", "There's ", "I can see ", "You can see ",
           "The picture shows ")
_ARTICLE = re.compile(r"\b([Aa]) (?=(\w+))")
_SAYS_CONSONANT = ("uti", "uni", "use", "one")
_SAYS_VOWEL = ("suv",)


def _finish(text: str) -> str:
    text = re.sub(r"\s+", " ", text).strip()

    def article(m: re.Match) -> str:
        word = m.group(2).lower()
        vowel = word[:1] in "aeiou" and not word.startswith(_SAYS_CONSONANT) or word.startswith(_SAYS_VOWEL)
        return m.group(1) + ("n " if vowel else " ")

    text = _ARTICLE.sub(article, text)
    text = re.sub(r"\b([Aa])n other\b", r"\1nother", text)
    text = re.sub(r"; (\w)", lambda m: "; " + m.group(1).lower(), text)
    return text[:1].upper() + text[1:]

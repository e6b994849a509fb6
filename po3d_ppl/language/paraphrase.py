"""Ordinary English the parser's training questions never use, read as the words they do use.

Why a table and not only the network: a word the corpus never wrote has no embedding, and its character n-grams
say what it looks like, not what it means ("shade" looks like "shape", one letter away; it means "colour"). The
typo corrector would then rewrite it confidently into the wrong word. The words below are ordinary synonyms
(colour words, materials, sizes, occlusion verbs, spatial idioms, "X-facing" adjectives), each read as the corpus
word with the same meaning in every question this language can ask. They are applied before typo correction.

Two kinds of entry, with two rules that keep in-distribution questions untouched:

- **one word** (``"hue": "color"``) is read as its replacement only where the word is outside the parser's
  vocabulary, so a word the corpus does use keeps the meaning the network learnt for it;
- **a phrase** of several words (``"in back of": "behind"``) is read wherever it occurs; every such phrase is
  checked to occur nowhere in the training corpus (``tests/test_language_paraphrase.py``).

A rewrite is reported like a typo correction (``QuestionParse.corrections``) and counted by the confidence
calibration. Entries are chosen by meaning, never by the questions of a held-out set.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from types import MappingProxyType

from po3d_ppl.language.lexicon import object_noun_words

#: word -> the corpus word(s) it is read as, where the word is outside the vocabulary.
WORDS: Mapping[str, str] = MappingProxyType({
    # the attribute nouns
    **{w: "color" for w in ("shade", "shades", "hue", "hues", "tint", "tints", "colouring", "coloring",
                            "coloration", "colouration")},
    "model": "shape", "models": "shapes",
    "substance": "material", "fabric": "material", "composition": "material",
    "dimension": "size", "dimensions": "size", "bigness": "size",
    # colours
    **{w: "red" for w in ("crimson", "scarlet", "ruby", "cherry", "maroon")},
    **{w: "blue" for w in ("navy", "cobalt", "sapphire", "indigo")},
    **{w: "green" for w in ("emerald", "lime", "jade", "olive")},
    **{w: "cyan" for w in ("teal", "aqua", "aquamarine")},
    **{w: "purple" for w in ("lilac", "lavender", "mauve", "plum", "magenta")},
    **{w: "yellow" for w in ("golden", "lemon", "canary")},
    **{w: "brown" for w in ("chocolate", "tan", "beige", "bronze", "coffee")},
    **{w: "gray" for w in ("silvery", "ash", "slate", "charcoal")},
    # materials
    **{w: "metal" for w in ("steel", "iron", "aluminium", "aluminum", "chromed", "gleaming")},
    **{w: "rubber" for w in ("nonreflective", "unpolished")},
    # sizes
    **{w: "large" for w in ("gigantic", "oversized", "jumbo", "hefty", "sizable",
                            "sizeable", "biggish")},
    **{w: "small" for w in ("petite", "teeny", "wee", "smallish")},
    # nouns
    "tyre": "wheel", "tyres": "wheels", "tire": "wheel", "tires": "wheels",
    # occlusion verbs
    "obstructed": "occluded", "obstructs": "occludes", "obstruct": "occlude", "obstructing": "occluding",
    "concealed": "hidden", "conceals": "hides", "conceal": "hide", "concealing": "hiding",
    "shielded": "hidden", "screened": "hidden", "masked": "hidden", "eclipsed": "hidden",
    # more attribute nouns, colours, materials and sizes
    "paint": "color", "paintwork": "color", "livery": "color", "makeup": "material", "variety": "type",
    **{w: "blue" for w in ("azure", "cerulean", "ultramarine")},
    **{w: "brown" for w in ("chestnut", "auburn", "rust", "mahogany", "sepia", "umber", "caramel")},
    **{w: "yellow" for w in ("amber", "mustard", "ochre", "saffron")},
    **{w: "green" for w in ("mint",)},
    **{w: "red" for w in ("vermilion", "carmine", "rose", "burgundy")},
    **{w: "metal" for w in ("tin", "chromium", "steely", "brass")},
    **{w: "rubber" for w in ("plastic", "nonmetallic", "unshiny")},
    **{w: "small" for w in ("undersized", "compact", "diminutive", "minuscule", "pint", "dinky")},
    **{w: "large" for w in ("bulky", "hulking", "whopping", "oversize", "mammoth", "colossal", "immense",
                            "vast")},
    # nouns for any object, and shape and part words
    "figure": "thing", "figures": "things", "toy": "thing", "toys": "things", "piece": "thing",
    "pieces": "things", "article": "object", "articles": "objects",
    "mpv": "minivan", "mpvs": "minivans", "vespa": "scooter", "vespas": "scooters", "atb": "mountain bike",
    "lorry": "truck", "lorries": "trucks",
    "rim": "wheel", "rims": "wheels", "handgrip": "handle", "handgrips": "handles", "grip": "handle",
    "grips": "handles", "hatch": "trunk", "tailgate": "trunk", "rooftop": "roof",
    # positions
    "before": "in front of",
})

#: phrase -> its reading, wherever it occurs (every phrase absent from the training corpus).
PHRASES: Mapping[str, str] = MappingProxyType({
    "in back of": "behind", "to the rear of": "behind",
    "ahead of": "in front of",
    "left hand side of": "left side of", "right hand side of": "right side of",
    "lefthand side of": "left side of", "righthand side of": "right side of",
    **{f"{verb} part of": f"partially {verb}" for verb in ("hide", "hides", "hiding", "block", "blocks",
                                                           "blocking", "cover", "covers", "covering",
                                                           "occlude", "occludes", "occluding")},
    **{f"{verb} some of": f"partially {verb}" for verb in ("hide", "hides", "hiding", "block", "blocks",
                                                           "blocking", "cover", "covers", "covering")},
    "in the way of": "hiding",
    "hidden from view": "hidden",
    "can you find": "is there", "can you spot": "is there",
    "would you say": "",
    "hidden from sight": "hidden",
    # positions said as comparisons
    **{f"{lead} {side} of": f"to the {side} of" for lead in ("off to the", "over to the", "away to the")
       for side in ("left", "right")},
    **{f"{more} {side} than": f"{side} of" for more in ("further", "farther", "more to the", "further to the",
                                                           "farther to the")
       for side in ("left", "right")},
    "out in front of": "in front of", "further back than": "behind", "farther back than": "behind",
    "further forward than": "in front of",
    # colours, materials and shapes said in several words
    **{p: "cyan" for p in ("blue green", "greenish blue", "bluish green", "sea green")},
    **{p: "matte" for p in ("not shiny", "non reflective")},
    "make up": "material", "paint colour": "color", "paint color": "color", "shade of paint": "color",
    "all terrain bike": "mountain bike", "all terrain bicycle": "mountain bike",
    **{p: "tandem bike" for p in ("two seater bike", "two seater bicycle", "two seat bike", "bicycle built for two",
                                  "bike built for two", "bicycle for two", "bike for two")},
    **{p: "articulated bus" for p in ("two section bus", "jointed bus", "hinged bus", "accordion bus")},
    **{p: "fighter jet" for p in ("combat jet", "combat plane")},
    "jumbo jet": "airliner", "motor car": "car", "motor cars": "cars", "passenger car": "car",
    "passenger cars": "cars", "shooting brake": "station wagon", "people mover": "people carrier",
    "hand grip": "handle", "hand grips": "handles", "rear hatch": "trunk", "bumper bar": "bumper",
    "piece of": "part of", "pieces of": "parts of",
    # comparisons
    "coloured like": "the same color as", "colored like": "the same color as",
    "made of the same thing": "made of the same material", "made from the same thing": "made of the same material",
    "outnumbered by": "fewer than",
})

#: Adjectives before a noun phrase that the corpus says after it ("the left-facing red car" -> "the red car facing
#: to the left"): read as their phrase, moved behind the noun phrase that follows.
POSTPOSED: Mapping[str, str] = MappingProxyType({
    "left facing": "facing to the left", "right facing": "facing to the right",
    "leftward facing": "facing to the left", "rightward facing": "facing to the right",
    "camera facing": "facing towards the camera", "forward facing": "facing towards the camera",
    "front facing": "facing towards the camera", "backward facing": "facing away from the camera",
    "rear facing": "facing away from the camera", "back facing": "facing away from the camera",
})
#: How far (in words) a postposed adjective's noun phrase may end.
NOUN_PHRASE_REACH = 5

_PHRASE_WORDS = {tuple(p.split()): (tuple(r.split()), False) for p, r in PHRASES.items()}
_PHRASE_WORDS.update({tuple(p.split()): (tuple(r.split()), True) for p, r in POSTPOSED.items()})
#: Longest phrase, in words.
MAX_PHRASE = max(len(p) for p in _PHRASE_WORDS)


def _noun_phrase_end(words: Sequence[str], start: int) -> int | None:
    """The index after the first run of object-noun words within reach of ``start`` (None if there is none)."""
    nouns = object_noun_words()
    for j in range(start, min(start + NOUN_PHRASE_REACH, len(words))):
        if words[j] in nouns:
            while j < len(words) and words[j] in nouns:
                j += 1
            return j
    return None


def paraphrase(words: Sequence[str], vocabulary: Mapping[str, int] | frozenset[str]
               ) -> tuple[list[str], list[tuple[str, str]]]:
    """``words`` with every phrase of :data:`PHRASES` and every out-of-vocabulary word of :data:`WORDS` read
    as its replacement (longest phrase first, left to right), and the (original, replacement) pairs. A
    replacement with a word outside ``vocabulary`` is not applied."""
    out: list[str] = []
    rewrites: list[tuple[str, str]] = []
    i = 0
    while i < len(words):
        for size in range(min(MAX_PHRASE, len(words) - i), 1, -1):
            reading, postposed = _PHRASE_WORDS.get(tuple(words[i:i + size]), (None, False))
            if reading is not None and all(w in vocabulary for w in reading):
                end = (_noun_phrase_end(words, i + size) if postposed else None) or i + size
                reading = (*words[i + size:end], *reading)  # a postposed adjective follows its noun phrase
                rewrites.append((" ".join(words[i:end]), " ".join(reading)))
                out.extend(reading)
                i = end
                break
        else:
            word = words[i]
            reading = WORDS.get(word)
            if word not in vocabulary and reading is not None and all(w in vocabulary for w in reading.split()):
                rewrites.append((word, reading))
                out.extend(reading.split())
            else:
                out.append(word)
            i += 1
    return out, rewrites

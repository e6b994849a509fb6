"""Words for program values: question text from templates, and answers in the public style (spec §3.4).

Readable names come from the ontology (``SUBTYPE_WORDS``, ``readable_name``); this module adds the synonyms and
the small amount of English (plurals, a/an, optional segments) that template filling needs.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

import numpy as np

from po3d_ppl import ontology

#: Alternative wordings of attribute values and of the null description.
SYNONYMS: dict[str, tuple[str, ...]] = {
    "large": ("large", "big"),
    "small": ("small", "tiny"),
    "metal": ("metal", "metallic", "shiny"),
    "rubber": ("rubber", "matte"),
    "thing": ("thing", "object"),
    "motorbike": ("motorbike", "motorcycle"),
    "aeroplane": ("aeroplane", "airplane", "plane"),
    "bicycle": ("bicycle", "bike"),
}

#: How a facing direction (``front_pose`` ...) is said after "faces".
POSE_WORDS: dict[str, tuple[str, ...]] = {
    "front_pose": ("front", "forward", "towards the camera"),
    "back_pose": ("back", "backward", "away from the camera"),
    "left_pose": ("left", "to the left"),
    "right_pose": ("right", "to the right"),
}

#: How a spatial relation is said between two object descriptions.
RELATION_WORDS: dict[str, tuple[str, ...]] = {
    "left": ("left of", "to the left of", "on the left side of"),
    "right": ("right of", "to the right of", "on the right side of"),
    "behind": ("behind",),
    "front": ("in front of",),
    "above": ("above", "higher than"),
    "below": ("below", "lower than"),
    "closer": ("closer to the camera than", "nearer to the camera than"),
    "farther": ("farther from the camera than", "further away from the camera than"),
}

_PLACEHOLDER = re.compile(r"<([A-Z])(\d*)>(s?)")
_OPTIONAL = re.compile(r"\[([^\[\]]*)\]")
_ARTICLE = re.compile(r"\b([Aa])n? (?=(\w+))")
#: Words whose spelling misleads the a/an rule (``a utility bike``, ``an suv``).
_SAYS_CONSONANT = ("uti", "uni", "use", "one")
_SAYS_VOWEL = ("suv",)


def _article_n(word: str) -> str:
    word = word.lower()
    vowel = word[:1] in ("a", "e", "i", "o", "u") and not word.startswith(_SAYS_CONSONANT)
    return "n" if vowel or word.startswith(_SAYS_VOWEL) else ""


def _choose(rng: np.random.Generator, options: tuple[str, ...]) -> str:
    return options[int(rng.integers(len(options)))] if len(options) > 1 else options[0]


def plural(noun_phrase: str) -> str:
    """Plural of a noun phrase ending in a countable noun (``road bike`` -> ``road bikes``, ``bus`` -> ``buses``)."""
    if noun_phrase.endswith(("s", "x", "ch", "sh")):
        return noun_phrase + "es"
    return noun_phrase + "s"


def value_words(value_type: str, value: str | None, rng: np.random.Generator) -> str:
    """Words for a template slot; ``None`` is the null description ('' / 'thing' / 'part')."""
    if value is None:
        if value_type == "Shape":
            return _choose(rng, SYNONYMS["thing"])
        return "part" if value_type == "Partname" else ""
    if value_type == "Pose":
        return _choose(rng, POSE_WORDS[value])
    if value_type == "Relation":
        return _choose(rng, RELATION_WORDS[value])
    if value_type == "Shape" and value in ontology.SUBTYPE_WORDS:
        return ontology.SUBTYPE_WORDS[value]
    if value in SYNONYMS:
        return _choose(rng, SYNONYMS[value])
    if value_type == "Partname":
        return ontology.readable_name(value)
    return value


def fill_text(text: str, param_types: Mapping[str, str], assignment: Mapping[str, str | None],
              rng: np.random.Generator) -> str:
    """Instantiate a template text: placeholders, ``<S>s`` plurals, ``[optional]`` segments, a/an, spacing."""
    text = _OPTIONAL.sub(lambda m: m.group(1) if rng.random() < 0.5 else "", text)

    def replace(match: re.Match) -> str:
        name = f"<{match.group(1)}{match.group(2)}>"
        words = value_words(param_types[name], assignment.get(name), rng)
        return plural(words) if match.group(3) and words else words

    text = _PLACEHOLDER.sub(replace, text)
    text = re.sub(r"\s+", " ", text).strip()
    text = re.sub(r" ([?,.;'])", r"\1", text)
    text = _ARTICLE.sub(lambda m: m.group(1) + _article_n(m.group(2)) + " ", text)
    return text[:1].upper() + text[1:]


def verbalise_answer(value: object, output_type: str) -> object:
    """The public answer for a raw value: readable part and shape names; Bool and Integer stay raw."""
    if output_type in ("Bool", "Integer"):
        return value
    if output_type == "Shape":
        return ontology.SUBTYPE_WORDS.get(value, ontology.readable_name(value))
    if output_type == "Partname":
        return ontology.readable_name(value)
    if isinstance(value, str):
        return value
    raise ValueError(f"cannot verbalise a {output_type} value ({value!r}): only attribute, Bool and Integer "
                     "values are answers")

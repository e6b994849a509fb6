"""Surface forms of every program value: the words people and the public files use for shapes, parts, attributes,
poses and relations, derived from :mod:`po3d_ppl.ontology` (declared once here, used by the question realiser that
writes the parser's training questions, by the parser's word normaliser, and by answers in words).

Why one table: the parser can only read what its training questions say, and the answer words must be the words
questions use. Deriving both from the ontology keeps them from drifting apart.

- Shapes: the public ``Shapename`` words (``school bus``), the bare subtype (``school``), joined forms (``schoolbus``),
  the category word (hypernym), synonyms (``motorcycle``, ``airplane``) and plurals, including the public
  generator's plural quirk (``buss``: it appends ``s``).
- Parts: the public readable name (``back left wheel``), the raw name read as words (``wheel back left``), spaced and
  joined forms (``tail light`` / ``taillight``, ``side stand`` / ``sidestand``, ``rear light`` / ``rearlight``), and
  British/American variants (``licence`` / ``license``). Spellings that name *another* value (``headlight`` is the
  motorbike's part, ``head light`` the car's) are only offered where the object's category decides.
"""

from __future__ import annotations

from functools import cache
from types import MappingProxyType

from po3d_ppl import ontology

#: Attribute words: the value first (how answers say it), then synonyms questions use.
ATTRIBUTE_FORMS: MappingProxyType = MappingProxyType({
    "large": ("large", "big", "huge"),
    "small": ("small", "tiny", "little"),
    "metal": ("metal", "metallic", "shiny"),
    "rubber": ("rubber", "matte"),
    "gray": ("gray", "grey"),
    **{c: (c,) for c in ontology.COLORS if c != "gray"},
})

#: Nouns for "any object" (the null shape).
THING_FORMS: tuple[str, ...] = ("thing", "object", "vehicle", "item", "entity")
THING_PLURALS: tuple[str, ...] = ("things", "objects", "vehicles", "items", "entities")

#: Category words (hypernyms) and their synonyms.
_CATEGORY_FORMS = {
    "car": ("car", "automobile"),
    "bus": ("bus", "coach"),
    "motorbike": ("motorbike", "motorcycle", "motor bike"),
    "aeroplane": ("aeroplane", "airplane", "plane", "aircraft"),
    "bicycle": ("bicycle", "bike", "cycle", "push bike", "pedal bike"),
}
#: Subtype forms beyond the public word (``ontology.SUBTYPE_WORDS``).
_SUBTYPE_EXTRA = {
    "suv": ("suv", "sport utility vehicle"), "wagon": ("wagon", "station wagon", "estate car", "estate"),
    "minivan": ("minivan", "mini van", "people carrier"),
    "sedan": ("sedan", "saloon", "saloon car"), "truck": ("truck", "pickup truck"),
    "articulated": ("articulated bus", "articulated", "bendy bus"), "regular": ("regular bus", "normal bus", "ordinary bus", "standard bus", "city bus"),
    "double": ("double bus", "double decker bus", "double decker", "double-decker bus"),
    "school": ("school bus", "schoolbus"),
    "chopper": ("chopper", "chopper motorbike"),
    "dirtbike": ("dirtbike", "dirt bike", "off-road motorbike", "off road bike", "motocross bike", "trail bike"),
    "scooter": ("scooter", "motor scooter"), "cruiser": ("cruiser", "cruiser motorbike"),
    "jet": ("jet", "jet plane", "private jet", "business jet"), "fighter": ("fighter", "fighter jet", "fighter plane"),
    "biplane": ("biplane", "bi plane"), "airliner": ("airliner", "passenger plane", "passenger jet", "jetliner"),
    "road": ("road bike", "roadbike", "road bicycle"), "utility": ("utility bike", "utility bicycle"),
    "mountain": ("mountain bike", "mountainbike", "mountain bicycle"), "tandem": ("tandem bike", "tandem",
                                                                                "tandem bicycle"),
}

#: How the facing direction of an object (``filter_pose`` value / ``query_pose`` answer) is said.
POSE_FORMS: MappingProxyType = MappingProxyType({
    "front_pose": ("front", "forward", "towards the camera", "toward the camera", "the front"),
    "back_pose": ("back", "backward", "away from the camera", "the back", "backwards", "away"),
    "left_pose": ("left", "to the left", "the left", "leftward"),
    "right_pose": ("right", "to the right", "the right", "rightward"),
})

#: Spatial relations between two objects.
RELATION_FORMS: MappingProxyType = MappingProxyType({
    "left": ("left of", "to the left of", "on the left side of", "on the left of"),
    "right": ("right of", "to the right of", "on the right side of", "on the right of"),
    "behind": ("behind",),
    "front": ("in front of",),
    "above": ("above", "higher than"),
    "below": ("below", "lower than", "beneath"),
    "closer": ("closer to the camera than", "nearer to the camera than", "closer than"),
    "farther": ("farther from the camera than", "further away from the camera than", "farther away than"),
})

#: Spaced / joined variants of part words (either direction).
_JOINED = {"tail light": "taillight", "head light": "headlight", "side stand": "sidestand",
           "rear light": "rearlight", "gas tank": "gastank", "license plate": "licenseplate",
           "wind screen": "windscreen", "tail plane": "tailplane", "crank arm": "crankarm",
           "drive chain": "drivechain", "foot rest": "footrest"}
#: Other words for part words (applied word by word).
_PART_WORD_SYNONYMS = {"license": ("license", "licence"), "back": ("back", "rear"), "center": ("center", "centre",
                                                                                               "middle"),
                       "mid": ("mid", "middle"), "gas": ("gas", "fuel"), "windscreen": ("windscreen", "windshield")}
#: Other names for whole part phrases (British/American, trade and everyday names), applied to every spelling.
_PART_PHRASE_SYNONYMS = {"side stand": ("kickstand", "kick stand"), "sidestand": ("kickstand",),
                         "tail light": ("tail lamp", "rear lamp"), "taillight": ("tail lamp", "rear lamp"),
                         "head light": ("head lamp", "headlamp"), "headlight": ("headlamp", "head lamp"),
                         "rear light": ("back light", "rear lamp"), "rearlight": ("back light",),
                         "license plate": ("number plate", "registration plate"),
                         "licence plate": ("number plate",), "trunk": ("boot",), "hood": ("bonnet",),
                         "fender": ("mudguard", "mud guard"), "handle": ("handlebar", "handle bar"),
                         "fin": ("tail fin", "vertical stabilizer", "vertical stabiliser"),
                         "tailplane": ("horizontal stabilizer", "horizontal stabiliser", "tail plane"),
                         "propeller": ("prop", "propellor"), "exhaust": ("exhaust pipe",),
                         "gas tank": ("petrol tank", "tank"), "crank arm": ("crank",), "drive chain": ("chain",),
                         "windscreen": ("windshield",), "mirror": ("side mirror",), "saddle": ("bike seat",)}


def _join_forms(words: str) -> set[str]:
    out = {words}
    for spaced, joined in _JOINED.items():
        for w in tuple(out):  # a snapshot: the loop adds to ``out``
            if spaced in w:
                out.add(w.replace(spaced, joined))
            if joined in w.split():
                out.add(" ".join(spaced if t == joined else t for t in w.split()))
    return out


def _word_synonyms(words: str) -> set[str]:
    out = {""}
    for token in words.split():
        options = _PART_WORD_SYNONYMS.get(token, (token,))
        out = {f"{prefix} {o}".strip() for prefix in out for o in options}
    return out


@cache
def _primary_part_forms(value: str) -> tuple[str, ...]:
    """The readable name and the raw name read as words, with word synonyms (``rear`` for ``back``)."""
    readable = ontology.readable_name(value)
    raw_words = value.replace("_", " ").removesuffix(" s")
    forms = [readable]
    for base in (readable, raw_words):
        forms += sorted(_word_synonyms(base))
    return tuple(dict.fromkeys(forms))


def _phrase_synonyms(words: str) -> set[str]:
    out = {words}
    padded = f" {words} "
    for phrase, others in _PART_PHRASE_SYNONYMS.items():
        if f" {phrase} " in padded:
            out.update(padded.replace(f" {phrase} ", f" {o} ").strip() for o in others)
    return out


@cache
def _secondary_part_forms(value: str) -> tuple[str, ...]:
    """Spaced / joined variants of the primary forms (``tail light`` <-> ``taillight``) and other names of the
    part (``boot`` for ``trunk``, ``kickstand`` for ``side stand``)."""
    primary = _primary_part_forms(value)
    joined = [f for p in primary for f in sorted(_join_forms(p))]
    forms = joined + [o for f in joined for o in sorted(_phrase_synonyms(f))]
    return tuple(dict.fromkeys(f for f in forms if f not in primary))


@cache
def _claims() -> dict[str, frozenset[str]]:
    """Form -> every canonical value that has it as a primary or secondary form."""
    claims: dict[str, set[str]] = {}
    for value in ontology.CANONICAL_PARTNAME_VALUES:
        for form in (*_primary_part_forms(value), *_secondary_part_forms(value)):
            claims.setdefault(form, set()).add(value)
    return {k: frozenset(v) for k, v in claims.items()}


@cache
def part_forms(value: str) -> tuple[str, ...]:
    """Every wording of a canonical part-name value that names it alone, its readable name first (what answers
    say). A spaced or joined variant that another value also reads as (``left headlight`` is the motorbike's
    ``headlight_left``, ``left head light`` the car's ``head_light_left``) is left to
    :func:`part_forms_for_category`."""
    claims = _claims()
    primary = [f for f in _primary_part_forms(value) if claims[f] == {value}
               or all(f not in _primary_part_forms(v) for v in claims[f] - {value})]
    return tuple(primary + [f for f in _secondary_part_forms(value) if claims[f] == {value}])


@cache
def _categories_of_part(value: str) -> frozenset[str]:
    return frozenset(ontology.CATEGORY_OF[s] for s, parts in ontology.PARTS.items()
                     if any(ontology.spelt_alike(p, value) for p in parts))


@cache
def part_forms_for_category(value: str, category: str) -> tuple[str, ...]:
    """Wordings of ``value`` when the owner's category is known: also the spaced/joined spellings that no other
    value of that category reads as (a car's ``head_light_left`` may be called its "left headlight": the
    motorbike's value of that spelling is no part of a car)."""
    forms = list(part_forms(value))
    claims = _claims()
    for form in (*_primary_part_forms(value), *_secondary_part_forms(value)):
        if form not in forms and all(category not in _categories_of_part(v) for v in claims[form] - {value}):
            forms.append(form)
    return tuple(forms)


@cache
def shape_forms(value: str) -> tuple[str, ...]:
    """Singular wordings of a shape value (subtype or category), the public ``Shapename`` word first."""
    if value in _CATEGORY_FORMS:
        return _CATEGORY_FORMS[value]
    public = ontology.SUBTYPE_WORDS[value]
    return tuple(dict.fromkeys((public, *_SUBTYPE_EXTRA.get(value, (value,)))))


def plural(noun_phrase: str) -> str:
    """English plural of a noun phrase ending in a countable noun (``road bike`` -> ``road bikes``)."""
    if noun_phrase.endswith(("s", "x", "ch", "sh")):
        return noun_phrase + "es"
    if noun_phrase.endswith("y") and noun_phrase[-2:-1] not in "aeiou":
        return noun_phrase[:-1] + "ies"
    return noun_phrase + "s"


def plural_forms(form: str) -> tuple[str, ...]:
    """Plurals of one singular form: the English one and, for buses, the public generator's ``buss``."""
    english = plural(form)
    quirk = form + "s"
    return (english, quirk) if quirk != english else (english,)


@cache
def lexicon_words() -> frozenset[str]:
    """Every word of every surface form (the parser's normaliser prefers these when correcting typos)."""
    words: set[str] = set()
    groups = [*ATTRIBUTE_FORMS.values(), THING_FORMS, THING_PLURALS, *POSE_FORMS.values(), *RELATION_FORMS.values()]
    groups += [shape_forms(v) for v in ontology.SHAPE_VALUES]
    groups += [tuple(p for f in shape_forms(v) for p in plural_forms(f)) for v in ontology.SHAPE_VALUES]
    groups += [(*_primary_part_forms(v), *_secondary_part_forms(v)) for v in ontology.CANONICAL_PARTNAME_VALUES]
    for group in groups:
        for form in group:
            words.update(form.split())
    return frozenset(words)


@cache
def object_noun_words() -> frozenset[str]:
    """The words of every noun phrase naming an object (shapes, their plurals, "thing" and its synonyms): where a
    noun phrase ends, for words that must follow it."""
    forms = [*THING_FORMS, *THING_PLURALS]
    for value in ontology.SHAPE_VALUES:
        forms += [*shape_forms(value), *(p for f in shape_forms(value) for p in plural_forms(f))]
    return frozenset(w for form in forms for w in form.split())


#: Words for answer values that are not said as the value itself.
_BOOL_WORDS = {True: "yes", False: "no"}


def value_words(value: object, value_type: str) -> str:
    """The words a person expects for a raw answer value, as the public question files write answers:
    ``school`` -> "school bus", ``wheel_back_left`` -> "back left wheel", ``True`` -> "yes", ``left_pose`` /
    ``left`` -> "left", ``3`` -> "3"."""
    if value_type == "Bool" or isinstance(value, bool):
        return _BOOL_WORDS[bool(value)]
    if value_type == "Integer":
        return str(int(value))
    text = str(value)
    if value_type == "Shape":
        return shape_forms(text)[0] if text in ontology.SHAPE_VALUES else ontology.readable_name(text)
    if value_type == "Partname":
        return ontology.readable_name(text)
    if value_type in ("Pose", "Direction"):
        return text.removesuffix("_pose")
    return text.replace("_", " ")

"""The vocabulary of the world: the single source of truth for categories, subtypes, parts and attributes.

Everything here is derived from the two files of the public release that ship in ``world/data``:
``part_dict.json`` (raw part names per subtype; the *order* of each list defines part ids, spec §1.4) and
``properties.json`` (colour RGB, sizes, hierarchy, model boxes). Every other module imports its names from here, so the
world, the question engine, the grammar and the reasoning engine cannot drift apart.

Conventions:
- subtype ids follow ``SUBTYPES`` (grouped by category, in the order of spec §1.4);
- part ids are positions in ``PARTS[subtype]``;
- ``addi`` ("regular car") exists in the public metadata but is never rendered; it is kept only in
  :data:`HYPERNYM_MEMBERS` so imported public programs that mention it still resolve.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from functools import cache
from importlib import resources
from types import MappingProxyType

from po3d_ppl.errors import UnknownNameError


def _load(name: str) -> dict:
    return json.loads(resources.files("po3d_ppl.world.data").joinpath(name).read_text())


_PART_DICT = _load("part_dict.json")
_PROPERTIES = _load("properties.json")

#: The five categories (hypernyms), in the order used for category ids.
CATEGORIES: tuple[str, ...] = ("car", "bus", "motorbike", "aeroplane", "bicycle")

#: The 21 rendered subtypes, grouped by category (spec §1.4 order). Index = subtype id.
SUBTYPES: tuple[str, ...] = (
    "suv", "wagon", "minivan", "sedan", "truck",
    "articulated", "regular", "double", "school",
    "chopper", "dirtbike", "scooter", "cruiser",
    "jet", "fighter", "biplane", "airliner",
    "road", "utility", "mountain", "tandem",
)

#: subtype -> category, from ``properties.json`` ``info_hier``.
CATEGORY_OF: MappingProxyType = MappingProxyType(
    {s: cat for cat, members in _PROPERTIES["info_hier"].items() for s in members if s in SUBTYPES}
)

#: category -> all public subtypes, ``addi`` included (it only matters for hypernym matching).
HYPERNYM_MEMBERS: MappingProxyType = MappingProxyType(
    {cat: tuple(members) for cat, members in _PROPERTIES["info_hier"].items()}
)

#: subtype -> raw part names, in the order that defines part ids.
PARTS: MappingProxyType = MappingProxyType({s: tuple(_PART_DICT[s]) for s in SUBTYPES})

#: Largest number of parts of any subtype (cruiser: 26). Part-slot tensors have this width.
MAX_PARTS: int = max(len(p) for p in PARTS.values())

#: Every distinct raw part name (85), sorted. Index = global raw-part id.
RAW_PART_NAMES: tuple[str, ...] = tuple(sorted({n for names in PARTS.values() for n in names}))

COLORS: tuple[str, ...] = tuple(_PROPERTIES["colors"])
COLOR_RGB: MappingProxyType = MappingProxyType({c: tuple(v) for c, v in _PROPERTIES["colors"].items()})
MATERIALS: tuple[str, ...] = tuple(_PROPERTIES["materials"])  # ("rubber", "metal")
SIZES: tuple[str, ...] = tuple(_PROPERTIES["sizes"])  # ("large", "small")
SIZE_SCALE: MappingProxyType = MappingProxyType(dict(_PROPERTIES["sizes"]))
#: subtype -> the public model's bounding-box size ``info_box`` as listed (width, length, height; bicycles:
#: length, width, height). ``meshes.canonical_extents`` turns it into our mesh frame.
INFO_BOX: MappingProxyType = MappingProxyType({s: tuple(_PROPERTIES["info_box"][s]) for s in SUBTYPES})

#: The four facing directions of an object relative to the camera (spec §1.7).
POSES: tuple[str, ...] = ("front", "back", "left", "right")
#: Pose labels as stored in scene files; ``"None"`` marks the 30-degree dead zones.
POSE_LABELS: tuple[str, ...] = tuple(f"{p}_pose" for p in POSES)
NO_POSE = "None"

#: The spatial relations of CLEVR (computed from 3D coordinates and the camera's ground directions).
RELATIONS: tuple[str, ...] = ("left", "right", "behind", "front")
#: Height and depth relations for the elevated-aeroplane extension (paper §6): ``above``/``below`` compare world
#: heights, ``closer``/``farther`` compare distances to the camera, with the same margin as CLEVR's relations.
HEIGHT_DEPTH_RELATIONS: tuple[str, ...] = ("above", "below", "closer", "farther")

_DIRECTION_TOKENS = frozenset({"right", "left", "front", "back", "center", "mid"})


def super_part_name(raw: str) -> str:
    """The coarse part name shared by all instances: ``wheel_back_left`` -> ``wheel``, ``exhaust_left_s`` -> ``exhaust``."""
    return "_".join(t for t in raw.split("_") if t not in _DIRECTION_TOKENS and t != "s")


def readable_name(value: str) -> str:
    """Words for a raw name, the public ``post_process_part_name`` rule (spec §3.4).

    Split on ``_``, drop a trailing ``s`` token and move trailing direction tokens to the front:
    ``wheel_back_left`` -> ``back left wheel``, ``door_left_s`` -> ``left door``.
    """
    tokens = value.split("_")
    if len(tokens) > 1 and tokens[-1] == "s":
        tokens = tokens[:-1]
    lead: list[str] = []
    while len(tokens) > 1 and tokens[-1] in _DIRECTION_TOKENS:
        lead.insert(0, tokens.pop())
    return " ".join(lead + tokens)


#: Words for each subtype (``metadata.types.Shapename``): buses and bikes carry their category word.
SUBTYPE_WORDS: MappingProxyType = MappingProxyType(
    {
        s: (f"{s} bus" if CATEGORY_OF[s] == "bus" else f"{s} bike" if CATEGORY_OF[s] == "bicycle" else s)
        for s in SUBTYPES
    }
)

#: Every coarse part name (35), sorted.
SUPER_PART_NAMES: tuple[str, ...] = tuple(sorted({super_part_name(n) for n in RAW_PART_NAMES}))

#: Values a ``filter_shape`` may take: subtypes and categories (hypernyms).
SHAPE_VALUES: tuple[str, ...] = SUBTYPES + CATEGORIES
#: Values a ``partfilter_partname`` may take: raw part names and super-part names. Every raw name stays a valid
#: value (imported public programs use them); two raw names with the same words select the same parts.
PARTNAME_VALUES: tuple[str, ...] = RAW_PART_NAMES + tuple(n for n in SUPER_PART_NAMES if n not in RAW_PART_NAMES)


def _joined(words: str) -> str:
    """A name's words with spaces and underscores dropped: "head light" and "headlight" are one word spelt two
    ways (the world's buses have ``head_light_left``, its cars ``headlight_left``), so they compare equal."""
    return words.replace(" ", "").replace("_", "")


@cache
def _raw_part_words() -> dict[str, str]:
    """Raw part name -> its readable words (looked up for every part a filter visits)."""
    return {name: readable_name(name) for name in RAW_PART_NAMES}


@cache
def _canonical_by_words() -> dict[str, str]:
    """Readable words -> the first (sorted) raw name with those words."""
    out: dict[str, str] = {}
    for name in RAW_PART_NAMES:  # sorted, so the first name of each group wins
        out.setdefault(readable_name(name), name)
    return out


def canonical_part_name(value: str) -> str:
    """The spelling of a part-name value that programs we generate use: for a raw part name, the first (sorted)
    raw name with the same words (``wheel_back_left`` -> ``back_left_wheel``); super-part names map to themselves.

    The public verbalisation gives 17 pairs of raw names the same words, so a question's text cannot choose
    between them; with one spelling per meaning, the program is a function of the text.
    """
    if value in SUPER_PART_NAMES and value not in RAW_PART_NAMES:
        return value
    if value not in RAW_PART_NAMES:
        raise UnknownNameError("part name", value, PARTNAME_VALUES)
    return _canonical_by_words()[readable_name(value)]


#: The part-name values generated programs (and the question parser) use: canonical raw names and the super-part
#: names that are not raw names, in :data:`PARTNAME_VALUES` order (85 = 68 + 17).
CANONICAL_PARTNAME_VALUES: tuple[str, ...] = tuple(v for v in PARTNAME_VALUES if canonical_part_name(v) == v)

#: Value vocabulary per value type, as used in programs.
VALUE_VOCABULARY: MappingProxyType = MappingProxyType(
    {
        "Color": COLORS,
        "Material": MATERIALS,
        "Size": SIZES,
        "Shape": SHAPE_VALUES,
        "Partname": PARTNAME_VALUES,
        "Pose": POSE_LABELS,
        "Relation": RELATIONS + HEIGHT_DEPTH_RELATIONS,
    }
)


def category_of(subtype: str) -> str:
    """Category of a subtype (``addi`` included), with a clear error for unknown names."""
    for cat, members in HYPERNYM_MEMBERS.items():
        if subtype in members:
            return cat
    raise UnknownNameError("subtype", subtype, SUBTYPES)


def shape_matches(subtype: str, value: str) -> bool:
    """``filter_shape`` semantics: the subtype itself or its category (hypernym) matches."""
    return value == subtype or value == category_of(subtype)


def partname_matches(raw: str, value: str) -> bool:
    """``partfilter_partname`` semantics: a part name means its words. ``value`` selects raw part ``raw`` if it
    is ``raw``'s super-part name (``wheel`` selects ``wheel_back_left``) or a raw name that reads the same
    (``back_left_wheel`` and ``wheel_back_left`` both read "back left wheel" and select both spellings). Spaced
    and joined forms of a word are the same word: ``headlight_left`` selects a bus's ``head_light_left`` and
    ``taillight`` a bus's tail lights, since a question says "the left headlight of the bus" either way.

    The public code uses a substring test (``'wheel' in 'wheel_front'``): it adds accidents (``'light'`` would
    match ``head_light``) and tells apart raw names that questions verbalise identically, so the question text
    would not determine the program. Matching by words makes both spellings of a name mean the same parts.
    """
    return _names_alike(raw, value, _joined)


def spelt_alike(raw: str, value: str) -> bool:
    """Whether ``value`` selects raw part ``raw`` *and* is spelt as it: its super-part name, or a raw name with the
    same words. Narrower than :func:`partname_matches`, which also takes joined forms for spaced ones; the lexicon
    uses it to choose which spelling a generated program writes (so the training corpus, and the shipped parsers
    trained on it, stay what they were before joined forms matched)."""
    return _names_alike(raw, value, lambda words: words)


def _names_alike(raw: str, value: str, spelling: Callable[[str], str]) -> bool:
    """``value`` is ``raw``'s super-part name or a raw name with its words, compared as ``spelling`` writes them."""
    if spelling(value) == spelling(super_part_name(raw)):
        return True
    words = _raw_part_words().get(value)
    return words is not None and spelling(words) == spelling(_raw_part_words()[raw])


@cache
def canonical_names_selecting(raw: str) -> tuple[str, ...]:
    """The canonical part-name values (:data:`CANONICAL_PARTNAME_VALUES`) that select raw part ``raw``."""
    return tuple(v for v in CANONICAL_PARTNAME_VALUES if partname_matches(raw, v))


def part_id(subtype: str, raw: str) -> int:
    """Part id of raw part ``raw`` in ``subtype`` (its index in the part list)."""
    try:
        return PARTS[subtype].index(raw)
    except ValueError:
        raise UnknownNameError(f"part of {subtype}", raw, PARTS[subtype]) from None
    except KeyError:
        raise UnknownNameError("subtype", subtype, SUBTYPES) from None


def pose_label(pose_degree: float) -> str:
    """Pose label of an azimuth in degrees, with the 30-degree dead zones of spec §1.7.

    ``pose_degree`` is the clockwise angle (seen from above) from the viewing direction to the object's front: 0
    means the camera sees the object's back.
    """
    d = pose_degree % 360.0
    if d < 30.0 or d > 330.0:
        return "back_pose"
    if 60.0 < d <= 120.0:
        return "right_pose"
    if 150.0 < d <= 210.0:
        return "front_pose"
    if 240.0 < d <= 300.0:
        return "left_pose"
    return NO_POSE


def pose_relation(reference_degree: float, reference_label: str, other_degree: float) -> str | None:
    """Pairwise pose relation of spec §2.3: ``same`` if the azimuths differ by < 45 degrees, ``opposite`` if by
    > 135, else ``vertical``. ``None`` when the reference object's label is ``'None'`` (dead zone)."""
    if reference_label == NO_POSE:
        return None
    diff = abs(reference_degree - other_degree) % 360.0
    diff = min(diff, 360.0 - diff)
    if diff < 45.0:
        return "same"
    if diff > 135.0:
        return "opposite"
    return "vertical"

"""The question parser's training corpus: every template family instantiated without a scene, in many phrasings.

The parser needs (question, program) pairs that cover the language, not answers, so rendering scenes is
unnecessary: each family's params are drawn at random (respecting ``NULL`` / ``NOT-NULL`` / ``NOT_ALL_NULL`` /
``NEQ``, with part names drawn from the parts of the object's shape when the family names one), the shorthands
are expanded into concrete filters exactly as the generator expands them (one filter per non-null slot, in
side-input order), and the question is written either from the family's template text (``fill_text``: our
templates as a dataset build says them) or by the program realiser (:mod:`po3d_ppl.questions.realise`: many
phrasings composed from the program). Redundant descriptions (more attributes than needed, as the public generator
keeps some) are drawn with probability ``redundant``.

Families: the dataset template files (Super-CLEVR-3D's 61, our core and height/depth), the 90 CLEVR-core
families of ``templates/clevr/`` and the further forms of ``templates/extra/`` (object occlusion, pose and occlusion
counts, part counts). Deterministic from ``seed``; a different seed gives an unseen sample of the same
distribution (the in-distribution test).

Opt-in family sets (:data:`OPT_IN_FAMILIES`; ``CorpusConfig.extra_families``, ``po3d train parser
--extra-families NAME``) join the corpus only when named, so the default corpus stays what the shipped parser was
trained on: ``compare_relate`` (``templates/extra/compare_relate.json``, six integer comparisons of two counts
around one referent named once, with the realiser's "... than left of it" wording) trained the ensemble's second
and third members (docs/language.md); ``wording2`` (no families of its own: the realiser's second round of
phrasings, ``Realiser(wording=True)``) came from reading dev 2's misses. A named set's files take the place they sort to among their folder's files,
as when they were part of the default corpus, so those members' corpus is reproduced item for item.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from po3d_ppl import ontology
from po3d_ppl.errors import InputError
from po3d_ppl.language.json_io import program_from_json
from po3d_ppl.language.seq2seq.data import Example, canonical_targets
from po3d_ppl.questions.realise import Realiser, Unrealisable
from po3d_ppl.questions.template_format import (
    FILTER_KINDS,
    OBJECT_SLOTS,
    PART_SLOTS,
    TEMPLATE_FOLDERS,
    Template,
    load_template_file,
    load_template_folder,
    template_files,
)
from po3d_ppl.questions.verbalise import fill_text

#: Probability that an optional filter slot of each type is filled (minimal descriptions name one or two).
FILL = {"Shape": 0.65, "Color": 0.45, "Size": 0.3, "Material": 0.3, "Pose": 0.2, "Partname": 0.85}
#: Part names a shape's objects have (canonical values and their super-part names).
_PARTS_OF_CATEGORY = {
    cat: tuple(sorted({v for s, parts in ontology.PARTS.items() if ontology.CATEGORY_OF[s] == cat for p in parts
                       for v in (ontology.canonical_part_name(p), ontology.super_part_name(p))
                       if v in ontology.CANONICAL_PARTNAME_VALUES}))
    for cat in ontology.CATEGORIES
}


#: Family sets outside the default corpus, by name: their template files (``folder/file.json``), whether the
#: realiser also says two counts around one referent with the referent named once (``Realiser.compare_around``)
#: and whether it uses its second round of phrasings (``Realiser.wording``: indirect questions, same-attribute
#: counts said of the referent, the referent of two counts introduced first, "stand / sit / located", more shape
#: names; no template files of its own), and whether it uses its third (``Realiser.wording3``: from reading dev 4's
#: misses; no template files either).
OPT_IN_FAMILIES: dict[str, dict] = {
    "compare_relate": {"files": ("extra/compare_relate.json",), "compare_around": True, "wording": False,
                       "wording3": False},
    "wording2": {"files": (), "compare_around": False, "wording": True, "wording3": False},
    "wording3": {"files": (), "compare_around": False, "wording": False, "wording3": True},
}


@dataclass(frozen=True)
class CorpusConfig:
    seed: int = 0
    #: Share of questions written from the template text (the rest by the realiser).
    template_text: float = 0.35
    #: Share of questions with redundant descriptions.
    redundant: float = 0.15
    #: Names of :data:`OPT_IN_FAMILIES` sets to add (none: the default corpus).
    extra_families: tuple[str, ...] = ()

    def __post_init__(self):
        object.__setattr__(self, "extra_families", check_extra_families(self.extra_families))


def check_extra_families(names) -> tuple[str, ...]:
    """``names`` as a sorted tuple without repeats, each a key of :data:`OPT_IN_FAMILIES` (else an InputError)."""
    names = tuple(sorted(set(names or ())))
    unknown = [n for n in names if n not in OPT_IN_FAMILIES]
    if unknown:
        raise InputError("--extra-families", f"unknown family set {', '.join(map(repr, unknown))}; known: "
                                             f"{', '.join(OPT_IN_FAMILIES)}")
    return names


def corpus_families(extra_families: tuple[str, ...] = ()) -> list[Template]:
    """Every family the corpus draws from: the default ones, and those of the named opt-in sets."""
    wanted = {f for name in check_extra_families(extra_families) for f in OPT_IN_FAMILIES[name]["files"]}
    opt_in = {f for spec in OPT_IN_FAMILIES.values() for f in spec["files"]}
    families = [t for f in template_files() for t in load_template_file(f)]
    for folder in TEMPLATE_FOLDERS:
        for filename, templates in load_template_folder(folder).items():
            if filename not in opt_in or filename in wanted:
                families.extend(templates)
    return families


def family_group(template: Template) -> str:
    """``parts``, ``pose``, ``occlusion``, ``occlusion_by``, ``core``, ``height_depth``, ``clevr/zero_hop`` ..."""
    return template.filename.removesuffix(".json")


def _slot_params(template: Template) -> tuple[set[str], set[str]]:
    """Params that sit in filter slots (may be null) and params every program needs (concrete values)."""
    slots, needed = set(), set()
    for node in template.nodes:
        side = node.get("side_inputs", [])
        if node["type"] in FILTER_KINDS:
            if node["type"].startswith("relate_filter"):
                needed.add(side[0])
                side = side[1:]
            slots.update(side)
        else:
            needed.update(side)
    return slots, needed


def draw_assignment(template: Template, rng: np.random.Generator, redundant: bool) -> dict[str, str | None]:
    """Random param values for ``template`` that satisfy its value constraints (not its scene constraints)."""
    slots, needed = _slot_params(template)
    nulls = template.null_params()
    not_null = {p for c in template.constraints if c.type == "NOT-NULL" for p in c.params}
    groups = [c.params for c in template.constraints if c.type == "NOT_ALL_NULL"]
    neq = [c.params for c in template.constraints if c.type == "NEQ"]
    for _ in range(100):
        assign: dict[str, str | None] = {}
        shapes = []
        for name, ptype in template.param_types.items():
            if ptype == "Partname":
                continue
            if name in nulls:
                assign[name] = None
                continue
            fill = FILL.get(ptype, 1.0) if name in slots and name not in not_null else 1.0
            if redundant:
                fill = 1 - (1 - fill) * 0.35
            if name in needed or float(rng.random()) < fill:
                values = template.param_values[name]
                assign[name] = values[int(rng.integers(len(values)))]
                if ptype == "Shape":
                    shapes.append(assign[name])
            else:
                assign[name] = None
        for name, ptype in template.param_types.items():
            if ptype != "Partname":
                continue
            if name in nulls:
                assign[name] = None
                continue
            fill = FILL["Partname"] if name in slots and name not in not_null else 1.0
            if name in needed or float(rng.random()) < fill:
                pool = ontology.CANONICAL_PARTNAME_VALUES
                if shapes:  # the named object's own parts: "the car's headlight" is the car's head_light
                    shape = shapes[0]
                    pool = _PARTS_OF_CATEGORY[shape if shape in ontology.CATEGORIES else ontology.CATEGORY_OF[shape]]
                allowed = template.param_values[name]
                if len(allowed) < len(ontology.CANONICAL_PARTNAME_VALUES):  # a family restricted to some names
                    pool = tuple(v for v in pool if v in allowed) or allowed
                assign[name] = pool[int(rng.integers(len(pool)))]
            else:
                assign[name] = None
        if any(all(assign.get(p) is None for p in g) for g in groups):
            continue
        if any(assign.get(a) is not None and assign.get(a) == assign.get(b) for a, b in neq):
            continue
        if any(_all_null_part_key(node, assign) for node in template.nodes):
            continue
        return assign
    raise ValueError(f"{template.name}: no assignment satisfies the constraints")


def _all_null_part_key(node: dict, assign: dict) -> bool:
    side = node.get("side_inputs", [])
    return node["type"] in FILTER_KINDS and node["type"].startswith("partfilter") and bool(side) and all(
        assign.get(p) is None for p in side)


def expand(template: Template, assign: dict[str, str | None]) -> list[dict]:
    """The public node list of the program ``template`` gives for ``assign`` (the generator's expansion)."""
    out: list[dict] = []
    where: list[int] = []
    for node in template.nodes:
        kind, side = node["type"], node.get("side_inputs", [])
        inputs = [where[i] for i in node.get("inputs", [])]
        if kind in FILTER_KINDS:
            _, aggregate = FILTER_KINDS[kind]
            prev = inputs[0]
            if kind.startswith("relate_filter"):
                out.append({"type": "relate", "inputs": [prev], "value_inputs": [assign[side[0]]]})
                prev = len(out) - 1
                side = side[1:]
            slots = PART_SLOTS if kind.startswith("partfilter") else OBJECT_SLOTS
            for p in side:
                if assign.get(p) is not None:
                    out.append({"type": slots[template.param_types[p]], "inputs": [prev],
                                "value_inputs": [assign[p]]})
                    prev = len(out) - 1
            if aggregate is not None:
                out.append({"type": aggregate, "inputs": [prev], "value_inputs": []})
                prev = len(out) - 1
            where.append(prev)
        else:
            out.append({"type": kind, "inputs": inputs, "value_inputs": [assign[s] for s in side]})
            where.append(len(out) - 1)
    return out


#: Probability that a shape query whose referent names no shape is given one (realised questions only).
NAME_QUERIED_SHAPE = 0.4
_OBJECT_FILTERS = ("filter_size", "filter_color", "filter_material", "filter_pose", "filter_occludee")


def name_queried_shape(nodes: list[dict], rng: np.random.Generator, p: float = NAME_QUERIED_SHAPE) -> list[dict]:
    """Shape queries whose referent is described without a shape, given one now and then.

    CLEVR's shape templates leave the shape out of the description (the answer would be in the question), but
    people ask "What kind of vehicle is the car?" about a category to get its subtype, and redundant descriptions
    keep a subtype: ``... | filter_color[red] | unique | query_shape`` becomes ``... | filter_color[red] |
    filter_shape[car] | unique | query_shape`` (the public filter order puts the shape last). Category in four of
    five cases, else a subtype."""
    out = [dict(n, inputs=list(n.get("inputs", []))) for n in nodes]
    k = len(out) - 1
    while k >= 0:
        node = out[k]
        if node["type"] == "query_shape" and out[node["inputs"][0]]["type"] == "unique" and float(rng.random()) < p:
            u = node["inputs"][0]
            chain, j = [], out[u]["inputs"][0]
            while out[j]["type"] in (*_OBJECT_FILTERS, "filter_shape"):
                chain.append(out[j]["type"])
                j = out[j]["inputs"][0]
            if "filter_shape" not in chain:
                if float(rng.random()) < 0.8:
                    value = ontology.CATEGORIES[int(rng.integers(len(ontology.CATEGORIES)))]
                else:
                    value = ontology.SUBTYPES[int(rng.integers(len(ontology.SUBTYPES)))]
                new = {"type": "filter_shape", "inputs": [out[u]["inputs"][0]], "value_inputs": [value]}
                for n in out:
                    n["inputs"] = [i + 1 if i >= u else i for i in n["inputs"]]
                out.insert(u, new)
                out[u + 1]["inputs"] = [u]
        k -= 1
    return out


def generate_corpus(count: int, config: CorpusConfig = CorpusConfig(),
                    families: list[Template] | None = None) -> list[Example]:
    """``count`` examples, families drawn uniformly (each family its share, whatever its file)."""
    return list(iter_corpus(count, config, families))


def iter_corpus(count: int, config: CorpusConfig = CorpusConfig(),
                families: list[Template] | None = None) -> Iterator[Example]:
    families = families if families is not None else corpus_families(config.extra_families)
    rng = np.random.default_rng(config.seed)
    realiser = Realiser(rng, compare_around=any(OPT_IN_FAMILIES[n]["compare_around"] for n in config.extra_families),
                        wording=any(OPT_IN_FAMILIES[n]["wording"] for n in config.extra_families),
                        wording3=any(OPT_IN_FAMILIES[n]["wording3"] for n in config.extra_families))
    made = 0
    while made < count:
        template = families[int(rng.integers(len(families)))]
        assign = draw_assignment(template, rng, float(rng.random()) < config.redundant)
        nodes = expand(template, assign)
        program = canonical_targets(program_from_json(nodes))
        question = None
        if float(rng.random()) >= config.template_text:
            try:
                named = canonical_targets(program_from_json(name_queried_shape(nodes, rng)))
                question = realiser.question(named)
                program = named
            except Unrealisable:
                question = None
        if question is None:
            text = template.texts[int(rng.integers(len(template.texts)))]
            question = fill_text(text, template.param_types, assign, rng)
        made += 1
        yield Example(question, program, family_group(template), f"{template.filename}:{template.index}")

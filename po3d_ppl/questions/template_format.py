"""Question templates in the public JSON format (spec §3), loaded and checked once.

A template file is a JSON list of ``{"text": [...], "nodes": [...], "params": [...], "constraints": [...]}``.
Nodes are registry operations or the public template-only shorthands (``filter_unique`` ...), which the generator
expands into concrete filter nodes. One extension: a param may carry ``"values": [...]`` to restrict its
vocabulary (the height/depth templates restrict ``Relation`` to above/below or closer/farther).

Checking everything at load time (node types, param references, constraint types, that every text mentions every
param that can be non-null, and the type of every node) turns a template typo into an error that names the file
and family, instead of a generator that silently never emits that family.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from functools import cache
from importlib import resources

from po3d_ppl.catalogue import value_vocabulary
from po3d_ppl.errors import InputError
from po3d_ppl.language.typecheck import default_registry

#: Template-only node types, by what they consume and produce: (input type, emitted aggregation or None).
FILTER_KINDS: dict[str, tuple[str, str | None]] = {
    "filter": ("ObjectSet", None), "filter_unique": ("ObjectSet", "unique"),
    "filter_count": ("ObjectSet", "count"), "filter_exist": ("ObjectSet", "exist"),
    "relate_filter": ("Object", None), "relate_filter_unique": ("Object", "unique"),
    "relate_filter_count": ("Object", "count"), "relate_filter_exist": ("Object", "exist"),
    "partfilter": ("PartSet", None), "partfilter_unique": ("PartSet", "unique"),
    "partfilter_count": ("PartSet", "count"), "partfilter_exist": ("PartSet", "exist"),
}
#: Slot types a filter key may hold, and the concrete filter emitted for each.
OBJECT_SLOTS = {"Pose": "filter_pose", "Size": "filter_size", "Color": "filter_color", "Material": "filter_material",
                "Shape": "filter_shape"}
PART_SLOTS = {"Size": "partfilter_size", "Color": "partfilter_color", "Material": "partfilter_material",
              "Partname": "partfilter_partname"}
CONSTRAINT_TYPES = ("NULL", "NOT-NULL", "NOT_ALL_NULL", "OUT_NEQ", "NEQ")
_AGGREGATE_OUTPUT = {"unique": {"ObjectSet": "Object", "PartSet": "Part"}, "count": "Integer", "exist": "Bool"}
_PLACEHOLDER = re.compile(r"<[A-Z]\d*>")


class TemplateError(InputError):
    """A template file is malformed; the field names the file and family."""


@dataclass(frozen=True)
class Constraint:
    type: str
    params: tuple


@dataclass(frozen=True)
class Template:
    """One question family."""

    filename: str
    index: int
    texts: tuple[str, ...]
    nodes: tuple[dict, ...]
    #: placeholder -> value type, in declaration order
    param_types: dict[str, str]
    #: placeholder -> allowed values (the vocabulary of its type unless restricted)
    param_values: dict[str, tuple[str, ...]]
    constraints: tuple[Constraint, ...]
    #: output type of every node (after expansion, the type of its last emitted node)
    node_types: tuple[str, ...]

    @property
    def name(self) -> str:
        return f"{self.filename.removesuffix('.json')}[{self.index}]"

    @property
    def answer_type(self) -> str:
        return self.node_types[-1]

    def null_params(self) -> frozenset[str]:
        return frozenset(p for c in self.constraints if c.type == "NULL" for p in c.params)


def _node_output(where: str, node: dict, input_types: list[str], params: dict[str, str]) -> str:
    kind = node["type"]
    side = node.get("side_inputs", [])
    if kind in FILTER_KINDS:
        wanted, aggregate = FILTER_KINDS[kind]
        if input_types != [wanted]:
            raise TemplateError(where, f"{kind} takes one {wanted}, got {input_types}")
        slots = [params[s] for s in side]
        allowed = PART_SLOTS if kind.startswith("partfilter") else OBJECT_SLOTS
        if kind.startswith("relate_filter"):
            if not slots or slots[0] != "Relation":
                raise TemplateError(where, f"{kind} needs a Relation as its first side input")
            slots = slots[1:]
        bad = [t for t in slots if t not in allowed]
        if bad or not slots:
            raise TemplateError(where, f"{kind} side inputs must be of types {sorted(allowed)}, got {slots}")
        set_type = "PartSet" if kind.startswith("partfilter") else "ObjectSet"
        if aggregate is None:
            return set_type
        out = _AGGREGATE_OUTPUT[aggregate]
        return out[set_type] if isinstance(out, dict) else out
    registry = default_registry()  # the built-in operations, whichever module was imported first
    if kind not in registry:
        raise TemplateError(where, f"unknown node type {kind!r}")
    op = registry.resolve(kind, tuple(input_types))
    if op is None:
        raise TemplateError(where, f"{kind} does not accept inputs {input_types}")
    if len(side) != (1 if op.value else 0) or (op.value and params[side[0]] != op.value):
        raise TemplateError(where, f"{kind} needs {'one ' + op.value if op.value else 'no'} side input, got {side}")
    return op.output


def parse_template(filename: str, index: int, raw: dict) -> Template:
    where = f"{filename}[{index}]"
    for key in ("text", "nodes", "params"):
        if key not in raw:
            raise TemplateError(where, f"missing {key!r}")
    params: dict[str, str] = {}
    values: dict[str, tuple[str, ...]] = {}
    for p in raw["params"]:
        name, ptype = p.get("name"), p.get("type")
        if not isinstance(name, str) or not _PLACEHOLDER.fullmatch(name):
            raise TemplateError(where, f"param name {name!r} must look like <Z2>")
        vocab = value_vocabulary(ptype)
        restricted = tuple(p.get("values", vocab))
        if not set(restricted) <= set(vocab):
            raise TemplateError(where, f"param {name}: values {sorted(set(restricted) - set(vocab))} not in {ptype}")
        params[name], values[name] = ptype, restricted
    node_types: list[str] = []
    used: set[str] = set()
    for k, node in enumerate(raw["nodes"]):
        inputs = node.get("inputs", [])
        if any(not 0 <= i < k for i in inputs):
            raise TemplateError(f"{where}.nodes[{k}]", f"inputs {inputs} must name earlier nodes")
        for s in node.get("side_inputs", []):
            if s not in params:
                raise TemplateError(f"{where}.nodes[{k}]", f"side input {s} is not a declared param")
            used.add(s)
        node_types.append(_node_output(f"{where}.nodes[{k}]", node, [node_types[i] for i in inputs], params))
    constraints = []
    for c in raw.get("constraints", []):
        ctype, cparams = c.get("type"), tuple(c.get("params", ()))
        if ctype not in CONSTRAINT_TYPES:
            raise TemplateError(where, f"unknown constraint type {ctype!r} (known: {', '.join(CONSTRAINT_TYPES)})")
        if ctype == "OUT_NEQ":
            if len(cparams) != 2 or any(not isinstance(i, int) or not 0 <= i < len(node_types) for i in cparams):
                raise TemplateError(where, f"OUT_NEQ needs two node indices, got {list(cparams)}")
        elif any(p not in params for p in cparams) or (ctype == "NEQ" and len(cparams) != 2):
            raise TemplateError(where, f"{ctype} params {list(cparams)} must be declared params")
        constraints.append(Constraint(ctype, cparams))
    if set(params) - used:
        raise TemplateError(where, f"params {sorted(set(params) - used)} are declared but never used")
    tmpl = Template(filename, index, tuple(raw["text"]), tuple(raw["nodes"]), params, values, tuple(constraints),
                    tuple(node_types))
    if not tmpl.texts:
        raise TemplateError(where, "needs at least one text")
    nulls = tmpl.null_params()
    for text in tmpl.texts:
        mentioned = set(_PLACEHOLDER.findall(text))
        if mentioned - set(params):
            raise TemplateError(where, f"text {text!r} mentions undeclared {sorted(mentioned - set(params))}")
        missing = set(params) - nulls - mentioned
        if missing:
            raise TemplateError(where, f"text {text!r} does not mention {sorted(missing)}, which can be non-null")
    if tmpl.answer_type in ("ObjectSet", "PartSet", "Object", "Part"):
        raise TemplateError(where, f"the last node must give an answer value, not a {tmpl.answer_type}")
    return tmpl


@cache
def load_template_file(filename: str) -> tuple[Template, ...]:
    """The families of one shipped template file (e.g. ``parts.json``)."""
    try:
        text = resources.files("po3d_ppl.questions.templates").joinpath(filename).read_text()
    except FileNotFoundError:
        raise TemplateError("template file", f"{filename!r} is not shipped; known: {', '.join(template_files())}")
    return tuple(parse_template(filename, i, raw) for i, raw in enumerate(json.loads(text)))


def template_files() -> list[str]:
    return sorted(p.name for p in resources.files("po3d_ppl.questions.templates").iterdir()
                  if p.name.endswith(".json"))


#: Template folders beside the dataset files: families the question parser's corpus instantiates but dataset builds
#: do not (``clevr/``: the 90 CLEVR-core families; ``extra/``: further forms people ask). Files of an opt-in set
#: (``parser_corpus.OPT_IN_FAMILIES``, e.g. ``extra/compare_relate.json``) are listed here but enter the corpus only
#: when it names them.
TEMPLATE_FOLDERS = ("clevr", "extra")


@cache
def load_template_folder(folder: str) -> dict[str, tuple[Template, ...]]:
    """The families of every template file of a shipped folder, keyed ``folder/file.json``."""
    if folder not in TEMPLATE_FOLDERS:
        raise TemplateError("template folder", f"{folder!r} is not shipped; known: {', '.join(TEMPLATE_FOLDERS)}")
    root = resources.files("po3d_ppl.questions.templates").joinpath(folder)
    out = {}
    for path in sorted((p for p in root.iterdir() if p.name.endswith(".json")), key=lambda p: p.name):
        name = f"{folder}/{path.name}"
        out[name] = tuple(parse_template(name, i, raw) for i, raw in enumerate(json.loads(path.read_text())))
    return out

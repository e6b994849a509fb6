"""Instantiate question templates over a scene (spec §3.3, §3.5): a randomised depth-first search.

For each family we walk the template's nodes in order. Concrete nodes run the reference semantics; filter
shorthands (``filter_unique`` ...) enumerate filter keys from the scene's precomputed denotations
(:class:`FilterIndex`) and expand into concrete ``filter_*`` nodes plus ``unique``/``count``/``exist``. Every
partial state is checked against the template's constraints, so dead branches are cut early:

- ``NULL`` / ``NOT-NULL`` slots are fixed while enumerating keys (``NOT-NULL`` is enforced for every type);
- ``NOT_ALL_NULL`` rejects keys whose listed slots are all null; ``NEQ`` (the intended one) rejects two equal,
  non-null params; ``OUT_NEQ`` rejects equal outputs of two nodes (a set and one of its members also clash);
- part keys may not be all-null (spec §3.2);
- a ``unique`` must have exactly one member, a plain ``filter`` a non-empty output;
- after a relational step (relate, same_*, *_pose, occlusion relations and filters) a ``unique``/``filter`` key
  whose scene-wide denotation has at most one member is skipped: the key alone would identify the referent and
  make the relational step redundant (the public ``extra_filter`` rule, extended to every relational step);
- redundancy (``redundancy`` = the public ``--remove_redundant r``): with r > 0 a key is dropped with probability
  r when a key with one slot fewer selects the same members (r = 1: minimal descriptions only); with r < 0 each
  free slot is filled, with probability -r, with the value its members all share (for objects *and* parts; the
  public code crashes on parts).

The search returns a few *candidates* per family with distinct answers; :mod:`po3d_ppl.questions.balance`
chooses among them to balance answers across a whole dataset.

Under ``semantics="public"`` the generator follows the public code instead (docs/semantics.md rows 11-16, 21,
22): answers come from the public reference (:mod:`po3d_ppl.questions.public`); ``NOT-NULL`` is enforced only for
poses and need not be needed; ``NEQ`` skips when both params are set and *differ*; the ``extra_filter`` rule uses
the public list (``opposite_pose``, ``relate``, ``same_*`` and ``relate_occluding_part`` not covered) for every
aggregate; ``OUT_NEQ`` never sees a set equal to one of its members; with r > 0 keys redundant on the whole scene
are dropped too; r < 0 on part keys is the public crash (an :class:`~po3d_ppl.errors.InputError`); pose values
read "front pose"; a question that still holds a ``<Z>``/``<C>``/``<M>``/``<S>`` placeholder is dropped.
"""

from __future__ import annotations

import dataclasses
import math
import zlib
from dataclasses import dataclass
from functools import cache

import numpy as np

from po3d_ppl import ontology
from po3d_ppl.catalogue import REGISTRY, Operation, value_vocabulary
from po3d_ppl.catalogue.semantics import DEFAULT_SEMANTICS, PUBLIC
from po3d_ppl.errors import InputError
from po3d_ppl.questions.context import SceneContext
from po3d_ppl.questions.executor import implementation_for
from po3d_ppl.questions.filter_index import FilterIndex, Key
from po3d_ppl.questions.program import to_public_output
from po3d_ppl.questions.public import PUBLIC_RELATIONAL
from po3d_ppl.questions.reference import InvalidStep
from po3d_ppl.questions.template_format import FILTER_KINDS, OBJECT_SLOTS, PART_SLOTS, Template, load_template_file
from po3d_ppl.questions.verbalise import fill_text, verbalise_answer
from po3d_ppl.world.scene import Scene

#: Steps after which a following unique/filter key must not identify its referent on its own.
RELATIONAL = frozenset({
    "relate", "same_color", "same_material", "same_size", "same_shape", "same_pose", "opposite_pose",
    "vertical_pose", "filter_occludee", "partfilter_occludee", "relate_occluded", "relate_occluding",
    "relate_occluding_part", "filter_occluder",
})
_SET_TYPES = {"ObjectSet": "Object", "PartSet": "Part"}


def answer_support(answer_type: str) -> float:
    """How many different answers an output type can have (unbounded for counts)."""
    if answer_type == "Integer":
        return math.inf
    return 2 if answer_type == "Bool" else len(value_vocabulary(answer_type))


@dataclass(frozen=True)
class _Mask:
    """An intermediate filter output kept as a bitmask while searching."""

    mask: int
    part_level: bool


@dataclass(frozen=True)
class Candidate:
    """One instantiated question of a family (without image fields)."""

    template_filename: str
    question_family_index: int
    question: str
    program: tuple[dict, ...]
    answer: object
    answer_type: str

    @property
    def raw_answer(self) -> object:
        return self.program[-1]["_output"]

    def to_public(self) -> dict:
        return {"question": self.question, "program": [dict(n) for n in self.program], "answer": self.answer,
                "template_filename": self.template_filename, "question_family_index": self.question_family_index}

    def to_record(self) -> dict:
        """A JSON record that :meth:`from_record` restores exactly (used for a build's work files)."""
        return {**self.to_public(), "answer_type": self.answer_type}

    @classmethod
    def from_record(cls, record: dict) -> Candidate:
        return cls(record["template_filename"], record["question_family_index"], record["question"],
                   tuple(record["program"]), record["answer"], record["answer_type"])


@dataclass(frozen=True)
class _FilterStep:
    """Static description of one filter shorthand node of a template."""

    part_level: bool
    aggregate: str | None
    relation_param: str | None
    params: tuple[str, ...]
    slots: tuple[str, ...]
    emits: tuple[str, ...]
    forced_null: tuple[bool, ...]
    forced_nonnull: tuple[bool, ...]
    groups: tuple[tuple[int, ...], ...]
    #: Equal for steps that allow the same keys (whatever family they belong to), so they share cached options.
    options_id: int = -1


@dataclass(frozen=True)
class _Plan:
    template: Template
    steps: tuple[_FilterStep | Operation, ...]
    cross_groups: tuple[tuple[str, ...], ...]
    neq: tuple[tuple[str, str], ...]
    out_neq_at: dict[int, tuple[tuple[int, int], ...]]


_OPTION_IDS: dict[tuple, int] = {}


@cache
def _plan(filename: str, index: int) -> _Plan:
    tmpl = load_template_file(filename)[index]
    by_type: dict[str, list[tuple]] = {}
    for c in tmpl.constraints:
        by_type.setdefault(c.type, []).append(c.params)
    nulls = tmpl.null_params()
    nonnull = {p for ps in by_type.get("NOT-NULL", []) for p in ps}
    steps: list = []
    placed: list[set[str]] = []
    for k, node in enumerate(tmpl.nodes):
        side = list(node.get("side_inputs", []))
        kind = node["type"]
        if kind in FILTER_KINDS:
            relation = side.pop(0) if kind.startswith("relate_filter") else None
            part_level = kind.startswith("partfilter")
            slots = tuple(tmpl.param_types[p] for p in side)
            emit = PART_SLOTS if part_level else OBJECT_SLOTS
            groups = tuple(tuple(side.index(p) for p in g) for g in by_type.get("NOT_ALL_NULL", [])
                           if set(g) <= set(side))
            step = _FilterStep(part_level, FILTER_KINDS[kind][1], relation, tuple(side), slots,
                               tuple(emit[s] for s in slots), tuple(p in nulls for p in side),
                               tuple(p in nonnull for p in side), groups)
            signature = (part_level, step.aggregate, slots, step.forced_null, step.forced_nonnull, groups)
            steps.append(dataclasses.replace(step, options_id=_OPTION_IDS.setdefault(signature, len(_OPTION_IDS))))
        else:
            steps.append(REGISTRY.resolve(kind, tuple(tmpl.node_types[i] for i in node.get("inputs", []))))
        placed.append(set(node.get("side_inputs", [])))
    cross = tuple(tuple(g) for g in by_type.get("NOT_ALL_NULL", []) if not any(set(g) <= s for s in placed))
    out_neq: dict[int, list] = {}
    for i, j in by_type.get("OUT_NEQ", []):
        out_neq.setdefault(max(i, j), []).append((i, j))
    return _Plan(tmpl, tuple(steps), cross, tuple(tuple(p) for p in by_type.get("NEQ", [])),
                 {t: tuple(v) for t, v in out_neq.items()})


def _clash(a: object, ta: str, b: object, tb: str, public: bool = False) -> bool:
    if ta == tb:
        return a == b
    if public:  # the public code compares a set with a part, which are never equal
        return False
    if _SET_TYPES.get(ta) == tb:
        return b in a
    if _SET_TYPES.get(tb) == ta:
        return a in b
    return False


def family_rng(seed: int, filename: str, index: int) -> np.random.Generator:
    """The random stream of one family in one scene, independent of which other families run."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(zlib.crc32(filename.encode()), index)))


class SceneQuestionGenerator:
    """Generates candidate questions of any family over one scene, sharing the scene's filter denotations."""

    def __init__(self, scene: Scene | SceneContext, seed: int, *, redundancy: float = 1.0,
                 max_candidates: int = 3, budget: int = 150, semantics: str = DEFAULT_SEMANTICS):
        if not -1.0 <= redundancy <= 1.0:
            raise ValueError(f"redundancy must be in [-1, 1], got {redundancy}")
        self.ctx = scene if isinstance(scene, SceneContext) else SceneContext(scene, semantics)
        self.public = self.ctx.semantics == PUBLIC
        self.relational_steps = PUBLIC_RELATIONAL if self.public else RELATIONAL
        self.implementation = implementation_for(self.ctx)
        self.index = FilterIndex(self.ctx)
        self.seed, self.redundancy = int(seed), float(redundancy)
        self.max_candidates, self.budget = max_candidates, budget
        self._options: dict[tuple, tuple] = {}

    def candidates(self, filename: str, index: int) -> list[Candidate]:
        """Up to ``max_candidates`` well-posed questions of one family, with distinct answers."""
        return _Search(self, _plan(filename, index), family_rng(self.seed, filename, index)).run()

    # ---- filter options, shared by all families of the scene ----------------------------------------------
    def filter_options(self, step: _FilterStep, within: int, relational: bool) -> tuple[tuple, tuple]:
        """(key, output mask) pairs the step may use on input ``within``: (minimal keys, redundant keys).

        A key is redundant when a key with one slot fewer, also allowed, selects the same members; checking one
        slot fewer suffices because every key between two keys with equal outputs has that output too. Dropping
        a NOT-NULL slot counts even though the smaller key is not allowed: the pose in "the car that faces left"
        must be what singles the car out.
        """
        cache_key = (step.options_id, within, relational)
        found = self._options.get(cache_key)
        if found is not None:
            return found
        index = self.index
        scene_keys = index.keys(step.part_level, step.slots, step.forced_null)
        aggregate = step.aggregate
        if aggregate in ("count", "exist"):
            outs = {k: den & within for k, den in scene_keys.items()}
            outs.update(self._empty_keys(step, outs))
        else:
            outs = index.keys(step.part_level, step.slots, step.forced_null, within)
        check_scene = relational and (self.public or aggregate in (None, "unique"))
        nonnull = tuple(s for s, need in enumerate(step.forced_nonnull)
                        if need and (not self.public or step.slots[s] == "Pose"))
        groups = step.groups
        null_key = (None,) * len(step.slots) if step.part_level else None
        allowed: dict[Key, int] = {}
        for key, out in outs.items():
            if nonnull and any(key[s] is None for s in nonnull):
                continue
            if groups and any(all(key[s] is None for s in g) for g in groups):
                continue
            if key == null_key or (check_scene and scene_keys[key].bit_count() <= 1):
                continue
            allowed[key] = out
        minimal, redundant = [], []
        for key, out in allowed.items():
            if aggregate == "unique":
                if out.bit_count() != 1:
                    continue
            elif aggregate is None and not out:
                continue
            needed = True
            for s, v in enumerate(key):
                smaller = key[:s] + (None,) + key[s + 1:]
                if v is None:
                    continue
                if self.public:  # the public rule: same-size denotation, on the subset or on the whole scene
                    if allowed.get(smaller) == out or (smaller in scene_keys and key in scene_keys and
                                                       scene_keys[smaller].bit_count() == scene_keys[key].bit_count()):
                        needed = False
                        break
                # a NOT-NULL slot must also be needed: compare with the (disallowed) key without it
                elif (outs if s in nonnull else allowed).get(smaller) == out:
                    needed = False
                    break
            (minimal if needed else redundant).append((key, out))
        found = self._options[cache_key] = (tuple(minimal), tuple(redundant))
        return found

    def _empty_keys(self, step: _FilterStep, outs: dict[Key, int]) -> dict[Key, int]:
        """Keys of at most two slots that select nothing, made by adding one slot to a key that selects something
        (``red bus`` when there are red things and buses but no red bus), so count/exist questions also get the
        answers 0 / no. Object slots range over the whole vocabulary, part slots over the scene's values."""
        vocab = [self.index.values(step.part_level, slot) for slot in step.slots]
        if not step.part_level:
            vocab = [{v: vals.get(v, 0) for v in value_vocabulary(slot)} for slot, vals in zip(step.slots, vocab)]
        found: dict[Key, int] = {}
        for key, out in outs.items():
            if not out or sum(v is not None for v in key) > 1:
                continue
            for s, v in enumerate(key):
                if v is not None or step.forced_null[s]:
                    continue
                for value, vmask in vocab[s].items():
                    if out & vmask == 0:
                        found[key[:s] + (value,) + key[s + 1:]] = 0
        return {k: v for k, v in found.items() if k not in outs}

    def shared_value(self, part_level: bool, slot: str, out: int) -> str | None:
        """The value of ``slot`` that every member of ``out`` has, if any (for r < 0 redundant filters)."""
        for value, vmask in self.index.values(part_level, slot).items():
            if out & vmask == out and (slot != "Shape" or value in ontology.SUBTYPES) and (
                    slot != "Partname" or value in ontology.RAW_PART_NAMES):
                return value
        return None


class _Search:
    """One randomised depth-first instantiation of one template."""

    def __init__(self, gen: SceneQuestionGenerator, plan: _Plan, rng: np.random.Generator):
        self.gen, self.plan, self.rng = gen, plan, rng
        self.ctx, self.index = gen.ctx, gen.index
        self.tmpl = plan.template
        self.nodes: list[dict] = []
        self.outputs: list = []
        self.types: list[str] = []
        self.tmap: list[int] = []
        self.assign: dict[str, str | None] = {}
        self.found: list[Candidate] = []
        self.answers: set = set()
        self.visits = 0
        self.wanted = min(gen.max_candidates, answer_support(self.tmpl.answer_type))

    def run(self) -> list[Candidate]:
        self._visit(0)
        return self.found

    def _done(self) -> bool:
        return len(self.found) >= self.wanted or self.visits >= self.gen.budget

    # ---- state -------------------------------------------------------------------------------------------------
    def _push(self, function: str, inputs: list[int], values: list[str], output, out_type: str) -> None:
        self.nodes.append({"type": function, "inputs": inputs, "value_inputs": values})
        self.outputs.append(output)
        self.types.append(out_type)

    def _pop_to(self, length: int) -> None:
        del self.nodes[length:], self.outputs[length:], self.types[length:]

    def _constraints_ok(self, t: int) -> bool:
        a, plan = self.assign, self.plan
        for group in plan.cross_groups:
            if all(p in a for p in group) and all(a[p] is None for p in group):
                return False
        for p, q in plan.neq:
            if self.gen.public:  # the public (inverted) test: skip when both are set and differ
                if p in a and q in a and a[p] != a[q]:
                    return False
            elif a.get(p) is not None and a.get(p) == a.get(q):
                return False
        if t not in plan.out_neq_at:
            return True
        for i, j in plan.out_neq_at[t]:
            pi, pj = self.tmap[i], self.tmap[j]
            if _clash(self.outputs[pi], self.types[pi], self.outputs[pj], self.types[pj], self.gen.public):
                return False
        return True

    def _order(self, n: int):
        return self.rng.permutation(n) if n > 1 else range(n)

    # ---- search ------------------------------------------------------------------------------------------------
    def _visit(self, t: int) -> None:
        if self._done():
            return
        self.visits += 1
        if t == len(self.tmpl.nodes):
            self._emit()
            return
        step = self.plan.steps[t]
        if isinstance(step, _FilterStep):
            self._visit_filter(t, step)
        else:
            self._visit_op(t, step)

    def _visit_op(self, t: int, op: Operation) -> None:
        node = self.tmpl.nodes[t]
        inputs = [self.tmap[i] for i in node.get("inputs", [])]
        args = [self.outputs[i] for i in inputs]
        side = node.get("side_inputs", [])
        if side:
            param = side[0]
            if param in self.assign:
                choices = [self.assign[param]]
            else:
                pool = self.tmpl.param_values[param]
                choices = [pool[k] for k in self._order(len(pool))]
        else:
            param, choices = None, [None]
        mark = len(self.nodes)
        for value in choices:
            try:
                out = self.gen.implementation(op)(self.ctx, *args, *([value] if param else []))
            except InvalidStep:
                continue
            fresh = param is not None and param not in self.assign
            if fresh:
                self.assign[param] = value
            self._push(op.name, inputs, [value] if param else [], out, op.output)
            self.tmap.append(mark)
            if self._constraints_ok(t):
                self._visit(t + 1)
            self.tmap.pop()
            self._pop_to(mark)
            if fresh:
                del self.assign[param]
            if self._done():
                return

    def _visit_filter(self, t: int, step: _FilterStep) -> None:
        node = self.tmpl.nodes[t]
        source = self.tmap[node["inputs"][0]]
        if step.relation_param is None:
            self._filter_from(t, step, source, self.nodes[source]["type"] in self.gen.relational_steps)
            return
        param = step.relation_param
        pool = [self.assign[param]] if param in self.assign else list(self.tmpl.param_values[param])
        mark = len(self.nodes)
        for k in self._order(len(pool)):
            relation = pool[k]
            related = self.ctx.related(self.outputs[source], relation)
            fresh = param not in self.assign
            if fresh:
                self.assign[param] = relation
            self._push("relate", [source], [relation], related, "ObjectSet")
            self._filter_from(t, step, mark, not self.gen.public)  # raw relate is not in the public list
            self._pop_to(mark)
            if fresh:
                del self.assign[param]
            if self._done():
                return

    def _filter_from(self, t: int, step: _FilterStep, source: int, relational: bool) -> None:
        index = self.index
        members = self.outputs[source]
        within = index.part_mask(members) if step.part_level else index.object_mask(members)
        minimal, redundant = self.gen.filter_options(step, within, relational)
        r = self.gen.redundancy
        if r < 0 and step.part_level and self.gen.public:
            raise InputError("redundancy", f"{r} < 0 on part keys: the public generator crashes here "
                             "(np.random.choice(p=[r, 1 - r])); use r >= 0 under public semantics")
        if r >= 1:
            options = minimal
        elif r > 0:
            options = minimal + tuple(o for o in redundant if self.rng.random() >= r)
        else:
            options = minimal + redundant
        values = [index.values(step.part_level, s) for s in step.slots]
        set_type = "PartSet" if step.part_level else "ObjectSet"
        mark = len(self.nodes)
        for k in self._order(len(options)):
            key, out = options[k]
            if r < 0 and out:
                key = self._add_redundant(step, key, out, -r)
            for p, v in zip(step.params, key, strict=True):
                self.assign[p] = v
            prev, mask = source, within
            for s, v in enumerate(key):
                if v is None:
                    continue
                mask &= values[s].get(v, 0)
                # intermediate sets stay masks until the question is emitted (see _emit)
                self._push(step.emits[s], [prev], [v], _Mask(mask, step.part_level), set_type)
                prev = len(self.nodes) - 1
            if step.aggregate == "unique":
                self._push("unique", [prev], [], self._members(out, step.part_level)[0], _SET_TYPES[set_type])
            elif step.aggregate == "count":
                self._push("count", [prev], [], out.bit_count(), "Integer")
            elif step.aggregate == "exist":
                self._push("exist", [prev], [], bool(out), "Bool")
            elif prev != source:  # the filtered set feeds later nodes
                self.outputs[prev] = self._set(out, step.part_level)
            self.tmap.append(len(self.nodes) - 1)
            if self._constraints_ok(t):
                self._visit(t + 1)
            self.tmap.pop()
            self._pop_to(mark)
            for p in step.params:
                del self.assign[p]
            if self._done():
                return

    def _set(self, mask: int, part_level: bool) -> frozenset:
        return self.index.parts_of(mask) if part_level else self.index.objects_of(mask)

    def _members(self, mask: int, part_level: bool) -> list:
        return sorted(self._set(mask, part_level))

    def _add_redundant(self, step: _FilterStep, key: Key, out: int, probability: float) -> Key:
        filled = list(key)
        for s, v in enumerate(key):
            if v is None and not step.forced_null[s] and self.rng.random() < probability:
                filled[s] = self.gen.shared_value(step.part_level, step.slots[s], out)
        return tuple(filled)

    def _emit(self) -> None:
        answer = self.outputs[-1]
        if answer in self.answers:
            return
        self.answers.add(answer)
        program = tuple(
            {**node, "_output": to_public_output(self._set(out.mask, out.part_level) if isinstance(out, _Mask)
                                                 else out, typ)}
            for node, out, typ in zip(self.nodes, self.outputs, self.types, strict=True)
        )
        texts = self.tmpl.texts
        text = texts[int(self.rng.integers(len(texts)))]
        types = self.tmpl.param_types
        if self.gen.public:  # a pose value is verbalised like a part name: "front pose"
            types = {p: "Partname" if t == "Pose" and self.assign.get(p) else t for p, t in types.items()}
        question = fill_text(text, types, self.assign, self.rng)
        if self.gen.public and any(f"<{c}" in question for c in "ZCMS"):
            return  # the public post-filling check
        self.found.append(Candidate(self.tmpl.filename, self.tmpl.index, question, program,
                                    verbalise_answer(answer, self.types[-1]), self.types[-1]))

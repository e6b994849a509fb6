"""Answer ceilings: which evidence table limits the answers from the image?

Each *oracle* replaces one group of tables by what the scene says, on the proposals matched to an object (box IoU
>= 0.5), and the same questions are answered again on the same cached evidence. The accuracy an oracle adds is
what that table's errors cost; ``every_table`` (all oracles together, false proposals and the objects perception
missed left as they are) and ``matched_truth`` (the noiseless simulated sensor on the matched objects alone: the
bound the missed objects set) bracket what no table fix can reach.

This reads the scene by design, as the ``oracle`` column of ``po3d eval vqa`` does: it is an analysis of the
perception stage, never a way of answering. Oracles are registered by name with :func:`oracle`; a new table needs
one function here and the command and report pick it up.
"""

from __future__ import annotations

import dataclasses
import difflib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch

from po3d_ppl import ontology
from po3d_ppl.errors import InputError
from po3d_ppl.evidence import SceneEvidence, style_index

#: Log-odds (and log-likelihood gap) an oracle writes: as sure as the noiseless simulated sensor's readings.
CERTAIN = 8.0
#: Proposals count as an object when their box overlaps its box this much (the evidence scores' rule).
MIN_IOU = 0.5
#: The two brackets, computed besides the registered oracles.
EVERY_TABLE = "every_table"
MATCHED_TRUTH = "matched_truth"
PERCEPTION = "perception"


@dataclass
class OracleContext:
    """What an oracle writes into: the evidence's tensors (cloned), the matched proposals and the scene."""

    tensors: dict[str, Any]
    matched: list[tuple[int, Any, int, int]]  # (proposal, object, object index, true subtype index)
    proposal_of: dict[int, int]  # object index -> its proposal
    scene: Any

    def others(self, object_index: int) -> list[tuple[int, int]]:
        """(object index, proposal) of every other matched object."""
        return [(k, p) for k, p in self.proposal_of.items() if k != object_index]


def _log_odds(truth: bool) -> float:
    return CERTAIN if truth else -CERTAIN


def _one_hot(row: torch.Tensor, index: int) -> torch.Tensor:
    out = torch.full_like(row, -CERTAIN)
    out[index] = 0.0
    return out


ORACLES: dict[str, Callable[[OracleContext], None]] = {}


def oracle(name: str) -> Callable[[Callable[[OracleContext], None]], Callable[[OracleContext], None]]:
    """Register an oracle: a function that writes the truth of its tables for every matched proposal."""
    def register(fn: Callable[[OracleContext], None]) -> Callable[[OracleContext], None]:
        if name in ORACLES or name in (EVERY_TABLE, MATCHED_TRUTH, PERCEPTION):
            raise ValueError(f"oracle {name!r} is already defined")
        ORACLES[name] = fn
        return fn
    return register


@oracle("existence")
def _existence(ctx: OracleContext) -> None:
    """Matched proposals exist and the others (false or duplicate proposals) do not."""
    matched = {i for i, *_ in ctx.matched}
    exist = ctx.tensors["exist_logodds"]
    for i in range(exist.shape[0]):
        exist[i] = _log_odds(i in matched)


@oracle("subtype")
def _subtype(ctx: OracleContext) -> None:
    for i, _, _, s in ctx.matched:
        ctx.tensors["subtype_loglik"][i] = _one_hot(ctx.tensors["subtype_loglik"][i], s)


@oracle("attributes")
def _attributes(ctx: OracleContext) -> None:
    """Colour, material and size."""
    for i, obj, _, _ in ctx.matched:
        for table, values, truth in (("color_loglik", ontology.COLORS, obj.color),
                                     ("material_loglik", ontology.MATERIALS, obj.material),
                                     ("size_loglik", ontology.SIZES, obj.size)):
            ctx.tensors[table][i] = _one_hot(ctx.tensors[table][i], values.index(truth))


@oracle("pose")
def _pose(ctx: OracleContext) -> None:
    """The proposal's azimuth grid restarted at the true azimuth, all its weight there (every category)."""
    support, loglik = ctx.tensors["pose_support"], ctx.tensors["pose_loglik"]
    k = support.shape[1]
    grid = torch.arange(k, dtype=support.dtype) * (360.0 / k)
    for i, obj, _, _ in ctx.matched:
        support[i] = (float(obj.pose_degree) + grid) % 360.0
        loglik[i] = -CERTAIN
        loglik[i, :, 0] = 0.0


@oracle("occlusion")
def _occlusion(ctx: OracleContext) -> None:
    """Whether each object is occluded, and by which matched object."""
    for i, obj, j, _ in ctx.matched:
        ctx.tensors["occluded_logodds"][i] = _log_odds(obj.occluded)
        for k, other in ctx.others(j):
            ctx.tensors["occludes_logodds"][i, other] = _log_odds(k in obj.occluded_by)


def _parts(ctx: OracleContext):
    """(proposal, object, true subtype, part slot, raw part name) of every part of every matched object."""
    for i, obj, j, s in ctx.matched:
        for p, raw in enumerate(ontology.PARTS[obj.subtype]):
            yield i, obj, j, s, p, raw


@oracle("part_visibility")
def _part_visibility(ctx: OracleContext) -> None:
    from po3d_ppl.perception.simulated import part_visible

    for i, obj, _, s, p, raw in _parts(ctx):
        ctx.tensors["part_visible_logodds"][i, s, p] = _log_odds(part_visible(obj, raw))


@oracle("part_style")
def _part_style(ctx: OracleContext) -> None:
    """Plain, or the recoloured part's colour and material, for the parts the image shows (the world's visibility
    rule): no reading can know the look of a hidden part, so its entry stays perception's."""
    from po3d_ppl.perception.simulated import part_visible

    table = ctx.tensors["part_style_loglik"]
    for i, obj, _, s, p, raw in _parts(ctx):
        if not part_visible(obj, raw):
            continue
        style = obj.parts.get(raw)
        table[i, s, p] = _one_hot(table[i, s, p], style_index(style.color, style.material) if style else 0)


@oracle("part_occlusion")
def _part_occlusion(ctx: OracleContext) -> None:
    """Whether each part is occluded, and by which matched object."""
    for i, obj, j, s, p, raw in _parts(ctx):
        ctx.tensors["part_occluded_logodds"][i, s, p] = _log_odds(obj.part_occluded(raw))
        by = obj.part_occluded_by(raw)
        for k, other in ctx.others(j):
            ctx.tensors["part_occludes_logodds"][i, s, p, other] = _log_odds(k in by)


def variants(oracles: Sequence[str] | None = None) -> tuple[str, ...]:
    """The variants a ceiling run reports: perception, each oracle, every table together and matched truth."""
    chosen = tuple(ORACLES) if oracles is None else tuple(oracles)
    for name in chosen:
        if name not in ORACLES:
            close = difflib.get_close_matches(name, list(ORACLES), n=2)
            hint = f" (did you mean {' or '.join(close)}?)" if close else ""
            raise InputError("--oracles", f"unknown oracle {name!r}{hint}; choose from {', '.join(ORACLES)}")
    return (PERCEPTION, *chosen, EVERY_TABLE, MATCHED_TRUTH)


def with_truth(evidence: SceneEvidence, scene, variant: str) -> SceneEvidence:
    """``evidence`` with the tables of ``variant`` (an oracle name, :data:`EVERY_TABLE`, :data:`MATCHED_TRUTH` or
    :data:`PERCEPTION`) replaced by the scene's truth on the matched proposals."""
    from po3d_ppl.evaluation.projection import matched_proposals

    if variant == PERCEPTION:
        return evidence
    matched, proposal_of = matched_proposals(evidence, scene, MIN_IOU)
    if variant == MATCHED_TRUTH:
        from po3d_ppl.perception.simulated import simulated_evidence

        return objects_subset(simulated_evidence(scene, 0.0), sorted(j for _, _, j, _ in matched))
    names = tuple(ORACLES) if variant == EVERY_TABLE else (variant,)
    if any(name not in ORACLES for name in names):
        raise InputError("variant", f"unknown ceiling variant {variant!r}; choose from {', '.join(variants())}")
    tensors = {f.name: getattr(evidence, f.name) for f in dataclasses.fields(evidence)}
    tensors = {k: v.clone() if torch.is_tensor(v) else v for k, v in tensors.items()}
    ctx = OracleContext(tensors, matched, proposal_of, scene)
    for name in names:
        ORACLES[name](ctx)
    return dataclasses.replace(evidence, **tensors)


#: Tables indexed by a second object axis (the occluder) besides the first.
_PAIR_TABLES = ("occludes_logodds", "part_occludes_logodds")


def objects_subset(evidence: SceneEvidence, keep: Sequence[int]) -> SceneEvidence:
    """The evidence of the objects ``keep`` only (in that order), occluder axes included."""
    n = evidence.num_objects
    index = torch.as_tensor(np.asarray(keep, dtype=np.int64))
    out = {}
    for f in dataclasses.fields(evidence):
        value = getattr(evidence, f.name)
        if torch.is_tensor(value) and value.dim() >= 1 and value.shape[0] == n:
            value = value[index]
            if f.name in _PAIR_TABLES:
                value = value[..., index]
        out[f.name] = value
    return dataclasses.replace(evidence, **out)


@dataclass
class CeilingRow:
    """One variant's accuracy: over every question, per question file and per Table 1 column."""

    variant: str
    overall: float
    files: dict[str, float]
    columns: dict[str, float]


@dataclass
class CeilingReport:
    rows: list[CeilingRow]
    questions: dict[str, int]  # per file
    images: int

    def to_json(self) -> dict[str, Any]:
        return {"images": self.images, "questions": self.questions, "rows": [dataclasses.asdict(r) for r in self.rows]}

    def markdown(self) -> str:
        """Accuracy (%) per variant and file, and the change against perception in points."""
        files = sorted(self.questions)
        base = self.rows[0]
        head = "| variant | all | " + " | ".join(files) + " |"
        lines = [head, "|" + "---|" * (len(files) + 2)]
        for row in self.rows:
            cells = [_cell(row.overall, None if row is base else base.overall),
                     *(_cell(row.files[f], None if row is base else base.files[f]) for f in files)]
            lines.append(f"| {row.variant} | " + " | ".join(cells) + " |")
        lines.append(f"| *questions* | {sum(self.questions.values())} | "
                     + " | ".join(str(self.questions[f]) for f in files) + " |")
        return "\n".join(lines) + "\n"


def _cell(value: float, reference: float | None) -> str:
    """A percentage, with its change in points against ``reference`` when there is one."""
    return f"{100 * value:.2f}" if reference is None else f"{100 * value:.2f} ({100 * (value - reference):+.2f})"


def _accuracy(records, key: Callable[[Any], str | None]) -> dict[str, float]:
    right: dict[str, list[int]] = {}
    for record in records:
        group = key(record)
        if group is not None:
            tally = right.setdefault(group, [0, 0])
            tally[0] += record.correct("ours")
            tally[1] += 1
    return {group: r / n for group, (r, n) in sorted(right.items())}


def evaluate_ceilings(dataset, split: str, backend, *, cache=None, limit: int | None = None, priors=None,
                      oracles: Sequence[str] | None = None, files: Sequence[str] | None = None,
                      progress: Callable[[str, int, int], None] | None = None) -> CeilingReport:
    """``ours`` on every variant of :func:`variants`: one :func:`~po3d_ppl.evaluation.runner.evaluate` run each,
    on the evidence of ``cache`` (parsed into it on the first run when missing; every run reads it again, which
    costs little beside exact inference at about 0.1 s a question) edited per variant. ``files`` keeps only those
    question files. ``progress(variant, done, total)`` after each image."""
    from po3d_ppl.evaluation.runner import evaluate

    rows, questions, images = [], {}, 0
    for variant in variants(oracles):
        run = evaluate(dataset, split, backend, ("ours",), cache=cache, limit=limit, priors=priors, files=files,
                       evidence_transform=lambda evidence, scene, v=variant: with_truth(evidence, scene, v),
                       progress=None if progress is None else (lambda d, t, v=variant: progress(v, d, t)))
        by_file = _accuracy(run.records, lambda r: r.item.file)
        overall = sum(r.correct("ours") for r in run.records) / max(len(run.records), 1)
        rows.append(CeilingRow(variant, overall, by_file, _accuracy(run.records, lambda r: r.item.column)))
        questions = {f: sum(r.item.file == f for r in run.records) for f in by_file}
        images = run.images
    return CeilingReport(rows, questions, images)

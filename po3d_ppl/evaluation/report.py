"""Reports: JSON and Markdown for ``po3d eval vqa`` and ``po3d eval calibration``, and the noise sweep."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

from po3d_ppl.evaluation import difficulty as dif
from po3d_ppl.evaluation.backends import SimulatedBackend
from po3d_ppl.evaluation.cache import EvidenceCache
from po3d_ppl.evaluation.calibration import SweepPoint, binned_calibration_error, top_answers
from po3d_ppl.evaluation.metrics import family_markdown, family_table, table1, table1_json, table1_markdown
from po3d_ppl.evaluation.runner import EvalRun, evaluate

#: (title, x label, Table 1 columns, binning key, paper curves)
DIFFICULTY_PANELS = (
    ("pose questions by occlusion ratio", "min occlusion ratio of the trace (%)", ("Pose",), "occlusion",
     dif.PAPER_POSE_BY_OCCLUSION),
    ("part questions by part size", "largest part's visible area (px)", ("Part",), "part_size",
     dif.PAPER_PART_BY_SIZE),
    ("part+occlusion questions by part size", "largest part's visible area (px)", ("Part+Occ.",), "part_size",
     dif.PAPER_PART_OCC_BY_SIZE),
)


def difficulty_panels(run: EvalRun, paper: bool = True) -> list[tuple[str, str, list, dict]]:
    return [(title, xlabel, dif.difficulty_table(run.records, run.variants, columns, key),
             {"PO3D-VQA": curves["PO3D-VQA"]} if paper else {})
            for title, xlabel, columns, key, curves in DIFFICULTY_PANELS]


def difficulty_markdown(title: str, rows: Sequence[dif.DifficultyRow], paper: dict) -> str:
    bins = list(dict.fromkeys(r.bin for r in rows))
    lines = [f"**{title}**", "", "| method | | " + " | ".join(str(b) for b in bins) + " |",
             "|" + "---|" * (len(bins) + 2)]
    first = [next(r for r in rows if r.bin == b) for b in bins]
    lines.append("| *questions* | n | " + " | ".join(str(r.n) for r in first) + " |")
    with_found = any(r.found is not None for r in rows)  # the evidence could be matched to the scenes
    if with_found:
        lines.append("| *every referent found* | n | " + " | ".join(
            "-" if r.found is None else str(r.found) for r in first) + " |")
    for method in dict.fromkeys(r.method for r in rows):
        mine = [r for r in rows if r.method == method]
        lines.append(f"| {method} | accuracy | " + " | ".join(
            "-" if r.accuracy is None else f"{100 * r.accuracy:.2f}" for r in mine) + " |")
        lines.append("| | drop | " + " | ".join(
            "-" if r.drop is None else f"{100 * r.drop:.2f}%" for r in mine) + " |")
        if with_found:
            lines.append("| | accuracy, referents found | " + " | ".join(
                "-" if r.found_accuracy is None else f"{100 * r.found_accuracy:.2f}" for r in mine) + " |")
    for name, values in paper.items():
        lines.append(f"| *paper: {name}* | accuracy | " + " | ".join(f"{v:.2f}" for v in values) + " |")
        lines.append("| | drop | " + " | ".join(f"{100 * (values[0] - v) / values[0]:.2f}%" for v in values) + " |")
    return "\n".join(lines)


def vqa_json(run: EvalRun) -> dict:
    families = family_table(run)
    return {
        "split": run.split, "images": run.images, "questions": len(run.records), "backend": run.backend,
        "priors": run.priors,
        "variants": list(run.variants), "timings_s": run.timings, "evidence_cache": run.cache,
        "budget_failures": run.failures,
        "table1": table1_json(table1(run)),
        "families": [{"file": f, "family": fam, "n": next(iter(a.values())).n,
                      **{v: a[v].value for v in run.variants}} for (f, fam), a in families.items()],
        "difficulty": {title: [r.__dict__ for r in rows] for title, _, rows, _ in difficulty_panels(run)},
    }


def question_rows(run: EvalRun) -> list[dict]:
    """One row per question: what was asked, the truth, its difficulty, whether perception found its referents and
    every variant's answer (top outcome, confidence, the truth's probability, the invalid mass): the run's records
    for error analysis, which the aggregate report sums away."""
    rows = []
    for record in run.records:
        item = record.item
        rows.append({
            "image": item.image_index, "question_index": item.question_index, "file": item.file,
            "family": item.family, "column": item.column, "question": item.question, "truth": item.truth,
            "answer_type": record.answer_type, "occlusion_ratio": record.occlusion_ratio,
            "part_size": record.part_size, "referents_found": record.referents_found,
            "answers": {variant: {"top": prediction.top, "confidence": prediction.confidence,
                                  "p_truth": prediction.probability(item.truth), "invalid": prediction.invalid,
                                  "correct": record.correct(variant), "failure": prediction.failure}
                        for variant, prediction in record.predictions.items()},
        })
    return rows


def vqa_markdown(run: EvalRun, figure: str | None = None) -> str:
    per_question = {k: v / max(len(run.records), 1) * 1000 for k, v in run.timings.items()}
    parts = [
        f"# VQA accuracy: split {run.split}, {run.images} images, {len(run.records)} questions",
        "", f"Evidence: `{run.backend}`; cache {run.cache}; budget failures {run.failures}.", "",
        "Per-stage time, ms per question: " + ", ".join(f"{k[:-2]} {v:.1f}" for k, v in per_question.items()),
        "", "## Table 1 columns (accuracy %)", "", table1_markdown(table1(run)), "",
        "## Difficulty (paper section 5.4)", "",
    ]
    for title, _, rows, paper in difficulty_panels(run):
        parts += [difficulty_markdown(title, rows, paper), ""]
    if figure:
        parts += [f"![difficulty]({figure})", ""]
    parts += ["## Per family (accuracy %)", "", family_markdown(family_table(run), run.variants), ""]
    return "\n".join(parts)


def noise_sweep(dataset, split: str, noises: Sequence[float], methods: Sequence[str], *, seed: int = 0,
                cache: EvidenceCache | None = None, limit: int | None = None, priors=None,
                progress: Callable[[float, int, int], None] | None = None) -> list[SweepPoint]:
    """Accuracy and ECE of every method at each noise level of the simulated sensor (same questions)."""
    points = []
    for noise in noises:
        run = evaluate(dataset, split, SimulatedBackend(noise, seed), methods, cache=cache, limit=limit,
                       priors=priors,
                       progress=None if progress is None else (lambda d, t, n=noise: progress(n, d, t)))
        for variant in run.variants:
            conf, correct = top_answers(run.records, variant)
            points.append(SweepPoint(noise, variant, sum(correct) / len(correct),
                                     binned_calibration_error(conf, correct), len(correct)))
    return points


def sweep_markdown(points: Sequence[SweepPoint]) -> str:
    noises = sorted({p.noise for p in points})
    methods = list(dict.fromkeys(p.method for p in points))
    lines = ["| method | | " + " | ".join(f"{n:g}" for n in noises) + " |", "|" + "---|" * (len(noises) + 2)]
    for m in methods:
        mine = {p.noise: p for p in points if p.method == m}
        lines.append(f"| {m} | accuracy | " + " | ".join(f"{mine[n].accuracy:.3f}" for n in noises) + " |")
        lines.append("| | ECE | " + " | ".join(f"{mine[n].ece:.3f}" for n in noises) + " |")
    return "\n".join(lines)


def write_text(path: Path, text: str) -> None:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)

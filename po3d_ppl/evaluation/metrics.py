"""Accuracy tables: the paper's Table 1 columns, the CLEVR core row and one row per question family."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from po3d_ppl.evaluation.runner import COLUMNS, CORE, EvalRun

#: The paper's Table 1 (accuracy %, test split of Super-CLEVR-3D), for side-by-side reporting.
PAPER_TABLE1 = {
    "FiLM": (50.53, 38.24, 67.82, 51.41, 44.66),
    "mDETR": (55.72, 41.52, 71.76, 64.99, 50.47),
    "PNSVQA": (64.39, 50.61, 87.78, 65.80, 53.35),
    "PNSVQA + Projection": (68.15, 56.30, 86.70, 70.70, 58.90),
    "PO3D-VQA": (75.64, 71.85, 86.40, 76.90, 67.40),
}


@dataclass(frozen=True)
class Accuracy:
    correct: int
    n: int

    @property
    def value(self) -> float | None:
        return self.correct / self.n if self.n else None

    @property
    def stderr(self) -> float | None:
        """Binomial standard error: how far a column could move on another draw of questions."""
        p = self.value
        return None if p is None else math.sqrt(p * (1 - p) / self.n)


def accuracy(records, variant: str) -> Accuracy:
    return Accuracy(sum(r.correct(variant) for r in records), len(records))


@dataclass(frozen=True)
class Table1Row:
    """One method's row: the four columns, their mean (the paper's Mean), CLEVR core and all questions."""

    method: str
    columns: dict[str, Accuracy]
    core: Accuracy
    overall: Accuracy

    @property
    def mean(self) -> float | None:
        values = [self.columns[c].value for c in COLUMNS]
        return None if any(v is None for v in values) else sum(values) / len(values)


def table1(run: EvalRun) -> list[Table1Row]:
    by_column = {c: [r for r in run.records if r.item.column == c] for c in (*COLUMNS, CORE)}
    return [Table1Row(v, {c: accuracy(by_column[c], v) for c in COLUMNS}, accuracy(by_column[CORE], v),
                      accuracy(run.records, v)) for v in run.variants]


def family_table(run: EvalRun) -> dict[tuple[str, str], dict[str, Accuracy]]:
    """(question file, family) -> variant -> accuracy."""
    groups: dict[tuple[str, str], list] = {}
    for r in run.records:
        groups.setdefault((r.item.file, r.item.family), []).append(r)
    return {k: {v: accuracy(rs, v) for v in run.variants} for k, rs in sorted(groups.items(), key=_family_key)}


def _family_key(kv) -> tuple:
    (file, family), _ = kv
    template, index = family.rsplit(":", 1)
    return file, template, int(index)


def _pct(value: float | None) -> str:
    return "-" if value is None else f"{100 * value:.2f}"


def table1_markdown(rows: Sequence[Table1Row], paper: bool = True) -> str:
    head = "| method | Mean | " + " | ".join(COLUMNS) + f" | {CORE} | all |"
    lines = [head, "|" + "---|" * (len(COLUMNS) + 4)]
    for row in rows:
        cells = [_pct(row.mean), *(_pct(row.columns[c].value) for c in COLUMNS), _pct(row.core.value),
                 _pct(row.overall.value)]
        lines.append(f"| {row.method} | " + " | ".join(cells) + " |")
    if rows:
        counts = [str(rows[0].columns[c].n) for c in COLUMNS]
        lines.append("| *questions* | | " + " | ".join(counts) + f" | {rows[0].core.n} | {rows[0].overall.n} |")
    if paper:
        for name, values in PAPER_TABLE1.items():
            lines.append(f"| *paper: {name}* | " + " | ".join(f"{v:.2f}" for v in values) + " | | |")
    return "\n".join(lines)


def family_markdown(families: dict, variants: Sequence[str]) -> str:
    lines = ["| file | family | n | " + " | ".join(variants) + " |", "|" + "---|" * (len(variants) + 3)]
    for (file, family), accs in families.items():
        n = next(iter(accs.values())).n
        lines.append(f"| {file} | {family} | {n} | " + " | ".join(_pct(accs[v].value) for v in variants) + " |")
    return "\n".join(lines)


def table1_json(rows: Sequence[Table1Row]) -> list[dict]:
    return [{"method": r.method, "mean": r.mean,
             **{c: {"accuracy": r.columns[c].value, "n": r.columns[c].n, "stderr": r.columns[c].stderr}
                for c in COLUMNS},
             CORE: {"accuracy": r.core.value, "n": r.core.n}, "all": {"accuracy": r.overall.value, "n": r.overall.n}}
            for r in rows]

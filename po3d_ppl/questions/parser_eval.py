"""Evaluating the question parser on question sets with scenes: exact match, or the same answer on the scene.

An independent question set (``tests/data/independent_questions/``: JSON Lines records with ``question``,
``program`` (our text syntax), ``family_group``, ``family`` and ``scene``, a path relative to the set's folder) is
read by :func:`load_question_set`. A parse counts as correct when its prefix tokens equal the gold program's (part
names respelled canonically on both sides), or when it is valid on the record's scene and gives the gold program's
answer there: two filter orders, or ``car`` for the only car's ``suv``, are the same question. Lives in the questions
stage because it runs the reference executor.
"""

from __future__ import annotations

import json
from collections import defaultdict
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from po3d_ppl.errors import InputError
from po3d_ppl.language import parse_program
from po3d_ppl.language.ast import Program
from po3d_ppl.language.seq2seq.data import canonical_targets
from po3d_ppl.language.tokens import program_to_tokens
from po3d_ppl.questions.executor import execute


@dataclass(frozen=True)
class SceneQuestion:
    """One evaluation record."""

    id: str
    question: str
    program: Program
    family_group: str
    family: str
    scene_path: Path | None


@dataclass(frozen=True)
class Judged:
    record: SceneQuestion
    predicted: str
    confidence: float
    exact: bool
    same_answer: bool
    unknown_words: tuple[str, ...]

    @property
    def correct(self) -> bool:
        return self.exact or self.same_answer


def load_question_set(directory: Path) -> list[SceneQuestion]:
    """Every record of every ``*.jsonl`` file of ``directory`` (in file order)."""
    directory = Path(directory)
    files = sorted(directory.glob("*.jsonl"))
    if not files:
        raise InputError("--independent", f"{directory} holds no *.jsonl question files")
    out = []
    for path in files:
        for line_no, line in enumerate(path.read_text().splitlines(), 1):
            if not line.strip():
                continue
            where = f"{path.name}:{line_no}"
            try:
                raw = json.loads(line)
                program = canonical_targets(parse_program(raw["program"]))
            except (ValueError, KeyError) as exc:
                raise InputError(where, f"cannot read the record ({exc})") from None
            scene = raw.get("scene")
            out.append(SceneQuestion(str(raw.get("id", where)), raw["question"], program,
                                     str(raw.get("family_group", path.stem)), str(raw.get("family", "?")),
                                     directory / scene if scene else None))
    return out


def judge(records: Sequence[SceneQuestion], parse: Callable[[str], object]) -> list[Judged]:
    """Parse every record (``parse(question)`` returns a ``QuestionParse``) and judge its best program."""
    from po3d_ppl.world.scene_io import load_scenes

    scenes: dict[Path, object] = {}
    out = []
    for record in records:
        result = parse(record.question)
        best = result.best.program
        exact = program_to_tokens(best) == program_to_tokens(record.program)
        same = False
        if not exact and record.scene_path is not None:
            if record.scene_path not in scenes:
                scenes[record.scene_path] = load_scenes(record.scene_path)[0]
            scene = scenes[record.scene_path]
            gold, got = execute(scene, record.program), execute(scene, best)
            same = gold.valid and got.valid and got.answer == gold.answer
        from po3d_ppl.language import program_to_text

        out.append(Judged(record, program_to_text(best, style="pipeline"), result.confidence, exact, same,
                          tuple(result.unknown_words)))
    return out


def summarise(judged: Sequence[Judged]) -> dict:
    """Accuracy (exact or same answer), exact match, mean confidence, overall and per family group."""
    groups: dict[str, list[Judged]] = defaultdict(list)
    for j in judged:
        groups[j.record.family_group].append(j)

    def row(items: Sequence[Judged]) -> dict:
        n = len(items)
        return {"count": n, "accuracy": sum(j.correct for j in items) / n, "exact_match": sum(j.exact for j in items) / n,
                "mean_confidence": sum(j.confidence for j in items) / n}

    return {**row(judged), "per_group": {g: row(v) for g, v in sorted(groups.items())}}

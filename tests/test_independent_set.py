"""The independent question sets (tests/data/independent_questions, _v2, _v3, _v4 and _v5): every
record's program parses, type-checks and gives the stored answer on its stored scene with the reference executor.

The sets are for evaluation only (never training or model selection); see their READMEs.
"""

from __future__ import annotations

import json
from collections import Counter
from functools import cache
from pathlib import Path

import pytest

from po3d_ppl.language import check_program, parse_program
from po3d_ppl.questions.context import SceneContext
from po3d_ppl.questions.executor import execute
from po3d_ppl.world import load_scene

ROOT = Path(__file__).resolve().parent / "data"
#: set folder -> the least number of records it must hold
SETS = {"independent_questions": 300, "independent_questions_v2": 1500, "independent_questions_v3": 1500,
        "independent_questions_v4": 1500, "independent_questions_v5": 1500}
GROUPS = {"core_query", "core_count", "core_exist", "core_compare_attribute", "core_compare_integer",
          "core_same_relate", "core_spatial", "parts", "pose", "occlusion", "part_occlusion", "redundant",
          "synonyms_quirks_typos"}
FIELDS = {"id", "question", "program", "family_group", "family", "scene", "answer"}

pytestmark = pytest.mark.parametrize("name", sorted(SETS))


@cache
def _records(name: str) -> tuple[dict, ...]:
    out = []
    for path in sorted((ROOT / name).glob("*.jsonl")):
        for n, line in enumerate(path.read_text().splitlines(), 1):
            if line.strip():
                out.append(dict(json.loads(line), _where=f"{name}/{path.name}:{n}"))
    return tuple(out)


def _plain(value):
    if isinstance(value, (frozenset, set)):
        return sorted(value)
    if isinstance(value, tuple):
        return list(value)
    return value


def test_set_size_and_fields(name):
    records = _records(name)
    assert len(records) >= SETS[name]
    ids = Counter(r["id"] for r in records)
    assert not [i for i, c in ids.items() if c > 1], "duplicate ids"
    for r in records:
        assert FIELDS <= r.keys(), r["_where"]
        assert r["family_group"] in GROUPS, r["_where"]
        assert (ROOT / name / r["scene"]).is_file(), r["_where"]
    assert {r["family_group"] for r in records} == GROUPS


def test_no_duplicate_questions_per_scene(name):
    seen = Counter((r["scene"], r["question"]) for r in _records(name))
    assert not [k for k, c in seen.items() if c > 1]


def test_programs_type_check_and_answers_match_reference_executor(name):
    contexts: dict[str, SceneContext] = {}
    bad = []
    for r in _records(name):
        ctx = contexts.get(r["scene"])
        if ctx is None:
            ctx = contexts[r["scene"]] = SceneContext(load_scene(ROOT / name / r["scene"]))
        typed = check_program(parse_program(r["program"]))
        result = execute(ctx, typed)
        if not result.valid or _plain(result.answer) != r["answer"]:
            bad.append((r["_where"], r["question"], result.reason or _plain(result.answer), r["answer"]))
    assert not bad, bad[:5]


def test_directory_is_small(name):
    total = sum(p.stat().st_size for p in (ROOT / name).rglob("*") if p.is_file())
    assert total < 5_000_000, total


if __name__ == "__main__":  # pragma: no cover
    pytest.main([__file__, "-q"])

"""The development question set (tests/data/dev_questions/): every record is well formed, every program parses and
type-checks, and a sample of the stored answers equals the reference executor's on the record's scene."""

from __future__ import annotations

import json
from collections import Counter
from functools import cache
from pathlib import Path

import pytest

from po3d_ppl.language import check_program, parse_program
from po3d_ppl.questions.executor import execute
from po3d_ppl.world.scene_io import load_scene

DEV = Path(__file__).parent / "data" / "dev_questions"
GROUPS = {"core_query", "core_count", "core_exist", "core_compare_attribute", "core_compare_integer",
          "core_same_relate", "core_spatial", "parts", "pose", "occlusion", "part_occlusion", "redundant",
          "synonyms_quirks_typos"}
KEYS = {"id", "question", "program", "family_group", "family", "scene", "answer"}


def _records(name: str) -> list[dict]:
    return [json.loads(line) for line in (DEV / name).read_text().splitlines() if line.strip()]


@cache
def records() -> tuple[dict, ...]:
    return tuple(_records("generated.jsonl") + _records("hand_written.jsonl") + _records("compare_integer_extra.jsonl"))


@cache
def scene(rel: str):
    return load_scene(DEV / rel)


def test_records_are_well_formed():
    recs = records()
    assert len({r["id"] for r in recs}) == len(recs)
    for r in recs:
        assert KEYS <= set(r) <= KEYS | {"phrasing_notes"}, r["id"]
        assert r["family_group"] in GROUPS, r["id"]
        assert isinstance(r["answer"], (bool, int, str)), r["id"]
        assert (DEV / r["scene"]).is_file(), r["id"]
        assert r["question"].strip() and r["family"], r["id"]


def test_sizes():
    generated, hand = _records("generated.jsonl"), _records("hand_written.jsonl")
    assert len(generated) >= 1300
    assert len(hand) >= 150
    per_group = Counter(r["family_group"] for r in generated)
    assert set(per_group) == GROUPS
    assert min(per_group.values()) >= 100


def test_every_program_parses_and_type_checks():
    for r in records():
        check_program(parse_program(r["program"]))


@pytest.mark.parametrize("offset", [0, 5])
def test_sampled_answers_match_the_reference_executor(offset):
    for r in records()[offset::10]:
        result = execute(scene(r["scene"]), parse_program(r["program"]))
        assert result.valid, (r["id"], result.reason)
        assert result.answer == r["answer"] and type(result.answer) is type(r["answer"]), r["id"]


def test_the_cli_loader_reads_the_folder():
    from po3d_ppl.questions.parser_eval import load_question_set

    loaded = load_question_set(DEV)
    assert len(loaded) == len(records())
    assert all(q.scene_path is not None and q.scene_path.is_file() for q in loaded[::50])

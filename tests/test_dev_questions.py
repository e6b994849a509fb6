"""The development question sets (tests/data/dev_questions/ and tests/data/dev_questions_2/): every record is well
formed, every program parses and type-checks, and a sample of the stored answers (a fifth) equals the reference
executor's on the record's scene."""

from __future__ import annotations

import json
from collections import Counter
from functools import cache
from pathlib import Path

import pytest

from po3d_ppl.language import check_program, parse_program
from po3d_ppl.questions.executor import execute
from po3d_ppl.world.scene_io import load_scene

DATA = Path(__file__).parent / "data"
#: set folder -> its question files (generated first, hand-written second)
SETS = {
    "dev_questions": ("generated.jsonl", "hand_written.jsonl", "compare_integer_extra.jsonl"),
    "dev_questions_2": ("generated.jsonl", "hand_written.jsonl"),
}
#: set folder -> id prefixes its records use (None: not checked)
ID_PREFIXES = {"dev_questions": None, "dev_questions_2": ("d2g", "d2h")}
GROUPS = {"core_query", "core_count", "core_exist", "core_compare_attribute", "core_compare_integer",
          "core_same_relate", "core_spatial", "parts", "pose", "occlusion", "part_occlusion", "redundant",
          "synonyms_quirks_typos"}
KEYS = {"id", "question", "program", "family_group", "family", "scene", "answer"}

pytestmark = pytest.mark.parametrize("name", sorted(SETS))


def _records(name: str, file: str) -> list[dict]:
    return [json.loads(line) for line in (DATA / name / file).read_text().splitlines() if line.strip()]


@cache
def records(name: str) -> tuple[dict, ...]:
    return tuple(r for file in SETS[name] for r in _records(name, file))


@cache
def scene(name: str, rel: str):
    return load_scene(DATA / name / rel)


def test_records_are_well_formed(name):
    recs = records(name)
    assert len({r["id"] for r in recs}) == len(recs)
    prefixes = ID_PREFIXES[name]
    for r in recs:
        assert KEYS <= set(r) <= KEYS | {"phrasing_notes"}, r["id"]
        assert r["family_group"] in GROUPS, r["id"]
        assert isinstance(r["answer"], (bool, int, str)), r["id"]
        assert (DATA / name / r["scene"]).is_file(), r["id"]
        assert r["question"].strip() and r["family"], r["id"]
        assert prefixes is None or r["id"].startswith(prefixes), r["id"]
    assert not [k for k, c in Counter((r["scene"], r["question"]) for r in recs).items() if c > 1]


def test_sizes(name):
    generated, hand = _records(name, SETS[name][0]), _records(name, SETS[name][1])
    assert len(generated) >= 1300
    assert len(hand) >= 150
    per_group = Counter(r["family_group"] for r in generated)
    assert set(per_group) == GROUPS
    assert min(per_group.values()) >= 100
    assert {r["family_group"] for r in hand} == GROUPS or name == "dev_questions"


def test_every_program_parses_and_type_checks(name):
    for r in records(name):
        check_program(parse_program(r["program"]))


@pytest.mark.parametrize("offset", [0, 5])
def test_sampled_answers_match_the_reference_executor(name, offset):
    for r in records(name)[offset::10]:
        result = execute(scene(name, r["scene"]), parse_program(r["program"]))
        assert result.valid, (r["id"], result.reason)
        assert result.answer == r["answer"] and type(result.answer) is type(r["answer"]), r["id"]


def test_the_cli_loader_reads_the_folder(name):
    from po3d_ppl.questions.parser_eval import load_question_set

    loaded = load_question_set(DATA / name)
    assert len(loaded) == len(records(name))
    assert all(q.scene_path is not None and q.scene_path.is_file() for q in loaded[::50])

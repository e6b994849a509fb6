"""(question, program) examples for training and evaluating the question parser.

Examples come from question records in the public format (``question``, ``program``, and for grouping
``question_family_index`` / ``template_filename``), whether produced by our dataset builder or by the released
Super-CLEVR-3D question files. Their programs are respelled with canonical part names (:func:`canonical_targets`)
so that equal texts have equal targets: the released files spell "back left wheel" ``wheel_back_left`` on buses
and ``back_left_wheel`` on cars, which means the same (``ontology.partname_matches``).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

from po3d_ppl.errors import InputError
from po3d_ppl.language.ast import Program
from po3d_ppl.language.json_io import program_from_json
from po3d_ppl import ontology

if TYPE_CHECKING:
    from po3d_ppl.questions.dataset import Dataset


@dataclass(frozen=True)
class Example:
    question: str
    program: Program
    #: The question file the example came from (parts, pose, occlusion ...).
    source: str
    #: Template family, ``<template file>:<index>`` when the record says so.
    family: str


def canonical_targets(program: Program) -> Program:
    """``program`` with every raw part-name value in its canonical spelling (``wheel_back_left`` ->
    ``back_left_wheel``), which selects the same parts. Value vocabularies of different types are disjoint, so a
    raw part name is a Partname literal whatever operation carries it."""
    nodes = tuple(replace(node, value=ontology.canonical_part_name(node.value))
                  if node.value in ontology.RAW_PART_NAMES else node for node in program)
    return program if nodes == tuple(program) else Program(nodes, program.source)


def examples_from_records(records: Iterable[Mapping], source: str) -> list[Example]:
    """Examples from public question records (``source`` names the question file in errors and reports)."""
    out = []
    for i, record in enumerate(records):
        where = f"{source}[{i}]"
        question = record.get("question") if isinstance(record, Mapping) else None
        if not isinstance(question, str) or not question.strip():
            raise InputError(f"{where}.question", "every record needs a non-empty 'question' string")
        program = program_from_json(record.get("program"), where=f"{where}.program")
        template = str(record.get("template_filename", source))
        family = f"{Path(template).stem}:{record.get('question_family_index', '?')}"
        out.append(Example(question, canonical_targets(program), source, family))
    return out


def open_dataset(data_dir: Path) -> Dataset:
    """A dataset directory built by ``po3d dataset build``, read once (its splits, questions and manifest)."""
    from po3d_ppl.questions.dataset import load_dataset

    data_dir = Path(data_dir)
    if not data_dir.is_dir():
        raise InputError("--data", f"{data_dir} is not a directory; build one with `po3d dataset build --out DIR`")
    return load_dataset(data_dir)


def split_examples(dataset: Dataset, split: str) -> list[Example]:
    """Every question of ``split`` in ``dataset``, grouped by question file."""
    if split not in dataset.splits:
        raise InputError("--split", f"unknown split {split!r} (known: {', '.join(dataset.splits)})")
    members = set(dataset.splits[split])
    examples: list[Example] = []
    for source, records in dataset.questions.items():
        examples.extend(examples_from_records((r for r in records if r.get("image_index") in members), source))
    if not examples:
        raise InputError("--split", f"no questions for split {split!r} in {dataset.root}")
    return examples


def load_examples(data_dir: Path, split: str) -> list[Example]:
    """Every question of ``split`` in a dataset built by ``po3d dataset build``, grouped by question file."""
    return split_examples(open_dataset(data_dir), split)

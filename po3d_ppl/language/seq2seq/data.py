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

from po3d_ppl import ontology
from po3d_ppl.errors import InputError
from po3d_ppl.language.ast import Program
from po3d_ppl.language.json_io import program_from_json


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

"""Programs as text, typed ASTs, public JSON and token sequences, and the question -> program parser.

>>> program = parse_program("query_color(unique(filter_shape[car](filter_color[red](scene()))))")
>>> check_program(program).type
'Color'
>>> program_to_tokens(program)
['query_color', 'unique', 'filter_shape[car]', 'filter_color[red]', 'scene']

``QuestionParser`` (the seq2seq model) and ``load_question_parser`` (the shipped parser: an ensemble of
``QuestionParser`` members) are imported lazily because they need torch.
"""

from po3d_ppl.language.ast import Node, Program, Span
from po3d_ppl.language.errors import (
    ProgramArityError,
    ProgramError,
    ProgramStructureError,
    ProgramSyntaxError,
    ProgramTypeError,
    ProgramValueError,
    UnknownProgramNameError,
)
from po3d_ppl.language.json_io import program_from_json, program_to_json
from po3d_ppl.language.parser import parse_program
from po3d_ppl.language.printer import program_to_text
from po3d_ppl.language.program_input import as_typed_program
from po3d_ppl.language.tokens import program_from_tokens, program_to_tokens
from po3d_ppl.language.typecheck import TypedNode, TypedProgram, check_program

__all__ = [
    "Node",
    "Program",
    "ProgramArityError",
    "ProgramError",
    "ProgramStructureError",
    "ProgramSyntaxError",
    "ProgramTypeError",
    "ProgramValueError",
    "QuestionParser",
    "Span",
    "TypedNode",
    "TypedProgram",
    "UnknownProgramNameError",
    "as_typed_program",
    "check_program",
    "load_question_parser",
    "parse_program",
    "program_from_json",
    "program_from_tokens",
    "program_to_json",
    "program_to_text",
    "program_to_tokens",
]


def __getattr__(name: str):
    if name == "QuestionParser":
        from po3d_ppl.language.seq2seq.model_io import QuestionParser

        return QuestionParser
    if name == "load_question_parser":
        from po3d_ppl.language.seq2seq.ensemble import load_question_parser

        return load_question_parser
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

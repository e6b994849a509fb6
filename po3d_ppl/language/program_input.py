"""The one place that turns "a program" as callers hand it over into a type-checked program.

Library entry points (the reasoning compiler, the reference executor) accept whatever a researcher has at hand:
program text, a public JSON node list or its JSON text, a question record holding one under ``program``, a
``Program`` AST, or an already checked ``TypedProgram``.
"""

from __future__ import annotations

from po3d_ppl.errors import InputError
from po3d_ppl.language.ast import Program
from po3d_ppl.language.json_io import program_from_json
from po3d_ppl.language.parser import parse_program
from po3d_ppl.language.typecheck import TypedProgram, check_program


def as_typed_program(program: object, allow_text: bool = True) -> TypedProgram:
    """Type-check ``program`` (see the module docstring for what it may be); typed errors name what is wrong.
    With ``allow_text=False`` a string is always read as JSON (for readers of public files)."""
    if isinstance(program, TypedProgram):
        return program
    if allow_text and isinstance(program, str) and not program.lstrip().startswith(("[", "{")):
        program = parse_program(program)
    elif isinstance(program, (str, list, tuple, dict)):
        program = program_from_json(program)
    if not isinstance(program, Program):
        raise InputError("program", "expected program text, a JSON node list, a question record, or a Program; "
                                    f"got {type(program).__name__}")
    return check_program(program)

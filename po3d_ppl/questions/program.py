"""How the question engine reads programs, and the public ``_output`` encoding.

Programs are read and type-checked by the language stage (``po3d_ppl.language``: one JSON reader, one type checker
for the whole project); this module only adds what is specific to the public question files: the ``_output``
encoding of intermediate results.
"""

from __future__ import annotations

from po3d_ppl.language import Program, TypedProgram, check_program, program_from_json


def checked_program(program: object) -> TypedProgram:
    """A type-checked program from a public node list, a question record with a ``program``, or a ``Program``."""
    if isinstance(program, TypedProgram):
        return program
    if not isinstance(program, Program):
        program = program_from_json(program)
    return check_program(program)


def part_key(part: tuple[int, int]) -> str:
    """Public part id ``"<obj>_<part>"``."""
    return f"{part[0]}_{part[1]}"


def to_public_output(value: object, value_type: str) -> object:
    """Encode a value the way public ``_output`` fields hold it (sorted lists, ``"i_p"`` part ids)."""
    if value_type == "ObjectSet":
        return sorted(value)
    if value_type == "PartSet":
        return [part_key(p) for p in sorted(value)]
    if value_type == "Part":
        return part_key(value)
    return value

"""The public ``_output`` encoding of intermediate results in question files.

Programs themselves are read and type-checked by the language stage (``po3d_ppl.language.as_typed_program``: one
reader and one type checker for the whole project).
"""

from __future__ import annotations


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

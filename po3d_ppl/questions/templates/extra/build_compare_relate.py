"""Writes ``compare_relate.json``: integer comparisons of two counts taken around one referent.

CLEVR's compare-integer families count two independently described sets. People also compare what lies on two
sides of one object, naming it once and pointing back with a pronoun: "Are there more things right of the blue
car than left of it?", "Is the number of buses behind the truck the same as the number of cars in front of it?".
The program repeats the referent's chain on both sides (the public programs are trees). Two kinds per
comparison: the same description on both sides (the second one is usually left out: "... than left of it") and a
different one.

An opt-in family set (``po3d train parser --extra-families compare_relate``; ``parser_corpus.OPT_IN_FAMILIES``):
the default corpus leaves this file out. It trained the shipped ensemble's second and third members.

    python -m po3d_ppl.questions.templates.extra.build_compare_relate
"""

from __future__ import annotations

import json
from pathlib import Path

RELATIONS = ["left", "right", "behind", "front"]
ANCHOR = ["<Z>", "<C>", "<M>", "<S>"]
FIRST = ["<Z2>", "<C2>", "<M2>", "<S2>"]
SECOND = ["<Z3>", "<C3>", "<M3>", "<S3>"]
TYPES = ("Size", "Color", "Material", "Shape")

_X = "<Z2> <C2> <M2> <S2>s <R> the <Z> <C> <M> <S>"
TEXTS = {
    ("greater_than", "same"): [f"Are there more {_X} than <R2> it?",
                               f"Is the number of {_X} greater than the number <R2> it?"],
    ("less_than", "same"): [f"Are there fewer {_X} than <R2> it?",
                            f"Is the number of {_X} less than the number <R2> it?"],
    ("equal_integer", "same"): [f"Are there as many {_X} as <R2> it?",
                                f"Is the number of {_X} the same as the number <R2> it?"],
    ("greater_than", "other"): [f"Are there more {_X} than <Z3> <C3> <M3> <S3>s <R2> it?",
                                f"Is the number of {_X} greater than the number of <Z3> <C3> <M3> <S3>s <R2> it?"],
    ("less_than", "other"): [f"Are there fewer {_X} than <Z3> <C3> <M3> <S3>s <R2> it?",
                             f"Is the number of {_X} less than the number of <Z3> <C3> <M3> <S3>s <R2> it?"],
    ("equal_integer", "other"): [f"Are there as many {_X} as <Z3> <C3> <M3> <S3>s <R2> it?",
                                 f"Is the number of {_X} equal to the number of <Z3> <C3> <M3> <S3>s <R2> it?"],
}


def _params(names: list[str]) -> list[dict]:
    return [{"type": t, "name": n} for t, n in zip(TYPES, names)]


def build() -> list[dict]:
    out = []
    for (op, kind), texts in TEXTS.items():
        second = FIRST if kind == "same" else SECOND
        nodes = [{"type": "scene", "inputs": []},
                 {"type": "filter_unique", "inputs": [0], "side_inputs": ANCHOR},
                 {"type": "relate_filter_count", "inputs": [1], "side_inputs": ["<R>", *FIRST]},
                 {"type": "scene", "inputs": []},
                 {"type": "filter_unique", "inputs": [3], "side_inputs": ANCHOR},
                 {"type": "relate_filter_count", "inputs": [4], "side_inputs": ["<R2>", *second]},
                 {"type": op, "inputs": [2, 5]}]
        params = [*_params(ANCHOR), {"type": "Relation", "name": "<R>", "values": RELATIONS}, *_params(FIRST),
                  {"type": "Relation", "name": "<R2>", "values": RELATIONS}]
        if kind == "other":
            params += _params(SECOND)
        out.append({"text": texts, "nodes": nodes, "params": params,
                    "constraints": [{"type": "NEQ", "params": ["<R>", "<R2>"]},
                                    {"type": "NOT_ALL_NULL", "params": ANCHOR}]})
    return out


def main() -> None:
    path = Path(__file__).with_name("compare_relate.json")
    path.write_text("[\n" + ",\n".join(json.dumps(t) for t in build()) + "\n]\n")
    print(f"{path}: {len(build())} families")


if __name__ == "__main__":
    main()

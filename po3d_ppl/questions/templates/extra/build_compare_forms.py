"""Writes ``compare_forms.json``: CLEVR integer comparisons whose counts are not plain attribute filters.

CLEVR's compare-integer families count attribute-filtered sets (or objects related to a unique one); people also
compare occluded objects ("Are there more occluded cars than buses?") and owners of a part ("Is the number of
buses that have a red wheel greater than the number of cars?"). Each family here has one such side and an
attribute (or the other kind of) side, in either order, for each of the three comparisons. Unlike CLEVR's, an
attribute side may have no filter at all ("things"), so that a bare "things" is not read as occluded things.

    python -m po3d_ppl.questions.templates.extra.build_compare_forms
"""

from __future__ import annotations

import json
from pathlib import Path

OPS = {
    "greater_than": ("Are there more {a} than {b}?", "Is the number of {a} greater than the number of {b}?",
                     "Do the {a} outnumber the {b}?"),
    "less_than": ("Are there fewer {a} than {b}?", "Is the number of {a} less than the number of {b}?",
                  "Are the {a} outnumbered by the {b}?"),
    "equal_integer": ("Are there the same number of {a} and {b}?", "Are there as many {a} as {b}?",
                      "Is the number of {a} equal to the number of {b}?"),
}
KINDS = (("occ", "attr"), ("attr", "occ"), ("part", "attr"), ("attr", "part"), ("occ", "part"), ("part", "occ"))


def _side(kind: str, k: int, nodes: list, params: list, constraints: list) -> tuple[int, str]:
    z, c, m, s = (f"<{x}{'' if k == 0 else k + 1}>" for x in "ZCMS")
    obj = [{"type": "Size", "name": z}, {"type": "Color", "name": c}, {"type": "Material", "name": m},
           {"type": "Shape", "name": s}]
    np = f"{z} {c} {m} {s}s"
    if kind == "attr":
        nodes.append({"type": "filter", "inputs": [0], "side_inputs": [z, c, m, s]})
        params.extend(obj)  # may be all null: "Are there more things than occluded cars?"
        return len(nodes) - 1, np
    if kind == "occ":
        nodes.append({"type": "filter_occludee", "inputs": [0]})
        nodes.append({"type": "filter", "inputs": [len(nodes) - 1], "side_inputs": [z, c, m, s]})
        params.extend(obj)
        return len(nodes) - 1, f"occluded {np}"
    pc, pm, p = f"<C{k + 3}>", f"<M{k + 3}>", f"<P{'' if k == 0 else k + 1}>"
    nodes.append({"type": "filter", "inputs": [0], "side_inputs": [z, c, m, s]})
    nodes.append({"type": "object2part", "inputs": [len(nodes) - 1]})
    nodes.append({"type": "partfilter", "inputs": [len(nodes) - 1], "side_inputs": [pc, pm, p]})
    nodes.append({"type": "part2object", "inputs": [len(nodes) - 1]})
    # the part side's params first: a family's part names are drawn from its first shape's parts
    params[:0] = obj + [{"type": "Color", "name": pc}, {"type": "Material", "name": pm},
                        {"type": "Partname", "name": p}]
    constraints.append({"type": "NOT_ALL_NULL", "params": [pc, pm, p]})
    return len(nodes) - 1, f"{np} that have a {pc} {pm} {p}"


def build() -> list[dict]:
    out = []
    for op, texts in OPS.items():
        for kinds in KINDS:
            nodes: list = [{"type": "scene", "inputs": []}]
            params: list = []
            constraints: list = []
            counts, phrases = [], []
            for k, kind in enumerate(kinds):
                head, phrase = _side(kind, k, nodes, params, constraints)
                nodes.append({"type": "count", "inputs": [head]})
                counts.append(len(nodes) - 1)
                phrases.append(phrase)
            nodes.append({"type": op, "inputs": counts})
            out.append({"text": [t.format(a=phrases[0], b=phrases[1]) for t in texts], "nodes": nodes,
                        "params": params, "constraints": constraints})
    return out


def main() -> None:
    path = Path(__file__).with_name("compare_forms.json")
    path.write_text("[\n" + ",\n".join(json.dumps(t) for t in build()) + "\n]\n")
    print(f"{path}: {len(build())} families")


if __name__ == "__main__":
    main()

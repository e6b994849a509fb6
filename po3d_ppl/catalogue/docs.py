"""``docs/operations.md``, generated from the catalogue: ``python -m po3d_ppl.catalogue.docs [OUT]``.

Written from the declarations alone, so an operation's docs live in one place (its ``declare`` or its
``register_operation`` docstring); ``tests/test_catalogue_docs.py`` fails when the file is stale.
"""

from __future__ import annotations

import sys
from pathlib import Path

from po3d_ppl.catalogue import REGISTRY, OperationRegistry


def operations_markdown(registry: OperationRegistry = REGISTRY) -> str:
    lines = ["# Program operations", "",
             "Generated from `po3d_ppl.catalogue` by `python -m po3d_ppl.catalogue.docs docs/operations.md`; do not "
             "edit by hand.", "",
             "Types: sets (`ObjectSet`, `PartSet`), single entities (`Object`, `Part`), `Integer`, `Bool`, and value",
             "types whose literals appear in brackets (`filter_color[red]`).", ""]
    families: dict[str, list] = {}
    for op in registry:
        families.setdefault(op.family, []).append(op)
    for family in sorted(families):
        lines += [f"## {family}", "", "| operation | signature | meaning |", "|---|---|---|"]
        for op in families[family]:
            doc = " ".join(op.doc.split()).replace("|", "\\|")
            lines.append(f"| `{op.name}` | `{op.signature}` | {doc} |")
        lines.append("")
    return "\n".join(lines)


def main(argv: list[str]) -> None:
    text = operations_markdown()
    if argv:
        Path(argv[0]).write_text(text)
    else:
        sys.stdout.write(text)


if __name__ == "__main__":
    main(sys.argv[1:])

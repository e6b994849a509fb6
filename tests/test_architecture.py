"""The stages depend one way: world -> perception -> reasoning, with language (and the questions built on it) beside
them, all on the torch-free catalogue, ontology and evidence contract. Checked statically over every import
statement (function-level ones included) and at run time in fresh interpreters."""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "po3d_ppl"

#: What each top-level module or subpackage of po3d_ppl may import (besides itself).
BASE = {"errors", "resources", "ontology"}
ALLOWED = {
    "errors": set(),
    "resources": set(),
    "ontology": {"errors"},
    "model_store": {"errors", "resources"},
    "catalogue": BASE,
    "world": BASE,
    "language": BASE | {"catalogue", "model_store"},
    "questions": BASE | {"catalogue", "world", "language"},
    "evidence": BASE | {"world"},
    "perception": BASE | {"world", "evidence", "model_store"},
    # model_store: the shipped answer calibration (reasoning/answer_calibration.py) is read with its sha256 check
    "reasoning": BASE | {"catalogue", "world", "evidence", "language", "model_store"},
    "pipeline": BASE | {"language", "reasoning", "evidence", "perception"},
    "evaluation": None,  # benchmarks every stage against the others
    "cli": None,  # the command line may use every stage
    "__main__": None,
    "__init__": set(),
}


def _imports(path: Path) -> set[str]:
    """The po3d_ppl stages a source file imports, by any import statement anywhere in it."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("po3d_ppl"):
            parts = node.module.split(".")
            out |= {parts[1]} if len(parts) > 1 else {alias.name for alias in node.names}
        elif isinstance(node, ast.Import):
            out |= {alias.name.split(".")[1] for alias in node.names if alias.name.startswith("po3d_ppl.")}
    return out


def test_every_stage_imports_only_what_it_may():
    violations = []
    for path in sorted(PACKAGE.rglob("*.py")):
        stage = path.relative_to(PACKAGE).parts[0].removesuffix(".py")
        assert stage in ALLOWED, f"{stage}: a new stage; add it to ALLOWED with its dependencies"
        if ALLOWED[stage] is None:
            continue
        bad = _imports(path) - ALLOWED[stage] - {stage}
        violations += [f"{path.relative_to(PACKAGE)} imports po3d_ppl.{name}" for name in sorted(bad)]
    assert not violations, "\n".join(violations)


PROBE = """
import json, sys
{code}
loaded = sorted(m for m in sys.modules if m.split(".")[0] in ("torch", "pyro") or m.startswith("po3d_ppl."))
print(json.dumps(loaded))
"""

#: (code run in a fresh interpreter, module prefixes that must not be loaded by it)
RUNTIME = {
    "language": ("import po3d_ppl.language as l\n"
                 "p = l.parse_program('count(filter_shape[car](scene()))')\n"
                 "l.program_from_json(l.program_to_json(l.check_program(p).program))",
                 ("torch", "pyro", "po3d_ppl.reasoning", "po3d_ppl.questions", "po3d_ppl.world.renderer")),
    "catalogue": ("from po3d_ppl.catalogue import REGISTRY\nassert 'unique' in REGISTRY",
                  ("torch", "pyro", "po3d_ppl.language", "po3d_ppl.reasoning", "po3d_ppl.questions")),
    "questions": ("from po3d_ppl.questions.executor import execute\nfrom po3d_ppl.questions import generator",
                  ("pyro", "po3d_ppl.reasoning", "po3d_ppl.perception")),
    "evidence": ("import po3d_ppl.evidence", ("pyro", "po3d_ppl.reasoning", "po3d_ppl.perception")),
    "perception": ("from po3d_ppl.perception import simulated_evidence",
                   ("pyro", "po3d_ppl.reasoning", "po3d_ppl.language", "po3d_ppl.questions")),
    "reasoning": ("from po3d_ppl.reasoning import SceneReasoner, METHODS\nimport po3d_ppl.reasoning.inference.exact",
                  ("po3d_ppl.questions", "po3d_ppl.perception", "po3d_ppl.language.seq2seq")),
}


@pytest.mark.parametrize("stage", sorted(RUNTIME))
def test_a_stage_loads_only_what_it_needs(stage):
    code, forbidden = RUNTIME[stage]
    run = subprocess.run([sys.executable, "-c", PROBE.format(code=code)], capture_output=True, text=True,
                         timeout=120, check=True)
    loaded = json.loads(run.stdout.strip().splitlines()[-1])
    leaked = sorted(m for m in loaded if any(m == f or m.startswith(f + ".") for f in forbidden))
    assert not leaked, f"importing {stage} loaded {leaked}"

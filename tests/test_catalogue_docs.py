from pathlib import Path

from po3d_ppl.catalogue import REGISTRY
from po3d_ppl.catalogue.docs import operations_markdown

DOCS = Path(__file__).resolve().parents[1] / "docs" / "operations.md"


def test_operations_doc_is_generated_from_the_catalogue():
    assert DOCS.read_text() == operations_markdown(), (
        "docs/operations.md is stale: run python -m po3d_ppl.catalogue.docs docs/operations.md")


def test_every_declared_operation_has_docs_and_both_implementations():
    import po3d_ppl.questions.reference  # noqa: F401  (attach the implementations)
    import po3d_ppl.reasoning.operations  # noqa: F401

    for op in REGISTRY:
        assert op.doc, op.name
        assert op.world_fn is not None and op.reference_fn is not None, f"{op.name}{op.signature}"

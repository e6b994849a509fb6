"""The side-by-side detection table the detection benchmarks print: two :func:`po3d_ppl.evaluation.objects.summarise`
results in two columns."""

from __future__ import annotations


def print_detection_table(left: dict, right: dict, left_label: str, right_label: str, failures: bool = False) -> None:
    """Proposals, precision, recall and recall of objects >= 20% occluded of ``left`` and ``right`` side by side;
    ``failures`` adds the detection failures by kind."""
    width = max(12, len(left_label), len(right_label))
    rows = [("proposals", left["proposals"], right["proposals"]),
            ("precision", left["precision"], right["precision"]),
            ("recall", left["recall"], right["recall"]),
            ("recall, >= 20% occluded", left["occluded_20pct"]["recall"], right["occluded_20pct"]["recall"])]
    if failures:
        rows += [(f"{group}: {kind}", left["detection_failures"][group][kind],
                  right["detection_failures"][group][kind])
                 for group in ("missed", "false_proposals") for kind in left["detection_failures"][group]]
    print(f"{'':28s} {left_label:>{width}s} {right_label:>{width}s}")
    for name, x, y in rows:
        cell = ".3f" if isinstance(x, float) else "d"
        print(f"{name:28s} {x:{width}{cell}} {y:{width}{cell}}")

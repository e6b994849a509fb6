"""Leave-one-seed-out check of the answer calibration: fit on every validation seed but one, measure on that one.

Each seed's questions are answered once by ours from the image (the evidence cache of ``--cache``; the same
records ``po3d train answer-calibration`` fits on), then for each objective of
:data:`po3d_ppl.evaluation.answer_calibration.OBJECTIVES`, without and with the top-answer map (``+top``), the
calibration is fitted on the other seeds and its top-answer ECE (15 bins), mean confidence and NLL are measured
on the held-out one. Use validation seeds only: this chooses how the shipped calibration is fitted.

    python benchmarks/answer_calibration_crossfit.py --data /work/data/perc_val_s712 --data /work/data/val_s716 \\
        --data /work/data/val_s717 --data /work/data/val_s718 --cache /work/data/cache/val --json crossfit.json
"""

from __future__ import annotations

import argparse
import json
import statistics
from pathlib import Path


def answered(data: Path, cache: Path | None, backend) -> list:
    """The records of ours (raw posterior) on every question of ``data``, from the image evidence."""
    from rich.console import Console

    from po3d_ppl.cli.evaluate import _run

    _, run, _ = _run(data, "all", "ours", 0.0, 0, None, cache, False, "cpu", 1, Console(stderr=True), data.name,
                     "image", priors="shipped", recalibrate=False, backend=backend)
    return run.records


def held_out(records: dict[str, list], objective: str, top_answer: bool) -> list[dict]:
    """Per held-out seed: raw accuracy and ECE, and mean confidence, ECE and NLL after the fit on the others."""
    from po3d_ppl.evaluation.answer_calibration import fit
    from po3d_ppl.evaluation.calibration import calibration_report
    from po3d_ppl.evaluation.runner import CALIBRATED, recalibrated

    rows = []
    for name, test in records.items():
        calibration, _ = fit([r for other, rs in records.items() if other != name for r in rs], objective=objective,
                             top_answer=top_answer)
        for record in test:
            record.predictions[CALIBRATED] = recalibrated(record, calibration)
        raw, after = calibration_report(test, "ours").row(), calibration_report(test, CALIBRATED).row()
        rows.append({"held_out": name, "questions": len(test), "accuracy": raw["accuracy"], "ece_raw": raw["ece"],
                     "confidence": after["mean_confidence"], "ece": after["ece"], "nll": after["nll"]})
    return rows


def main() -> None:
    from po3d_ppl.cli.evaluate import make_backend
    from po3d_ppl.evaluation.answer_calibration import OBJECTIVES

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", type=Path, action="append", required=True, help="validation dataset (>= 2)")
    parser.add_argument("--cache", type=Path, default=None, help="evidence cache directory")
    parser.add_argument("--json", type=Path, default=None, help="write every row here")
    args = parser.parse_args()
    if len(args.data) < 2:
        parser.error("give at least two --data seeds: one is held out while the others are fitted on")
    backend = make_backend("image", 0.0, 0, None)
    records = {d.name: answered(d, args.cache, backend) for d in args.data}
    report = {}
    for objective in OBJECTIVES:
        for top_answer in (False, True):
            family = f"{objective}+top" if top_answer else objective
            rows = held_out(records, objective, top_answer)
            report[family] = {"rows": rows, "mean_ece": statistics.mean(r["ece"] for r in rows),
                              "mean_nll": statistics.mean(r["nll"] for r in rows)}
            for r in rows:
                print(f"{family:9s} {r['held_out']:16s} n {r['questions']:5d} accuracy {r['accuracy']:.4f} "
                      f"raw ECE {r['ece_raw']:.4f} -> confidence {r['confidence']:.4f} ECE {r['ece']:.4f} "
                      f"NLL {r['nll']:.3f}")
            print(f"{family:9s} mean held-out ECE {report[family]['mean_ece']:.4f}, "
                  f"NLL {report[family]['mean_nll']:.3f}")
    if args.json is not None:
        args.json.write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()

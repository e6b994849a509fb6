"""Exact inference on image evidence: seconds per question file and fallbacks to sampling, from a dataset's cache.

Reads the evidence that `po3d eval vqa --perception image` cached (DATA/eval_cache; nothing is parsed: an image
without cached evidence stops the run) and answers every question of the chosen images with ``auto``, as the
pipeline does, timing each. To compare two versions of the reasoning code side by side, run it from both
checkouts (``PYTHONPATH=OTHER python benchmarks/bench_image_inference.py ...``) with ``--json`` and
``--compare OTHER.json``: the per-file seconds, their ratio and the largest difference between the answers.

    python benchmarks/bench_image_inference.py --data /work/data/val_s716 --images 12
"""

from __future__ import annotations

import argparse
import json
import time
import warnings
from collections import defaultdict
from pathlib import Path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", required=True, help="dataset whose eval_cache holds the image evidence")
    parser.add_argument("--images", type=int, default=12, help="the first N images")
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--json", default=None, help="write the answers and times here")
    parser.add_argument("--compare", default=None, help="another run's --json, shown side by side")
    args = parser.parse_args()

    import torch

    from po3d_ppl.cli.evaluate import resolve_priors
    from po3d_ppl.evaluation.backends import ImageBackend
    from po3d_ppl.evaluation.cache import EvidenceCache
    from po3d_ppl.evaluation.runner import split_items
    from po3d_ppl.questions.dataset import load_dataset
    from po3d_ppl.reasoning.inference import SceneReasoner

    torch.set_num_threads(args.threads)
    data = Path(args.data)
    dataset, backend, store = load_dataset(data), ImageBackend(), EvidenceCache(data / "eval_cache")
    priors = resolve_priors("shipped", None)
    by_image = split_items(dataset, "all")

    def uncached():
        raise SystemExit(f"no cached evidence for an image of {data}: run `po3d eval vqa --data {data} "
                         "--perception image` first")

    rows = []
    for index in list(by_image)[:args.images]:
        evidence = backend.calibrate(store.get(dataset.image_path(index), backend.identity(), uncached))
        reasoner = SceneReasoner(evidence, priors)
        reasoner.posteriors  # once per image, as the evaluation does; not counted per question
        for item in by_image[index]:
            start = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                dist = reasoner.infer(list(item.program), "auto")
            rows.append({"image": index, "question": item.question_index, "file": item.file,
                         "seconds": time.perf_counter() - start, "fallback": "fallback" in dist.info,
                         "probs": {str(k): float(v) for k, v in dist.probs.items()}, "invalid": float(dist.invalid)})
    if args.json:
        Path(args.json).write_text(json.dumps(rows))
    other = json.loads(Path(args.compare).read_text()) if args.compare else None
    _print(rows, other)


def _totals(rows) -> dict[str, tuple[int, float, int]]:
    """(questions, seconds, fallbacks) per question file, and over all of them under "all"."""
    files: dict[str, list] = defaultdict(list)
    for row in rows:
        files[row["file"]].append(row)
    files = {**dict(sorted(files.items())), "all": rows}
    return {f: (len(rs), sum(r["seconds"] for r in rs), sum(r["fallback"] for r in rs)) for f, rs in files.items()}


def _print(rows, other) -> None:
    mine, theirs = _totals(rows), _totals(other) if other else {}
    print(f"{'file':16s} {'questions':>9s} {'seconds':>8s} {'fallbacks':>9s}" + ("  other s  ratio  fallbacks"
                                                                                  if other else ""))
    for name, (n, s, f) in mine.items():
        line = f"{name:16s} {n:9d} {s:8.1f} {f:9d}"
        if other:
            o = theirs.get(name, (0, 0.0, 0))
            line += f"  {o[1]:7.1f}  {o[1] / max(s, 1e-9):5.1f}  {o[2]:9d}"
        print(line)
    if other:
        same = [(a, b) for a, b in zip(rows, other) if not a["fallback"] and not b["fallback"]]
        worst = max((abs(a["probs"].get(k, 0.0) - b["probs"].get(k, 0.0)) for a, b in same
                     for k in set(a["probs"]) | set(b["probs"])), default=0.0)
        print(f"largest answer difference where both answered exactly: {worst:.2e} over {len(same)} questions")


if __name__ == "__main__":
    main()

"""Answers from the image split by whether the question's objects were detected.

Every question of ``--data`` is answered with the ground-truth program on the image evidence (the shipped models,
the evidence cache ``po3d eval vqa --perception image`` fills), and split by whether every object of its reference
trace (the ``unique`` results, queried objects and the owners of queried parts, as the difficulty analysis reads
them) has a proposal at box IoU >= 0.5. It tells how much of each file's error waits on detection rather than on
the evidence of the objects that were found. Ground truth is read here for scoring only.

    python benchmarks/answers_by_detection.py --data /work/data/val_s716 [--limit 60]
"""

from __future__ import annotations

from collections import defaultdict

from dataset_args import dataset_parser


def main() -> None:
    parser = dataset_parser(__doc__)
    args = parser.parse_args()

    import numpy as np
    import torch

    from po3d_ppl.cli.evaluate import resolve_priors
    from po3d_ppl.evaluation.backends import ImageBackend, Observation
    from po3d_ppl.evaluation.cache import EvidenceCache
    from po3d_ppl.evaluation.objects import match_boxes
    from po3d_ppl.evaluation.runner import evaluate, parse_methods
    from po3d_ppl.questions.dataset import load_dataset
    from po3d_ppl.questions.executor import execute

    torch.set_num_threads(args.threads)
    dataset = load_dataset(args.data)
    backend, store = ImageBackend(), EvidenceCache(args.data / "eval_cache")
    run = evaluate(dataset, args.split, backend, parse_methods("ours"), cache=store, limit=args.limit,
                   priors=resolve_priors("shipped"))
    detected: dict[int, set[int]] = {}
    for index in sorted({r.item.image_index for r in run.records}):
        scene = dataset.scene(index)
        seen = Observation(index, dataset.image_path(index), scene)
        evidence = store.get(seen.image_path, backend.identity(), lambda: backend.evidence(seen))  # cached above
        boxes = np.array([o.annotation.bbox for o in scene.objects], dtype=np.float64).reshape(-1, 4)
        detected[index] = {j for _, j in match_boxes(evidence.boxes.numpy(), boxes, 0.5)}
    tally: dict[tuple[str, bool], list[int]] = defaultdict(lambda: [0, 0])
    for record in run.records:
        trace = execute(dataset.scene(record.item.image_index), record.item.program)
        objects = {int(v) for v, kind in zip(trace.outputs, trace.types) if kind == "Object"}
        objects |= {int(v[0]) for v, kind in zip(trace.outputs, trace.types) if kind == "Part"}
        found = objects <= detected[record.item.image_index]
        tally[(record.item.file, found)][0] += record.correct("ours")
        tally[(record.item.file, found)][1] += 1
    print(f"{len(run.records)} questions on {len(detected)} images of {args.data}")
    print("| file | trace all detected: n, accuracy | an object missed: n, accuracy |")
    print("|---|---|---|")
    for file in sorted({f for f, _ in tally}):
        cells = []
        for found in (True, False):
            right, n = tally.get((file, found), (0, 0))
            cells.append(f"{n}, {100 * right / n:.1f}%" if n else "0, -")
        print(f"| {file} | {cells[0]} | {cells[1]} |")


if __name__ == "__main__":
    main()

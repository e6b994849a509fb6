"""Inference speed on 10-object scenes: exact and sampling per question, against Pyro's generic path.

For every question of a freshly built dataset of 10-object scenes (all question files), time ``exact`` (the lifted
engine), ``sampling`` (4,096 posterior samples) and the ``thresholded``/``soft`` baselines; on a subset, also time
``generic`` (Pyro's ``TraceEnum_ELBO.compute_marginals`` on the same factor graph) and report the speed ratio on
the same questions. Evidence comes from the ground truth with sensor noise (``--noise``; 0 = certain). Posterior
tables are computed once per scene (as ``SceneReasoner`` does) and reported separately; the baselines' per-scene
views are built by the first question of each scene and counted in its time.

    python benchmarks/bench_inference.py --scenes 8 --noise 0.1 --generic 24
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from collections import defaultdict


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=8)
    parser.add_argument("--objects", type=int, default=10)
    parser.add_argument("--noise", type=float, default=0.1)
    parser.add_argument("--samples", type=int, default=4096)
    parser.add_argument("--generic", type=int, default=24, help="questions also run through the generic path")
    parser.add_argument("--generic-files", default="core,pose,obj_occlusion",
                        help="question files the generic path samples from (it takes minutes per part question)")
    parser.add_argument("--generic-gib", type=float, default=2.0, help="memory budget of each generic call")
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--seed", type=int, default=11)
    parser.add_argument("--data", default=None, help="reuse a built dataset directory")
    args = parser.parse_args()

    import torch

    torch.set_num_threads(args.threads)
    from po3d_ppl.perception import simulated_evidence
    from po3d_ppl.questions.dataset import BuildConfig, build_dataset, load_dataset
    from po3d_ppl.reasoning import Budget, BudgetExceeded, SceneReasoner

    root = args.data or tempfile.mkdtemp(prefix="bench_inference_")
    if not os.path.exists(os.path.join(root, "manifest.json")):
        build_dataset(root, BuildConfig(scenes=args.scenes, seed=args.seed, width=320, height=240,
                                        min_objects=args.objects, max_objects=args.objects), workers=2)
    data = load_dataset(root)
    questions = [(name, q) for name, qs in sorted(data.questions.items()) for q in qs]
    print(f"{len(questions)} questions on {len(data.public_scenes)} scenes of {args.objects} objects, "
          f"noise {args.noise}, {args.threads} thread(s)")

    warm = SceneReasoner(simulated_evidence(data.scene(0)))  # first calls pay one-off initialisation
    warm.infer([{k: v for k, v in n.items() if k != "_output"} for n in questions[0][1]["program"]], "exact")
    reasoners, tables = {}, []
    times: dict[str, list[float]] = defaultdict(list)
    by_file: dict[str, list[float]] = defaultdict(list)
    generic_pairs, generic_refused = [], []
    generic_budget = Budget(max_bytes=int(args.generic_gib * 2**30), max_seconds=None)
    fallbacks = 0
    for k, (name, q) in enumerate(questions):
        index = q["image_index"]
        if index not in reasoners:
            reasoners[index] = SceneReasoner(simulated_evidence(data.scene(index), noise=args.noise,
                                                                      seed=index))
            start = time.perf_counter()
            reasoners[index].posteriors
            tables.append(time.perf_counter() - start)
        reasoner = reasoners[index]
        program = [{key: v for key, v in node.items() if key != "_output"} for node in q["program"]]
        start = time.perf_counter()
        try:
            reasoner.infer(program, "exact")
            exact = time.perf_counter() - start
        except Exception as reason:  # noqa: BLE001 - a benchmark reports, it does not stop
            exact = float("nan")
            fallbacks += 1
            print(f"  exact refused: {name} {q['question']!r}: {reason}")
        times["exact"].append(exact)
        by_file[name].append(exact)
        start = time.perf_counter()
        reasoner.infer(program, "sampling", num_samples=args.samples)
        times["sampling"].append(time.perf_counter() - start)
        for baseline in ("thresholded", "soft"):
            start = time.perf_counter()
            reasoner.infer(program, baseline)
            times[baseline].append(time.perf_counter() - start)
        if (name in args.generic_files.split(",") and k % max(1, len(questions) // max(4 * args.generic, 1)) == 0
                and len(generic_pairs) < args.generic and exact == exact):
            start = time.perf_counter()
            try:
                reasoner.reference(program, "generic", budget=generic_budget)
                generic_pairs.append((time.perf_counter() - start, exact))
            except BudgetExceeded as refusal:
                generic_refused.append(str(refusal))

    def ms(values):
        values = [v for v in values if v == v]
        return (f"median {1000 * statistics.median(values):7.1f} ms   p90 "
                f"{1000 * sorted(values)[int(0.9 * (len(values) - 1))]:7.1f} ms   max {1000 * max(values):7.1f} ms")

    print(f"posterior tables (once per scene): {ms(tables)}")
    print(f"exact    ({len(times['exact'])} questions): {ms(times['exact'])}   refused: {fallbacks}")
    print(f"sampling ({args.samples} samples):        {ms(times['sampling'])}")
    print(f"thresholded baseline:          {ms(times['thresholded'])}")
    print(f"soft baseline:                 {ms(times['soft'])}")
    for name, values in sorted(by_file.items()):
        print(f"  exact on {name:<14} {ms(values)}")
    if generic_pairs:
        generic = [g for g, _ in generic_pairs]
        ratios = [g / e for g, e in generic_pairs if e == e and e > 0]
        print(f"generic  ({len(generic)} questions): {ms(generic)}")
        print(f"speed-up of exact over generic on the same questions: median {statistics.median(ratios):.0f}x, "
              f"min {min(ratios):.0f}x")
    if generic_refused:
        print(f"generic refused ({len(generic_refused)}, budget {args.generic_gib:g} GiB): {generic_refused[0]}")


if __name__ == "__main__":
    main()

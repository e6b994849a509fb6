"""Every answer and probability of every public inference method on a fixed set of questions, as exact bits.

Refactors of the reasoning stack must not change a single number: run this before and after and compare the two
files (``cmp``). Floats are written with ``float.hex`` so equal files mean bit-identical results.

    python benchmarks/answer_snapshot.py --out before.json
    python benchmarks/answer_snapshot.py --out after.json && cmp before.json after.json
"""

from __future__ import annotations

import argparse
import json


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True)
    parser.add_argument("--scenes", type=int, default=6)
    parser.add_argument("--noise", type=float, default=0.1)
    parser.add_argument("--seed", type=int, default=20261201)
    parser.add_argument("--methods", default="exact,sampling,thresholded,soft,dense")
    args = parser.parse_args()

    import torch

    torch.set_num_threads(1)
    from po3d_ppl.questions.scene_questions import generate_questions
    from po3d_ppl.reasoning import SceneReasoner
    from po3d_ppl.world import generate_scene
    from po3d_ppl.world.sampler import SceneConfig

    try:  # the simulated sensor's home after the architecture refactor
        from po3d_ppl.perception import simulated_evidence
    except ImportError:

        simulated_evidence = simulated_evidence

    records = []
    for index in range(args.scenes):
        scene = generate_scene(seed=args.seed + index, config=SceneConfig(min_objects=5, max_objects=8)).scene
        questions = generate_questions(scene, seed=index)
        reasoner = SceneReasoner(simulated_evidence(scene, noise=args.noise, seed=index))
        for file_name, qs in sorted(questions.items()):
            for q in qs:
                program = [{k: v for k, v in n.items() if k != "_output"} for n in q["program"]]
                row = {"scene": index, "file": file_name, "question": q["question"]}
                for method in args.methods.split(","):
                    try:
                        dist = (reasoner.reference(program, method) if method == "dense"
                                else reasoner.infer(program, method, num_samples=512))
                    except Exception as error:  # noqa: BLE001 - a refusal is part of the snapshot
                        row[method] = f"refused: {type(error).__name__}"
                        continue
                    row[method] = {"invalid": float(dist.invalid).hex(),
                                   "probs": {str(a): float(p).hex() for a, p in dist.probs.items()}}
                records.append(row)
    with open(args.out, "w") as fh:
        json.dump(records, fh, indent=0, sort_keys=True)
    print(f"{len(records)} questions on {args.scenes} scenes -> {args.out}")


if __name__ == "__main__":
    main()

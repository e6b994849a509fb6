"""Dataset build throughput: scenes/s/core, questions per scene, and where the time goes (render vs questions).

    python benchmarks/bench_dataset.py [--scenes 20] [--width 640 --height 480] [--toy-scenes 100]

Two measurements:
1. a real build (``build_dataset``, one worker = one core) of ``--scenes`` scenes: per-scene render time
   (sampling, ray casting, annotation, shading, PNG) and question time (candidates of every family), plus the
   sequential assembly (balancing, JSON files);
2. question generation alone on ``--toy-scenes`` random hand-built scenes (no rendering), the generator's own
   speed: candidates of every family + balanced selection, per scene.
Targets: >= 2 scenes/s/core for the build with about 30 questions per scene; question time well under 0.2 s.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time

from po3d_ppl.questions.balance import AnswerBalancer
from po3d_ppl.questions.dataset import BuildConfig, build_dataset
from po3d_ppl.questions.scene_questions import generate_questions
from po3d_ppl.questions.toy_scenes import random_toy_scene

TARGET_SCENES_PER_S = 2.0
TARGET_QUESTION_S = 0.2


def bench_build(scenes: int, width: int, height: int) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        config = BuildConfig(scenes=scenes, seed=1, width=width, height=height)
        report = build_dataset(tmp, config, workers=1)
    render = [t.render_s for t in report.timings]
    questions = [t.questions_s for t in report.timings]
    emitted = sum(report.manifest["counts"]["questions"].values())
    per_scene = report.wall_s / scenes
    print(f"build: {scenes} scenes at {width}x{height}, 1 worker (1 core)")
    print(f"  wall {report.wall_s:.1f} s -> {1 / per_scene:.2f} scenes/s/core "
          f"(target {TARGET_SCENES_PER_S}: ratio {1 / per_scene / TARGET_SCENES_PER_S:.2f})")
    print(f"  render    mean {statistics.mean(render):.3f} s/scene  median {statistics.median(render):.3f}")
    print(f"  questions mean {statistics.mean(questions):.3f} s/scene  median {statistics.median(questions):.3f}")
    print(f"  assembly  {report.assemble_s / scenes * 1000:.1f} ms/scene")
    print(f"  share: render {sum(render) / report.wall_s:.0%}, questions {sum(questions) / report.wall_s:.0%}")
    print(f"  questions emitted: {emitted / scenes:.1f} per scene "
          f"({', '.join(f'{k} {v}' for k, v in report.manifest['counts']['questions'].items())})")


def bench_questions(scenes: int) -> None:
    toy = [random_toy_scene(seed) for seed in range(scenes)]
    balancer = AnswerBalancer()
    times, counts = [], []
    for seed, scene in enumerate(toy):
        start = time.perf_counter()
        out = generate_questions(scene, seed, balancer=balancer)
        times.append(time.perf_counter() - start)
        counts.append(sum(len(v) for v in out.values()))
    mean = statistics.mean(times)
    print(f"questions only: {scenes} toy scenes (3-10 objects)")
    print(f"  {mean * 1000:.1f} ms/scene mean, {statistics.median(times) * 1000:.1f} median, "
          f"{max(times) * 1000:.1f} max; {statistics.mean(counts):.1f} questions/scene "
          f"(target < {TARGET_QUESTION_S * 1000:.0f} ms: ratio {mean / TARGET_QUESTION_S:.2f})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=20)
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)
    parser.add_argument("--toy-scenes", type=int, default=100)
    args = parser.parse_args()
    if args.toy_scenes > 0:
        bench_questions(args.toy_scenes)
    if args.scenes > 0:
        bench_build(args.scenes, args.width, args.height)


if __name__ == "__main__":
    main()

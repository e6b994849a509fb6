"""Fuzz the inference engine: random well-typed programs on rendered 10-object scenes at sensor noise 0.1.

Each program runs through ``auto`` under a per-call budget (default 2 GiB, 4.5 s). Reported: crashes (anything
but a typed ``Po3dError``), the slowest call, calls over 5 s, the peak resident memory any call added (sampled by
a thread every 2 ms), and the share of programs answered exactly, by sampling, and refused.

    python benchmarks/bench_fuzz_inference.py --programs 2000 --scenes 10
    python benchmarks/bench_fuzz_inference.py --programs 200 --method exact   # refusals instead of fallbacks
"""

from __future__ import annotations

import argparse
import os
import random
import threading
import time
from collections import Counter


class PeakMemory:
    """Resident memory sampled on a thread: ``peak - base`` of the last ``measure`` block, in bytes."""

    def __init__(self, interval: float = 0.002):
        self.interval, self.page = interval, os.sysconf("SC_PAGE_SIZE")
        self.base = self.peak = 0
        self._running = False

    def rss(self) -> int:
        with open("/proc/self/statm") as fh:
            return int(fh.read().split()[1]) * self.page

    def _watch(self) -> None:
        while self._running:
            self.peak = max(self.peak, self.rss())
            time.sleep(self.interval)

    def __enter__(self):
        self.base = self.peak = self.rss()
        self._running = True
        self._thread = threading.Thread(target=self._watch, daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._running = False
        self._thread.join()
        self.peak = max(self.peak, self.rss())

    @property
    def added(self) -> int:
        return self.peak - self.base


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--programs", type=int, default=2000)
    parser.add_argument("--scenes", type=int, default=10)
    parser.add_argument("--noise", type=float, default=0.1)
    parser.add_argument("--method", default="auto")
    parser.add_argument("--max-gib", type=float, default=2.0)
    parser.add_argument("--max-seconds", type=float, default=4.5)
    parser.add_argument("--max-depth", type=int, default=7)
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args()

    import torch

    torch.set_num_threads(1)
    from po3d_ppl.errors import Po3dError
    from po3d_ppl.language import program_to_text
    from po3d_ppl.language.random_programs import random_program
    from po3d_ppl.perception import simulated_evidence
    from po3d_ppl.reasoning import Budget, SceneReasoner
    from po3d_ppl.reasoning.compiler import ANSWER_TYPES
    from po3d_ppl.world import generate_scene
    from po3d_ppl.world.sampler import SceneConfig

    config = SceneConfig(min_objects=10, max_objects=10)
    reasoners = []
    for k in range(args.scenes):
        scene = generate_scene(seed=args.seed * 1000 + k, config=config).scene
        reasoners.append(SceneReasoner(simulated_evidence(scene, noise=args.noise, seed=k)))
    budget = Budget(int(args.max_gib * 2**30), args.max_seconds)
    rng = random.Random(args.seed)
    outcomes: Counter = Counter()
    crashes, slow, times, peaks = [], [], [], []
    for k in range(args.programs):
        program = random_program(rng, ANSWER_TYPES, max_depth=args.max_depth)
        reasoner = reasoners[k % len(reasoners)]
        start = time.perf_counter()
        with PeakMemory() as memory:
            try:
                dist = reasoner.infer(program, args.method, budget=budget)
                outcome = "sampling" if dist.method == "sampling" or "fallback" in dist.info else "exact"
            except Po3dError as refusal:
                outcome = f"refused ({type(refusal).__name__})"
            except Exception as error:  # noqa: BLE001 - a crash is what the benchmark looks for
                outcome = "crash"
                crashes.append((program_to_text(program), f"{type(error).__name__}: {error}"))
        elapsed = time.perf_counter() - start
        outcomes[outcome] += 1
        times.append(elapsed)
        peaks.append(memory.added)
        if elapsed > 5.0:
            slow.append((elapsed, program_to_text(program)))
        if (k + 1) % 100 == 0:
            print(f"  {k + 1}/{args.programs}: {dict(outcomes)}, slowest {max(times):.2f} s, "
                  f"peak +{max(peaks) / 2**20:.0f} MiB", flush=True)

    n = args.programs
    times.sort()
    print(f"\n{n} random well-typed programs (depth <= {args.max_depth}) on {args.scenes} scenes of 10 objects, "
          f"noise {args.noise}, method {args.method}, budget {args.max_gib:g} GiB / {args.max_seconds:g} s")
    for outcome, count in sorted(outcomes.items()):
        print(f"  {outcome:40s} {count:5d}  {100 * count / n:5.1f}%")
    print(f"  time per call: median {times[n // 2] * 1e3:.1f} ms, p99 {times[int(n * 0.99)] * 1e3:.0f} ms, "
          f"max {times[-1]:.2f} s; calls over 5 s: {len(slow)}")
    print(f"  peak resident memory added by a call: max {max(peaks) / 2**20:.0f} MiB "
          f"(calls over {args.max_gib:g} GiB: {sum(p > args.max_gib * 2**30 for p in peaks)})")
    print(f"  crashes: {len(crashes)}")
    for text, error in crashes[:10]:
        print(f"    {text}\n      {error[:300]}")
    for elapsed, text in sorted(slow, reverse=True)[:5]:
        print(f"  slow {elapsed:.1f} s: {text}")


if __name__ == "__main__":
    main()

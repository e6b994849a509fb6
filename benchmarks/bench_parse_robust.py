"""Latency of the shipped parser (the ensemble) and of its first member alone on questions in many phrasings (no
dataset needed), with and without the unknown-word mechanism.

    python benchmarks/bench_parse_robust.py --questions 300 [--corpus-seed 4242] [--independent DIR]

Questions: held-out parser-corpus questions (realised phrasings of every family; ``--corpus-seed`` is not a training
seed), each also with one typo, so the normaliser's work is timed too; or the records of ``--independent``. Per
question (batch of one, after warm-up) it times ``QuestionParser.parse`` (beam 5, best program, calibrated
confidence), and the same through the shipped ensemble (``load_question_parser``: one joint beam over its members,
each hypothesis scored by every member's decoder), and prints median / p90 wall milliseconds and the median CPU time of the process (on a shared machine
the wall time grows with the load; the CPU time is what a parse costs). Budget: beam-5 median <= 10 ms.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path

import numpy as np
import torch


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--questions", type=int, default=300)
    parser.add_argument("--corpus-seed", type=int, default=4242)
    parser.add_argument("--independent", type=Path, default=None)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--model-dir", type=Path, default=None)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)

    from po3d_ppl.language import QuestionParser, load_question_parser
    from po3d_ppl.language.seq2seq.calibrate import perturb

    if args.independent is not None:
        from po3d_ppl.questions.parser_eval import load_question_set

        questions = [r.question for r in load_question_set(args.independent)][:args.questions]
    else:
        from po3d_ppl.questions.parser_corpus import CorpusConfig, generate_corpus

        rng = np.random.default_rng(args.corpus_seed)
        base = [e.question for e in generate_corpus(args.questions, CorpusConfig(seed=args.corpus_seed,
                                                                                 template_text=0.3))]
        questions = [q if i % 2 else perturb(q, rng) for i, q in enumerate(base)]
    loaded = QuestionParser.load(args.model_dir)
    ensemble = load_question_parser(args.model_dir)
    rows = []
    for label, qp in (("single beam5 (unknown-word mechanism on)", loaded),
                      ("single beam5 (off: ablation)", QuestionParser(loaded.trained, unknown_words=False)),
                      ("single beam5 n=3", loaded),
                      ("ensemble beam5 (shipped)", ensemble),
                      ("ensemble beam5 n=3", ensemble)):
        n = 3 if "n=3" in label else 1
        for q in questions[:10]:
            qp.parse(q, n=n)
        times, cpu = [], []
        for q in questions:
            start, start_cpu = time.perf_counter(), time.process_time()
            qp.parse(q, n=n)
            times.append(1000 * (time.perf_counter() - start))
            cpu.append(1000 * (time.process_time() - start_cpu))
        times.sort()
        rows.append((label, statistics.median(times), times[int(0.9 * (len(times) - 1))], statistics.median(cpu)))
    print(f"{len(questions)} questions, {args.threads} thread(s); os.getloadavg() = {os.getloadavg()}")
    print(f"{'decoder':<42} {'median ms':>10} {'p90 ms':>8} {'median CPU ms':>14}")
    for label, median, p90, cpu_median in rows:
        print(f"{label:<42} {median:>10.2f} {p90:>8.2f} {cpu_median:>14.2f}")


if __name__ == "__main__":
    main()

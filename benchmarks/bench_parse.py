"""Latency of parsing one question with the shipped parser, against unconstrained greedy decoding.

    python benchmarks/bench_parse.py --data DIR --questions 300     # DIR: a `po3d dataset build` directory

Per question (batch of one, after warm-up) it times
- ``beam5``: what ``QuestionParser.parse`` does by default (constrained beam search, width 5, best program),
- ``beam5 n=3``: the 3-best programs,
- ``greedy``: constrained greedy decoding (no beam, no satisfiability check),
- ``unconstrained``: arg-max over the whole vocabulary, stopping when the token arities close the program
  (the baseline: what a plain seq2seq decoder costs),
and prints the median and 90th percentile, the ratio of medians to the baseline, and each decoder's exact match
on the same questions (an unconstrained output that is not a valid program counts as wrong).
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import torch


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, help="dataset directory (po3d dataset build); default: built-in pairs")
    parser.add_argument("--split", default="test")
    parser.add_argument("--questions", type=int, default=300, help="how many questions to time")
    parser.add_argument("--threads", type=int, default=1, help="torch CPU threads")
    parser.add_argument("--model-dir", type=Path, default=None)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)

    from po3d_ppl.errors import Po3dError
    from po3d_ppl.language import QuestionParser, check_program, program_to_tokens
    from po3d_ppl.language.seq2seq.decode import greedy

    qp = QuestionParser.load(args.model_dir)
    if args.data is not None:
        from po3d_ppl.questions.parser_examples import load_examples

        examples = load_examples(args.data, args.split)
    else:
        import sys

        sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
        from language_pairs import pair_examples

        examples = pair_examples()
    examples = [examples[i] for i in range(0, len(examples), max(1, len(examples) // args.questions))]
    examples = examples[:args.questions]
    arity = {qp.trained.targets.op_id(op.name): len(op.inputs) for op in qp.registry
             if qp.trained.targets.op_id(op.name) is not None}

    def unconstrained(question: str) -> list[str] | None:
        _, words, ngrams, _, _ = qp.encode(question)
        ids = greedy(qp.model, words, None, arity, qp.trained.max_len, qp.step_weights, ngrams=ngrams)
        try:
            program = qp.trained.targets.decode(ids, qp.registry)
            check_program(program, qp.registry)
        except (Po3dError, IndexError):
            return None
        return program_to_tokens(program)

    def constrained_greedy(question: str) -> list[str]:
        _, words, ngrams, _, _ = qp.encode(question)
        ids = greedy(qp.model, words, qp.automaton, weights=qp.step_weights, ngrams=ngrams)
        return program_to_tokens(qp.trained.targets.decode(ids, qp.registry))

    decoders = {
        "beam5": lambda q: qp.parse(q, n=1, beam=5).best.tokens,
        "beam5 n=3": lambda q: qp.parse(q, n=3, beam=5).best.tokens,
        "greedy": constrained_greedy,
        "unconstrained": unconstrained,
    }
    for decode in decoders.values():  # warm-up: caches, allocator
        for example in examples[:10]:
            decode(example.question)
    timings: dict[str, list[float]] = {}
    correct: dict[str, int] = {}
    for name, decode in decoders.items():
        timings[name], correct[name] = [], 0
        for example in examples:
            start = time.perf_counter()
            tokens = decode(example.question)
            timings[name].append(time.perf_counter() - start)
            correct[name] += tokens == program_to_tokens(example.program)
    base = statistics.median(timings["unconstrained"])
    print(f"{len(examples)} questions, torch threads {torch.get_num_threads()}")
    print(f"{'decoder':<15}{'median ms':>11}{'p90 ms':>9}{'x baseline':>12}{'exact match':>13}")
    for name, ts in timings.items():
        median = statistics.median(ts)
        p90 = statistics.quantiles(ts, n=10)[-1]
        print(f"{name:<15}{median * 1e3:>11.2f}{p90 * 1e3:>9.2f}{median / base:>12.2f}"
              f"{correct[name] / len(examples):>13.4f}")


if __name__ == "__main__":
    main()

"""Decoding: constrained beam search (n-best programs with probabilities) and greedy baselines.

Log-probabilities are taken after masking, i.e. under the model's distribution restricted to well-typed
continuations, so the n-best probabilities are those of complete, valid programs. Beam search stops as soon as
no unfinished hypothesis can beat the n-th finished one (scores only decrease), which is exact for the
hypotheses the beam kept.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from po3d_ppl.language.seq2seq.constraints import DecodeState, TypeAutomaton
from po3d_ppl.language.seq2seq.model import Seq2SeqParser, StepWeights


@dataclass(frozen=True)
class Hypothesis:
    ids: tuple[int, ...]
    log_prob: float


def _masked_log_softmax(logits: torch.Tensor, allowed: np.ndarray) -> torch.Tensor:
    mask = torch.from_numpy(allowed).to(logits.device)
    return torch.log_softmax(logits.masked_fill(~mask, float("-inf")), dim=-1)


def select_extensions(scores: list[float], indices: list[int], vocab: int, active: list, automaton: TypeAutomaton,
                      beam: int) -> tuple[list[tuple[float, tuple[int, ...], int, int]], list[int], list]:
    """One beam step's bookkeeping, shared by :func:`beam_search` and the ensemble's joint beam: walk the top
    extensions (``scores`` best first, ``indices`` into the flattened ``[hypotheses, vocab]`` table) and split
    them into finished programs ``(score, ids, row, token)`` and, up to ``beam``, the positions kept with their new
    ``(ids, state)`` hypotheses."""
    finished, kept, next_active = [], [], []
    for position, (score, index) in enumerate(zip(scores, indices)):
        row, token = divmod(index, vocab)
        ids, state = active[row]
        if automaton.completes(state, token):
            finished.append((score, (*ids, token), row, token))
        elif len(kept) < beam:
            kept.append(position)
            next_active.append(((*ids, token), automaton.advance(state, token)))
    return finished, kept, next_active


@torch.inference_mode()
def beam_search(model: Seq2SeqParser, automaton: TypeAutomaton, words: torch.Tensor, n: int = 1, beam: int = 5,
                weights: StepWeights | None = None, ngrams: torch.Tensor | None = None,
                start: tuple[torch.Tensor, ...] | None = None) -> list[Hypothesis]:
    """The ``n`` most probable complete programs for one question ``words`` ``[T]`` (beam width ``beam``).

    ``weights`` (from :meth:`Seq2SeqParser.step_weights`) and ``start`` (the encoder's output,
    :meth:`Seq2SeqParser.start` of ``words``) can be computed once and passed in to save time.
    """
    beam = max(beam, n)
    w = weights or model.step_weights()
    memory, keys, h, c = start if start is not None else model.start(words, ngrams)
    active: list[tuple[tuple[int, ...], DecodeState]] = [((), automaton.initial())]
    active_scores = torch.zeros(1)
    finished: list[Hypothesis] = []
    prev = torch.zeros(1, dtype=torch.long, device=words.device)
    for _ in range(automaton.max_len):
        logits, h, c = model.step(w, prev, h, c, memory, keys)
        allowed = np.stack([automaton.allowed(s) for _, s in active])
        scores = _masked_log_softmax(logits, allowed).cpu() + active_scores[:, None]
        vocab = scores.shape[1]
        top_scores, top_index = scores.flatten().topk(min(2 * beam, int(allowed.sum())))
        score_list = top_scores.tolist()
        done, kept, next_active = select_extensions(score_list, top_index.tolist(), vocab, active, automaton, beam)
        finished += [Hypothesis(ids, score) for score, ids, _, _ in done]
        finished.sort(key=lambda hyp: -hyp.log_prob)
        if not kept or (len(finished) >= n and score_list[kept[0]] <= finished[n - 1].log_prob):
            break
        kept_index = torch.tensor(kept)
        rows = (top_index[kept_index] // vocab).to(h.device)
        h, c = h[rows], c[rows]
        prev = (top_index[kept_index] % vocab).to(words.device)
        active_scores = top_scores[kept_index]
        active = next_active
    return finished[:n]


@torch.inference_mode()
def greedy(model: Seq2SeqParser, words: torch.Tensor, automaton: TypeAutomaton | None = None,
           arity: dict[int, int] | None = None, max_len: int = 64,
           weights: StepWeights | None = None, ngrams: torch.Tensor | None = None) -> list[int]:
    """Greedy decoding of one question on the same fast step as :func:`beam_search`. With ``automaton`` it is
    constrained; without (the baseline) it takes the arg-max over the whole vocabulary and stops when
    ``arity`` says the prefix program is complete (value tokens take no slot), or at ``max_len``."""
    w = weights or model.step_weights()
    memory, keys, h, c = model.start(words, ngrams)
    state = automaton.initial() if automaton is not None else None
    open_slots, ids = 1, []
    prev = torch.zeros(1, dtype=torch.long, device=words.device)
    for _ in range(automaton.max_len if automaton is not None else max_len):
        logits, h, c = model.step(w, prev, h, c, memory, keys)
        if automaton is not None:
            logits = logits.masked_fill(~torch.from_numpy(automaton.allowed(state)).to(logits.device),
                                        float("-inf"))
        token = int(logits.argmax())
        ids.append(token)
        if automaton is not None:
            state = automaton.advance(state, token)
            if state.complete:
                break
        else:
            if token in arity:
                open_slots += arity[token] - 1
            if open_slots <= 0:
                break
        prev = torch.tensor([token], device=words.device)
    return ids


@torch.inference_mode()
def greedy_batch(model: Seq2SeqParser, automaton: TypeAutomaton | None, words: torch.Tensor,
                 lengths: torch.Tensor, arity: dict[int, int] | None = None, max_len: int = 64,
                 ngrams: torch.Tensor | None = None) -> list[list[int]]:
    """Greedy decoding of a batch. With ``automaton`` the output is constrained; without it (the baseline) the
    arg-max token is taken from the whole vocabulary and a sequence ends when ``arity`` says the prefix program
    is complete (value tokens take no slot), or at ``max_len``."""
    batch = words.shape[0]
    memory, mask, state = model.encode(words, lengths, ngrams)
    prev = torch.zeros(batch, 1, dtype=torch.long, device=words.device)
    outputs: list[list[int]] = [[] for _ in range(batch)]
    states = [automaton.initial() for _ in range(batch)] if automaton else None
    open_slots = [1] * batch
    done = [False] * batch
    limit = automaton.max_len if automaton else max_len
    for _ in range(limit):
        logits, state = model.decode(prev, state, memory, mask)
        logits = logits[:, 0, :]
        if automaton is not None:
            allowed = np.stack([automaton.allowed(s) if not s.complete else np.ones(logits.shape[1], bool)
                                for s in states])
            logits = logits.masked_fill(~torch.from_numpy(allowed).to(logits.device), float("-inf"))
        tokens = logits.argmax(dim=-1).tolist()
        for b, token in enumerate(tokens):
            if done[b]:
                continue
            outputs[b].append(token)
            if automaton is not None:
                states[b] = automaton.advance(states[b], token)
                done[b] = states[b].complete
            else:
                if token in arity:
                    open_slots[b] += arity[token] - 1
                done[b] = open_slots[b] <= 0
        if all(done):
            break
        prev = torch.tensor(tokens, device=words.device)[:, None]
    return outputs

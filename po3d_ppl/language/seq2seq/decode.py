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
from po3d_ppl.language.seq2seq.model import Seq2SeqParser


@dataclass(frozen=True)
class Hypothesis:
    ids: tuple[int, ...]
    log_prob: float


def _masked_log_softmax(logits: torch.Tensor, allowed: np.ndarray) -> torch.Tensor:
    mask = torch.from_numpy(allowed).to(logits.device)
    return torch.log_softmax(logits.masked_fill(~mask, float("-inf")), dim=-1)


@torch.inference_mode()
def beam_search(model: Seq2SeqParser, automaton: TypeAutomaton, words: torch.Tensor, n: int = 1,
                beam: int = 5) -> list[Hypothesis]:
    """The ``n`` most probable complete programs for one question ``words`` ``[T]`` (beam width ``beam``)."""
    beam = max(beam, n)
    device = words.device
    ctx = model.start(words)
    h, c = ctx.h, ctx.c
    active: list[tuple[tuple[int, ...], float, DecodeState]] = [((), 0.0, automaton.initial())]
    finished: list[Hypothesis] = []
    prev = torch.zeros(1, dtype=torch.long, device=device)
    for _ in range(automaton.max_len):
        logits, h, c = model.step(prev, h, c, ctx)
        allowed = np.stack([automaton.allowed(s) for _, _, s in active])
        log_probs = _masked_log_softmax(logits, allowed)
        scores = log_probs + torch.tensor([score for _, score, _ in active], device=device).unsqueeze(1)
        flat = scores.flatten()
        count = min(2 * beam, int(allowed.sum()))
        top_scores, top_index = flat.topk(count)
        vocab = scores.shape[1]
        keep_rows, keep = [], []
        for score, index in zip(top_scores.tolist(), top_index.tolist()):
            row, token = divmod(index, vocab)
            ids, _, state = active[row]
            new_state = automaton.advance(state, token)
            if new_state.complete:
                finished.append(Hypothesis((*ids, token), score))
            elif len(keep) < beam:
                keep.append(((*ids, token), score, new_state))
                keep_rows.append(row)
        finished.sort(key=lambda hyp: -hyp.log_prob)
        if not keep or (len(finished) >= n and keep[0][1] <= finished[n - 1].log_prob):
            break
        rows = torch.tensor(keep_rows, device=device)
        h, c = h[rows], c[rows]
        prev = torch.tensor([ids[-1] for ids, _, _ in keep], device=device)
        active = keep
    return finished[:n]


@torch.inference_mode()
def greedy_batch(model: Seq2SeqParser, automaton: TypeAutomaton | None, words: torch.Tensor,
                 lengths: torch.Tensor, arity: dict[int, int] | None = None, max_len: int = 64) -> list[list[int]]:
    """Greedy decoding of a batch. With ``automaton`` the output is constrained; without it (the baseline) the
    arg-max token is taken from the whole vocabulary and a sequence ends when ``arity`` says the prefix program
    is complete (value tokens take no slot), or at ``max_len``."""
    batch = words.shape[0]
    memory, mask, state = model.encode(words, lengths)
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

"""Training and evaluation of the question parser (deterministic from the seed, CPU or any torch device).

Determinism: parameters are initialised from a ``torch.Generator``, batches are shuffled by
``numpy.random.default_rng(seed)``, word dropout draws from that generator, and dropout layers draw from a
forked, seeded torch RNG (``torch.random.fork_rng``), so the process-wide RNG state is left untouched.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import torch
from torch import nn

from po3d_ppl.catalogue import OperationRegistry
from po3d_ppl.errors import InputError
from po3d_ppl.language.seq2seq.constraints import TypeAutomaton
from po3d_ppl.language.seq2seq.data import Example
from po3d_ppl.language.seq2seq.decode import greedy_batch
from po3d_ppl.language.seq2seq.model import ParserConfig, Seq2SeqParser
from po3d_ppl.language.seq2seq.vocab import TargetVocabulary, WordVocabulary, ngram_tensor_rows
from po3d_ppl.language.tokens import program_to_tokens
from po3d_ppl.language.typecheck import check_program


@dataclass(frozen=True)
class TrainConfig:
    seed: int = 0
    epochs: int = 6
    batch_size: int = 64
    lr: float = 2e-3
    embed: int = 64
    hidden: int = 128
    dropout: float = 0.1
    word_dropout: float = 0.02
    clip: float = 5.0
    #: Mask the softmax with the type automaton (the default); False trains a plain seq2seq (ablation).
    constrained_loss: bool = True
    #: Stop after this many optimiser steps (tests use a handful); None trains all epochs.
    max_steps: int | None = None
    #: Character n-gram hash buckets of the subword input (0: words only).
    ngram_buckets: int = 0
    #: Of the words dropped to ``<unk>``, the share that keeps its n-grams (an unseen word still has its letters);
    #: the rest lose both, as words do when the unknown-word mechanism is switched off.
    keep_ngrams: float = 0.7
    #: Stop after this many seconds of training (the budget); None: no limit.
    max_seconds: float | None = None


@dataclass
class Encoded:
    """Examples as padded id tensors plus the per-position constraint mask ids."""

    words: torch.Tensor  # [N, T]
    lengths: torch.Tensor  # [N]
    targets: torch.Tensor  # [N, L], -100 after the end
    mask_ids: torch.Tensor  # [N, L]


@dataclass
class Trained:
    model: Seq2SeqParser
    words: WordVocabulary
    targets: TargetVocabulary
    root_types: tuple[str, ...]
    max_len: int
    history: list[dict] = field(default_factory=list)
    #: The confidence calibration (model_io.Calibration) once fitted.
    calibration: object | None = None


def ngram_table(words: WordVocabulary, buckets: int) -> torch.Tensor:
    """``[V, K]`` n-gram ids of every vocabulary word (padding and ``<unk>`` have none)."""
    rows = ngram_tensor_rows(["", "", *words.words[2:]], buckets) if buckets else [[0]] * len(words)
    table = torch.tensor(rows, dtype=torch.long)
    table[:2] = 0
    return table


def encode_questions(examples: Sequence[Example], words: WordVocabulary) -> tuple[torch.Tensor, torch.Tensor]:
    """Padded word ids ``[N, T]`` of the questions and their lengths ``[N]`` (a question with no words is one
    ``<unk>``)."""
    word_ids = [words.encode(e.question)[0] or [1] for e in examples]
    padded = torch.zeros(len(word_ids), max(map(len, word_ids)), dtype=torch.long)
    for i, ids in enumerate(word_ids):
        padded[i, :len(ids)] = torch.tensor(ids)
    return padded, torch.tensor([len(ids) for ids in word_ids])


def encode_targets(examples: Sequence[Example], targets: TargetVocabulary) -> list[list[int]]:
    """Target ids of each example's program, or a typed error naming the question with an unknown token."""
    out = []
    for e in examples:
        try:
            out.append(targets.encode(e.program))
        except KeyError as exc:
            raise InputError("program", f"{e.source} question {e.question!r}: token {exc} is not in the parser's "
                                        "target vocabulary") from None
    return out


def encode_examples(examples: Sequence[Example], words: WordVocabulary, target_ids: Sequence[Sequence[int]],
                    automaton: TypeAutomaton) -> Encoded:
    """The training tensors of ``examples`` whose programs encode to ``target_ids`` (:func:`encode_targets`)."""
    mask_ids = []
    for ids in target_ids:
        state, keys = automaton.initial(), []
        for token in ids:
            keys.append(automaton.mask_key_id(state))
            state = automaton.advance(state, token)
        mask_ids.append(keys)
    n, length = len(examples), max(map(len, target_ids))
    out = Encoded(*encode_questions(examples, words), torch.full((n, length), -100, dtype=torch.long),
                  torch.zeros(n, length, dtype=torch.long))
    for i, (ids, keys) in enumerate(zip(target_ids, mask_ids)):
        out.targets[i, :len(ids)] = torch.tensor(ids)
        out.mask_ids[i, :len(keys)] = torch.tensor(keys)
    return out


def _decoder_inputs(targets: torch.Tensor) -> torch.Tensor:
    """Shift right: start token 0, then the target ids (padding positions become 0 too)."""
    shifted = torch.zeros_like(targets)
    shifted[:, 1:] = targets[:, :-1].clamp(min=0)
    return shifted


def train_parser(train: Sequence[Example], config: TrainConfig, registry: OperationRegistry,
                 validation: Sequence[Example] = (), device: str | torch.device = "cpu",
                 progress: Callable[[int, int, dict], None] | None = None) -> Trained:
    """Train a parser on ``train``; after each epoch the exact match on ``validation`` is recorded and the
    best epoch's weights are kept. ``progress(step, total_steps, info)`` is called after every step."""
    if not train:
        raise InputError("--data", "no training examples")
    root_types = tuple(sorted({check_program(e.program, registry).type for e in train}))
    words = WordVocabulary.build(e.question for e in train)
    targets = TargetVocabulary.from_registry(registry)
    target_ids = encode_targets(train, targets)
    automaton = TypeAutomaton(registry, targets, root_types, max_len=2 * max(map(len, target_ids)) + 8)
    data = encode_examples(train, words, target_ids, automaton)
    masks = torch.from_numpy(automaton.mask_table()).to(device)

    model_config = ParserConfig(len(words), len(targets), config.embed, config.hidden, config.dropout,
                                config.ngram_buckets)
    table = ngram_table(words, config.ngram_buckets)
    model = Seq2SeqParser(model_config).to(device)
    generator = torch.Generator().manual_seed(config.seed)
    model.reset_parameters(generator)
    optimiser = torch.optim.Adam(model.parameters(), lr=config.lr)
    rng = np.random.default_rng(config.seed)
    n = len(train)
    steps_per_epoch = (n + config.batch_size - 1) // config.batch_size
    total = steps_per_epoch * config.epochs if config.max_steps is None else min(
        config.max_steps, steps_per_epoch * config.epochs)
    schedule = torch.optim.lr_scheduler.OneCycleLR(optimiser, max_lr=config.lr, total_steps=max(total, 1),
                                                   pct_start=0.1)
    loss_fn = nn.CrossEntropyLoss(ignore_index=-100)
    trained = Trained(model, words, targets, root_types, automaton.max_len)
    best_state, best_accuracy, step = None, -1.0, 0
    import time

    started = time.perf_counter()
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(config.seed)
        for epoch in range(config.epochs):
            model.train()
            order = rng.permutation(n)
            running = 0.0
            for start in range(0, n, config.batch_size):
                if step >= total or (config.max_seconds is not None
                                     and time.perf_counter() - started > config.max_seconds):
                    total = step
                    break
                index = torch.from_numpy(order[start:start + config.batch_size])
                length = int(data.lengths[index].max())
                batch_words = data.words[index, :length]
                batch_ngrams = table[batch_words] if config.ngram_buckets else None
                if config.word_dropout > 0:
                    drop = torch.from_numpy(rng.random(tuple(batch_words.shape)) < config.word_dropout)
                    drop &= batch_words > 0
                    if batch_ngrams is not None:
                        lose = drop & torch.from_numpy(rng.random(tuple(batch_words.shape)) >= config.keep_ngrams)
                        batch_ngrams = batch_ngrams.masked_fill(lose[..., None], 0)
                    batch_words = torch.where(drop, torch.ones_like(batch_words), batch_words)
                batch_targets = data.targets[index]
                keep = int((batch_targets >= 0).sum(dim=1).max())
                batch_targets = batch_targets[:, :keep].to(device)
                logits = model(batch_words.to(device), data.lengths[index], _decoder_inputs(batch_targets),
                               None if batch_ngrams is None else batch_ngrams.to(device))
                if config.constrained_loss:
                    allowed = masks[data.mask_ids[index, :keep].to(device)]
                    logits = logits.masked_fill(~allowed, -1e9)
                loss = loss_fn(logits.reshape(-1, logits.shape[-1]), batch_targets.reshape(-1))
                optimiser.zero_grad()
                loss.backward()
                nn.utils.clip_grad_norm_(model.parameters(), config.clip)
                optimiser.step()
                schedule.step()
                step += 1
                value = loss.item()
                running += value
                if progress:
                    progress(step, total, {"epoch": epoch + 1, "loss": value})
            done_steps = step - epoch * steps_per_epoch if step < (epoch + 1) * steps_per_epoch else steps_per_epoch
            record = {"epoch": epoch + 1, "steps": step, "seconds": round(time.perf_counter() - started, 1),
                      "train_loss": running / max(1, done_steps)}
            if validation:
                record["val_exact_match"] = evaluate(trained, validation, registry)["exact_match"]
                if record["val_exact_match"] > best_accuracy:
                    best_accuracy = record["val_exact_match"]
                    best_state = {k: v.detach().clone() for k, v in model.state_dict().items()}
            trained.history.append(record)
            if step >= total:
                break
    if best_state is not None:
        model.load_state_dict(best_state)
    model.eval()
    return trained


def evaluate(trained: Trained, examples: Sequence[Example], registry: OperationRegistry, batch_size: int = 256,
             predict: Callable[[Sequence[Example]], list[list[list[str]]]] | None = None) -> dict:
    """Exact match of the best program (predicted prefix tokens == gold prefix tokens), overall, per question
    file and per family, and, when ``predict`` returns several candidates per question, how often the gold program
    is among them.

    By default predictions are constrained greedy decodes; ``predict`` substitutes another decoder (it returns,
    per example, a list of candidate token lists, best first).
    """
    if predict is None:
        automaton = TypeAutomaton(registry, trained.targets, trained.root_types, trained.max_len)

        def predict(batch: Sequence[Example]) -> list[list[list[str]]]:
            return [[trained.targets.decode_tokens(ids)] for ids in _greedy(trained, automaton, batch)]

    was_training = trained.model.training
    trained.model.eval()
    counts: dict[str, list[int]] = defaultdict(lambda: [0, 0, 0])
    failures: list[dict] = []
    for start in range(0, len(examples), batch_size):
        batch = examples[start:start + batch_size]
        for example, candidates in zip(batch, predict(batch)):
            gold = program_to_tokens(example.program)
            exact = candidates[0] == gold
            listed = gold in candidates
            for key in ("all", f"file:{example.source}", f"family:{example.source}/{example.family}"):
                row = counts[key]
                row[0] += exact
                row[1] += listed
                row[2] += 1
            if not exact:
                failures.append({"question": example.question, "family": f"{example.source}/{example.family}",
                                 "predicted": " ".join(candidates[0]), "gold": " ".join(gold)})
    trained.model.train(was_training)

    def summary(row: list[int]) -> dict:
        return {"exact_match": row[0] / row[2], "in_n_best": row[1] / row[2], "count": row[2]}

    overall = summary(counts["all"]) if examples else {"exact_match": 0.0, "count": 0}
    return {
        **overall,
        "per_file": {k[5:]: summary(v) for k, v in sorted(counts.items()) if k.startswith("file:")},
        "per_family": {k[7:]: summary(v) for k, v in sorted(counts.items()) if k.startswith("family:")},
        "failures": failures,
    }


def _greedy(trained: Trained, automaton: TypeAutomaton, batch: Sequence[Example]) -> list[list[int]]:
    device = next(trained.model.parameters()).device
    words, lengths = encode_questions(batch, trained.words)
    ngrams = None
    if trained.model.config.ngram_buckets:
        ngrams = ngram_table(trained.words, trained.model.config.ngram_buckets)[words].to(device)
    return greedy_batch(trained.model, automaton, words.to(device), lengths, ngrams=ngrams)

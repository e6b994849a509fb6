"""Fitting the parser's confidence calibration (:class:`~po3d_ppl.language.seq2seq.model_io.Calibration`).

The development questions are held-out corpus questions (a seed the model never trained on), some with the damage
real questions bring (:func:`perturb`: a typo, an unseen filler word, a word replaced by an unseen one). Each is parsed; the features are the logit of the top parse's model probability and the numbers of
unknown and corrected words, the label whether the top parse is the gold program. Logistic regression (Newton's
method, a small L2 penalty) gives the four numbers. The independent test set is never used.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from po3d_ppl.language.seq2seq.data import Example
from po3d_ppl.language.tokens import program_to_tokens

#: Words no question uses, to stand for the unknown words of real questions.
_STRANGERS = ("blorp", "quixotic", "zephyr", "kumquat", "marzipan", "wobbly", "glimmering", "xylophone", "tundra",
              "velvet", "hovering", "ancient", "plaid", "sparkly", "rusty", "nearby", "gigantic", "parked")


@dataclass(frozen=True)
class CalibrationReport:
    calibration: object
    questions: int
    accuracy: float
    ece_before: float
    ece_after: float


def _typo(word: str, rng: np.random.Generator) -> str:
    if len(word) < 4:
        return word
    i = int(rng.integers(1, len(word) - 1))
    kind = int(rng.integers(3))
    if kind == 0:
        return word[:i] + word[i + 1:]
    if kind == 1:
        return word[:i] + word[i + 1] + word[i] + word[i + 2:]
    return word[:i] + "abcdefghijklmnopqrstuvwxyz"[int(rng.integers(26))] + word[i + 1:]


def perturb(question: str, rng: np.random.Generator) -> str:
    """``question`` unchanged (two times in five) or with one kind of damage real questions have: a typo in a word,
    a filler word the parser never saw, or a word replaced by one it never saw (which may leave the question
    undecidable: the parse is then likely wrong, and the confidence should say so). No deletions: they change the
    question's meaning while its gold program stays, which would mislabel the development set."""
    words = question.rstrip("?.").split()
    kind = int(rng.integers(5))
    if kind <= 1 or len(words) < 3:
        return question
    i = int(rng.integers(len(words)))
    stranger = _STRANGERS[int(rng.integers(len(_STRANGERS)))]
    if kind == 2:
        words[i] = _typo(words[i], rng)
    elif kind == 3:
        words.insert(i, stranger)
    else:
        words[i] = stranger
    return " ".join(words) + "?"


def expected_calibration_error(confidence: Sequence[float], correct: Sequence[bool], bins: int = 15) -> float:
    """Equal-width-bin ECE: torchmetrics' binned calibration error, confidences clamped below 1 (its issue #3510
    puts a confidence of exactly 1.0 into a bin of its own; see po3d_ppl.evaluation.calibration)."""
    import torch
    from torchmetrics.functional.classification import binary_calibration_error

    if len(confidence) == 0:
        return float("nan")
    conf = torch.tensor(list(confidence), dtype=torch.float64).clamp(0.0, 1.0 - 1e-6)
    target = torch.tensor([int(bool(c)) for c in correct])
    return float(binary_calibration_error(conf, target, n_bins=bins, norm="l1"))


def fit_calibration(parser, examples: Sequence[Example], seed: int = 0, beam: int = 5) -> CalibrationReport:
    """Fit ``parser``'s calibration on perturbed copies of ``examples`` (held-out corpus questions)."""
    from po3d_ppl.language.seq2seq.model_io import Calibration

    rng = np.random.default_rng(seed)
    features, labels, raw = [], [], []
    for example in examples:
        question = perturb(example.question, rng)
        parse = parser.parse(question, n=1, beam=beam)
        p = min(max(parse.best.probability, 1e-9), 1 - 1e-9)
        features.append([math.log(p / (1 - p)), len(parse.unknown_words), len(parse.corrections), 1.0])
        labels.append(parse.best.tokens == program_to_tokens(example.program))
        raw.append(p)
    x, y = np.asarray(features), np.asarray(labels, dtype=float)
    w = np.array([1.0, 0.0, 0.0, 0.0])
    penalty = np.diag([1e-3, 1e-3, 1e-3, 0.0])
    for _ in range(50):
        z = np.clip(x @ w, -30, 30)
        q = 1 / (1 + np.exp(-z))
        gradient = x.T @ (q - y) + penalty @ w
        hessian = (x * (q * (1 - q))[:, None]).T @ x + penalty + 1e-9 * np.eye(4)
        step = np.linalg.solve(hessian, gradient)
        w -= step
        if np.abs(step).max() < 1e-8:
            break
    calibration = Calibration(scale=float(w[0]), unknown=float(w[1]), corrected=float(w[2]), bias=float(w[3]))
    after = [calibration(p, int(f[1]), int(f[2])) for p, f in zip(raw, features)]
    return CalibrationReport(calibration, len(examples), float(y.mean()),
                             expected_calibration_error(raw, labels), expected_calibration_error(after, labels))

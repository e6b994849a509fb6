"""An ensemble of question parsers: the members' n-best lists merged and re-scored under every member.

Why: on questions worded by a new author the parser's accuracy moves by one to two points with the training seed
alone (docs/language.md, dev 2), so one run's mistakes are partly its own. Models trained with other seeds or
corpora disagree on those, and a candidate that all of them find probable is more likely right.

How: each member reads the question with its own words and normaliser. Where the members share their target
vocabulary (the shipped ones do), one joint beam (:func:`joint_beam_search`) extends hypotheses under every
member's decoder at once and ranks them by the combined score below, so each candidate's score is the rule applied
to the members' own log-probabilities of it and nothing is re-scored (about half the time of the path below, with
the same accuracy on the dev sets: docs/language.md). Otherwise each member decodes with its own constrained beam
and proposes its n-best programs. Every candidate of the union is then scored under every member by teacher forcing: the
log-probability of the candidate's target tokens under that member's constrained (masked) distribution, the same
quantity its beam search reports. A member whose vocabulary, registry or length budget cannot express a candidate
gives it -inf. The members' log-probabilities are combined by

- ``"product"``: their mean (the log of the geometric mean of the probabilities, a product of experts with
  exponents 1/M). Its sum over all programs is at most 1 (geometric mean <= arithmetic mean), so it is left
  unnormalised: the intractable normaliser would only raise every probability by the same factor, and leaving
  it keeps M copies of one parser identical to that parser.
- ``"mixture"``: the log of the mean probability, a proper distribution over programs (chosen on dev 2).

Re-scoring whole candidates lets members have different target vocabularies and costs one batched
teacher-forced pass per member; it is the fallback for such members.

The result is a :class:`~po3d_ppl.language.seq2seq.model_io.QuestionParse` like a single parser's, so answering,
evaluation and the CLI work unchanged. Words, unknown words and corrections are the first member's. The
confidence is the mean of the members' calibrations applied to the combined top probability (each with its own
unknown-word and rewrite counts; with one member, that member's confidence), unless the ensemble has a
calibration of its own (:meth:`ParserEnsemble.fit_calibration`, fitted as a single parser's is).

The shipped parser is an ensemble: ``models/manifest.json`` lists it as ``question_parser_ensemble`` (its members'
manifest entries, in order, and the file ``question_parser_ensemble.json`` holding them, the rule and the
ensemble's calibration; written by ``po3d train parser-ensemble``). :func:`load_question_parser` loads it, every
member file checked against its sha256, or the single parser where a directory lists no ensemble.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Literal

import numpy as np
import torch

from po3d_ppl.errors import InputError, ModelFileError
from po3d_ppl.language.ast import Program
from po3d_ppl.language.satisfiable import unsatisfiable_node
from po3d_ppl.language.seq2seq.calibrate import CalibrationReport, fit_calibration
from po3d_ppl.language.seq2seq.data import Example
from po3d_ppl.language.seq2seq.decode import beam_search, select_extensions
from po3d_ppl.language.seq2seq.model_io import (
    MODEL_NAME,
    Calibration,
    ParsedProgram,
    QuestionParse,
    QuestionParser,
)
from po3d_ppl.language.seq2seq.vocab import tokenize
from po3d_ppl.language.tokens import program_to_tokens
from po3d_ppl.language.typecheck import check_program

Rule = Literal["product", "mixture"]
RULES: tuple[str, ...] = ("product", "mixture")
#: The shipped ensemble's manifest entry and its one file (members, rule, calibration).
ENSEMBLE_NAME = "question_parser_ensemble"
ENSEMBLE_FILE = f"{ENSEMBLE_NAME}.json"
ENSEMBLE_FORMAT = 1
_RESTORE = ("restore it with `git checkout models/`, or retrain it with the commands in its entry of "
            "models/manifest.json")


@torch.inference_mode()
def sequence_log_probs(member: QuestionParser, words: torch.Tensor, ngrams: torch.Tensor | None,
                       programs: Sequence[Program], start: tuple[torch.Tensor, ...] | None = None) -> list[float]:
    """Teacher-forced log-probability of each of ``programs`` under ``member`` for the encoded question
    (``words``, ``ngrams`` from ``member.encode``), under the type-constrained distribution its beam search uses;
    -inf for a program the member cannot express (a token outside its vocabulary, a token its automaton does not
    allow there, or too long). ``start``: the member's encoder output for the question, if already computed."""
    automaton, targets = member.automaton, member.trained.targets
    out = [-math.inf] * len(programs)
    rows: list[int] = []
    sequences: list[list[int]] = []
    for i, program in enumerate(programs):
        try:
            ids = targets.encode(program)
        except KeyError:
            continue
        if 0 < len(ids) <= automaton.max_len:
            rows.append(i)
            sequences.append(ids)
    if not rows:
        return out
    k, length = len(rows), max(len(s) for s in sequences)
    memory, keys, h, c = start if start is not None else member.model.start(words, ngrams)
    h, c = h.expand(k, -1).contiguous(), c.expand(k, -1).contiguous()
    states = [automaton.initial() for _ in rows]
    totals = np.zeros(k)
    alive = np.ones(k, dtype=bool)
    prev = torch.zeros(k, dtype=torch.long, device=words.device)
    vocab = automaton.vocab_size
    for t in range(length):
        logits, h, c = member.model.step(member.step_weights, prev, h, c, memory, keys)
        running = [j for j in range(k) if alive[j] and t < len(sequences[j])]
        if not running:
            break
        allowed = np.zeros((k, vocab), dtype=bool)
        allowed[:, 0] = True  # rows with nothing to score here (finished or dead) keep a finite softmax
        for j in running:
            allowed[j] = automaton.allowed(states[j])
        mask = torch.from_numpy(allowed).to(logits.device)
        log_probs = torch.log_softmax(logits.masked_fill(~mask, float("-inf")), dim=-1)
        tokens = [sequences[j][t] if t < len(sequences[j]) else 0 for j in range(k)]
        picked = log_probs.gather(1, torch.tensor(tokens, device=logits.device)[:, None])[:, 0].tolist()
        for j in running:
            token = tokens[j]
            if not allowed[j, token] or states[j].complete:
                alive[j] = False
                continue
            totals[j] += picked[j]
            states[j] = automaton.advance(states[j], token)
        prev = torch.tensor(tokens, device=words.device)
    for j, i in enumerate(rows):
        if alive[j] and states[j].complete:
            out[i] = float(totals[j])
    return out


class MemberDecoders:
    """The members' decoder steps one after another, for the joint beam (every member extends the same
    hypotheses): the interface :class:`StackedDecoder` batches, for members whose decoders differ in shape."""

    def __init__(self, members: Sequence[QuestionParser]):
        self.members = list(members)

    def start(self, starts: Sequence[tuple[torch.Tensor, ...]]) -> tuple:
        """The decoding context (the members' encoder outputs) and the initial states."""
        return list(starts), [s[2] for s in starts], [s[3] for s in starts]

    def step(self, tokens: torch.Tensor, h: list, c: list, context: list) -> tuple[torch.Tensor, list, list]:
        """One step of every member on ``tokens`` ``[R]``: logits ``[M, R, V]`` and the new states."""
        steps = [member.model.step(member.step_weights, tokens, h[m], c[m], context[m][0], context[m][1])
                 for m, member in enumerate(self.members)]
        return torch.stack([s[0] for s in steps]), [s[1] for s in steps], [s[2] for s in steps]

    @staticmethod
    def keep(states: list, rows: torch.Tensor) -> list:
        return [state[rows.to(state.device)] for state in states]


class StackedDecoder:
    """The members' decoder steps as one batched computation (``bmm`` over a member axis), for the joint beam,
    where every member extends the same hypotheses: at these sizes a step costs its kernel launches, not its
    arithmetic, so three members in one set of kernels take little more than one. Computes what
    :meth:`Seq2SeqParser.step` computes for each member (up to float rounding); same interface as
    :class:`MemberDecoders`."""

    def __init__(self, members: Sequence[QuestionParser]):
        weights = [member.step_weights for member in members]
        self.embedding = torch.stack([w.embedding for w in weights])  # [M, V, E]
        self.gate_weight = torch.stack([w.gate_weight for w in weights])
        self.gate_bias = torch.stack([w.gate_bias for w in weights])[:, None]
        self.combine_weight = torch.stack([w.combine_weight for w in weights])
        self.combine_bias = torch.stack([w.combine_bias for w in weights])[:, None]
        self.output_weight = torch.stack([w.output_weight for w in weights])
        self.output_bias = torch.stack([w.output_bias for w in weights])[:, None]

    @staticmethod
    def fits(members: Sequence[QuestionParser]) -> bool:
        """Whether the members' decoders have one shape (they can be stacked)."""
        shapes = {tuple(tuple(getattr(m.step_weights, f.name).shape) for f in dataclasses.fields(m.step_weights))
                  for m in members}
        return len(shapes) == 1

    def start(self, starts: Sequence[tuple[torch.Tensor, ...]]) -> tuple:
        """The context: the members' memory and keys ``[M, T, H]`` (zero-padded to the longest question reading)
        and the padding mask ``[M, 1, T]``; and the stacked initial states ``[M, 1, H]``."""
        length = max(start[0].shape[0] for start in starts)
        memory = torch.stack([_pad_rows(start[0], length) for start in starts])
        keys = torch.stack([_pad_rows(start[1], length) for start in starts])
        padding = torch.stack([torch.arange(length, device=memory.device) >= start[0].shape[0] for start in starts])
        return ((memory, keys, padding[:, None, :]), torch.stack([s[2] for s in starts]),
                torch.stack([s[3] for s in starts]))

    def step(self, tokens: torch.Tensor, h: torch.Tensor, c: torch.Tensor, context: tuple
             ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """One step of every member on the same ``tokens`` ``[R]``: states ``[M, R, H]`` -> logits ``[M, R, V]``."""
        memory, keys, padding = context
        gates = torch.baddbmm(self.gate_bias, torch.cat([self.embedding[:, tokens], h], 2), self.gate_weight)
        i, f, g, o = gates.chunk(4, dim=2)
        c = torch.sigmoid(f) * c + torch.sigmoid(i) * torch.tanh(g)
        h = torch.sigmoid(o) * torch.tanh(c)
        attention = torch.bmm(h, keys.transpose(1, 2)).masked_fill(padding, float("-inf"))
        context = torch.bmm(torch.softmax(attention, dim=-1), memory)
        combined = torch.tanh(torch.baddbmm(self.combine_bias, torch.cat([h, context], 2), self.combine_weight))
        return torch.baddbmm(self.output_bias, combined, self.output_weight), h, c

    @staticmethod
    def keep(states: torch.Tensor, rows: torch.Tensor) -> torch.Tensor:
        return states[:, rows.to(states.device)]


def _pad_rows(rows: torch.Tensor, length: int) -> torch.Tensor:
    """``rows`` ``[T, H]`` zero-padded to ``[length, H]``."""
    return torch.nn.functional.pad(rows, (0, 0, 0, length - rows.shape[0]))


@torch.inference_mode()
def joint_beam_search(members: Sequence[QuestionParser], starts: Sequence[tuple[torch.Tensor, ...]], n: int,
                      beam: int, rule: Rule, decoders: StackedDecoder | MemberDecoders | None = None
                      ) -> list[tuple[tuple[int, ...], list[float]]]:
    """The ``n`` best programs under the ensemble's combined score, found by one beam whose hypotheses carry every
    member's log-probability (members sharing one target vocabulary; ``starts``: their encoder outputs). Each
    step runs every member's decoder on the same hypotheses, masks each by its own automaton (the first one's
    states: the automata differ only in their length budget) and ranks the extensions by the combined score;
    so no candidate is re-scored afterwards. The combined score of a prefix bounds its completions' (each
    member's probability only falls), so the search stops, as :func:`beam_search` does, once no unfinished
    hypothesis can beat the n-th finished one. ``decoders``: how the members step (default: one after another;
    :class:`StackedDecoder` where they have one shape). Returns (token ids, per-member log-probabilities), best
    first."""
    decoders = decoders or MemberDecoders(members)
    automaton = members[0].automaton
    log_members = math.log(len(members))
    context, hidden, cells = decoders.start(starts)
    active: list[tuple[tuple[int, ...], object]] = [((), automaton.initial())]
    scores = torch.zeros(len(members), 1)
    finished: list[tuple[float, tuple[int, ...], list[float]]] = []
    prev = torch.zeros(1, dtype=torch.long, device=starts[0][0].device)
    for _ in range(automaton.max_len):
        allowed = torch.from_numpy(np.stack([np.stack([member.automaton.allowed(state) for _, state in active])
                                             for member in members]))  # [members, hypotheses, tokens]
        logits, hidden, cells = decoders.step(prev, hidden, cells, context)
        log_probs = torch.log_softmax(logits.masked_fill(~allowed.to(logits.device), float("-inf")), dim=-1)
        table = scores[:, :, None] + log_probs.cpu()  # [members, hypotheses, tokens]
        combined = (torch.logsumexp(table, dim=0) - log_members if rule == "mixture" else table.mean(dim=0))
        vocab = combined.shape[1]
        flat = combined.flatten()
        reachable = int(torch.isfinite(flat).sum())
        if reachable == 0:
            break
        top_scores, top_index = flat.topk(min(2 * beam, reachable))
        score_list = top_scores.tolist()
        done, kept, next_active = select_extensions(score_list, top_index.tolist(), vocab, active, automaton, beam)
        finished += [(score, ids, table[:, row, token].tolist()) for score, ids, row, token in done]
        finished.sort(key=lambda item: -item[0])
        if not kept or (len(finished) >= n and score_list[kept[0]] <= finished[n - 1][0]):
            break
        kept_index = torch.tensor(kept)
        rows, tokens = top_index[kept_index] // vocab, top_index[kept_index] % vocab
        hidden, cells = decoders.keep(hidden, rows), decoders.keep(cells, rows)
        scores = table[:, rows, tokens]
        prev = tokens.to(prev.device)
        active = next_active
    return [(ids, per_member) for _, ids, per_member in finished[:n]]


def combine(log_probs: Sequence[float], rule: Rule) -> float:
    """The ensemble's log-probability of one candidate from its members' log-probabilities."""
    if rule == "product":
        return sum(log_probs) / len(log_probs)  # -inf if any member gives -inf
    finite = [lp for lp in log_probs if lp > -math.inf]
    if not finite:
        return -math.inf
    top = max(finite)
    return top + math.log(sum(math.exp(lp - top) for lp in finite) / len(log_probs))


class ParserEnsemble:
    """Question -> n-best programs from several :class:`QuestionParser` members (see the module docstring)."""

    def __init__(self, members: Sequence[QuestionParser], rule: Rule = "mixture", propose: int | None = None,
                 calibration: Calibration | None = None, names: Sequence[str] | None = None):
        """``propose``: how many programs each member proposes (default ``max(n, beam)`` of the call); ``names``:
        the members' manifest entries, when loaded from one (:meth:`from_manifest`)."""
        if not members:
            raise InputError("members", "an ensemble needs at least one parser")
        if rule not in RULES:
            raise InputError("rule", f"must be one of {', '.join(RULES)}, got {rule!r}")
        self.members = list(members)
        self.rule = rule
        self.propose = propose
        self.calibration = calibration
        self.registry = self.members[0].registry
        self.names = list(names) if names is not None else None
        #: one joint beam over all members where they share their target vocabulary (the shipped ones do), else
        #: each member's own beam and the union re-scored (the module docstring)
        first = tuple(self.members[0].trained.targets.tokens)
        self.joint = all(tuple(m.trained.targets.tokens) == first for m in self.members)
        self._decoders = (StackedDecoder(self.members) if StackedDecoder.fits(self.members)
                          else MemberDecoders(self.members))

    @classmethod
    def load(cls, directories: Sequence[str | None], rule: Rule = "mixture", device: str | torch.device = "cpu",
             unknown_words: bool = True, **options) -> ParserEnsemble:
        """Members loaded from ``directories`` (None: the shipped parser), each checked against its manifest."""
        members = [QuestionParser.load(directory, device=device, unknown_words=unknown_words)
                   for directory in directories]
        return cls(members, rule, **options)

    @classmethod
    def from_manifest(cls, directory: str | Path | None = None, device: str | torch.device = "cpu",
                      unknown_words: bool = True, rule: Rule | None = None) -> ParserEnsemble:
        """The ensemble the manifest of ``directory`` (default: models/) lists as ``question_parser_ensemble``:
        its file and every member's files checked against their sha256 (a missing or changed file is a
        :class:`~po3d_ppl.errors.ModelFileError` naming it). ``rule`` overrides the stored rule (an ablation; the
        stored calibration was fitted for the stored rule)."""
        from po3d_ppl.model_store import model_files, models_dir, read_manifest

        directory = Path(directory) if directory is not None else models_dir()
        path = model_files(ENSEMBLE_NAME, directory, _RESTORE)[ENSEMBLE_FILE]
        try:
            spec = json.loads(path.read_text())
            if spec.get("format") != ENSEMBLE_FORMAT:
                raise ValueError(f"format {spec.get('format')!r}, expected {ENSEMBLE_FORMAT}")
            names, stored_rule = [str(m) for m in spec["members"]], spec["rule"]
            calibration = Calibration(**spec["calibration"]) if spec.get("calibration") else None
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise ModelFileError(f"cannot read the parser ensemble {path} ({exc}); {_RESTORE}") from None
        listed = read_manifest(directory)[ENSEMBLE_NAME].get("members")
        if listed is not None and list(listed) != names:
            raise ModelFileError(f"{path} lists the members {names}, its manifest entry {list(listed)}; {_RESTORE}")
        members = [QuestionParser.load(directory, device=device, name=name, retrain_hint=_RESTORE,
                                       unknown_words=unknown_words) for name in names]
        return cls(members, rule or stored_rule, calibration=calibration, names=names)

    def save(self, directory: str | Path, names: Sequence[str]) -> Path:
        """Write ``question_parser_ensemble.json`` (the members' manifest entry names ``names``, the rule and the
        calibration) into ``directory``; the caller records it in the manifest."""
        if len(names) != len(self.members):
            raise InputError("names", f"{len(self.members)} members, {len(names)} names")
        path = Path(directory) / ENSEMBLE_FILE
        path.write_text(json.dumps({"format": ENSEMBLE_FORMAT, "members": list(names), "rule": self.rule,
                                    "calibration": None if self.calibration is None
                                    else dataclasses.asdict(self.calibration)}, indent=1) + "\n")
        path.chmod(0o644)
        return path

    def parse(self, question: str, n: int = 1, beam: int = 5) -> QuestionParse:
        """The ``n`` most probable programs for ``question`` under the combined scores (beam ``max(beam, n)``
        for each member)."""
        if not isinstance(question, str) or not tokenize(question):
            raise InputError("question", f"{question!r} has no words to parse")
        if n < 1:
            raise InputError("n", f"must be at least 1, got {n}")
        beam = max(beam, n)
        if self.joint:
            return self._parse_jointly(question, n, beam)
        propose = max(self.propose or beam, n)
        encoded = [member.encode(question) for member in self.members]
        programs: dict[tuple[str, ...], Program] = {}
        known: list[dict[tuple[str, ...], float]] = []  # each member's own beam scores (= its teacher-forced ones)
        # each member's encoder runs once: its beam search and its teacher forcing read the same states
        with torch.inference_mode():
            started = [member.model.start(words, ngrams) for member, (_, words, ngrams, _, _) in
                       zip(self.members, encoded)]
        for member, (_, words, ngrams, _, _), start in zip(self.members, encoded, started):
            scores = {}
            for hypothesis in beam_search(member.model, member.automaton, words, n=propose, beam=max(beam, propose),
                                          weights=member.step_weights, ngrams=ngrams, start=start):
                program = member.trained.targets.decode(hypothesis.ids, member.registry)
                key = tuple(program_to_tokens(program))
                programs.setdefault(key, program)
                scores[key] = hypothesis.log_prob
            known.append(scores)
        keys = list(programs)
        table = np.empty((len(self.members), len(keys)))
        for m, (member, (_, words, ngrams, _, _)) in enumerate(zip(self.members, encoded)):
            missing = [key for key in keys if key not in known[m]]
            rescored = dict(zip(missing, sequence_log_probs(member, words, ngrams, [programs[k] for k in missing],
                                                            started[m])))
            table[m] = [known[m][key] if key in known[m] else rescored[key] for key in keys]
        combined = [combine(table[:, i].tolist(), self.rule) for i in range(len(keys))]
        if all(score == -math.inf for score in combined):  # no candidate every member can express
            combined = [combine(table[:, i].tolist(), "mixture") for i in range(len(keys))]
        order = sorted((i for i in range(len(keys)) if combined[i] > -math.inf), key=lambda i: -combined[i])[:n]
        return self._result(question, encoded, [(programs[keys[i]], combined[i]) for i in order])

    def _parse_jointly(self, question: str, n: int, beam: int) -> QuestionParse:
        encoded = [member.encode(question) for member in self.members]
        with torch.inference_mode():
            starts = [member.model.start(words, ngrams) for member, (_, words, ngrams, _, _) in
                      zip(self.members, encoded)]
        found = joint_beam_search(self.members, starts, n, beam, self.rule, self._decoders)
        if not found and self.rule != "mixture":  # no program every member can express
            found = joint_beam_search(self.members, starts, n, beam, "mixture", self._decoders)
        targets, registry = self.members[0].trained.targets, self.members[0].registry
        return self._result(question, encoded, [(targets.decode(ids, registry), combine(per_member, self.rule))
                                                for ids, per_member in found])

    def _result(self, question: str, encoded: list, scored: list[tuple[Program, float]]) -> QuestionParse:
        candidates = []
        for program, log_prob in scored:
            types = check_program(program, self.registry).types
            candidates.append(ParsedProgram(program, log_prob, unsatisfiable_node(program, types) is None))
        tokens, _, _, corrections, unknown = encoded[0]
        return QuestionParse(question, tuple(tokens), tuple(unknown), tuple(candidates), tuple(corrections),
                             self._confidence(candidates[0].probability, encoded) if candidates else 0.0)

    def fit_calibration(self, examples: Sequence[Example], seed: int = 0) -> CalibrationReport:
        """Fit the ensemble's own calibration on perturbed held-out corpus ``examples``, as ``po3d train
        parser-calibration`` fits a single parser's, and use it from now on (the combined probability is not the
        members' own, so their calibrations only approximate it)."""
        self.calibration = None
        report = fit_calibration(self, examples, seed=seed)
        self.calibration = report.calibration
        return report

    def _confidence(self, probability: float, encoded: list) -> float:
        if self.calibration is not None:
            _, _, _, corrections, unknown = encoded[0]
            return self.calibration(probability, len(unknown), len(corrections))
        return sum(member.calibration(probability, len(unknown), len(corrections))
                   for member, (_, _, _, corrections, unknown) in zip(self.members, encoded)) / len(self.members)


def has_ensemble(directory: str | Path | None = None) -> bool:
    """Whether the manifest of ``directory`` (default: models/) lists a parser ensemble."""
    from po3d_ppl.model_store import read_manifest

    return ENSEMBLE_NAME in read_manifest(Path(directory) if directory is not None else None)


def load_question_parser(directory: str | Path | None = None, *, single: bool = False,
                         device: str | torch.device = "cpu", unknown_words: bool = True, rule: Rule | None = None
                         ) -> ParserEnsemble | QuestionParser:
    """The shipped question parser: the ensemble the manifest of ``directory`` (default: models/) lists, or, where
    it lists none or with ``single=True`` (the ablation), the single parser (manifest entry ``question_parser``).
    ``unknown_words=False`` switches the unknown-word mechanism off in every member (the ablation); ``rule``
    overrides an ensemble's stored rule (an InputError for a single parser, which has none)."""
    if not single and has_ensemble(directory):
        return ParserEnsemble.from_manifest(directory, device=device, unknown_words=unknown_words, rule=rule)
    if rule is not None:
        raise InputError("rule", "the single parser has no ensemble rule")
    return QuestionParser.load(directory, device=device, name=MODEL_NAME, unknown_words=unknown_words)

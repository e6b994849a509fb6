"""The trained question parser as shipped: safetensors weights + a vocabulary JSON, checked by the manifest.

:class:`QuestionParser` is the public entry point: ``QuestionParser.load().parse("What colour is the bus?",
n=3)`` returns the n most probable well-typed programs with their probabilities and the words the model did not
know.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import torch
from safetensors.torch import load_file, save_file

from po3d_ppl.catalogue import OperationRegistry
from po3d_ppl.errors import InputError, ModelFileError
from po3d_ppl.language.ast import Program
from po3d_ppl.language.satisfiable import unsatisfiable_node
from po3d_ppl.language.seq2seq.constraints import TypeAutomaton
from po3d_ppl.language.seq2seq.decode import beam_search
from po3d_ppl.language.seq2seq.model import ParserConfig, Seq2SeqParser
from po3d_ppl.language.seq2seq.normalise import Normaliser
from po3d_ppl.language.seq2seq.train import Trained
from po3d_ppl.language.seq2seq.vocab import TargetVocabulary, WordVocabulary, ngram_tensor_rows, tokenize
from po3d_ppl.language.tokens import program_to_tokens
from po3d_ppl.language.typecheck import check_program, default_registry

MODEL_NAME = "question_parser"
FORMAT = 2
#: Formats this code reads (1: words only, no counts, no calibration).
READABLE_FORMATS = (1, 2)
#: Below this calibrated confidence a parse comes with a warning.
LOW_CONFIDENCE = 0.5
RETRAIN = "restore it with `git checkout models/` or retrain: `po3d train parser --data DIR`"


@dataclass(frozen=True)
class ParsedProgram:
    """One parse: the program, its log-probability and probability under the (constrained) model, and whether
    some scene could satisfy it (:mod:`po3d_ppl.language.satisfiable`)."""

    program: Program
    log_prob: float
    satisfiable: bool = True

    @property
    def probability(self) -> float:
        return math.exp(self.log_prob)

    @property
    def tokens(self) -> list[str]:
        return program_to_tokens(self.program)


@dataclass(frozen=True)
class Calibration:
    """Maps the top parse's model probability to a calibrated confidence:
    ``sigmoid(scale * logit(p) + unknown * n_unknown + corrected * n_corrected + bias)``.

    Why: a seq2seq model trained on templated questions is sure of itself on anything; its probability of the top
    parse alone cannot say that a question is outside what it was trained on. Unknown and corrected words can, so
    they enter the confidence. Fitted by logistic regression on held-out corpus questions with injected unknown
    words and typos (:mod:`po3d_ppl.language.seq2seq.calibrate`), never on the independent test set.
    """

    scale: float = 1.0
    unknown: float = 0.0
    corrected: float = 0.0
    bias: float = 0.0

    def __call__(self, probability: float, unknown: int, corrected: int) -> float:
        p = min(max(probability, 1e-9), 1 - 1e-9)
        z = self.scale * math.log(p / (1 - p)) + self.unknown * unknown + self.corrected * corrected + self.bias
        return 1 / (1 + math.exp(-z)) if z > -700 else 0.0


@dataclass(frozen=True)
class QuestionParse:
    """The n-best parses of a question (most probable first), the words the parser did not know, the rewrites of
    unknown words it made (typos, compounds) and the calibrated confidence of the best parse."""

    question: str
    words: tuple[str, ...]
    unknown_words: tuple[str, ...]
    candidates: tuple[ParsedProgram, ...]
    corrections: tuple[tuple[str, str], ...] = ()
    confidence: float = 1.0

    @property
    def best(self) -> ParsedProgram:
        return self.candidates[0]

    @property
    def warning(self) -> str | None:
        """A sentence for the user when the parse should not be trusted (None otherwise)."""
        if self.confidence >= LOW_CONFIDENCE:
            return None
        why = f"; unknown words: {', '.join(self.unknown_words)}" if self.unknown_words else ""
        return (f"low confidence ({self.confidence:.2f}) in the parse: the question may be worded in a way the parser "
                f"does not cover{why}")


def parser_files(name: str = MODEL_NAME) -> tuple[str, str]:
    """The weights and vocabulary file names of the parser called ``name`` (an ensemble member has its own)."""
    return f"{name}.safetensors", f"{name}.vocab.json"


def save_parser(trained: Trained, directory: Path, name: str = MODEL_NAME) -> list[Path]:
    """Write the weights and vocabulary of ``trained`` into ``directory`` as ``name`` (:func:`parser_files`);
    returns the two paths."""
    directory.mkdir(parents=True, exist_ok=True)
    weights, vocab = (directory / f for f in parser_files(name))
    tensors = {k: v.detach().cpu().contiguous() for k, v in trained.model.state_dict().items()}
    save_file(tensors, str(weights), metadata={"format": str(FORMAT)})
    weights.chmod(0o644)
    vocab.write_text(json.dumps({
        "format": FORMAT,
        "config": trained.model.config.to_dict(),
        "words": list(trained.words.words),
        "operations": list(trained.targets.operations),
        "values": list(trained.targets.values),
        "root_types": list(trained.root_types),
        "max_len": trained.max_len,
        "counts": list(trained.words.counts),
        "calibration": vars(getattr(trained, "calibration", None) or Calibration()),
    }, indent=1) + "\n")
    return [weights, vocab]


class QuestionParser:
    """Question -> n-best programs, with grammar- and type-constrained beam search."""

    def __init__(self, trained: Trained, registry: OperationRegistry | None = None,
                 device: str | torch.device = "cpu", calibration: Calibration | None = None,
                 unknown_words: bool = True):
        """``unknown_words=False`` switches the unknown-word mechanism off (the ablation): no typo or compound
        rewriting and no character n-grams for words outside the vocabulary (they read as bare ``<unk>``)."""
        self.registry = registry if registry is not None else default_registry()
        self.trained = trained
        self.calibration = calibration or getattr(trained, "calibration", None) or Calibration()
        self.unknown_words = unknown_words
        self.normaliser = Normaliser(trained.words.frequencies())
        self.device = torch.device(device)
        self.model = trained.model.to(self.device).eval()
        self.automaton = TypeAutomaton(self.registry, trained.targets, trained.root_types, trained.max_len)
        with torch.no_grad():
            self.step_weights = self.model.step_weights()

    @classmethod
    def load(cls, directory: Path | str | None = None, registry: OperationRegistry | None = None,
             device: str | torch.device = "cpu", name: str = MODEL_NAME,
             retrain_hint: str = RETRAIN, unknown_words: bool = True) -> QuestionParser:
        """Load the shipped single parser (or the one in ``directory``), verifying the files against the manifest.
        ``name``: another parser's manifest entry there (an ensemble member: its ``NAME.safetensors`` and
        ``NAME.vocab.json``). ``unknown_words=False``: the ablation (see ``__init__``). The shipped default, an
        ensemble, is :func:`~po3d_ppl.language.load_question_parser`."""
        from po3d_ppl.model_store import model_files, models_dir

        directory = Path(directory) if directory is not None else models_dir()
        files = model_files(name, directory, retrain_hint)
        weights, vocab_path = (files.get(f) for f in parser_files(name))
        if weights is None or vocab_path is None:
            raise ModelFileError(f"model {name!r} in {directory} should list {name}.safetensors and "
                                 f"{name}.vocab.json, its manifest entry lists {', '.join(files)}; {retrain_hint}")
        try:
            meta = json.loads(vocab_path.read_text())
            if meta.get("format") not in READABLE_FORMATS:
                raise ModelFileError(f"{vocab_path}: format {meta.get('format')!r}, expected {FORMAT}; "
                                     f"{retrain_hint}")
            config = ParserConfig(**meta["config"])
            model = Seq2SeqParser(config)
            model.load_state_dict(load_file(str(weights)))
        except (OSError, ValueError, KeyError, TypeError, RuntimeError) as exc:
            raise ModelFileError(f"cannot load the question parser {name!r} from {directory} ({exc}); "
                                 f"{retrain_hint}") from None
        trained = Trained(model, WordVocabulary(tuple(meta["words"]), tuple(meta.get("counts", ()))),
                          TargetVocabulary(tuple(meta["operations"]), tuple(meta["values"])),
                          tuple(meta["root_types"]), int(meta["max_len"]))
        trained.calibration = Calibration(**meta.get("calibration", {}))
        return cls(trained, registry, device, unknown_words=unknown_words)

    def encode(self, question: str) -> tuple[list[str], torch.Tensor, torch.Tensor | None,
                                             tuple[tuple[str, str], ...], tuple[str, ...]]:
        """What the network reads for ``question``: its words, their ids ``[T]`` and n-gram ids ``[T, K]`` (None
        for a words-only model), after the normaliser's rewrites (which are returned, with the words that stayed
        unknown). With the unknown-word mechanism off, unknown words are bare ``<unk>``."""
        tokens = tokenize(question)
        if self.unknown_words:
            normalised = self.normaliser(tokens)
            read, corrections, unknown = normalised.words, normalised.corrections, normalised.unknown
        else:
            read, corrections = tokens, ()
            unknown = tuple(w for w in tokens if w not in self.normaliser.counts)
        ids = self.trained.words.ids(read)
        words = torch.tensor(ids, device=self.device)
        ngrams = None
        if self.model.config.ngram_buckets:
            shown = read if self.unknown_words else [w if i > 1 else "" for w, i in zip(read, ids)]
            rows = ngram_tensor_rows(shown, self.model.config.ngram_buckets)
            ngrams = torch.tensor(rows, dtype=torch.long, device=self.device)
        return tokens, words, ngrams, tuple(corrections), tuple(unknown)

    def parse(self, question: str, n: int = 1, beam: int = 5) -> QuestionParse:
        """The ``n`` most probable programs for ``question`` (beam width ``max(beam, n)``).

        A program that no scene can satisfy keeps its rank, flagged ``satisfiable=False``: it is what the
        question says (e.g. "the front wheel of the car", a part cars do not have), and promoting a less probable
        parse would answer another question. Part names come out in their canonical spelling (the target
        vocabulary has no other), which selects every part that reads the same.
        """
        if not isinstance(question, str) or not tokenize(question):
            raise InputError("question", f"{question!r} has no words to parse")
        if n < 1:
            raise InputError("n", f"must be at least 1, got {n}")
        tokens, words, ngrams, corrections, unknown = self.encode(question)
        hypotheses = beam_search(self.model, self.automaton, words, n=n, beam=max(beam, n),
                                 weights=self.step_weights, ngrams=ngrams)
        candidates = []
        for hypothesis in hypotheses:
            program = self.trained.targets.decode(hypothesis.ids, self.registry)
            types = check_program(program, self.registry).types
            candidates.append(ParsedProgram(program, hypothesis.log_prob, unsatisfiable_node(program, types) is None))
        confidence = self.calibration(candidates[0].probability, len(unknown), len(corrections)) if candidates else 0.0
        return QuestionParse(question, tuple(tokens), tuple(unknown), tuple(candidates), tuple(corrections),
                             confidence)

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
from po3d_ppl.language.seq2seq.train import Trained
from po3d_ppl.language.seq2seq.vocab import TargetVocabulary, WordVocabulary, tokenize
from po3d_ppl.language.tokens import program_to_tokens
from po3d_ppl.language.typecheck import check_program, default_registry

MODEL_NAME = "question_parser"
WEIGHTS = f"{MODEL_NAME}.safetensors"
VOCABULARY = f"{MODEL_NAME}.vocab.json"
FORMAT = 1
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
class QuestionParse:
    """The n-best parses of a question (most probable first) and the words the parser did not know."""

    question: str
    words: tuple[str, ...]
    unknown_words: tuple[str, ...]
    candidates: tuple[ParsedProgram, ...]

    @property
    def best(self) -> ParsedProgram:
        return self.candidates[0]


def save_parser(trained: Trained, directory: Path) -> list[Path]:
    """Write the weights and vocabulary of ``trained`` into ``directory``; returns the two paths."""
    directory.mkdir(parents=True, exist_ok=True)
    weights, vocab = directory / WEIGHTS, directory / VOCABULARY
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
    }, indent=1) + "\n")
    return [weights, vocab]


class QuestionParser:
    """Question -> n-best programs, with grammar- and type-constrained beam search."""

    def __init__(self, trained: Trained, registry: OperationRegistry | None = None,
                 device: str | torch.device = "cpu"):
        self.registry = registry if registry is not None else default_registry()
        self.trained = trained
        self.device = torch.device(device)
        self.model = trained.model.to(self.device).eval()
        self.automaton = TypeAutomaton(self.registry, trained.targets, trained.root_types, trained.max_len)
        with torch.no_grad():
            self.step_weights = self.model.step_weights()

    @classmethod
    def load(cls, directory: Path | str | None = None, registry: OperationRegistry | None = None,
             device: str | torch.device = "cpu") -> QuestionParser:
        """Load the shipped parser (or the one in ``directory``), verifying the files against the manifest."""
        from po3d_ppl.model_store import model_files, models_dir

        directory = Path(directory) if directory is not None else models_dir()
        files = model_files(MODEL_NAME, directory, RETRAIN)
        weights, vocab_path = files[WEIGHTS], files[VOCABULARY]
        try:
            meta = json.loads(vocab_path.read_text())
            if meta.get("format") != FORMAT:
                raise ModelFileError(f"{vocab_path}: format {meta.get('format')!r}, expected {FORMAT}; {RETRAIN}")
            config = ParserConfig(**meta["config"])
            model = Seq2SeqParser(config)
            model.load_state_dict(load_file(str(weights)))
        except (OSError, ValueError, KeyError, TypeError, RuntimeError) as exc:
            raise ModelFileError(f"cannot load the question parser from {directory} ({exc}); {RETRAIN}") from None
        trained = Trained(model, WordVocabulary(tuple(meta["words"])),
                          TargetVocabulary(tuple(meta["operations"]), tuple(meta["values"])),
                          tuple(meta["root_types"]), int(meta["max_len"]))
        return cls(trained, registry, device)

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
        ids, unknown = self.trained.words.encode(question)
        words = torch.tensor(ids, device=self.device)
        hypotheses = beam_search(self.model, self.automaton, words, n=n, beam=max(beam, n),
                                 weights=self.step_weights)
        candidates = []
        for hypothesis in hypotheses:
            program = self.trained.targets.decode(hypothesis.ids, self.registry)
            types = check_program(program, self.registry).types
            candidates.append(ParsedProgram(program, hypothesis.log_prob, unsatisfiable_node(program, types) is None))
        return QuestionParse(question, tuple(tokenize(question)), tuple(unknown), tuple(candidates))

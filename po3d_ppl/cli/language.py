"""``po3d parse``, ``po3d train parser`` / ``parser-calibration`` / ``parser-ensemble``, ``po3d eval parser`` /
``language``: the question parser (shipped as an ensemble of parsers) on the command line."""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import typer

from po3d_ppl.cli._common import write_report

_PARSER_DIR_HELP = ("Another parser directory, parsing together with --model-dir's single parser as an ensemble "
                    "(repeat for more; see po3d_ppl/language/seq2seq/ensemble.py).")
_ENSEMBLE_RULE_HELP = ("How an ensemble's members' program log-probabilities combine: product (their mean) or mixture "
                       "(the log of the mean probability). Default: the shipped ensemble's rule; mixture with "
                       "--parser-dir.")
_SINGLE_HELP = ("The single parser (manifest entry question_parser) instead of the shipped ensemble (the ablation).")
_NAME_HELP = ("The parser's name: its files NAME.safetensors and NAME.vocab.json and its manifest entry (an "
              "ensemble member has its own, e.g. question_parser_cr_seed0).")
_EXTRA_FAMILIES_HELP = ("Add an opt-in family set to the parser corpus (repeatable; known: compare_relate, wording2, wording3). Default: "
                        "none, the corpus the shipped single parser was trained on.")


def _load_parser(model_dir: Path | None, parser_dirs: list[Path] | None, rule: str | None, unknown_words: bool = True,
                 single: bool = False):
    """The parser of ``model_dir`` (default: models/): its ensemble where its manifest lists one, else (or with
    ``single``) its single parser; with ``parser_dirs`` an ensemble of its single parser and theirs."""
    from po3d_ppl.errors import InputError
    from po3d_ppl.language.seq2seq.ensemble import RULES, ParserEnsemble, has_ensemble, load_question_parser

    if rule is not None and rule not in RULES:
        raise InputError("--ensemble-rule", f"must be one of {', '.join(RULES)}, got {rule!r}")
    if parser_dirs:
        if single:
            raise InputError("--single-parser", "one parser; not with --parser-dir")
        return ParserEnsemble.load([model_dir, *parser_dirs], rule or "mixture", unknown_words=unknown_words)
    if rule is not None and (single or not has_ensemble(model_dir)):
        raise InputError("--ensemble-rule", "the single parser has no ensemble rule")
    return load_question_parser(model_dir, single=single, unknown_words=unknown_words, rule=rule)


def _check_name(name: str) -> str:
    """A parser name usable as a file stem and manifest key (lower-case letters, digits, underscores)."""
    import re

    from po3d_ppl.errors import InputError

    if not re.fullmatch(r"[a-z][a-z0-9_]{0,63}", name or ""):
        raise InputError("--name", f"must be lower-case letters, digits and underscores, starting with a letter "
                                   f"(e.g. question_parser_cr_seed0), got {name!r}")
    return name


def _name_words(name: str) -> list[str]:
    """``--name NAME`` unless it is the default parser's."""
    from po3d_ppl.language.seq2seq.model_io import MODEL_NAME

    return [] if name == MODEL_NAME else ["--name", name]


def _extra_families_words(extra: tuple[str, ...]) -> list[str]:
    """``--extra-families NAME`` for each opt-in set, as the recorded commands spell them."""
    return [word for name in extra for word in ("--extra-families", name)]


def parse(
    question: str = typer.Argument(..., help="The question, in quotes."),
    n: int = typer.Option(1, "--n", min=1, help="How many programs to return (n-best)."),
    beam: int = typer.Option(5, "--beam", min=1, help="Beam width (at least --n is used)."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON (text, tokens, public JSON, probabilities)."),
    model_dir: Path = typer.Option(None, "--model-dir", help="Directory with the parser files (default: models/)."),
    parser_dir: list[Path] = typer.Option(None, "--parser-dir", help=_PARSER_DIR_HELP),
    ensemble_rule: str = typer.Option(None, "--ensemble-rule", help=_ENSEMBLE_RULE_HELP),
    single_parser: bool = typer.Option(False, "--single-parser", help=_SINGLE_HELP),
) -> None:
    """Parse a question into its n most probable programs, with probabilities and unknown words."""
    from rich.console import Console

    from po3d_ppl.language import program_to_json, program_to_text

    result = _load_parser(model_dir, parser_dir, ensemble_rule, single=single_parser).parse(question, n=n, beam=beam)
    if as_json:
        print(json.dumps({
            "question": question,
            "unknown_words": list(result.unknown_words),
            "corrections": [list(c) for c in result.corrections],
            "confidence": result.confidence,
            "warning": result.warning,
            "programs": [{"program": program_to_text(c.program), "probability": c.probability,
                          "log_prob": c.log_prob, "satisfiable": c.satisfiable, "tokens": c.tokens,
                          "json": program_to_json(c.program)}
                         for c in result.candidates],
        }, indent=2))
        return
    console = Console()
    if result.corrections:
        console.print("read " + ", ".join(f"{a!r} as {b!r}" for a, b in result.corrections), style="dim",
                      markup=False, highlight=False)
    if result.unknown_words:
        console.print("unknown words (read by their letters only): " + ", ".join(result.unknown_words),
                      style="yellow", markup=False, highlight=False)
    if result.warning:
        console.print("warning: " + result.warning, style="bold yellow", markup=False, highlight=False)
    console.print(f"confidence {result.confidence:.3f}", style="dim", highlight=False)
    for rank, candidate in enumerate(result.candidates, 1):
        note = "" if candidate.satisfiable else "  (asks about objects or parts no scene can have)"
        console.print(f"[bold]#{rank}[/]  p = {candidate.probability:.4f}{note}", highlight=False)
        console.print(program_to_text(candidate.program, style="pipeline"), markup=False, highlight=False,
                      soft_wrap=True)


def train_parser_command(
    data: list[Path] = typer.Option(None, "--data", help="Dataset directory from `po3d dataset build` "
                                                          "(repeat to train on several)."),
    corpus: int = typer.Option(0, "--corpus", min=0, help="Also train on this many questions of the parser corpus "
                                                           "(every template family, realised phrasings; no scenes)."),
    corpus_seed: int = typer.Option(1, "--corpus-seed", min=0, help="Seed of the training corpus (the validation "
                                                                     "corpus uses seed + 1000)."),
    corpus_val: int = typer.Option(3000, "--corpus-val", min=0, help="Validation questions drawn from the corpus."),
    extra_families: list[str] = typer.Option(None, "--extra-families", help=_EXTRA_FAMILIES_HELP),
    ngram_buckets: int = typer.Option(4096, "--ngram-buckets", min=0,
                                      help="Character n-gram hash buckets of the subword input (0: words only)."),
    max_minutes: float = typer.Option(None, "--max-minutes", help="Stop training after this many minutes."),
    word_dropout: float = typer.Option(0.02, "--word-dropout", help="Share of question words read as <unk> in "
                                                                    "training (the model learns to cope with them)."),
    seed: int = typer.Option(0, "--seed", help="Seed for initialisation, shuffling and dropout (>= 0)."),
    epochs: int = typer.Option(6, "--epochs", min=1, help="Passes over the training split."),
    batch_size: int = typer.Option(64, "--batch-size", min=1),
    lr: float = typer.Option(2e-3, "--lr", help="Peak learning rate (one-cycle schedule)."),
    hidden: int = typer.Option(128, "--hidden", min=8, help="LSTM state size."),
    embed: int = typer.Option(64, "--embed", min=8, help="Word and token embedding size."),
    max_steps: int = typer.Option(None, "--max-steps", min=1, help="Stop after this many steps (smoke tests)."),
    unconstrained_loss: bool = typer.Option(False, "--unconstrained-loss",
                                            help="Ablation: plain softmax loss, without the type masks."),
    out: Path = typer.Option(None, "--out", help="Where to write the model files (default: models/)."),
    name: str = typer.Option("question_parser", "--name", help=_NAME_HELP),
    device: str = typer.Option("cpu", "--device", help="torch device, e.g. cpu or cuda."),
    threads: int = typer.Option(1, "--threads", min=1,
                                help="torch CPU threads. The model is small: more threads help little and "
                                     "slow training down badly when other processes share the cores."),
) -> None:
    """Train the question parser on a dataset's train split (val split for model selection)."""
    import dataclasses
    import sys
    import time

    import torch
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from po3d_ppl.cli._common import check_seed
    from po3d_ppl.errors import InputError
    from po3d_ppl.language.seq2seq.model_io import save_parser
    from po3d_ppl.language.seq2seq.train import TrainConfig, train_parser
    from po3d_ppl.language.typecheck import default_registry
    from po3d_ppl.model_store import models_dir, write_entry
    from po3d_ppl.questions.parser_examples import open_dataset, split_examples

    check_seed(seed)
    _check_name(name)
    torch.set_num_threads(threads)
    console = Console()
    registry = default_registry()
    if not data and not corpus:
        raise InputError("--data/--corpus", "give a dataset (--data DIR) or a corpus size (--corpus N)")
    from po3d_ppl.questions.parser_corpus import CorpusConfig, check_extra_families, generate_corpus

    extra = check_extra_families(extra_families)
    if extra and not corpus:
        raise InputError("--extra-families", "adds families to the parser corpus; give --corpus N")
    train, validation, data_manifests = [], [], []
    if corpus:
        train += generate_corpus(corpus, CorpusConfig(seed=corpus_seed, extra_families=extra))
        validation += generate_corpus(corpus_val, CorpusConfig(seed=corpus_seed + 1000, extra_families=extra))
        corpus_config = {"corpus": corpus, "corpus_val": corpus_val, "val_seed": corpus_seed + 1000}
        if extra:
            corpus_config["extra_families"] = list(extra)
        data_manifests.append({"seed": corpus_seed, "config": corpus_config})
    for directory in data or ():
        dataset = open_dataset(directory)
        data_manifests.append(dataset.manifest)
        train += split_examples(dataset, "train")
        try:
            validation += split_examples(dataset, "val")
        except InputError:  # a dataset without val questions
            pass
    config = TrainConfig(seed=seed, epochs=epochs, batch_size=batch_size, lr=lr, hidden=hidden, embed=embed,
                         max_steps=max_steps, constrained_loss=not unconstrained_loss, ngram_buckets=ngram_buckets,
                         word_dropout=word_dropout,
                         max_seconds=None if max_minutes is None else 60 * max_minutes)
    console.print(f"training on {len(train)} questions, validating on {len(validation)}", highlight=False)
    start = time.perf_counter()
    with Progress(TextColumn("[bold]train parser"), BarColumn(), MofNCompleteColumn(),
                  TextColumn("epoch {task.fields[epoch]} loss {task.fields[loss]:.4f}"), TimeRemainingColumn(),
                  console=console) as bar:
        task = bar.add_task("train", total=None, epoch=0, loss=float("nan"))

        def progress(step: int, total: int, info: dict) -> None:
            bar.update(task, completed=step, total=total, epoch=info["epoch"], loss=info["loss"])
            if not console.is_terminal and step % 200 == 0:  # a log file: a plain line now and then
                print(f"step {step}/{total} epoch {info['epoch']} loss {info['loss']:.4f} "
                      f"{time.perf_counter() - start:.0f} s", file=sys.stderr, flush=True)

        trained = train_parser(train, config, registry, validation, device=device, progress=progress)
    seconds = time.perf_counter() - start
    directory = Path(out) if out is not None else models_dir()
    files = save_parser(trained, directory, name)
    history = trained.history
    metrics = {"train_questions": len(train), "val_questions": len(validation), "train_seconds": round(seconds, 1),
               "history": history}
    if history and "val_exact_match" in history[-1]:
        metrics["val_exact_match"] = max(h["val_exact_match"] for h in history)
    entry = write_entry(name, files, directory,
                        command=_train_command(data or [], config, out, corpus, corpus_seed, corpus_val,
                                               max_minutes, threads, extra, name),
                        data_seed=[m.get("seed") for m in data_manifests],
                        data_config=[m.get("config") for m in data_manifests],
                        train_config=dataclasses.asdict(config), metrics=metrics)
    size = sum(f["bytes"] for f in entry["files"].values())
    console.print(f"wrote {', '.join(str(f) for f in files)} ({size / 1e6:.2f} MB) in {seconds:.0f} s; "
                  f"val exact match {metrics.get('val_exact_match', float('nan')):.4f}", markup=False,
                  highlight=False)


def eval_parser_command(
    data: Path = typer.Option(..., "--data", help="Dataset directory from `po3d dataset build`."),
    split: str = typer.Option("test", "--split", help="train, val or test."),
    json_out: Path = typer.Option(None, "--json", help="Write the full report (per file and family) here."),
    beam: int = typer.Option(5, "--beam", min=1, help="Beam width of the decoder (the best program is scored)."),
    n: int = typer.Option(3, "--n", min=1, help="Also report how often the gold program is among the n best."),
    model_dir: Path = typer.Option(None, "--model-dir", help="Directory with the parser files (default: models/)."),
    threads: int = typer.Option(1, "--threads", min=1, help="torch CPU threads."),
    record: bool = typer.Option(False, "--record", help="Store the summary in the model's manifest entry."),
) -> None:
    """Exact match of the parser's best program against the dataset's programs, overall, per file and family."""
    import torch
    from rich.console import Console
    from rich.table import Table

    from po3d_ppl.cli._common import literal
    from po3d_ppl.language import QuestionParser
    from po3d_ppl.language.seq2seq.train import evaluate
    from po3d_ppl.questions.parser_examples import open_dataset, split_examples

    torch.set_num_threads(threads)
    parser = QuestionParser.load(model_dir)
    dataset = open_dataset(data)
    examples = split_examples(dataset, split)

    def predict(batch):
        return [[c.tokens for c in parser.parse(e.question, n=n, beam=beam).candidates] for e in batch]

    report = evaluate(parser.trained, examples, parser.registry, predict=predict)
    report.update({"data": str(data), "split": split, "beam": beam, "n": n,
                   "data_seed": dataset.manifest.get("seed")})
    table = Table(title=literal(f"question parser on {data} [{split}]"),
                  caption=f"exact: best program = gold; in {n}-best: gold among the {n} best programs")
    for col in ("file", "questions", "exact", f"in {n}-best"):
        table.add_column(col, justify="left" if col == "file" else "right")
    for name, row in [*report["per_file"].items(), ("all", report)]:
        table.add_row(literal(name), str(row["count"]), f"{row['exact_match']:.4f}", f"{row['in_n_best']:.4f}")
    console = Console()
    console.print(table)
    worst = sorted(report["per_family"].items(), key=lambda kv: kv[1]["exact_match"])[:3]
    console.print("lowest families: " + ", ".join(f"{k} {v['exact_match']:.3f} ({v['count']})" for k, v in worst),
                  markup=False, highlight=False)
    write_report(json_out, report)
    if record:
        from po3d_ppl.language.seq2seq.model_io import MODEL_NAME
        from po3d_ppl.model_store import models_dir, record_metrics

        keys = ("exact_match", "in_n_best", "count")
        summary = {k: report[k] for k in keys}
        summary["per_file"] = {name: {k: row[k] for k in keys} for name, row in report["per_file"].items()}
        summary.update(data_seed=report["data_seed"], split=split, beam=beam, n=n,
                       command=shlex.join(["po3d", "eval", "parser", "--data", str(data), "--split", split,
                                           "--beam", str(beam), "--n", str(n)]))
        record_metrics(MODEL_NAME, f"eval_seed{report['data_seed']}_{split}", summary, model_dir or models_dir())


def calibrate_parser_command(
    model_dir: Path = typer.Option(None, "--model-dir", help="Directory with the parser files (default: models/)."),
    corpus_seed: int = typer.Option(2001, "--corpus-seed", min=0,
                                    help="Seed of the held-out corpus questions (not a training or test seed)."),
    questions: int = typer.Option(1500, "--questions", min=50, help="Development questions (each perturbed)."),
    extra_families: list[str] = typer.Option(None, "--extra-families", help=_EXTRA_FAMILIES_HELP + " Give the "
                                             "parser's training families."),
    name: str = typer.Option("question_parser", "--name", help=_NAME_HELP),
    threads: int = typer.Option(1, "--threads", min=1, help="torch CPU threads."),
) -> None:
    """Fit the parser's confidence calibration on perturbed held-out corpus questions and store it with the model."""
    import dataclasses
    import time

    import torch
    from rich.console import Console

    from po3d_ppl.language import QuestionParser
    from po3d_ppl.language.seq2seq.calibrate import fit_calibration
    from po3d_ppl.language.seq2seq.model_io import parser_files
    from po3d_ppl.model_store import models_dir, read_manifest, sha256_file, write_entry
    from po3d_ppl.questions.parser_corpus import CorpusConfig, check_extra_families, generate_corpus

    extra = check_extra_families(extra_families)
    _check_name(name)
    torch.set_num_threads(threads)
    directory = Path(model_dir) if model_dir is not None else models_dir()
    start = time.perf_counter()
    parser = QuestionParser.load(directory, name=name)
    report = fit_calibration(parser, generate_corpus(questions, CorpusConfig(seed=corpus_seed, extra_families=extra)),
                             seed=corpus_seed)
    weights_name, vocab_name = parser_files(name)
    vocab_path = directory / vocab_name
    meta = json.loads(vocab_path.read_text())
    meta["calibration"] = dataclasses.asdict(report.calibration)
    vocab_path.write_text(json.dumps(meta, indent=1) + "\n")
    entry = dict(read_manifest(directory)[name])
    entry.pop("files", None)
    metrics = dict(entry.pop("metrics", {}))
    metrics["calibration"] = {"command": shlex.join(["po3d", "train", "parser-calibration", "--corpus-seed",
                                                     str(corpus_seed), "--questions", str(questions),
                                                     *_extra_families_words(extra), *_name_words(name)]),
                              "questions": report.questions, "dev_accuracy": report.accuracy,
                              "dev_ece_before": report.ece_before, "dev_ece_after": report.ece_after,
                              "seconds": round(time.perf_counter() - start, 1),
                              **dataclasses.asdict(report.calibration)}
    write_entry(name, [directory / weights_name, vocab_path], directory, **entry, metrics=metrics)
    assert sha256_file(vocab_path)
    Console().print(f"calibration {report.calibration} on {report.questions} perturbed questions (top-1 accuracy "
                    f"{report.accuracy:.3f}): ECE {report.ece_before:.4f} -> {report.ece_after:.4f}",
                    markup=False, highlight=False)


def train_ensemble_command(
    member: list[str] = typer.Option(..., "--member", help="A parser's manifest entry in --model-dir (repeat, in "
                                                          "order; e.g. question_parser)."),
    rule: str = typer.Option("mixture", "--rule", help="product or mixture (see --ensemble-rule)."),
    model_dir: Path = typer.Option(None, "--model-dir", help="Directory with the members' files and manifest "
                                                             "(default: models/)."),
    corpus_seed: int = typer.Option(2001, "--corpus-seed", min=0,
                                    help="Seed of the held-out corpus questions (not a training or test seed)."),
    questions: int = typer.Option(1500, "--questions", min=50, help="Development questions (each perturbed)."),
    extra_families: list[str] = typer.Option(None, "--extra-families", help=_EXTRA_FAMILIES_HELP),
    threads: int = typer.Option(1, "--threads", min=1, help="torch CPU threads."),
) -> None:
    """Make the shipped parser an ensemble of --member parsers: fit its own confidence calibration on perturbed
    held-out corpus questions (as parser-calibration does for one parser) and write question_parser_ensemble.json
    with its manifest entry, which the default loader then uses."""
    import dataclasses
    import time

    import torch
    from rich.console import Console

    from po3d_ppl.errors import InputError
    from po3d_ppl.language import QuestionParser
    from po3d_ppl.language.seq2seq.ensemble import ENSEMBLE_NAME, RULES, ParserEnsemble
    from po3d_ppl.model_store import models_dir, write_entry
    from po3d_ppl.questions.parser_corpus import CorpusConfig, check_extra_families, generate_corpus

    if rule not in RULES:
        raise InputError("--rule", f"must be one of {', '.join(RULES)}, got {rule!r}")
    if len(set(member)) != len(member):
        raise InputError("--member", f"each member once, got {member}")
    extra = check_extra_families(extra_families)
    torch.set_num_threads(threads)
    directory = Path(model_dir) if model_dir is not None else models_dir()
    start = time.perf_counter()
    ensemble = ParserEnsemble([QuestionParser.load(directory, name=name) for name in member], rule)
    report = ensemble.fit_calibration(generate_corpus(questions, CorpusConfig(seed=corpus_seed, extra_families=extra)),
                                      seed=corpus_seed)
    path = ensemble.save(directory, member)
    words = ["po3d", "train", "parser-ensemble", *(w for name in member for w in ("--member", name)), "--rule", rule,
             "--corpus-seed", str(corpus_seed), "--questions", str(questions), *_extra_families_words(extra)]
    if model_dir is not None:
        words += ["--model-dir", str(model_dir)]
    config = {"questions": questions, **({"extra_families": list(extra)} if extra else {})}
    metrics = {"calibration": {"questions": report.questions, "dev_accuracy": report.accuracy,
                               "dev_ece_before": report.ece_before, "dev_ece_after": report.ece_after,
                               "seconds": round(time.perf_counter() - start, 1),
                               **dataclasses.asdict(report.calibration)}}
    write_entry(ENSEMBLE_NAME, [path], directory, members=list(member), rule=rule, command=shlex.join(words),
                data_seed=[corpus_seed], data_config=[config], metrics=metrics)
    Console().print(f"{path}: {len(member)} members, {rule} rule; calibration {report.calibration} on "
                    f"{report.questions} perturbed questions (top-1 accuracy {report.accuracy:.3f}): ECE "
                    f"{report.ece_before:.4f} -> {report.ece_after:.4f}", markup=False, highlight=False)


def eval_language_command(
    independent: Path = typer.Option(None, "--independent", help="A question set folder (*.jsonl records with "
                                                                 "question, program, family_group, scene)."),
    corpus_seed: int = typer.Option(None, "--corpus-seed", min=0, help="Instead: corpus questions of this seed "
                                                                       "(in distribution; use an unseen seed)."),
    questions: int = typer.Option(3000, "--questions", min=1, help="Corpus questions (with --corpus-seed)."),
    template_text: float = typer.Option(1.0, "--template-text", help="Share of corpus questions worded by the "
                                                                     "template texts (1: our templates only)."),
    unknown_words: bool = typer.Option(True, "--unknown-words/--no-unknown-words",
                                       help="--no-unknown-words: the ablation without typo/compound rewriting and "
                                            "subword input for unknown words."),
    beam: int = typer.Option(5, "--beam", min=1),
    extra_families: list[str] = typer.Option(None, "--extra-families", help="With --corpus-seed: "
                                             + _EXTRA_FAMILIES_HELP),
    model_dir: Path = typer.Option(None, "--model-dir", help="Directory with the parser files (default: models/)."),
    parser_dir: list[Path] = typer.Option(None, "--parser-dir", help=_PARSER_DIR_HELP),
    ensemble_rule: str = typer.Option(None, "--ensemble-rule", help=_ENSEMBLE_RULE_HELP),
    single_parser: bool = typer.Option(False, "--single-parser", help=_SINGLE_HELP),
    ensemble_calibration: int = typer.Option(0, "--ensemble-calibration", min=0,
                                             help="With --parser-dir: fit the ensemble's own confidence calibration "
                                                  "on this many perturbed corpus questions of seed 2001 (as `po3d "
                                                  "train parser-calibration`) first; 0: the mean of the members' "
                                                  "calibrations."),
    json_out: Path = typer.Option(None, "--json", help="Write the report (with every miss) here."),
    record: bool = typer.Option(False, "--record", help="Store the summary in the model's manifest entry."),
    threads: int = typer.Option(1, "--threads", min=1, help="torch CPU threads."),
) -> None:
    """Parser accuracy (exact, or same answer on the scene), per family group, and the ECE of its confidence."""
    import torch
    from rich.console import Console
    from rich.table import Table

    from po3d_ppl.cli._common import literal
    from po3d_ppl.errors import InputError
    from po3d_ppl.evaluation.calibration import binned_calibration_error
    from po3d_ppl.language.seq2seq.ensemble import ENSEMBLE_NAME, ParserEnsemble
    from po3d_ppl.language.seq2seq.model_io import MODEL_NAME
    from po3d_ppl.questions.parser_corpus import check_extra_families
    from po3d_ppl.questions.parser_eval import SceneQuestion, judge, load_question_set, summarise

    if (independent is None) == (corpus_seed is None):
        raise InputError("--independent/--corpus-seed", "give exactly one of them")
    extra = check_extra_families(extra_families)
    if extra and corpus_seed is None:
        raise InputError("--extra-families", "adds families to corpus questions; give --corpus-seed")
    if record and (parser_dir or ensemble_rule or extra):
        raise InputError("--record", "records the shipped parser's metrics in its manifest entry; not with "
                                     "--parser-dir, --ensemble-rule or --extra-families")
    torch.set_num_threads(threads)
    parser = _load_parser(model_dir, parser_dir, ensemble_rule, unknown_words, single_parser)
    shipped_ensemble = isinstance(parser, ParserEnsemble) and not parser_dir
    if ensemble_calibration and parser_dir:
        from po3d_ppl.questions.parser_corpus import CorpusConfig, generate_corpus

        fitted = parser.fit_calibration(generate_corpus(ensemble_calibration, CorpusConfig(seed=2001)), seed=2001)
        Console().print(f"ensemble calibration {fitted.calibration} (ECE on its {fitted.questions} questions "
                        f"{fitted.ece_before:.4f} -> {fitted.ece_after:.4f})", markup=False, highlight=False)
    if independent is not None:
        records = load_question_set(independent)
        source = str(independent)
    else:
        from po3d_ppl.questions.parser_corpus import CorpusConfig, generate_corpus

        corpus = generate_corpus(questions, CorpusConfig(seed=corpus_seed, template_text=template_text,
                                                         extra_families=extra))
        records = [SceneQuestion(str(i), e.question, e.program, e.source, e.family, None)
                   for i, e in enumerate(corpus)]
        source = f"corpus seed {corpus_seed} ({template_text:.0%} template texts)"
        if extra:
            source += f" with {', '.join(extra)}"
    judged = judge(records, lambda q: parser.parse(q, n=1, beam=beam))
    report = summarise(judged)
    report["ece"] = binned_calibration_error([j.confidence for j in judged], [j.correct for j in judged])
    report.update(source=source, unknown_words=unknown_words, beam=beam)
    if parser_dir:
        report["ensemble"] = {"members": [str(model_dir or "models/"), *map(str, parser_dir)], "rule": parser.rule,
                              "calibration_questions": ensemble_calibration}
    elif shipped_ensemble:
        report["ensemble"] = {"members": parser.names, "rule": parser.rule}
    title = f"question parser on {source}" + ("" if unknown_words else " (no unknown-word mechanism)")
    if isinstance(parser, ParserEnsemble):
        title += f" (ensemble of {len(parser.members)}, {parser.rule} rule)"
    table = Table(title=literal(title),
                  caption="correct: exact match or the same answer on the record's scene")
    for col in ("family group", "questions", "correct", "exact", "mean confidence"):
        table.add_column(col, justify="left" if col == "family group" else "right")
    for name, row in [*report["per_group"].items(), ("all", report)]:
        table.add_row(literal(name), str(row["count"]), f"{row['accuracy']:.4f}", f"{row['exact_match']:.4f}",
                      f"{row['mean_confidence']:.3f}")
    console = Console()
    console.print(table)
    console.print(f"ECE of the top parse's confidence: {report['ece']:.4f}", markup=False, highlight=False)
    if json_out is not None:
        report["misses"] = [{"id": j.record.id, "question": j.record.question, "group": j.record.family_group,
                             "predicted": j.predicted, "confidence": j.confidence} for j in judged if not j.correct]
        write_report(json_out, report)
    if record:
        from po3d_ppl.model_store import models_dir, record_metrics

        if independent is not None:  # the held-out set records as "independent", any other set by its folder
            name = Path(independent).resolve().name
            base = "independent" if name == "independent_questions" else f"set_{name}"
            key = f"{base}{'' if unknown_words else '_no_unknown_words'}"
        else:
            key = f"corpus_seed{corpus_seed}_template{template_text:g}"
        summary = {k: report[k] for k in ("count", "accuracy", "exact_match", "ece", "mean_confidence")}
        summary["per_group"] = {g: {k: r[k] for k in ("count", "accuracy", "exact_match")}
                                for g, r in report["per_group"].items()}
        summary["source"] = source
        record_metrics(ENSEMBLE_NAME if shipped_ensemble else MODEL_NAME, key, summary, model_dir or models_dir())


def _train_command(data: list[Path], config, out: Path | None, corpus: int = 0, corpus_seed: int = 1,
                   corpus_val: int = 3000, max_minutes: float | None = None, threads: int = 1,
                   extra_families: tuple[str, ...] = (), name: str = "question_parser") -> str:
    """The training command with every setting spelled out (defaults included), to reproduce the weights."""
    words = ["po3d", "train", "parser"]
    for directory in data:
        words += ["--data", str(directory)]
    if corpus:
        words += ["--corpus", str(corpus), "--corpus-seed", str(corpus_seed), "--corpus-val", str(corpus_val),
                  *_extra_families_words(extra_families)]
    words += ["--ngram-buckets", str(config.ngram_buckets), "--word-dropout", str(config.word_dropout),
              "--threads", str(threads)]
    if max_minutes is not None:
        words += ["--max-minutes", str(max_minutes)]
    words += ["--seed", str(config.seed), "--epochs", str(config.epochs), "--batch-size", str(config.batch_size),
              "--lr", str(config.lr), "--hidden", str(config.hidden), "--embed", str(config.embed)]
    if config.max_steps is not None:
        words += ["--max-steps", str(config.max_steps)]
    if not config.constrained_loss:
        words.append("--unconstrained-loss")
    if out is not None:
        words += ["--out", str(out)]
    return shlex.join(words + _name_words(name))


def register(app: typer.Typer, train_app: typer.Typer, eval_app: typer.Typer) -> None:
    app.command("parse")(parse)
    train_app.command("parser")(train_parser_command)
    train_app.command("parser-calibration")(calibrate_parser_command)
    train_app.command("parser-ensemble")(train_ensemble_command)
    eval_app.command("parser")(eval_parser_command)
    eval_app.command("language")(eval_language_command)

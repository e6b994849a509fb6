"""``po3d answer``: the answer distribution of a question or program about a scene."""

from __future__ import annotations

from pathlib import Path

import typer


def answer(
    question: str = typer.Argument(None, help="A question in English (parsed by the shipped question parser)."),
    scene: Path = typer.Option(None, "--scene", help="A scene file, or a scenes file ({info, scenes}): evidence from "
                                                     "its ground truth (--noise)."),
    image: Path = typer.Option(None, "--image", help="An image instead of --scene: evidence from perception on its "
                                                     "pixels (the shipped models)."),
    program: str = typer.Option(None, "--program", help="A program instead of a question: po3d text syntax, a JSON "
                                                        "node list, or a file holding either."),
    index: int = typer.Option(None, "--index", help="Which scene of a scenes file."),
    noise: float = typer.Option(0.0, "--noise", help="Sensor noise of the evidence made from the scene (0 = certain)."),
    seed: int = typer.Option(0, "--seed", help="Seed of the evidence noise and of sampling."),
    method: str = typer.Option("auto", "--method", help="auto, exact, sampling, thresholded, soft."),
    samples: int = typer.Option(4096, "--samples", help="Posterior samples for method=sampling."),
    n_best: int = typer.Option(3, "--parses", help="Parses of the question to marginalise over."),
    single_parser: bool = typer.Option(False, "--single-parser", help="The single question parser instead of the "
                                                                      "shipped ensemble (the ablation)."),
    max_gib: float = typer.Option(2.0, "--max-gib", help="Memory budget of the inference call, GiB."),
    max_seconds: float = typer.Option(10.0, "--max-seconds", help="Time budget of the inference call, seconds "
                                                                  "(auto falls back to sampling past half of it)."),
    joint: bool = typer.Option(False, "--joint", help="The joint distribution with its invalid outcome, instead of "
                                                      "the answers given the question's presuppositions."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON instead of a table."),
    semantics: str = typer.Option("intended", "--semantics", help="intended (default) or public: the public "
                                  "Super-CLEVR-3D code's answers; the evidence then reads the public annotation."),
) -> None:
    """Print the answer distribution for QUESTION (or --program) about an image (--image: perception on its
    pixels) or a scene (--scene: its ground truth, ``--noise`` makes it uncertain)."""
    import json

    from rich.console import Console
    from rich.text import Text

    from po3d_ppl.cli._common import check_seed, load_scene_arg, read_program_arg
    from po3d_ppl.errors import InputError
    from po3d_ppl.perception import simulated_evidence
    from po3d_ppl.pipeline import answer_question
    from po3d_ppl.reasoning import Budget, SceneReasoner

    check_seed(seed)
    if (question is None) == (program is None):
        raise InputError("QUESTION/--program", "give exactly one of a question or --program")
    if samples < 1:
        raise InputError("--samples", f"must be >= 1, got {samples}")
    if n_best < 1:
        raise InputError("--parses", f"must be >= 1, got {n_best}")
    if not 0 < max_gib < 1 << 20:
        raise InputError("--max-gib", f"must be a positive number of GiB, got {max_gib}")
    budget = Budget(max_bytes=max(int(max_gib * 2**30), 1 << 20), max_seconds=max_seconds)
    from po3d_ppl.catalogue.semantics import PUBLIC, check_semantics
    from po3d_ppl.questions.public import public_reading

    if (scene is None) == (image is None):
        raise InputError("--scene/--image", "give exactly one of a scene file or an image")
    parser = calibration = None  # the shipped parser; no answer calibration for the simulated sensor
    if single_parser and question is not None:
        from po3d_ppl.pipeline import _shipped_parser

        parser = _shipped_parser(single=True)
    if image is not None:
        if check_semantics(semantics) == PUBLIC:
            raise InputError("--semantics", "public semantics reads the public annotation of a scene file; use "
                                            "--scene with it")
        from po3d_ppl.pipeline import load_pipeline

        pipeline = load_pipeline(single_parser=single_parser)
        reasoner = SceneReasoner(pipeline.perception.evidence(image), pipeline.priors, semantics=semantics)
        parser, calibration = pipeline.parser, pipeline.answer_calibration  # fitted on perception's evidence
    else:
        from po3d_ppl.perception.priors import load_priors

        truth = load_scene_arg(scene, index)
        truth = public_reading(truth) if check_semantics(semantics) == PUBLIC else truth
        reasoner = SceneReasoner(simulated_evidence(truth, noise=noise, seed=seed), load_priors(),
                                 semantics=semantics)
    parse = None
    if program is not None:
        dist = reasoner.infer(read_program_arg(program, allow_text=True), method, num_samples=samples, seed=seed,
                              budget=budget)
        dist = dist if joint else dist.given_presuppositions(warn_above=None)
    else:
        dist, parse = answer_question(reasoner, question, parser, n_best=n_best, method=method, num_samples=samples,
                                      seed=seed, budget=budget, presuppose=False)
        dist = dist if joint else dist.given_presuppositions(warn_above=None)
    if calibration is not None:
        dist = calibration.apply(dist)
    console = Console()
    if as_json:
        from po3d_ppl.language.answer_words import add_answer_words

        out = add_answer_words(dist.to_dict())
        if parse is not None:
            from po3d_ppl.language import program_to_text

            out["parses"] = [{"program": program_to_text(c.program), "probability": c.probability}
                             for c in parse.candidates]
            out["unknown_words"] = list(parse.unknown_words)
            out["parse_confidence"], out["parse_warning"] = parse.confidence, parse.warning
        console.print_json(json.dumps(out))
        return
    if parse is not None:
        from po3d_ppl.language import program_to_text

        for c in parse.candidates:
            console.print(Text.assemble((f"{c.probability:.3f}", "dim"), "  ", program_to_text(c.program)),
                          highlight=False, soft_wrap=True)
        if parse.unknown_words:
            console.print(Text.assemble(("unknown words:", "yellow"), " ", ", ".join(parse.unknown_words)),
                          highlight=False)
        if parse.warning:
            console.print(Text.assemble(("warning:", "bold yellow"), " ", parse.warning), highlight=False)
    console.print(str(dist), markup=False, highlight=False)


def register(app: typer.Typer, train_app: typer.Typer, eval_app: typer.Typer) -> None:
    app.command("answer")(answer)

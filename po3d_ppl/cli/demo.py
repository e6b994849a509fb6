"""``po3d demo``: the whole pipeline on shipped defaults.

Renders a scene of our world, parses the **image** with the shipped perception models (render-and-compare object
parsing, parts and occlusion by mesh projection; no ground truth), asks questions of every kind about it (the
question engine's templates), parses each question with the shipped parser, and prints the answer distribution
from the reasoning engine next to the ground truth. It writes the image, the scene, an overlay of what perception
read and the answers into ``--out``. ``--evidence simulated`` answers from the scene's exact annotations through a
noisy sensor model (``--noise``) instead, to separate perception's errors from reasoning's.
"""

from __future__ import annotations

from pathlib import Path

import typer


def demo(
    out: Path = typer.Option(Path("po3d_demo"), "--out", help="Directory for the image, scene and answers."),
    seed: int = typer.Option(0, "--seed", help="Scene and question seed."),
    questions: int = typer.Option(6, "--questions", help="How many questions to ask."),
    noise: float = typer.Option(0.01, "--noise",
                              help="Sensor noise of the evidence (0 = certain; docs/reasoning.md measures its effect)."),
    method: str = typer.Option("auto", "--method", help="Inference method (see `po3d answer --help`)."),
    evidence: str = typer.Option("image", "--evidence", help="image (perception on the pixels) or simulated "
                                                            "(ground truth through the noisy sensor)."),
) -> None:
    """Render a scene, ask questions about it, and print answer distributions."""
    import json
    import warnings

    import cv2
    from rich.console import Console
    from rich.table import Table

    from po3d_ppl.cli._common import check_seed, literal
    from po3d_ppl.errors import InputError
    from po3d_ppl.language import program_to_text
    from po3d_ppl.perception import simulated_evidence
    from po3d_ppl.pipeline import answer_question
    from po3d_ppl.questions.scene_questions import generate_questions
    from po3d_ppl.reasoning import PresuppositionWarning, SceneReasoner
    from po3d_ppl.world import generate_scene, save_scene

    check_seed(seed)
    if evidence not in ("image", "simulated"):
        raise InputError("--evidence", f"{evidence!r} is not a source; use image or simulated")
    if questions < 1:
        raise InputError("--questions", f"must be >= 1, got {questions}")
    console = Console()
    out.mkdir(parents=True, exist_ok=True)
    with console.status("rendering a scene..."):
        rendered = generate_scene(seed)
    if not cv2.imwrite(str(out / "image.png"), rendered.image[..., ::-1]):
        raise InputError("--out", f"cannot write {out / 'image.png'}")
    save_scene(rendered.scene, out / "scene.json")
    scene = rendered.scene
    console.print(f"scene {seed}: {len(scene.objects)} objects -> {out / 'image.png'}", markup=False,
                  highlight=False)

    per_file = generate_questions(scene, seed)
    picked = []
    files = [name for name in sorted(per_file) if per_file[name]]
    while len(picked) < questions and any(per_file[name] for name in files):
        for name in files:
            if per_file[name] and len(picked) < questions:
                picked.append((name, per_file[name].pop(0)))
    calibration = None
    if evidence == "image":
        from po3d_ppl.perception.overlay import draw_overlay
        from po3d_ppl.pipeline import load_pipeline

        with console.status("parsing the image (render-and-compare, parts by projection)..."):
            pipeline = load_pipeline()
            parsed = pipeline.scene(rendered.image)
        cv2.imwrite(str(out / "overlay.png"), draw_overlay(rendered.image, parsed.proposals)[..., ::-1])
        console.print(f"perception: {parsed.evidence.num_objects} objects found in {parsed.timings['total']:.1f} s "
                      f"-> {out / 'overlay.png'}", markup=False, highlight=False)
        for note in parsed.notes:
            console.print(f"  note: {note}", markup=False, highlight=False)
        reasoner = SceneReasoner(parsed.evidence, pipeline.priors)
        parser, calibration = pipeline.parser, pipeline.answer_calibration  # fitted on perception's evidence
        source = "perception on the image"
    else:
        from po3d_ppl.perception.priors import load_priors

        parser = None  # answer_question's default: the shipped parser
        reasoner = SceneReasoner(simulated_evidence(scene, noise=noise, seed=seed), load_priors())
        source = f"ground truth with sensor noise {noise}"
    table = Table(title=f"answers given their presuppositions (evidence: {source})", show_lines=True)
    for column in ("question", "parsed program", "answer distribution", "truth"):
        table.add_column(column)
    report = []
    for name, q in picked:
        with warnings.catch_warnings():  # the table shows the failure probability itself
            warnings.simplefilter("ignore", PresuppositionWarning)
            dist, parse = answer_question(reasoner, q["question"], parser, method=method)
        dist = dist if calibration is None else calibration.apply(dist)
        top = ", ".join(f"{dist.words(a)} {p:.2f}" for a, p in list(dist.probs.items())[:3])
        if dist.presupposition_failure > 0.005:
            top += f" (presupposition fails: {dist.presupposition_failure:.2f})"
        table.add_row(*map(literal, (q["question"], f"{program_to_text(parse.best.program)}  "
                                     f"[{parse.best.probability:.2f}]", top, q["answer"])))
        report.append({"file": name, "question": q["question"], "truth": q["answer"],
                       "parses": [{"program": program_to_text(c.program), "probability": c.probability}
                                  for c in parse.candidates], "answer": dist.to_dict()})
    console.print(table)
    (out / "answers.json").write_text(json.dumps(report, indent=1) + "\n")
    console.print(f"details: {out / 'answers.json'}", markup=False, highlight=False)


def register(app: typer.Typer, train_app: typer.Typer, eval_app: typer.Typer) -> None:
    app.command("demo")(demo)

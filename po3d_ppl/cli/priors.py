"""``po3d train priors``: fit the scene model's priors to the rates of a built dataset's scenes."""

from __future__ import annotations

from pathlib import Path

import typer


def train_priors(
    data: Path = typer.Option(..., "--data", help="Dataset directory from `po3d dataset build`."),
    split: str = typer.Option("train", "--split", help="Split whose ground-truth scenes are counted."),
    out: Path = typer.Option(None, "--out", help="Model directory to write priors.json and its manifest entry "
                                                 "into (default: the shipped models/)."),
    dry_run: bool = typer.Option(False, "--dry-run", help="Only print the rates; write nothing."),
) -> None:
    """Count the world's rates of every binary latent (occlusion, part visibility, recolouring, ...), print them
    beside the hand-set priors, and write the fitted ``ScenePriors`` (the smoothed rates) as models/priors.json,
    which the pipeline and `po3d eval` read."""
    import shlex
    from dataclasses import asdict

    from rich.console import Console
    from rich.progress import track
    from rich.table import Table

    from po3d_ppl.errors import InputError
    from po3d_ppl.evidence import ScenePriors
    from po3d_ppl.model_store import models_dir, write_entry
    from po3d_ppl.perception.priors import FITTED, MODEL_NAME, fit_priors, save_priors
    from po3d_ppl.questions.parser_examples import open_dataset

    dataset = open_dataset(data)
    if split not in dataset.splits:
        raise InputError("--split", f"unknown split {split!r} (known: {', '.join(dataset.splits)})")
    indices = dataset.splits[split]
    scenes = (dataset.scene(i) for i in track(indices, description=f"counting {split} scenes"))
    fitted, rates = fit_priors(scenes)
    hand_set = ScenePriors()
    table = Table(title=f"world rates over {rates.scenes} {split} scenes of {data}")
    for column in ("prior", "hand-set", "fitted", "counted"):
        table.add_column(column)
    for name in FITTED:
        rate = rates.rates[name]
        table.add_row(name, f"{getattr(hand_set, name):.3f}", f"{getattr(fitted, name):.4f}",
                      f"{rate.hits} / {rate.total}")
    table.add_row("exists", f"{hand_set.exists:.3f}", f"{fitted.exists:.3f}", "(kept: a parser's proposals)")
    rule = rates.count_rule_objects
    table.add_row("max_recoloured_parts", "none", str(fitted.max_recoloured_parts),
                  f"{rule.hits} / {rule.total} objects with exactly min({rates.max_recoloured}, visible parts)")
    table.add_row("recoloured_unlike_body", "false", str(fitted.recoloured_unlike_body).lower(),
                  f"{rates.unlike_body.hits} / {rates.unlike_body.total} recoloured parts")
    console = Console()
    console.print(table)
    if dry_run:
        return
    directory = Path(out) if out is not None else models_dir()
    directory.mkdir(parents=True, exist_ok=True)
    words = ["po3d", "train", "priors", "--data", str(data), "--split", split]
    words += ["--out", str(out)] if out is not None else []
    write_entry(MODEL_NAME, [save_priors(fitted, directory)], directory, command=shlex.join(words),
                data_seed=dataset.manifest.get("seed"), data_config=dataset.manifest.get("config"),
                metrics={"scenes": rates.scenes, "hand_set": asdict(hand_set),
                         "counts": {k: [v.hits, v.total] for k, v in rates.rates.items()},
                         "recolouring_rule": {"objects": [rule.hits, rule.total],
                                              "unlike_body": [rates.unlike_body.hits, rates.unlike_body.total]}})
    console.print(f"fitted priors -> {directory / 'priors.json'} (manifest entry {MODEL_NAME!r})", markup=False,
                  highlight=False)


def register(app: typer.Typer, train_app: typer.Typer, eval_app: typer.Typer) -> None:
    train_app.command("priors")(train_priors)

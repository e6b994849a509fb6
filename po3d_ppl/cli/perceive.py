"""``po3d perceive IMAGE --out DIR``: the object parser's record and an overlay of what it read."""

from __future__ import annotations

from pathlib import Path

import typer


def perceive(
    image: Path = typer.Argument(..., help="An image (PNG/JPEG; resized to 640x480 with the intrinsics scaled)."),
    out: Path = typer.Option(..., "--out", help="Directory for proposals.json and overlay.png."),
    as_json: bool = typer.Option(False, "--json", help="Print the record as JSON instead of a summary."),
) -> None:
    """Parse the objects of IMAGE by render-and-compare (pixels only) and write the record and an overlay."""
    import json

    import cv2
    import numpy as np
    import torch
    from rich.console import Console

    from po3d_ppl.errors import InputError
    from po3d_ppl.perception.image_input import load_image
    from po3d_ppl.perception.object_parser import parse_objects
    from po3d_ppl.perception.overlay import draw_overlay, proposals_record

    torch.set_num_threads(1)  # small tensors; two spinning threads are slower on a busy 2-core machine
    loaded = load_image(image)
    proposals = parse_objects(loaded)
    if out.exists() and not out.is_dir():
        raise InputError("--out", f"{out} exists and is not a directory")
    out.mkdir(parents=True, exist_ok=True)
    record = proposals_record(proposals)
    (out / "proposals.json").write_text(json.dumps(record, indent=1) + "\n")
    rgb = (loaded.pixels.permute(1, 2, 0).numpy() * 255).round().astype(np.uint8)
    if not cv2.imwrite(str(out / "overlay.png"), draw_overlay(rgb, proposals, record)[..., ::-1]):
        raise InputError("--out", f"cannot write {out / 'overlay.png'}")
    console = Console()
    if as_json:
        console.print_json(json.dumps(record))
        return
    believed = [p for p in record["proposals"] if p["existence_logodds"] > 0]
    console.print(f"{len(believed)} objects ({len(record['proposals'])} proposals) in "
                  f"{sum(record['timings_s'].values()):.2f} s -> {out / 'overlay.png'}", markup=False,
                  highlight=False)
    for k, p in enumerate(believed):
        name = max(p["category"], key=p["category"].get)
        console.print(f"  {k}: {name} {p['category'][name]:.2f}, facing {p['pose_label']} "
                      f"({p['azimuth_degree']:.0f} deg), at ({p['position'][0]:.2f}, {p['position'][1]:.2f})",
                      markup=False, highlight=False)


def register(app: typer.Typer, train_app: typer.Typer, eval_app: typer.Typer) -> None:
    app.command("perceive")(perceive)

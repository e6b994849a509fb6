"""``po3d perceive IMAGE --out DIR``: what perception read from an image.

Writes ``proposals.json`` and ``overlay.png`` (the object parser's proposals, with the evidence's masks and boxes:
those the evaluation scores), ``evidence.safetensors`` (the full
``SceneEvidence``, every table, readable with ``po3d_ppl.evaluation.cache.evidence_from_tensors``),
``evidence.json`` (a reading of it: per object the likely subtype, colour, material, size, pose, occlusion and
parts) and ``scene.png`` (the most likely scene: projected meshes, part outlines, occluded parts in red, arrows
from occluders)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import typer


def perceive(
    image: Path = typer.Argument(..., help="An image (PNG/JPEG; resized to 640x480 with the intrinsics scaled)."),
    out: Path = typer.Option(..., "--out", help="Directory for the records and overlays."),
    as_json: bool = typer.Option(False, "--json", help="Print the evidence reading as JSON instead of a summary."),
) -> None:
    """Parse IMAGE (pixels only: render-and-compare, attributes, parts by projection) and write the evidence,
    its reading and overlays."""
    import json

    import cv2
    import numpy as np
    import torch
    from rich.console import Console

    from po3d_ppl.errors import InputError
    from po3d_ppl.perception.image_input import load_image
    from po3d_ppl.perception.overlay import draw_overlay, draw_scene_overlay, evidence_record, proposals_record
    from po3d_ppl.perception.scene_parser import ImageParser

    torch.set_num_threads(1)  # small tensors; two spinning threads are slower on a busy 2-core machine
    loaded = load_image(image)
    if out.exists() and not out.is_dir():
        raise InputError("--out", f"{out} exists and is not a directory")
    parsed = ImageParser.load().parse(loaded)
    out.mkdir(parents=True, exist_ok=True)
    # the object parser's readings with the masks and boxes the evidence carries (scene_parser.seen_ownership)
    shown = dataclasses.replace(parsed.proposals, masks=parsed.evidence.masks, boxes=parsed.evidence.boxes)
    record = proposals_record(shown)
    (out / "proposals.json").write_text(json.dumps(record, indent=1) + "\n")
    reading = evidence_record(parsed)
    (out / "evidence.json").write_text(json.dumps(reading, indent=1) + "\n")
    _save_evidence(parsed.evidence, out / "evidence.safetensors")
    rgb = (loaded.pixels.permute(1, 2, 0).numpy() * 255).round().astype(np.uint8)
    for name, picture in (("overlay.png", draw_overlay(rgb, shown, record)),
                          ("scene.png", draw_scene_overlay(rgb, parsed, reading))):
        if not cv2.imwrite(str(out / name), picture[..., ::-1]):
            raise InputError("--out", f"cannot write {out / name}")
    console = Console()
    if as_json:
        console.print_json(json.dumps(reading))
        return
    console.print(f"{len(reading['objects'])} objects in {parsed.timings['total']:.2f} s -> {out / 'scene.png'}",
                  markup=False, highlight=False)
    for k, entry in enumerate(reading["objects"]):
        subtype = next(iter(entry["subtype"]))
        colour = max(entry["color"], key=entry["color"].get)
        material = max(entry["material"], key=entry["material"].get)
        console.print(f"  {k}: {colour} {material} {subtype} {entry['subtype'][subtype]:.2f} "
                      f"(exists {entry['exists']:.2f}), facing {entry['pose_label']} ({entry['azimuth_degree']:.0f} "
                      f"deg), occluded {entry['occluded']:.2f}, {len(entry['parts'])} visible parts",
                      markup=False, highlight=False)
    for note in parsed.notes:
        console.print(f"  note: {note}", markup=False, highlight=False)


def _save_evidence(evidence, path: Path) -> None:
    """The evidence as safetensors (tensors only; the camera as JSON metadata), the evaluation cache's format."""
    from safetensors.torch import save_file

    from po3d_ppl.evaluation.cache import evidence_to_tensors

    tensors, metadata = evidence_to_tensors(evidence)
    tensors = {k: v for k, v in tensors.items() if k != "masks"}  # the overlays show them; 0.3 MB per object
    save_file(tensors, str(path), metadata=metadata)


def register(app: typer.Typer, train_app: typer.Typer, eval_app: typer.Typer) -> None:
    app.command("perceive")(perceive)

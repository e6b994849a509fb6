"""Where the part-look table goes wrong: each visible part (>= 20 px) of every matched object, the reading of its
true subtype's slot (plain, or colour and material) against the truth, split by whether the top subtype is right
and by how well the parse's most likely rendering covers the true part (IoU). The reading is the arg-max of the
posterior under the shipped priors (``models/priors.json``: recoloured with probability ``part_recoloured``, its
16 looks alike), as reasoning reads it; ``--likelihood`` takes the arg-max of the table alone.

    python benchmarks/part_look_errors.py --data /work/data/val_s716 --limit 60 [--first 0] [--rows rows.json]

Ground truth is read here, for scoring only: each scene is rendered again from its dataset seed to get the true
part masks. Objects are matched to proposals at visible-mask IoU >= 0.5 (objects of >= 200 px). About 4 s an
image (one full parse).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch

#: IoU buckets of the projected part against the true one.
IOU_EDGES = (0.0, 0.25, 0.5, 0.75, 1.0001)


def part_rows(data: Path, first: int, limit: int, likelihood: bool = False) -> list[dict]:
    from po3d_ppl import ontology
    from po3d_ppl.evaluation.projection import style_log_prior
    from po3d_ppl.evidence import NUM_STYLES, style_index
    from po3d_ppl.perception.priors import load_priors
    from po3d_ppl.perception.scene_parser import ImageParser
    from po3d_ppl.questions.dataset import BuildConfig, load_dataset, scene_seeds
    from po3d_ppl.world.generate import generate_scene

    dataset = load_dataset(data)
    config = dict(dataset.manifest["config"])
    config["split_fractions"] = tuple(config["split_fractions"])
    scene_config = BuildConfig(**config).scene_config()
    parser = ImageParser.load()
    log_prior = torch.zeros(NUM_STYLES, dtype=torch.float64) if likelihood else \
        style_log_prior(load_priors().part_recoloured)
    rows = []
    for index in range(first, min(first + limit, len(dataset.public_scenes))):
        truth = generate_scene(scene_seeds(dataset.manifest["seed"], index)[0], scene_config, image_index=index)
        parsed = parser.parse(dataset.image_path(index))
        evidence, masks = parsed.evidence, np.asarray(parsed.proposals.masks)
        for j, obj in enumerate(truth.scene.objects):
            object_mask = truth.object_ids == j
            if object_mask.sum() < 200 or len(masks) == 0:
                continue
            ious = [np.logical_and(m, object_mask).sum() / max(1, np.logical_or(m, object_mask).sum()) for m in masks]
            if max(ious) < 0.5:
                continue
            k = int(np.argmax(ious))
            subtype = ontology.SUBTYPES.index(obj.subtype)
            for p, name in enumerate(ontology.PARTS[obj.subtype]):
                true_part = object_mask & (truth.part_ids == p)
                if true_part.sum() < 20:
                    continue
                style = obj.parts.get(name)
                shown = (parsed.object_ids == k) & (parsed.part_ids == p)
                table = evidence.part_style_loglik[k, subtype, p].double()
                rows.append({"image": index, "subtype": obj.subtype, "part": name, "body_color": obj.color,
                             "pixels": int(true_part.sum()), "recoloured": style is not None,
                             "truth": 0 if style is None else style_index(style.color, style.material),
                             "table": table.tolist(), "read": int((table + log_prior).argmax()),
                             "subtype_right": int(evidence.subtype_loglik[k].argmax()) == subtype,
                             "iou": float(np.logical_and(shown, true_part).sum()
                                          / max(1, np.logical_or(shown, true_part).sum()))})
        print(f"image {index}: {len(rows)} parts so far", flush=True)
    return rows


def summary(rows: list[dict]) -> list[tuple[str, int, float]]:
    """(what, parts, accuracy) lines: plain and recoloured parts, by subtype and by placement."""
    lines = []

    def add(label: str, selected: list[dict]) -> None:
        if selected:
            lines.append((label, len(selected), sum(r["read"] == r["truth"] for r in selected) / len(selected)))

    for kind, recoloured in (("recoloured", True), ("plain", False)):
        chosen = [r for r in rows if r["recoloured"] == recoloured]
        add(f"{kind}: all", chosen)
        add(f"{kind}: top subtype wrong", [r for r in chosen if not r["subtype_right"]])
        for lo, hi in zip(IOU_EDGES, IOU_EDGES[1:]):
            add(f"{kind}: subtype right, part IoU {lo:.2f}-{min(hi, 1):.2f}",
                [r for r in chosen if r["subtype_right"] and lo <= r["iou"] < hi])
    placed = [r for r in rows if r["recoloured"] and r["subtype_right"] and r["iou"] >= 0.5]
    colour_right = [r for r in placed if r["read"] > 0 and (r["read"] - 1) // 2 == (r["truth"] - 1) // 2]
    if colour_right:
        lines.append(("recoloured, IoU >= 0.5, colour right: material right", len(colour_right),
                      sum((r["read"] - 1) % 2 == (r["truth"] - 1) % 2 for r in colour_right) / len(colour_right)))
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, required=True)
    parser.add_argument("--first", type=int, default=0)
    parser.add_argument("--limit", type=int, default=60)
    parser.add_argument("--rows", type=Path, default=None,
                        help="Also write every part's row here (JSON, with the slot's 17 log-likelihoods).")
    parser.add_argument("--likelihood", action="store_true", help="Read the table's arg-max, without the priors.")
    args = parser.parse_args()
    torch.set_num_threads(1)
    rows = part_rows(args.data, args.first, args.limit, args.likelihood)
    if args.rows is not None:
        args.rows.write_text(json.dumps(rows))
    print(f"{'parts':<58} {'n':>5} {'read right':>10}")
    for label, count, accuracy in summary(rows):
        print(f"{label:<58} {count:>5} {accuracy:>10.3f}")


if __name__ == "__main__":
    main()

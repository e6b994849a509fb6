"""The pose table with and without the viewpoint network, on the object parser's own proposals and masks.

Parses every image of a dataset once (object parser, shipped calibration), reads the viewpoint network on the
proposals' visible masks, and scores the pose table ``log_softmax((rc + w * viewpoint) / T)`` of matched objects
(>= 200 visible pixels, box IoU >= 0.5) for every weight ``w`` of ``--weights`` (0: render-and-compare alone):
azimuth within 30 degrees overall and per category, front/back flips, and the NLL and top-bin ECE (the bin nearest
the true azimuth) with T = 1 and with the temperature ``T`` that minimises the NLL. Use a validation seed to choose
``SceneParserConfig.viewpoint_weight`` and ``pose_temperature``; report the test seed with the chosen ones.

    python benchmarks/viewpoint_weight.py --data /work/data/perc_val_s712 --weights 0,0.5,1,1.5,2 --rows rows.st
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import torch


def parse_rows(data: Path, split: str, limit: int | None, model_dir: Path | None, viewpoint_dir: Path | None
               ) -> dict[str, torch.Tensor]:
    """Per matched object: category, true pose_degree, the render-and-compare table [5, K], the viewpoint reading
    [K] and the support [K]; and the viewpoint network's median seconds per image."""
    from rich.progress import track

    from po3d_ppl import ontology
    from po3d_ppl.evaluation.objects import match_boxes
    from po3d_ppl.perception.image_input import load_image
    from po3d_ppl.perception.neural_mesh import load_feature_model
    from po3d_ppl.perception.object_parser import parse_objects
    from po3d_ppl.perception.viewpoint import load_viewpoint_net
    from po3d_ppl.questions.dataset import load_dataset

    dataset = load_dataset(data)
    model = load_feature_model(model_dir)
    net = load_viewpoint_net(viewpoint_dir or model_dir)
    rows, seconds = [], []
    for i in track(dataset.split_indices(split)[:limit], description="parse"):
        scene = dataset.scene(i)
        image = load_image(dataset.image_path(i))
        proposals = parse_objects(image, model)
        start = time.perf_counter()
        view = net.azimuth_loglik(image, proposals.masks)
        seconds.append(time.perf_counter() - start)
        truth = np.array([o.annotation.bbox for o in scene.objects], dtype=np.float64).reshape(-1, 4)
        for p, j in match_boxes(proposals.boxes.numpy(), truth):
            obj = scene.objects[j]
            if obj.annotation.visible_pixels >= 200:
                rows.append((ontology.CATEGORIES.index(obj.category), float(obj.pose_degree),
                             proposals.pose_loglik[p], view[p], proposals.pose_support[p]))
    return {"category": torch.tensor([r[0] for r in rows]),
            "truth": torch.tensor([r[1] for r in rows], dtype=torch.float64),
            "rc": torch.stack([r[2] for r in rows]), "vp": torch.stack([r[3] for r in rows]),
            "support": torch.stack([r[4] for r in rows]),
            "viewpoint_seconds": torch.tensor([float(np.median(seconds))])}


def figures(rows: dict[str, torch.Tensor], weight: float) -> dict[str, float]:
    from po3d_ppl import ontology
    from po3d_ppl.perception.calibration import fit_temperature, top_label_ece
    from po3d_ppl.perception.viewpoint import combine_pose

    cats, truth, support = rows["category"], rows["truth"], rows["support"]
    m, k = support.shape
    true_bin = torch.round(truth / (360.0 / k)).long() % k
    table = combine_pose(rows["rc"], support, rows["vp"], weight)[torch.arange(m), cats]  # the true category's
    guess = support[torch.arange(m), table.argmax(-1)]
    err = ((guess - truth + 180.0) % 360.0 - 180.0).abs()
    temperature = fit_temperature(table, true_bin)
    scaled = torch.log_softmax(table / temperature, -1)
    out = {"within_30": float((err <= 30).double().mean()), "flips": float((err > 150).double().mean()),
           "nll": float(torch.nn.functional.nll_loss(table, true_bin)), "ece": top_label_ece(table, true_bin),
           "T": temperature, "nll_T": float(torch.nn.functional.nll_loss(scaled, true_bin)),
           "ece_T": top_label_ece(scaled, true_bin)}
    for c, name in enumerate(ontology.CATEGORIES):
        if (cats == c).any():
            out[name] = float((err[cats == c] <= 30).double().mean())
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True)
    ap.add_argument("--split", default="all")
    ap.add_argument("--limit", type=int, default=None)
    ap.add_argument("--weights", default="0,0.5,1,1.5,2")
    ap.add_argument("--model-dir", type=Path, default=None, help="shipped models (default: models/)")
    ap.add_argument("--viewpoint-dir", type=Path, default=None,
                    help="the viewpoint network's directory (default: --model-dir)")
    ap.add_argument("--rows", type=Path, default=None,
                    help="save the matched objects' tables here (safetensors), or read them back if it exists")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()
    torch.set_num_threads(1)
    from safetensors.torch import load_file, save_file

    if args.rows is not None and args.rows.exists():
        rows = load_file(str(args.rows))
    else:
        rows = parse_rows(args.data, args.split, args.limit, args.model_dir, args.viewpoint_dir)
        if args.rows is not None:
            save_file(rows, str(args.rows))
    report = {"data": str(args.data), "objects": int(rows["category"].numel()),
              "viewpoint_seconds_per_image": round(float(rows["viewpoint_seconds"][0]), 4)}
    print(f"{report['objects']} matched objects >= 200 px; viewpoint network {report['viewpoint_seconds_per_image']}"
          " s per image")
    for w in (float(w) for w in args.weights.split(",")):
        fig = figures(rows, w)
        report[f"w={w:g}"] = {key: round(v, 4) for key, v in fig.items()}
        print(f"w={w:<4g} " + "  ".join(f"{key} {v:.3f}" for key, v in fig.items()), flush=True)
    if args.json:
        args.json.write_text(json.dumps(report, indent=1) + "\n")


if __name__ == "__main__":
    main()

"""The pose table with and without the viewpoint network, on the object parser's own proposals and masks.

Parses every image of a dataset once (object parser, shipped calibration), reads the viewpoint network on the
proposals' visible masks, and scores the pose table ``log_softmax(rc + w * viewpoint)`` of matched objects
(>= 200 visible pixels, box IoU >= 0.5) for every weight ``w`` of ``--weights`` (0: render-and-compare alone):
azimuth within 30 degrees overall and per category, front/back flips, pose NLL and top-bin ECE. Use a validation
seed to choose ``SceneParserConfig.viewpoint_weight``; report the test seed with the chosen one.

    python benchmarks/viewpoint_weight.py --data /work/data/perc_val_s712 --weights 0,0.5,1,1.5,2
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import torch


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True)
    ap.add_argument("--split", default="all")
    ap.add_argument("--limit", type=int, default=None)
    ap.add_argument("--weights", default="0,0.5,1,1.5,2")
    ap.add_argument("--model-dir", type=Path, default=None)
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()
    torch.set_num_threads(1)

    from rich.progress import track

    from po3d_ppl import ontology
    from po3d_ppl.evaluation.objects import match_boxes
    from po3d_ppl.perception.calibration import top_label_ece
    from po3d_ppl.perception.image_input import load_image
    from po3d_ppl.perception.neural_mesh import load_feature_model
    from po3d_ppl.perception.object_parser import parse_objects
    from po3d_ppl.perception.viewpoint import combine_pose, load_viewpoint_net
    from po3d_ppl.questions.dataset import load_dataset

    weights = [float(w) for w in args.weights.split(",")]
    dataset = load_dataset(args.data)
    indices = dataset.split_indices(args.split)[: args.limit]
    model = load_feature_model(args.model_dir)
    net = load_viewpoint_net(args.model_dir)
    rows = []  # (category, true pose_degree, rc table [K], viewpoint [K], support [K])
    seconds = []
    for i in track(indices, description="parse"):
        scene = dataset.scene(i)
        image = load_image(dataset.image_path(i))
        proposals = parse_objects(image, model)
        start = time.perf_counter()
        view = net.azimuth_loglik(image, proposals.masks)
        seconds.append(time.perf_counter() - start)
        truth = np.array([o.annotation.bbox for o in scene.objects], dtype=np.float64).reshape(-1, 4)
        for p, j in match_boxes(proposals.boxes.numpy(), truth):
            obj = scene.objects[j]
            if obj.annotation.visible_pixels < 200:
                continue
            c = ontology.CATEGORIES.index(obj.category)
            rows.append((c, float(obj.pose_degree), proposals.pose_loglik[p], view[p], proposals.pose_support[p]))
    report = {"data": str(args.data), "objects": len(rows), "viewpoint_seconds_per_image": float(np.median(seconds))}
    cats = torch.tensor([r[0] for r in rows])
    truth = torch.tensor([r[1] for r in rows], dtype=torch.float64)
    rc = torch.stack([r[2] for r in rows])  # [M, 5, K]
    vp = torch.stack([r[3] for r in rows])
    support = torch.stack([r[4] for r in rows])
    k = support.shape[1]
    true_bin = torch.round(truth / (360.0 / k)).long() % k
    for w in weights:
        table = combine_pose(rc, support, vp, w)[torch.arange(len(rows)), cats]  # the true category's row
        guess = support[torch.arange(len(rows)), table.argmax(-1)]
        err = (guess - truth + 180.0) % 360.0 - 180.0
        err = err.abs()
        fig = {"within_30": float((err <= 30).double().mean()), "flips": float((err > 150).double().mean()),
               "nll": float(torch.nn.functional.nll_loss(table, true_bin)),
               "ece": top_label_ece(table, true_bin)}
        for c, name in enumerate(ontology.CATEGORIES):
            sel = cats == c
            if sel.any():
                fig[name] = float((err[sel] <= 30).double().mean())
        report[f"w={w:g}"] = {key: round(v, 4) for key, v in fig.items()}
        print(f"w={w:<4g} " + "  ".join(f"{key} {v:.3f}" for key, v in fig.items()), flush=True)
    if args.json:
        args.json.write_text(json.dumps(report, indent=1) + "\n")


if __name__ == "__main__":
    main()

"""Object parser on held-out renders: detection, category, azimuth, position and per-stage speed.

    python benchmarks/bench_object_parser.py --images 30 --seed 9001

Images are rendered like ``po3d dataset build --seed SEED`` renders scene i (``scene_seeds(SEED, i)``), 640x480,
default scene config (camera jitter 0.5; objects on the ground). The shipped features were trained on dataset seed
711 (evaluated on 712), so seed 9001 is held out. Ground truth is read here only, for scoring.

Matching: greedy by 2D IoU (proposal box vs the object's visible-mask bbox) >= 0.5, one-to-one. Recall counts
objects with >= 200 visible pixels; precision counts every proposal (a proposal matched to a smaller object is not
a false positive). Azimuth error is in the ``pose_degree`` frame; position error is on the ground plane.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import torch


def iou(a: np.ndarray, b: np.ndarray) -> float:
    ax0, ay0, aw, ah = a
    bx0, by0, bw, bh = b
    ix = max(0.0, min(ax0 + aw, bx0 + bw) - max(ax0, bx0))
    iy = max(0.0, min(ay0 + ah, by0 + bh) - max(ay0, by0))
    inter = ix * iy
    union = aw * ah + bw * bh - inter
    return inter / union if union > 0 else 0.0


def match(pred_boxes: np.ndarray, gt_boxes: np.ndarray, min_iou: float = 0.5) -> list[tuple[int, int]]:
    pairs = sorted(((iou(p, g), i, j) for i, p in enumerate(pred_boxes) for j, g in enumerate(gt_boxes)),
                   reverse=True)
    used_p, used_g, out = set(), set(), []
    for v, i, j in pairs:
        if v < min_iou:
            break
        if i in used_p or j in used_g:
            continue
        used_p.add(i)
        used_g.add(j)
        out.append((i, j))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--images", type=int, default=30)
    ap.add_argument("--seed", type=int, default=9001)
    ap.add_argument("--min-pixels", type=int, default=200)
    ap.add_argument("--camera-jitter", type=float, default=None,
                    help="scene config's camera jitter (default the world's 0.5; 0 isolates the parser's own error)")
    ap.add_argument("--refine-steps", type=int, default=None, help="gradient steps (default the parser's; 0: none)")
    ap.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                    help="override a ParserConfig field (repeatable), e.g. --set existence_threshold=40")
    args = ap.parse_args()
    torch.set_num_threads(1)

    from po3d_ppl.perception.object_parser import CATEGORIES, ParserConfig, parse_objects
    from po3d_ppl.questions.dataset import scene_seeds
    from po3d_ppl.world import generate_scene
    from po3d_ppl.world.sampler import SceneConfig

    config = SceneConfig() if args.camera_jitter is None else SceneConfig(camera_jitter=args.camera_jitter)
    overrides = {k: type(getattr(ParserConfig(), k))(v) for k, v in (kv.split("=", 1) for kv in args.set)}
    if args.refine_steps is not None:
        overrides["refine_steps"] = args.refine_steps
    parser_config = ParserConfig(**overrides)
    parse_objects(np.zeros((480, 640, 3), dtype=np.uint8), config=parser_config)  # warm-up: model, templates
    tp = n_pred = n_gt = 0
    cat_ok, az_ok, pos_err, rel_err, times = [], [], [], [], []
    stages: dict[str, list[float]] = {}
    for i in range(args.images):
        rendered = generate_scene(scene_seeds(args.seed, i)[0], config)
        t = time.perf_counter()
        rec = parse_objects(rendered.image, config=parser_config)
        times.append(time.perf_counter() - t)
        for k, v in rec.timings.items():
            stages.setdefault(k, []).append(v)
        objs = rendered.scene.objects
        gt_boxes = np.array([o.annotation.bbox for o in objs], dtype=np.float64).reshape(-1, 4)
        big = [o.annotation.visible_pixels >= args.min_pixels for o in objs]
        pairs = match(rec.boxes.numpy(), gt_boxes)
        matched_g = {j: i for i, j in pairs}
        n_gt += sum(big)
        n_pred += len(rec)
        tp_img = sum(1 for j in matched_g if big[j])
        tp += tp_img
        n_pred -= sum(1 for j in matched_g if not big[j])  # a proposal on a tiny object is no false positive
        cats = rec.categories
        deltas = []
        for j, p in matched_g.items():
            if not big[j]:
                continue
            o = objs[j]
            c = cats[p]
            cat_ok.append(c == o.category)
            ci = CATEGORIES.index(o.category)
            k = int(rec.pose_loglik[p, ci].argmax())
            d = abs((float(rec.pose_support[p, k]) - o.pose_degree + 180.0) % 360.0 - 180.0)
            az_ok.append(d <= 30.0)
            deltas.append(rec.positions[p, :2].numpy() - np.asarray(o.position[:2]))
            pos_err.append(float(np.linalg.norm(deltas[-1])))
        if len(deltas) >= 2:  # error left after removing the image's common shift (unobservable camera x-y jitter)
            d = np.array(deltas)
            rel_err.extend(np.linalg.norm(d - d.mean(0), axis=1).tolist())
        print(f"image {i}: {len(objs)} objects ({sum(big)} >= {args.min_pixels} px), {len(rec)} proposals, "
              f"{tp_img} matched, {times[-1]:.2f} s", flush=True)
    precision = tp / max(n_pred, 1)
    recall = tp / max(n_gt, 1)
    coarse = [sum(v) for v in zip(stages["features"], stages["coarse"], stages["nms"])]
    rows = [
        ("images", f"{args.images} (seed {args.seed}, 640x480, camera jitter {config.camera_jitter})"),
        ("parser settings changed", f"{overrides or 'none'}"),
        ("objects >= 200 px / proposals", f"{n_gt} / {n_pred}"),
        ("detection precision (IoU >= 0.5)", f"{precision:.3f}"),
        ("detection recall (IoU >= 0.5)", f"{recall:.3f}"),
        ("category accuracy (matched)", f"{np.mean(cat_ok):.3f}" if cat_ok else "-"),
        ("azimuth error <= 30 deg (matched)", f"{np.mean(az_ok):.3f}" if az_ok else "-"),
        ("median ground position error", f"{statistics.median(pos_err):.3f}" if pos_err else "-"),
        ("... after removing each image's mean shift", f"{statistics.median(rel_err):.3f}" if rel_err else "-"),
        ("seconds per image, all stages (median)", f"{statistics.median(times):.2f}"),
        ("... features + coarse search + 3D-NMS alone", f"{statistics.median(coarse):.2f}"),
    ] + [(f"... stage {k} (median)", f"{statistics.median(v):.3f}") for k, v in stages.items()]
    width = max(len(r[0]) for r in rows)
    for name, value in rows:
        print(f"{name:<{width}}  {value}")


if __name__ == "__main__":
    main()

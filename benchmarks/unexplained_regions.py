"""Foreground that no parsed object explains: how much of each missed object shows there, and what else does.

Each image of ``--data`` is parsed with the shipped models (:class:`~po3d_ppl.perception.scene_parser.ImageParser`).
The *unexplained* pixels are the background model's foreground that the most likely scene (each proposal's aligned
subtype silhouette, ``ParsedScene.object_ids``) leaves uncovered, opened by a 5x5 square; its connected regions of
at least ``--min-area`` pixels (:func:`~po3d_ppl.perception.object_parser.unexplained_regions`) are what the
parser's second search reads (``add_region_proposals``), and what this counts is left after it;
``--no-second-search`` counts them after the first reading (how the table in docs/perception.md was measured).
Subtype silhouettes are tight, unlike the enclosing category meshes the object parser scores with, so an object
behind a proposal's overshoot shows here.

Ground truth is read for scoring only. Per missed object (>= 200 visible pixels, no proposal at box IoU >= 0.5):
how many of its visible pixels lie in a region. Per region: whether most of it lies on a missed object, on a found
one (its own silhouette does not cover it: a misaligned or wrong subtype, or a part outside it) or on none, with
the cues a rule could use (the regions' median chroma against that of the proposals it touches).

    python benchmarks/unexplained_regions.py --data /work/data/perc_val_s712 --limit 60 [--regions]
"""

from __future__ import annotations

from collections import Counter
from dataclasses import replace

from dataset_args import dataset_parser


def main() -> None:
    parser = dataset_parser(__doc__)
    parser.add_argument("--min-area", type=int, default=200, help="smallest region kept (pixels)")
    parser.add_argument("--regions", action="store_true", help="print every region's cues")
    parser.add_argument("--no-second-search", action="store_true",
                        help="parse without the second search (ParserConfig.region_min_score=None)")
    args = parser.parse_args()

    import cv2
    import numpy as np
    import torch
    from rich.progress import track

    from po3d_ppl.evaluation.objects import match_boxes
    from po3d_ppl.perception.image_input import load_image
    from po3d_ppl.perception.object_parser import ParserConfig, _chroma, _default_background, _rgb8, unexplained_regions
    from po3d_ppl.perception.scene_parser import ImageParser
    from po3d_ppl.questions.dataset import load_dataset
    from po3d_ppl.world import rle

    torch.set_num_threads(args.threads)
    dataset = load_dataset(args.data)
    search_config = ParserConfig(region_min_score=None) if args.no_second_search else ParserConfig()
    region_config = replace(search_config, region_min_pixels=args.min_area)
    image_parser, background = replace(ImageParser.load(), parser_config=search_config), _default_background()
    if background is None:
        raise SystemExit("no background model is shipped: the foreground is unknown")
    indices = dataset.split_indices(args.split)[: args.limit]
    tally: Counter = Counter()
    colour_gaps: dict[str, list[float]] = {"missed": [], "found": []}
    for index in track(indices, description="parsing"):
        scene, image = dataset.scene(index), load_image(dataset.image_path(index))
        parsed = image_parser.parse(image)
        foreground = background.foreground(_rgb8(image))
        chroma = _chroma(image).numpy()
        seen = parsed.object_ids if parsed.object_ids is not None else np.full(foreground.shape, -1)
        regions = unexplained_regions(foreground, seen, region_config)
        objects = scene.objects
        boxes = np.array([o.annotation.bbox for o in objects], dtype=np.float64).reshape(-1, 4)
        found = {j for _, j in match_boxes(parsed.evidence.boxes.numpy(), boxes, 0.5)}
        height, width = foreground.shape
        masks = [rle.decode(o.annotation.visible_mask, height, width).astype(bool) for o in objects]
        in_region = np.any(regions, axis=0) if regions else np.zeros_like(foreground)
        for j, o in enumerate(objects):
            if o.annotation.visible_pixels < 200 or j in found:
                continue
            shown = int((masks[j] & in_region).sum())
            tally["missed objects"] += 1
            tally["missed, >= 200 px in a region"] += shown >= 200
            tally["missed, >= half in a region"] += shown >= 0.5 * o.annotation.visible_pixels
        bodies = {p: np.median(chroma[seen == p], 0) for p in np.unique(seen[seen >= 0]) if (seen == p).sum() > 30}
        for region in regions:
            area = int(region.sum())
            overlap, owner = max(((int((m & region).sum()), j) for j, m in enumerate(masks)), default=(0, -1))
            kind = "none" if overlap < 0.5 * area else ("missed" if owner not in found else "found")
            tally[f"regions on {'no' if kind == 'none' else 'a ' + kind} object"] += 1
            ring = cv2.dilate(region.astype(np.uint8), np.ones((9, 9), np.uint8)).astype(bool) & ~region
            touching = sorted(int(p) for p in np.unique(seen[ring]) if p >= 0)
            median = np.median(chroma[region], 0)
            gap = min((float(np.linalg.norm(median - bodies[p])) for p in touching if p in bodies), default=np.inf)
            if kind in colour_gaps:
                colour_gaps[kind].append(gap)
            if args.regions:
                print(f"image {index:4d}: {kind:6s} area {area:5d}, touches proposals {touching}, chroma gap to them "
                      f"{gap:5.1f}, grey distance {float(np.linalg.norm(median - 128.0)):5.1f}")
    print(f"{len(indices)} images of {args.data}, regions >= {args.min_area} px")
    for key in sorted(tally):
        print(f"  {key}: {tally[key]}")
    for kind, gaps in colour_gaps.items():
        if gaps:
            gaps_arr = np.array(gaps)
            print(f"  regions on a {kind} object: chroma gap to the proposals they touch > 10 in "
                  f"{int((gaps_arr > 10).sum())} of {len(gaps)}, none touched in {int(np.isinf(gaps_arr).sum())}")


if __name__ == "__main__":
    main()

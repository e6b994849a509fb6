"""Speed of the attribute network's inference API on 640x480 renders (one torch thread by default).

    python benchmarks/bench_attributes.py [--scenes 5] [--repeats 3] [--hypotheses 5] [--threads 1] [--models DIR]

Per image: ``object_loglik`` on every object's ground-truth mask, ``part_loglik`` on every visible part, and
``part_style_table`` as the scene parser would call it, with each object's ground-truth part-id map repeated under
``--hypotheses`` subtype hypotheses (the parser projects up to 5). Best of ``--repeats`` runs, median over scenes.
Accuracy is measured by ``po3d eval attributes``, not here.
"""

from __future__ import annotations

import argparse
import statistics
import time

import torch


def _best(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scenes", type=int, default=5)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--hypotheses", type=int, default=5)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--seed", type=int, default=100)
    parser.add_argument("--models", default=None, help="model directory (default: the shipped models/); an "
                                                         "ensemble's members each read every crop")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)

    from po3d_ppl import ontology
    from po3d_ppl.perception.attributes import load_attribute_net
    from po3d_ppl.perception.train_attributes import scene_masks
    from po3d_ppl.world import generate_scene, rle

    net = load_attribute_net(args.models)
    rows: dict[str, list[float]] = {"object_loglik": [], "part_loglik": [], "part_style_table": []}
    counts: dict[str, list[int]] = {"objects": [], "parts": [], "table_rows": []}
    for k in range(args.scenes):
        r = generate_scene(args.seed + k)
        pixels = torch.from_numpy(r.image).permute(2, 0, 1).float() / 255
        h, w = pixels.shape[1:]
        masks, parts = scene_masks(r.scene, h, w)
        part_masks = torch.stack([m for _, _, m in parts])
        owner = torch.tensor([i for i, _, _ in parts])
        maps = {}
        for i, obj in enumerate(r.scene.objects):
            ids = torch.full((h, w), -1)
            for p, raw in enumerate(ontology.PARTS[obj.subtype]):
                ann = obj.part_annotations.get(raw)
                if ann is not None and ann.visible_pixels:
                    ids[torch.from_numpy(rle.decode(ann.visible_mask, h, w))] = p
            base = ontology.SUBTYPES.index(obj.subtype)
            for j in range(args.hypotheses):  # the same map under other hypotheses: the parser's workload
                maps[(i, (base + j) % len(ontology.SUBTYPES))] = ids
        rows["object_loglik"].append(_best(lambda x=pixels, m=masks: net.object_loglik(x, m), args.repeats))
        rows["part_loglik"].append(_best(lambda x=pixels, pm=part_masks, m=masks, o=owner: net.part_loglik(x, pm, m, o),
                                         args.repeats))
        rows["part_style_table"].append(_best(lambda x=pixels, m=masks, t=maps: net.part_style_table(x, m, t),
                                              args.repeats))
        counts["objects"].append(len(masks))
        counts["parts"].append(len(parts))
        counts["table_rows"].append(sum(int((m >= 0).any()) for m in maps.values()))
    print(f"{args.scenes} scenes of 640x480, {args.threads} torch thread(s); median objects "
          f"{statistics.median(counts['objects'])}, visible parts {statistics.median(counts['parts'])}, "
          f"{args.hypotheses} subtype hypotheses per object in the table")
    for name, values in rows.items():
        print(f"{name:18s} {1000 * statistics.median(values):8.1f} ms")


if __name__ == "__main__":
    main()

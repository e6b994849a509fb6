"""Speed of the perception feature extractor: one 640x480 image at inference (eval mode, no grad), and one
training step (forward, contrastive loss against the momentum banks, backward, optimiser and bank update) at the
shipped schedule's batch and crop, with the untrained network's parameter count.

Prints the median milliseconds over repeats for each thread count.

    python benchmarks/bench_features.py [--repeats 5] [--threads 1,2] [--batch-size 8] [--crop 256x320]

On a machine whose cores are busy with other work, one thread is usually faster than two (OpenMP spin-waiting).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import torch

from po3d_ppl import ontology
from po3d_ppl.perception.category_meshes import category_mesh
from po3d_ppl.perception.features import FeatureConfig, FeatureExtractor, extract_features
from po3d_ppl.perception.train_features import BatchSampler, MemoryBank, TrainConfig, contrastive_loss, training_image


def median_ms(fn, repeats: int) -> float:
    fn()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return 1000 * float(np.median(times))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--batch-size", type=int, default=8)
    ap.add_argument("--crop", default="256x320")
    ap.add_argument("--dim", type=int, default=64)
    args = ap.parse_args()
    from po3d_ppl.world import generate_scene

    crop = tuple(int(v) for v in args.crop.split("x"))
    config = TrainConfig(batch_size=args.batch_size, crop=crop, feature=FeatureConfig(dim=args.dim))
    rendered = generate_scene(7)
    image = training_image(torch.from_numpy(rendered.image).permute(2, 0, 1).contiguous(), rendered.scene)
    pixels = image.pixels.float() / 255.0
    torch.manual_seed(0)
    net = FeatureExtractor(config.feature)
    print(f"extractor: {net.num_parameters():,} parameters, dim {config.feature.dim}, widths {config.feature.widths}")
    for threads in (int(t) for t in args.threads.split(",")):
        torch.set_num_threads(threads)
        infer = median_ms(lambda: extract_features(net, pixels), args.repeats)
        g = torch.Generator().manual_seed(0)
        bank = MemoryBank([category_mesh(c).num_vertices for c in ontology.CATEGORIES], config.feature.dim,
                          config.clutter_size, g)
        sampler = BatchSampler([image], config, g)
        opt = torch.optim.AdamW(net.parameters(), lr=config.lr)

        def step(sampler=sampler, bank=bank, opt=opt) -> None:
            batch = sampler.batch([0] * config.batch_size)
            net.train()
            loss, _, f, b = contrastive_loss(net(batch.images), batch, bank, config)
            opt.zero_grad()
            loss.backward()
            opt.step()
            bank.update(batch.anchor_cat, batch.anchor_vertex, f, b, config.momentum)

        train = median_ms(step, args.repeats)
        print(f"threads {threads}: inference 640x480 {infer:.0f} ms; training step (batch {config.batch_size}, "
              f"crop {crop[0]}x{crop[1]}) {train:.0f} ms")


if __name__ == "__main__":
    main()

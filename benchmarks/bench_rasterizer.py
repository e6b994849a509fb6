"""Speed of the torch rasteriser (perception's render-and-compare) against the embree ray caster (the world's
renderer) on the same silhouettes: every subtype in 8 poses, at 640x480 and at the stride-8 feature-map
resolution 80x60 that perception mostly renders at.

Prints milliseconds per mesh-pose (median over repeats) of ``rasterize`` on a batch of poses, with and without
back-face culling, and of ``renderer.cast_alone`` (embree, one pose at a time, rays only through the object's
projected box), and their ratio; and the silhouette IoU between the two.

    python benchmarks/bench_rasterizer.py [--repeats 5] [--threads 2] [--poses 8] [--subtypes sedan,road,...]

On a machine whose cores are busy with other work, run ``--threads 1`` or set ``OMP_WAIT_POLICY=passive``:
OpenMP's spin-waiting otherwise makes two intra-op threads several times slower than one.
"""

from __future__ import annotations

import argparse
import time
from functools import partial

import numpy as np
import torch

from po3d_ppl import ontology
from po3d_ppl.perception.rasterizer import rasterize_camera
from po3d_ppl.world.meshes import vehicle_mesh
from po3d_ppl.world.renderer import PlacedMesh, cast_alone, place_meshes
from po3d_ppl.world.sampler import ObjectSpec, make_camera
from po3d_ppl.world.scene import Camera


def posed(subtype: str, poses: int) -> list[PlacedMesh]:
    """The subtype, large, at the origin, at ``poses`` yaws (CLEVR's camera sees it from as many azimuths)."""
    return place_meshes([ObjectSpec(subtype, "gray", "rubber", "large", float(yaw), 0.0, 0.0)
                         for yaw in np.arange(poses) * 360.0 / poses + 10.0])


def median_time(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def embree_masks(meshes: list[PlacedMesh], camera: Camera) -> np.ndarray:
    out = np.zeros((len(meshes), camera.height, camera.width), dtype=bool)
    for i, m in enumerate(meshes):
        v = cast_alone(m, camera)
        h, w = v.face.shape
        out[i, v.y0:v.y0 + h, v.x0:v.x0 + w] = v.present
    return out


def bench(subtypes: list[str], poses: int, camera: Camera, repeats: int) -> dict[str, float]:
    totals = {"raster": 0.0, "raster_culled": 0.0, "embree": 0.0}
    worst = 1.0
    for s in subtypes:
        meshes = posed(s, poses)
        verts = torch.as_tensor(np.stack([m.vertices for m in meshes]), dtype=torch.float32)
        faces = torch.as_tensor(np.asarray(vehicle_mesh(s).mesh.faces), dtype=torch.int64)
        rasterize_camera(verts, faces, camera)  # warm-up
        totals["raster"] += median_time(partial(rasterize_camera, verts, faces, camera), repeats)
        totals["raster_culled"] += median_time(
            partial(rasterize_camera, verts, faces, camera, cull_backfaces=True), repeats)
        totals["embree"] += median_time(partial(embree_masks, meshes, camera), repeats)
        ours = rasterize_camera(verts, faces, camera).mask.numpy()
        ref = embree_masks(meshes, camera)
        iou = (ours & ref).sum(axis=(1, 2)) / np.maximum((ours | ref).sum(axis=(1, 2)), 1)
        worst = min(worst, float(iou.min()))
    n = len(subtypes) * poses
    return {k: 1000.0 * v / n for k, v in totals.items()} | {"iou": worst}


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--poses", type=int, default=8)
    parser.add_argument("--subtypes", default=",".join(ontology.SUBTYPES))
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    subtypes = args.subtypes.split(",")
    for s in subtypes:
        vehicle_mesh(s)  # build (and cache) the meshes outside the timings
    print(f"{len(subtypes)} subtypes x {args.poses} poses, torch {torch.__version__} on {args.threads} thread(s), "
          f"median of {args.repeats}; ms per mesh-pose")
    print(f"{'resolution':>12} {'raster':>8} {'culled':>8} {'embree':>8} {'embree/raster':>14} "
          f"{'embree/culled':>14} {'min IoU':>8}")
    for width, height in ((640, 480), (80, 60)):
        r = bench(subtypes, args.poses, make_camera(width, height), args.repeats)
        print(f"{width:>7}x{height:<4} {r['raster']:8.2f} {r['raster_culled']:8.2f} {r['embree']:8.2f} "
              f"{r['embree'] / r['raster']:14.2f} {r['embree'] / r['raster_culled']:14.2f} {r['iou']:8.4f}")


if __name__ == "__main__":
    main()

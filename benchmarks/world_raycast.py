"""Ray-casting speed on a scene-like load: 10 vehicles, one ray per pixel of a 640x480 image.

Prints the median time of the po3d RayCaster (build + cast) and of trimesh's own embree wrapper
(``trimesh.ray.ray_pyembree``, first hit per ray) on the same rays, and their ratio.

    python benchmarks/world_raycast.py [--repeats 5]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import trimesh

from po3d_ppl import ontology
from po3d_ppl.world.meshes import vehicle_mesh
from po3d_ppl.world.raycast import RayCaster, camera_rays, look_at_camera


def scene_meshes(seed: int = 0) -> list[trimesh.Trimesh]:
    rng = np.random.default_rng(seed)
    subtypes = rng.choice(ontology.SUBTYPES, 10, replace=False)
    meshes = []
    for k, s in enumerate(subtypes):
        m = vehicle_mesh(str(s)).mesh.copy()
        m.apply_scale(ontology.SIZE_SCALE["large" if k % 2 else "small"])
        m.apply_transform(trimesh.transformations.rotation_matrix(rng.uniform(0, 2 * np.pi), (0, 0, 1)))
        m.apply_translation((rng.uniform(-3, 3), rng.uniform(-3, 3), 0))
        meshes.append(m)
    return meshes


def median_time(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    meshes = scene_meshes()
    camera = look_at_camera((7.5, -6.5, 5.3), (0, 0, 0))
    o, d = camera_rays(camera)
    triangles = sum(len(m.faces) for m in meshes)
    build = median_time(lambda: RayCaster(meshes), args.repeats)
    caster = RayCaster(meshes)
    cast = median_time(lambda: caster.cast(o, d), args.repeats)
    hits = caster.cast(o, d)

    from trimesh.ray.ray_pyembree import RayMeshIntersector

    merged = trimesh.util.concatenate(meshes)
    ref = RayMeshIntersector(merged)
    o64, d64 = o.astype(np.float64), d.astype(np.float64)
    ref.intersects_first(o64[:10], d64[:10])  # build its BVH outside the timing, like ours
    baseline = median_time(lambda: ref.intersects_first(o64, d64), args.repeats)
    print(f"scene: 10 vehicles, {triangles} triangles, {len(o)} rays, {hits.hit.mean():.1%} hit")
    print(f"RayCaster build        {build * 1e3:7.1f} ms")
    print(f"RayCaster cast         {cast * 1e3:7.1f} ms  (first hit + face normal per ray)")
    print(f"trimesh ray_pyembree   {baseline * 1e3:7.1f} ms  (first-hit face index only)")
    print(f"speed-up               {baseline / cast:7.1f}x")


if __name__ == "__main__":
    main()

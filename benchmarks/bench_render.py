"""Scene rendering speed on one core: per-stage time of a 10-object 640x480 scene with all annotations, naive
baselines for the ray-casting stage, and end-to-end throughput including rejected layouts.

    python benchmarks/bench_render.py [--repeats 7] [--scenes 20]

The process is pinned to one core (embree's build threads included) and BLAS/OpenMP pools to one thread.
Times are process CPU time (robust on a shared machine) unless marked wall.

Ray-casting baselines, same scene and rays (ours: each object cast alone in its canonical frame against a BVH
cached per subtype, only inside its projected box, then a z-buffer over objects):
- scene BVH: one embree scene of the world-space meshes built per scene, every pixel cast, then the solo
  footprints by re-casting the pixels of each object's box that show another object against that object alone
  (a BVH per occluded object);
- naive: the scene BVH cast, plus one full-image render per object alone for its footprint;
- trimesh: the primary cast alone through trimesh's own embree wrapper (``RayMeshIntersector``).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ[_var] = "1"
if hasattr(os, "sched_setaffinity"):
    os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})

import argparse  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402


def cpu_median(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.process_time()
        fn()
        times.append(time.process_time() - start)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--scenes", type=int, default=20, help="scenes for the throughput figures")
    args = parser.parse_args()

    import trimesh

    from po3d_ppl import ontology
    from po3d_ppl.world import renderer, sampler
    from po3d_ppl.world.generate import generate_scene, render_layout
    from po3d_ppl.world.meshes import vehicle_mesh
    from po3d_ppl.world.raycast import RayCaster
    from po3d_ppl.world.scene_io import dumps, scene_to_public

    start = time.perf_counter()
    for s in ontology.SUBTYPES:
        vehicle_mesh(s)
        renderer.corner_normals(s)
        renderer.local_caster(s).cast(np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32))
    print(f"one-time setup per process (21 meshes, shading normals, BVHs), wall: {time.perf_counter() - start:.2f} s")

    # The accepted 10-object layout of generate_scene(0).
    config = sampler.SceneConfig.with_objects(10)
    result = generate_scene(0, config)
    rng = np.random.default_rng([0, result.attempts - 1])
    camera = sampler.sample_camera(rng, config)
    specs = sampler.sample_objects(rng, config)

    stages: dict[str, list[float]] = {}
    totals = []
    for _ in range(args.repeats):
        timings: dict[str, float] = {}
        t0 = time.process_time()
        rendered = render_layout(specs, camera, config, timings=timings)
        t1 = time.process_time()
        dumps(scene_to_public(rendered.scene))
        timings["export json"] = time.process_time() - t1
        totals.append(time.process_time() - t0)
        for k, v in timings.items():
            stages.setdefault(k, []).append(v)
    print(f"\n10-object 640x480 scene, all annotations, one core, CPU ms (median of {args.repeats}):")
    for k, v in stages.items():
        print(f"  {k:<12} {1000 * statistics.median(v):7.1f}")
    print(f"  {'total':<12} {1000 * statistics.median(totals):7.1f}   (target <= 500)")

    # Ray-casting baselines.
    meshes = renderer.place_meshes(specs)
    world = [trimesh.Trimesh(m.vertices, np.asarray(vehicle_mesh(m.subtype).mesh.faces), process=False)
             for m in meshes]
    dirs = renderer.pixel_directions(camera)
    origins = np.ascontiguousarray(np.broadcast_to(camera.location.astype(np.float32), dirs.shape))
    W = camera.width

    def scene_bvh(naive: bool) -> None:
        caster = RayCaster(world)
        geometry = caster.cast(origins, dirs).geometry
        for i, m in enumerate(meshes):
            if naive:
                caster.subset([i]).cast(origins, dirs)
                continue
            x0, y0, x1, y1 = renderer.projected_box(m, camera)
            box = (np.arange(y0, y1)[:, None] * W + np.arange(x0, x1)[None, :]).ravel()
            other = box[(geometry[box] >= 0) & (geometry[box] != i)]
            if other.size:
                caster.subset([i]).cast(origins[other], dirs[other])

    def trimesh_primary() -> None:
        intersector = trimesh.ray.ray_pyembree.RayMeshIntersector(trimesh.util.concatenate(world))
        intersector.intersects_first(origins, dirs)

    ours = cpu_median(lambda: renderer.render_geometry(meshes, camera), args.repeats)
    print(f"\nray casting + solo footprints, CPU ms: ours {1000 * ours:.1f}")
    for name, fn in (("scene BVH + re-cast occluded box pixels", lambda: scene_bvh(False)),
                     ("naive: scene BVH + full render per object", lambda: scene_bvh(True)),
                     ("trimesh RayMeshIntersector, primary only", trimesh_primary)):
        t = cpu_median(fn, args.repeats)
        print(f"  {name:<44} {1000 * t:7.1f}  -> ours is {t / ours:.1f}x faster")

    # Throughput including rejected layouts, one core.
    for name, cfg in (("3-10 objects (default)", sampler.SceneConfig()), ("10 objects", config)):
        attempts = 0
        wall, cpu = time.perf_counter(), time.process_time()
        for s in range(args.scenes):
            attempts += generate_scene(1000 + s, cfg).attempts
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        print(f"throughput, {name}: {args.scenes / cpu:.2f} scenes per CPU second ({args.scenes / wall:.2f} per wall "
              f"second here), {attempts / args.scenes:.1f} layouts tried per scene")


if __name__ == "__main__":
    main()

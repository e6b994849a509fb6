"""Render the scenes of the independent question set (run once; the set's questions are grounded in them).

    python tests/data/independent_questions/render_scenes.py
    python tests/data/independent_questions/render_scenes.py --first-seed 7100 \
        --out tests/data/independent_questions_v2/scenes          # the second set's scenes

Scenes come straight from the world (``po3d_ppl.world.generate_scene``), seeds 7000.. with 5-10 objects at
640x480. To keep the directory small the stored files drop the RLE masks (``obj_mask_box`` masks, the public
``occlusion`` masks and the ``po3d`` occlusion masks): every fact the reference executor reads (attributes,
recoloured parts, pose degrees, relationships, occlusion states and occluders) is kept, and the script checks that
the stripped file loads to the same executor facts as the full one.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from po3d_ppl.questions.context import SceneContext
from po3d_ppl.world import SceneConfig, generate_scene, load_scene, save_scene

HERE = Path(__file__).resolve().parent
FIRST_SEED, SCENES = 7000, 64


def strip(data: dict) -> dict:
    for entry in data.get("obj_mask_box", {}).values():
        for name, value in entry.items():
            if name != "info" and isinstance(value, list) and len(value) == 2:
                value[1] = None
    for entry in data.get("occlusion", {}).values():
        for value in entry.values():
            if isinstance(value, list) and len(value) >= 2:
                value[1] = None
    for obj in data.get("po3d", {}).get("annotations", []):
        for value in obj.values():
            value.pop("occlusion_mask", None)
            value.pop("visible_mask", None)
    return data


def facts(ctx: SceneContext):
    return (ctx.recoloured, ctx.occluded_parts, ctx.part_occluders, ctx.occludees_of, ctx.parts_occluded_by,
            [(o.subtype, o.color, o.material, o.size, o.pose_degree, o.occluded_by,
              o.annotation.occlusion.occluded) for o in ctx.objects],
            {k: v for k, v in ctx.scene.relationships.items()})


def main() -> None:
    import argparse

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--first-seed", type=int, default=FIRST_SEED)
    ap.add_argument("--out", type=Path, default=HERE / "scenes")
    args = ap.parse_args()
    out = args.out
    out.mkdir(exist_ok=True)
    tmp = Path("/tmp/indep_full.json")
    for k, seed in enumerate(range(args.first_seed, args.first_seed + SCENES)):
        n = 5 + k % 6
        r = generate_scene(seed, SceneConfig.with_objects(n, shadows=False))
        save_scene(r.scene, tmp)
        data = strip(json.loads(tmp.read_text()))
        path = out / f"scene_{seed}.json"
        path.write_text(json.dumps(data, separators=(",", ":")))
        full, small = SceneContext(load_scene(tmp)), SceneContext(load_scene(path))
        assert facts(full) == facts(small), seed
        occ = sum(o.annotation.occlusion.occluded for o in small.objects)
        print(f"{path.name}: {n} objects, {occ} occluded, {path.stat().st_size} bytes", file=sys.stderr)


if __name__ == "__main__":
    main()

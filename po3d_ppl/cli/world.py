"""``po3d world ...``: the synthetic world: vehicle meshes (``meshes``) and rendered scenes (``render``)."""

from __future__ import annotations

from pathlib import Path

import typer

from po3d_ppl.errors import InputError

world_app = typer.Typer(help="The synthetic 3D world: vehicle meshes and scenes.", no_args_is_help=True)


@world_app.command("meshes")
def meshes(
    out: Path = typer.Option(..., "--out", help="Directory to write <subtype>.glb, part_colors.json and contact_sheet.png."),
    subtype: list[str] = typer.Option(None, "--subtype", help="Only these subtypes (repeatable). Default: all 21."),
    legends: bool = typer.Option(False, "--legends", help="Also write legend_<subtype>.png (4 views + part key)."),
) -> None:
    """Export the part-labelled vehicle meshes (faces coloured by part) and a contact sheet of all of them."""
    import json

    from rich.console import Console

    from po3d_ppl.world import contact_sheet as cs
    from po3d_ppl.world.meshes import export_glb, vehicle_mesh
    from po3d_ppl.ontology import SUBTYPES

    chosen = list(subtype) if subtype else list(SUBTYPES)
    meshes_by_name = {s: vehicle_mesh(s) for s in chosen}  # UnknownNameError names the closest subtypes
    _make_out_dir(out)
    console = Console(stderr=True)
    colors = {}
    for name, vm in meshes_by_name.items():
        path = export_glb(vm, out / f"{name}.glb")
        palette = cs.part_palette(len(vm.part_names))
        colors[name] = {p: [int(round(c * 255)) for c in palette[i]] for i, p in enumerate(vm.part_names)}
        console.print(f"{path}  {len(vm.mesh.faces)} triangles, {len(vm.part_names)} parts", markup=False,
                      highlight=False)
    (out / "part_colors.json").write_text(json.dumps(colors, indent=1))
    sheet = cs.write_png(out / "contact_sheet.png", cs.contact_sheet(meshes_by_name))
    console.print(f"{sheet}", markup=False, highlight=False)
    if legends:
        for name in meshes_by_name:
            console.print(f"{cs.write_png(out / f'legend_{name}.png', cs.part_legend(name))}", markup=False,
                          highlight=False)


def _make_out_dir(out: Path) -> None:
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError("--out", f"cannot create directory {out}: {exc.strerror}") from None


def _int_option(option: str, text: str, lo: int, hi: int) -> int:
    """Parse an integer option here rather than in click, so bad values get the one-line error of ``po3d``."""
    try:
        value = int(text)
    except ValueError:
        raise InputError(option, f"expected an integer, got {text!r}") from None
    if not lo <= value <= hi:
        raise InputError(option, f"must be between {lo} and {hi}, got {value}")
    return value


@world_app.command("render")
def render(
    seed: str = typer.Option(..., "--seed", metavar="INT", help="Scene seed (>= 0); the same seed gives the same files."),
    out: Path = typer.Option(..., "--out", help="Directory to write image.png, scene.json and masks.png."),
    objects: str = typer.Option(None, "--objects", metavar="INT", help="Exact object count (1-30). Default: 3-10."),
    width: str = typer.Option("640", "--width", metavar="INT", help="Image width in pixels."),
    height: str = typer.Option("480", "--height", metavar="INT", help="Image height in pixels."),
    elevated_aeroplanes: bool = typer.Option(False, "--elevated-aeroplanes", help="Fly aeroplanes at random heights."),
) -> None:
    """Render one random scene: the image, its public Super-CLEVR-3D scene file and a false-colour part map."""
    import time

    import cv2
    from rich.console import Console

    from po3d_ppl.world.generate import generate_scene
    from po3d_ppl.world.sampler import SceneConfig
    from po3d_ppl.world.scene_io import save_scene
    from po3d_ppl.world.shading import false_colour_masks

    seed_value = _int_option("--seed", seed, 0, 2**63 - 1)
    size = {"width": _int_option("--width", width, 16, 4096), "height": _int_option("--height", height, 16, 4096)}
    if objects is None:
        config = SceneConfig(elevated_aeroplanes=elevated_aeroplanes, **size)
    else:
        config = SceneConfig.with_objects(_int_option("--objects", objects, 1, 30),
                                          elevated_aeroplanes=elevated_aeroplanes, **size)
    _make_out_dir(out)
    start = time.perf_counter()
    result = generate_scene(seed_value, config)
    elapsed = time.perf_counter() - start
    for name, rgb in (("image.png", result.image), ("masks.png", false_colour_masks(result.object_ids,
                                                                                  result.part_ids))):
        if not cv2.imwrite(str(out / name), rgb[:, :, ::-1]):
            raise InputError("--out", f"cannot write {out / name}")
    save_scene(result.scene, out / "scene.json")
    scene = result.scene
    occluded = sum(o.occluded for o in scene.objects)
    Console().print(f"{out}: {len(scene)} objects ({occluded} occluded), {result.attempts} layout(s) tried, "
                    f"{elapsed:.2f} s -> image.png, scene.json, masks.png", markup=False, highlight=False,
                    soft_wrap=True)


def register(app: typer.Typer, train_app: typer.Typer, eval_app: typer.Typer) -> None:
    app.add_typer(world_app, name="world")

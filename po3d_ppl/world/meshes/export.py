"""Preview colours of parts and finishes, and glTF export of a vehicle mesh with faces coloured by part."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from po3d_ppl.world.meshes.assembly import FINISHES, VehicleMesh

#: RGB (0..1) of unlabelled geometry per finish.
FINISH_RGB: dict[str, tuple[float, float, float]] = {
    "paint": (0.62, 0.62, 0.64),
    "glass": (0.22, 0.26, 0.32),
    "rubber": (0.16, 0.16, 0.17),
    "chrome": (0.80, 0.80, 0.82),
    "lamp": (0.95, 0.95, 0.85),
}

#: glTF is +y up with +z forward: canonical (front +x, left +y, up +z) -> glTF (x = left, y = up, z = front).
CANONICAL_TO_GLTF = np.array([[0.0, 1, 0, 0], [0, 0, 1, 0], [1, 0, 0, 0], [0, 0, 0, 1]])


def part_palette(n: int) -> np.ndarray:
    """``n`` distinct, saturated RGB colours (0..1), deterministic; neighbours in id order differ strongly."""
    import matplotlib

    tab = [c for k, c in enumerate(matplotlib.colormaps["tab20"].colors) if k not in (14, 15)]  # no greys
    base = tab[::2] + tab[1::2] + list(matplotlib.colormaps["Dark2"].colors[:7])
    base += list(matplotlib.colormaps["Set1"].colors[:8])
    return np.asarray([base[i % len(base)] for i in range(n)], dtype=np.float64)


def face_colors(vm: VehicleMesh) -> np.ndarray:
    """[F, 3] RGB (0..1) per face: its part's palette colour, or its finish's colour for unlabelled faces."""
    palette = part_palette(len(vm.part_names))
    finish = np.asarray([FINISH_RGB[f] for f in FINISHES])
    out = finish[vm.face_finish]
    labelled = vm.face_parts >= 0
    out[labelled] = palette[vm.face_parts[labelled]]
    return out


def export_glb(vm: VehicleMesh, path: str | Path) -> Path:
    """Write ``vm`` as binary glTF with per-face colours, rotated to glTF's +y-up convention."""
    path = Path(path)
    mesh = vm.mesh.copy()
    rgba = np.concatenate([face_colors(vm), np.ones((len(mesh.faces), 1))], axis=1)
    mesh.visual.face_colors = (rgba * 255).round().astype(np.uint8)
    mesh.apply_transform(CANONICAL_TO_GLTF)
    mesh.export(path, file_type="glb")
    return path

"""Preview renders of the part-labelled vehicle meshes: a contact sheet of all subtypes and per-subtype legends.

Images are ray cast with :class:`~po3d_ppl.world.raycast.RayCaster` (the same core the scene renderer uses), parts
drawn in distinct colours over a grey body with Lambert shading, and composed/annotated with OpenCV.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from po3d_ppl import ontology
from po3d_ppl.world.meshes import VehicleMesh, all_vehicle_meshes, vehicle_mesh
from po3d_ppl.world.meshes.export import face_colors, part_palette
from po3d_ppl.world.raycast import RayCaster, camera_rays, look_at_camera
from po3d_ppl.world.scene import Camera

BACKGROUND_RGB = (1.0, 1.0, 1.0)
#: (azimuth, elevation) in degrees of the contact-sheet views; azimuth 0 looks at the vehicle's front.
SHEET_VIEWS: tuple[tuple[float, float], ...] = ((40.0, 25.0), (220.0, 25.0))
LEGEND_VIEWS: tuple[tuple[float, float], ...] = ((40.0, 25.0), (140.0, 25.0), (220.0, 25.0), (320.0, 25.0))


def view_camera(extents: np.ndarray, azimuth: float, elevation: float, width: int, height: int,
                fill: float = 0.86) -> Camera:
    """A camera looking at a mesh of the given extents (centred at x = y = 0, resting on z = 0) from ``azimuth``
    (degrees, counter-clockwise from the +x axis seen from above) and ``elevation``, placed so that the bounding
    box spans ``fill`` of the image in its tighter direction."""
    import trimesh

    ext = np.asarray(extents, dtype=np.float64)
    centre = np.array([0.0, 0.0, ext[2] / 2])
    corners = trimesh.bounds.corners(np.array([centre - ext / 2, centre + ext / 2]))
    f = width * 35.0 / 32.0
    a, e = np.radians(azimuth), np.radians(elevation)
    direction = np.array([np.cos(a) * np.cos(e), np.sin(a) * np.cos(e), np.sin(e)])

    def spread(dist: float) -> float:
        cam = look_at_camera(centre + dist * direction, centre, width=width, height=height, focal_px=f)
        px = cam.project(corners)
        return max(2 * np.abs(px[:, 0] - width / 2).max() / width, 2 * np.abs(px[:, 1] - height / 2).max() / height)

    lo, hi = 0.1 * float(np.linalg.norm(ext)), 100.0 * float(np.linalg.norm(ext))
    for _ in range(40):  # spread() decreases with distance
        mid = np.sqrt(lo * hi)
        lo, hi = (mid, hi) if spread(mid) > fill else (lo, mid)
    return look_at_camera(centre + hi * direction, centre, width=width, height=height, focal_px=f)


def shade(vm: VehicleMesh, camera: Camera, caster: RayCaster | None = None) -> np.ndarray:
    """Render ``vm`` (canonical frame) as an RGB float image: part colours, grey body, Lambert shading."""
    caster = caster or RayCaster([vm.mesh])
    origins, dirs = camera_rays(camera)
    hits = caster.cast(origins, dirs)
    img = np.tile(np.asarray(BACKGROUND_RGB), (len(hits), 1))
    hit = hits.hit
    base = face_colors(vm)[hits.face[hit]]
    normal = hits.normal[hit].astype(np.float64)
    view = -dirs[hit].astype(np.float64)
    normal *= np.sign(np.sum(normal * view, axis=1, keepdims=True) + 1e-12)  # two-sided
    key = np.array([0.3, 0.5, 0.8]) / np.linalg.norm([0.3, 0.5, 0.8])
    lambert = 0.35 + 0.45 * np.clip(normal @ key, 0, 1) + 0.25 * np.clip(np.sum(normal * view, axis=1), 0, 1)
    img[hit] = np.clip(base * lambert[:, None], 0, 1)
    return img.reshape(camera.height, camera.width, 3)


def _to_bgr8(img: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray((np.clip(img, 0, 1) * 255).round().astype(np.uint8)[..., ::-1])


def _label(tile: np.ndarray, text: str, org: tuple[int, int], scale: float = 0.6,
           color: tuple[int, int, int] = (20, 20, 20)) -> None:
    import cv2

    cv2.putText(tile, text, org, cv2.FONT_HERSHEY_SIMPLEX, scale, color, 1, cv2.LINE_AA)


def render_views(vm: VehicleMesh, views: Sequence[tuple[float, float]], width: int, height: int) -> list[np.ndarray]:
    caster = RayCaster([vm.mesh])
    return [shade(vm, view_camera(vm.extents, a, e, width, height), caster=caster) for a, e in views]


def contact_sheet(meshes: dict[str, VehicleMesh] | None = None, *, tile: tuple[int, int] = (320, 240),
                  views: Sequence[tuple[float, float]] = SHEET_VIEWS, per_row: int = 3) -> np.ndarray:
    """All subtypes side by side (``views`` each), labelled with the subtype name. Returns a BGR uint8 image."""
    meshes = meshes if meshes is not None else all_vehicle_meshes()
    w, h = tile
    cells = []
    for subtype, vm in meshes.items():
        imgs = [_to_bgr8(im) for im in render_views(vm, views, w, h)]
        cell = np.concatenate(imgs, axis=1)
        _label(cell, f"{ontology.SUBTYPE_WORDS[subtype]} ({len(vm.mesh.faces)} tris)", (8, 22))
        cells.append(cell)
    blank = np.full_like(cells[0], 255)
    while len(cells) % per_row:
        cells.append(blank)
    rows = [np.concatenate(cells[i : i + per_row], axis=1) for i in range(0, len(cells), per_row)]
    sheet = np.concatenate(rows, axis=0)
    # thin separators between cells
    ch, cw = cells[0].shape[:2]
    sheet[::ch, :] = 200
    sheet[:, ::cw] = 200
    return sheet


def part_legend(subtype: str, *, tile: tuple[int, int] = (400, 300),
                views: Sequence[tuple[float, float]] = LEGEND_VIEWS) -> np.ndarray:
    """One subtype from several sides with a colour key of its parts. Returns a BGR uint8 image."""
    import cv2

    vm = vehicle_mesh(subtype)
    w, h = tile
    palette = part_palette(len(vm.part_names))
    imgs = [_to_bgr8(im) for im in render_views(vm, views, w, h)]
    grid = np.concatenate([np.concatenate(imgs[i : i + 2], axis=1) for i in range(0, len(imgs), 2)], axis=0)
    key_w = 230
    key = np.full((grid.shape[0], key_w, 3), 255, dtype=np.uint8)
    for pid, name in enumerate(vm.part_names):
        y = 22 + pid * 22
        bgr = tuple(int(c) for c in (palette[pid][::-1] * 255).round())
        cv2.rectangle(key, (8, y - 12), (24, y + 2), bgr, -1)
        _label(key, f"{pid} {name}", (30, y), 0.45)
    out = np.concatenate([grid, key], axis=1)
    _label(out, ontology.SUBTYPE_WORDS[subtype], (8, 22))
    return out


def write_png(path: str | Path, image_bgr: np.ndarray) -> Path:
    import cv2

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(path), image_bgr):
        from po3d_ppl.errors import ImageError

        raise ImageError(f"could not write {path} (is the directory writable and the disk not full?)")
    return path

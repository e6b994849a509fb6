"""Reading and writing scenes in the public Super-CLEVR-3D JSON layout (spec §1).

``scene_to_public`` writes every public field, so tools made for the real dataset (its question generator
included) read our files. What the public layout cannot hold - every occluder with its overlap, pixel counts,
the raw occlusion level of objects (the public file turns -1 into 0), occlusion masks of dropped entries, the
camera intrinsics and image size - goes under an extra ``"po3d"`` key that public tools ignore.
``scene_from_public`` reads our files losslessly and public files as far as they go:

- ``rotation`` in files is Blender's yaw of the *public* models, whose front is +y for cars, buses, motorbikes and
  aeroplanes and +x for bicycles (this is what the public pose formula ``(-rotation + 50) % 360`` vs
  ``(-rotation + 140) % 360`` encodes, given the camera's azimuth of about 136.7 degrees). Our meshes all face +x,
  so ``SceneObject.rotation = file rotation + FRONT_OFFSET[category]`` on import, and the reverse on export;
- ``pose_degree`` missing (older Super-CLEVR scenes): derived by the public formula; the ``pose`` label is always
  derived from ``pose_degree`` (``ontology.pose_label``), never trusted from the file;
- no camera fields: ``Scene.camera`` is None; ``directions`` are then required. Missing ``relationships`` are
  recomputed from ``3d_coords`` and ``directions``;
- no ``occlusion`` field: objects get no annotation (``Scene.has_occlusion`` is False), even if masks exist;
- public occlusion: ``occluded_by`` is the single largest occluder the file names (any overlap > 0, not our
  ``MIN_OCCLUDER_PIXELS`` rule) and ``overlaps`` is empty; parts without an entry get level 0 and
  ``unoccluded_pixels = visible_pixels``, which is wrong for the parts the public pipeline dropped because their
  object had no occluder - the file does not say which those are;
- ``3d_coords`` of public scenes are the model origins (z = -scale * info_z), not box centres.

Output is deterministic: fixed key order, floats already rounded in the scene (``scene.DECIMALS``), derived
matrices rounded to ``scene.MATRIX_DECIMALS``.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from po3d_ppl import ontology
from po3d_ppl.errors import InputError, SceneFormatError
from po3d_ppl.world import rle
from po3d_ppl.world.sampler import clevr_intrinsics
from po3d_ppl.world.scene import (
    DECIMALS,
    MATRIX_DECIMALS,
    MIN_VISIBLE_BEFORE_PIXELS,
    Camera,
    EntityAnnotation,
    Occlusion,
    PartStyle,
    Scene,
    SceneObject,
    compute_relationships,
)

#: Added to a file's ``rotation`` to get our yaw (our meshes face +x; the public models face +y except bicycles).
FRONT_OFFSET: Mapping[str, float] = {"car": 90.0, "bus": 90.0, "motorbike": 90.0, "aeroplane": 90.0, "bicycle": 0.0}
#: The public pose formula's constant per category (spec §1.7).
PUBLIC_POSE_CONSTANT: Mapping[str, float] = {c: (140.0 if c == "bicycle" else 50.0) for c in ontology.CATEGORIES}
#: Blender's default clipping range, used for ``projection_matrix``.
CLIP_START, CLIP_END = 0.1, 100.0
DIRECTION_NAMES = ("behind", "front", "left", "right", "above", "below")
RELATION_NAMES = ("behind", "front", "left", "right")
FORMAT_VERSION = 1


def _round(x: float, d: int = DECIMALS) -> float:
    return round(float(x), d) + 0.0


def public_rotation(subtype: str, rotation: float) -> float:
    return _round((rotation - FRONT_OFFSET[ontology.CATEGORY_OF[subtype]]) % 360.0) % 360.0


def our_rotation(subtype: str, rotation: float) -> float:
    return _round((rotation + FRONT_OFFSET[ontology.CATEGORY_OF[subtype]]) % 360.0) % 360.0


def public_pose_degree(subtype: str, file_rotation: float) -> float:
    """``pose_degree`` by the public formula (spec §1.7), from a file's rotation."""
    return _round((-file_rotation + PUBLIC_POSE_CONSTANT[ontology.CATEGORY_OF[subtype]]) % 360.0) % 360.0


def projection_matrix(camera: Camera) -> list[list[float]]:
    """Blender's ``calc_matrix_camera`` (OpenGL projection) for the camera's intrinsics and image size."""
    K, W, H = camera.K, camera.width, camera.height
    n, f = CLIP_START, CLIP_END
    P = np.zeros((4, 4))
    P[0, 0], P[0, 2] = 2 * K[0, 0] / W, 1 - 2 * K[0, 2] / W
    P[1, 1], P[1, 2] = 2 * K[1, 1] / H, 2 * K[1, 2] / H - 1
    P[2, 2], P[2, 3] = -(f + n) / (f - n), -2 * f * n / (f - n)
    P[3, 2] = -1.0
    return [[_round(v, MATRIX_DECIMALS) for v in row] for row in P]


def intrinsics_from_projection(P: np.ndarray, width: int, height: int) -> tuple[tuple[float, ...], ...]:
    fx, fy = P[0, 0] * width / 2, P[1, 1] * height / 2
    cx, cy = width / 2 * (1 - P[0, 2]), height / 2 * (1 + P[1, 2])
    return ((_round(fx), 0.0, _round(cx)), (0.0, _round(fy), _round(cy)), (0.0, 0.0, 1.0))


# --------------------------------------------------------------------------------------------------- export


def _entity_extra(ann: EntityAnnotation, with_mask: bool) -> dict[str, Any]:
    occ = ann.occlusion
    out: dict[str, Any] = {
        "visible_pixels": ann.visible_pixels,
        "unoccluded_pixels": ann.unoccluded_pixels,
        "level": occ.level,
        "visible_before": occ.visible_before,
        "occluded": occ.occluded,
        "occluded_by": list(occ.occluded_by),
        "overlaps": {str(j): px for j, px in sorted(occ.overlaps.items())},
    }
    if with_mask:
        out["occlusion_mask"] = ann.occlusion_mask
    return out


def _largest_occluder(occ: Occlusion) -> int | None:
    """The public ``find_occluded_by``: the object with the largest overlap (> 0), lowest index on ties."""
    if occ.overlaps:
        return max(sorted(occ.overlaps), key=lambda j: occ.overlaps[j])
    return occ.occluded_by[0] if occ.occluded_by else None


def _public_occlusion(obj: SceneObject) -> dict[str, list]:
    """The public ``occlusion[i]`` entry with its keep/drop rules (spec §1.6)."""
    entries: dict[str, list] = {}
    names = ["obj"] + [n for n in ontology.PARTS[obj.subtype] if n in obj.part_annotations]
    for name in names:
        ann = obj.annotation if name == "obj" else obj.part_annotations[name]
        occ = ann.occlusion
        level = occ.level
        if name == "obj" and level == -1:
            level = 0
        if name != "obj" and not (level > 0 and occ.visible_before):
            continue
        entry = [level, ann.occlusion_mask, str(bool(occ.visible_before))]
        if level > 0:
            occluder = _largest_occluder(occ)
            if occluder is None:
                if name == "obj":  # the object stays (length 3) and all its part entries are dropped
                    entries = {"obj": entry}
                    break
                continue
            entry.append(str(occluder))
        entries[name] = entry
    return entries


def _pixel_coords(obj: SceneObject, camera: Camera | None) -> list | None:
    if obj.pixel_coords is None:
        return None
    px, py, depth = obj.pixel_coords
    as_int = [int(v) if float(v).is_integer() else float(v) for v in (px, py)]
    size = [camera.width, camera.height] if camera else [640, 480]
    return [[as_int[0], as_int[1], float(depth)], size]


def scene_to_public(scene: Scene) -> dict[str, Any]:
    """The public Super-CLEVR-3D scene dict (plus the ``"po3d"`` extras)."""
    cam = scene.camera
    objects = []
    for obj in scene.objects:
        o: dict[str, Any] = {
            "shape": obj.subtype,
            "size": obj.size,
            "3d_coords": [float(v) for v in obj.position],
            "rotation": public_rotation(obj.subtype, obj.rotation),
        }
        pc = _pixel_coords(obj, cam)
        if pc is not None:
            o["pixel_coords"] = pc
        o.update({"color": obj.color, "material": obj.material, "texture": None})
        o["parts"] = {name: {"color": st.color, "material": st.material, "size": obj.size, "texture": None}
                      for name, st in obj.parts.items()}
        o["pose"] = obj.pose
        o["pose_degree"] = float(obj.pose_degree)
        objects.append(o)
    out: dict[str, Any] = {
        "split": scene.split,
        "image_index": scene.image_index,
        "image_filename": scene.image_filename,
        "objects": objects,
        "directions": {k: [float(v) for v in scene.directions[k]] for k in DIRECTION_NAMES if k in scene.directions},
        "relationships": {k: [list(js) for js in scene.relationships[k]] for k in RELATION_NAMES
                          if k in scene.relationships},
    }
    extra: dict[str, Any] = {"format": FORMAT_VERSION}
    if cam is not None:
        M = cam.matrix_world
        out["matrix_world"] = [list(row) for row in cam.camera_to_world]
        out["matrix_world_inverted"] = [[_round(v, MATRIX_DECIMALS) for v in row] for row in np.linalg.inv(M)]
        out["projection_matrix"] = projection_matrix(cam)
        out["camera_location"] = [float(cam.camera_to_world[i][3]) for i in range(3)]
        extra["camera"] = {"width": cam.width, "height": cam.height,
                           "intrinsics": [list(row) for row in cam.intrinsics]}
    if scene.objects and scene.has_occlusion:
        masks, occlusion, annotations = {}, {}, []
        counts: dict[str, int] = {}
        for i, obj in enumerate(scene.objects):
            k = counts.get(obj.subtype, 0)
            counts[obj.subtype] = k + 1
            entry: dict[str, Any] = {"info": f"{obj.subtype}_{k}", "obj": [list(obj.annotation.bbox),
                                                                           obj.annotation.visible_mask]}
            for name in ontology.PARTS[obj.subtype]:
                if name in obj.part_annotations:
                    ann = obj.part_annotations[name]
                    entry[name] = [list(ann.bbox), ann.visible_mask]
            masks[str(i)] = entry
            occlusion[str(i)] = _public_occlusion(obj)
            kept = occlusion[str(i)]
            record = {"obj": _entity_extra(obj.annotation, "obj" not in kept)}
            for name, ann in obj.part_annotations.items():
                record[name] = _entity_extra(ann, name not in kept)
            annotations.append(record)
        out["obj_mask_box"] = masks
        out["occlusion"] = occlusion
        extra["annotations"] = annotations
    out["po3d"] = extra
    return out


def dumps(data: Any) -> str:
    """Deterministic JSON text (insertion key order, repr floats), newline-terminated."""
    return json.dumps(data, allow_nan=False) + "\n"


def save_scene(scene: Scene, path: str | os.PathLike) -> None:
    """Write one scene as a public scene file."""
    with open(path, "w", encoding="utf-8") as f:
        f.write(dumps(scene_to_public(scene)))


def save_scenes(scenes: Sequence[Scene], path: str | os.PathLike, info: Mapping[str, Any] | None = None) -> None:
    """Write scenes in the public ``{"info", "scenes"}`` wrapper (what the public question generator reads)."""
    header = {"date": "", "version": "1.0", "split": scenes[0].split if scenes else "new",
              "license": "Creative Commons Attribution (CC-BY 4.0)"}
    header.update(info or {})
    with open(path, "w", encoding="utf-8") as f:
        f.write(dumps({"info": header, "scenes": [scene_to_public(s) for s in scenes]}))


# --------------------------------------------------------------------------------------------------- import


class _Reader:
    """Field access with errors that name the file and the field path."""

    def __init__(self, source: str):
        self.source = source

    def fail(self, path: str, msg: str) -> SceneFormatError:
        return SceneFormatError(f"{self.source}: {path}: {msg}")

    def get(self, d: Mapping, key: str, path: str, default: Any = ...) -> Any:
        if not isinstance(d, Mapping):
            raise self.fail(path, f"expected an object, got {type(d).__name__}")
        if key not in d:
            if default is ...:
                raise self.fail(f"{path}.{key}" if path else key, "missing field")
            return default
        return d[key]

    def number(self, v: Any, path: str) -> float:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise self.fail(path, f"expected a finite number, got {v!r:.60}")
        return float(v)

    def integer(self, v: Any, path: str) -> int:
        if isinstance(v, bool) or not isinstance(v, int):
            raise self.fail(path, f"expected an integer, got {v!r:.60}")
        return v

    def vector(self, v: Any, n: int, path: str) -> tuple[float, ...]:
        if not isinstance(v, (list, tuple)) or len(v) != n:
            raise self.fail(path, f"expected a list of {n} numbers, got {v!r:.60}")
        return tuple(self.number(x, f"{path}[{k}]") for k, x in enumerate(v))

    def matrix(self, v: Any, rows: int, cols: int, path: str) -> tuple[tuple[float, ...], ...]:
        if not isinstance(v, (list, tuple)) or len(v) != rows:
            raise self.fail(path, f"expected a {rows}x{cols} matrix (list of {rows} rows)")
        return tuple(self.vector(r, cols, f"{path}[{k}]") for k, r in enumerate(v))

    def name(self, v: Any, known: Sequence[str], kind: str, path: str) -> str:
        if v not in known:
            shown = ", ".join(known[:25]) + (", ..." if len(known) > 25 else "")
            raise self.fail(path, f"{v!r:.60} is not {kind} (known: {shown})")
        return v

    def mask(self, v: Any, total: int, path: str) -> str:
        try:
            runs = rle.runs_of(v)
        except InputError as exc:
            raise self.fail(path, str(exc).removeprefix("rle: ")) from None
        if int(runs.sum()) != total:
            raise self.fail(path, f"mask runs cover {int(runs.sum())} pixels, expected {total}")
        return v

    def box(self, v: Any, path: str) -> tuple[int, int, int, int]:
        if not isinstance(v, (list, tuple)) or len(v) != 4:
            raise self.fail(path, f"expected [x, y, w, h], got {v!r:.60}")
        return tuple(int(self.number(x, f"{path}[{k}]")) for k, x in enumerate(v))


def _read_object(r: _Reader, o: Any, path: str) -> tuple[SceneObject, float]:
    """The object without annotations, and its rotation as written in the file."""
    subtype = r.name(r.get(o, "shape", path), ontology.SUBTYPES, "a rendered subtype", f"{path}.shape")
    color = r.name(r.get(o, "color", path), ontology.COLORS, "a colour", f"{path}.color")
    material = r.name(r.get(o, "material", path), ontology.MATERIALS, "a material", f"{path}.material")
    size = r.name(r.get(o, "size", path), ontology.SIZES, "a size", f"{path}.size")
    file_rotation = r.number(r.get(o, "rotation", path), f"{path}.rotation")
    position = r.vector(r.get(o, "3d_coords", path), 3, f"{path}.3d_coords")
    degree = r.get(o, "pose_degree", path, None)
    if degree is None:
        pose_degree = public_pose_degree(subtype, file_rotation)
    else:
        pose_degree = r.number(degree, f"{path}.pose_degree") % 360.0
    parts_in = r.get(o, "parts", path, {}) or {}
    if not isinstance(parts_in, Mapping):
        raise r.fail(f"{path}.parts", "expected an object mapping part names to styles")
    parts = {}
    for name, st in parts_in.items():
        p = f"{path}.parts.{name}"
        r.name(name, ontology.PARTS[subtype], f"a part of {subtype}", p)
        parts[name] = PartStyle(r.name(r.get(st, "color", p), ontology.COLORS, "a colour", f"{p}.color"),
                                r.name(r.get(st, "material", p), ontology.MATERIALS, "a material", f"{p}.material"))
    pixel = r.get(o, "pixel_coords", path, None)
    pixel_coords = None
    if pixel is not None:
        p = f"{path}.pixel_coords"
        if isinstance(pixel, (list, tuple)) and len(pixel) == 2 and isinstance(pixel[0], (list, tuple)):
            pixel = pixel[0]  # S3D: [[px, py, depth], [W, H]]; CLEVR: [px, py, depth]
        pixel_coords = r.vector(pixel, 3, p)
    return SceneObject(subtype, color, material, size, our_rotation(subtype, file_rotation), position,
                       pose_degree, parts, pixel_coords), file_rotation


def _read_camera(r: _Reader, d: Mapping, extra: Mapping, image_size: tuple[int, int] | None) -> Camera | None:
    if "matrix_world" not in d:
        return None
    matrix = r.matrix(d["matrix_world"], 4, 4, "matrix_world")
    cam_extra = r.get(extra, "camera", "po3d", None)
    if cam_extra is not None:
        width = r.integer(r.get(cam_extra, "width", "po3d.camera"), "po3d.camera.width")
        height = r.integer(r.get(cam_extra, "height", "po3d.camera"), "po3d.camera.height")
        K = r.matrix(r.get(cam_extra, "intrinsics", "po3d.camera"), 3, 3, "po3d.camera.intrinsics")
        return Camera(width, height, K, matrix)
    width, height = image_size or (640, 480)
    if "projection_matrix" in d:
        P = np.asarray(r.matrix(d["projection_matrix"], 4, 4, "projection_matrix"))
        K = intrinsics_from_projection(P, width, height)
    else:
        K = clevr_intrinsics(width, height)
    return Camera(width, height, K, matrix)


def _occlusion_from_extra(r: _Reader, e: Any, path: str) -> tuple[Occlusion, int, int]:
    level = r.integer(r.get(e, "level", path), f"{path}.level")
    overlaps_in = r.get(e, "overlaps", path, {})
    if not isinstance(overlaps_in, Mapping):
        raise r.fail(f"{path}.overlaps", "expected an object mapping object index -> pixels")
    overlaps = {int(j): r.integer(px, f"{path}.overlaps.{j}") for j, px in overlaps_in.items()}
    by = tuple(r.integer(j, f"{path}.occluded_by") for j in r.get(e, "occluded_by", path, []))
    occ = Occlusion(level, bool(r.get(e, "visible_before", path)), by, overlaps,
                    bool(r.get(e, "occluded", path, bool(by))))
    return (occ, r.integer(r.get(e, "visible_pixels", path), f"{path}.visible_pixels"),
            r.integer(r.get(e, "unoccluded_pixels", path), f"{path}.unoccluded_pixels"))


def _read_annotation(r: _Reader, name: str, box_entry: Any, occ_entry: Any, extra: Any, total: int,
                     path: str) -> EntityAnnotation:
    p = f"obj_mask_box.{path}.{name}"
    if not isinstance(box_entry, (list, tuple)) or len(box_entry) != 2:
        raise r.fail(p, "expected [[x, y, w, h], mask]")
    bbox = r.box(box_entry[0], f"{p}[0]")
    visible_mask = r.mask(box_entry[1], total, f"{p}[1]") if box_entry[1] is not None else None
    visible = rle.count(visible_mask) if visible_mask is not None else 0
    occ_mask = None
    if occ_entry is not None:
        q = f"occlusion.{path}.{name}"
        if not isinstance(occ_entry, (list, tuple)) or len(occ_entry) not in (3, 4):
            raise r.fail(q, "expected [level, mask, visible_before, (occluder)]")
        occ_mask = r.mask(occ_entry[1], total, f"{q}[1]") if occ_entry[1] is not None else None
    if extra is not None:
        q = f"po3d.annotations.{path}.{name}"
        occ, visible, unoccluded = _occlusion_from_extra(r, extra, q)
        if occ_entry is None:
            mask = r.get(extra, "occlusion_mask", q, None)
            occ_mask = r.mask(mask, total, f"{q}.occlusion_mask") if mask is not None else None
        return EntityAnnotation(visible, unoccluded, bbox, occ, visible_mask, occ_mask)
    if occ_entry is None:  # the public file dropped it: level 0 is all that can be assumed
        occ = Occlusion(0, visible >= MIN_VISIBLE_BEFORE_PIXELS)
        return EntityAnnotation(visible, visible, bbox, occ, visible_mask, None)
    level = r.integer(occ_entry[0], f"occlusion.{path}.{name}[0]")
    visible_before = occ_entry[2] in ("True", True)
    by: tuple[int, ...] = ()
    if len(occ_entry) == 4 and level > 0:
        occluder = occ_entry[3]
        if not (isinstance(occluder, int) or (isinstance(occluder, str) and occluder.isdigit())):
            raise r.fail(f"occlusion.{path}.{name}[3]", f"expected an object index, got {occluder!r:.40}")
        by = (int(occluder),)
    hidden = rle.count(occ_mask) if occ_mask is not None else 0
    return EntityAnnotation(visible, visible + hidden, bbox, Occlusion(level, visible_before, by), visible_mask,
                            occ_mask)


def scene_from_public(data: Mapping[str, Any], source: str = "<scene>") -> Scene:
    """Read a public (or po3d) scene dict. Errors name ``source`` and the offending field."""
    r = _Reader(source)
    if not isinstance(data, Mapping):
        raise r.fail("scene", f"expected an object, got {type(data).__name__}")
    objs_in = r.get(data, "objects", "")
    if not isinstance(objs_in, list):
        raise r.fail("objects", "expected a list")
    extra = r.get(data, "po3d", "", {}) or {}
    read = [_read_object(r, o, f"objects[{i}]") for i, o in enumerate(objs_in)]
    objects = [o for o, _ in read]
    image_size = None
    for o in objs_in:
        pc = o.get("pixel_coords") if isinstance(o, Mapping) else None
        if isinstance(pc, list) and len(pc) == 2 and isinstance(pc[1], list) and len(pc[1]) == 2:
            image_size = (r.integer(pc[1][0], "pixel_coords[1][0]"), r.integer(pc[1][1], "pixel_coords[1][1]"))
            break
    camera = _read_camera(r, data, extra, image_size)
    if "directions" in data:
        dirs_in = data["directions"]
        directions = {k: r.vector(r.get(dirs_in, k, "directions"), 3, f"directions.{k}") for k in DIRECTION_NAMES
                      if k in dirs_in}
        for k in RELATION_NAMES:
            r.get(dirs_in, k, "directions")
    elif camera is not None:
        directions = {k: tuple(_round(v) for v in vec) for k, vec in camera.ground_directions().items()}
    else:
        raise r.fail("directions", "missing field (needed when the scene has no camera matrix_world)")
    if "relationships" in data:
        rel_in = data["relationships"]
        relationships = {}
        for k in RELATION_NAMES:
            lists = r.get(rel_in, k, "relationships")
            if not isinstance(lists, list) or len(lists) != len(objects):
                raise r.fail(f"relationships.{k}", f"expected one list per object ({len(objects)})")
            relationships[k] = tuple(tuple(r.integer(j, f"relationships.{k}[{i}]") for j in js)
                                     for i, js in enumerate(lists))
    else:
        relationships = compute_relationships(np.array([o.position for o in objects]).reshape(-1, 3), directions)

    if "occlusion" in data and "obj_mask_box" in data:
        W, H = (camera.width, camera.height) if camera else (image_size or (640, 480))
        total = W * H
        masks, occlusion = data["obj_mask_box"], data["occlusion"]
        ann_extra = r.get(extra, "annotations", "po3d", None)
        if ann_extra is not None and (not isinstance(ann_extra, list) or len(ann_extra) != len(objects)):
            raise r.fail("po3d.annotations", f"expected one entry per object ({len(objects)})")
        for i, obj in enumerate(objects):
            key = str(i)
            box = r.get(masks, key, "obj_mask_box")
            occ = r.get(occlusion, key, "occlusion")
            ex = ann_extra[i] if ann_extra is not None else {}
            for value, where in ((box, f"obj_mask_box.{key}"), (occ, f"occlusion.{key}"),
                                 (ex, f"po3d.annotations[{i}]")):
                if not isinstance(value, Mapping):
                    raise r.fail(where, f"expected an object, got {type(value).__name__}")
            annotation = _read_annotation(r, "obj", r.get(box, "obj", f"obj_mask_box.{key}"),
                                          r.get(occ, "obj", f"occlusion.{key}"), ex.get("obj") if ex else None,
                                          total, key)
            part_annotations = {
                name: _read_annotation(r, name, box[name], occ.get(name), ex.get(name) if ex else None, total, key)
                for name in ontology.PARTS[obj.subtype] if name in box
            }
            objects[i] = SceneObject(obj.subtype, obj.color, obj.material, obj.size, obj.rotation, obj.position,
                                     obj.pose_degree, obj.parts, obj.pixel_coords, annotation, part_annotations)
    index = data.get("image_index", 0)
    if isinstance(index, str) and index.isdigit():
        index = int(index)
    return Scene(
        objects=tuple(objects),
        directions=directions,
        relationships=relationships,
        camera=camera,
        image_index=r.integer(index, "image_index"),
        image_filename=str(data.get("image_filename", "")),
        split=str(data.get("split", "new")),
    )


def _read_json(path: str | os.PathLike) -> Any:
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except FileNotFoundError:
        raise SceneFormatError(f"{path}: no such file") from None
    except json.JSONDecodeError as exc:
        raise SceneFormatError(f"{path}: not valid JSON ({exc.msg} at line {exc.lineno} column {exc.colno})") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneFormatError(f"{path}: cannot be read ({exc})") from None


def load_scenes(path: str | os.PathLike) -> list[Scene]:
    """Scenes from a ``{"info", "scenes"}`` file or a single-scene file."""
    data = _read_json(path)
    if isinstance(data, Mapping) and "scenes" in data:
        if not isinstance(data["scenes"], list):
            raise SceneFormatError(f"{path}: scenes: expected a list")
        return [scene_from_public(s, f"{path}: scenes[{i}]") for i, s in enumerate(data["scenes"])]
    if isinstance(data, Mapping):
        return [scene_from_public(data, str(path))]
    raise SceneFormatError(f"{path}: expected a scene or a {{info, scenes}} object, got a {type(data).__name__}")


def load_scene(path: str | os.PathLike) -> Scene:
    """One scene: a single-scene file, or a scene-list file holding exactly one scene."""
    scenes = load_scenes(path)
    if len(scenes) != 1:
        raise SceneFormatError(f"{path}: holds {len(scenes)} scenes; use load_scenes to read them all")
    return scenes[0]

"""Training, calibrating and measuring the attribute network (:mod:`po3d_ppl.perception.attributes`) on a dataset
built by ``po3d dataset build``.

**Supervision (training only).** Each object's crop is cut around its ground-truth visible mask (the RLE of the
scene file's ``obj_mask_box``), each part's around its own stored visible mask, with exactly the functions the
inference API uses (:func:`~po3d_ppl.perception.attributes.object_inputs`, ``part_inputs``). Labels: the object's
subtype, colour, material and size; a part is *recoloured* when the scene's ``parts`` field lists it, and then has
that colour and material. Parts with fewer than ``min_part_pixels`` visible pixels are left out (the world only
recolours parts it shows with >= 20 pixels, and a 3-pixel crop says nothing).

**Crop cache.** Decoding masks and cutting crops takes a few seconds per hundred images; the crops of each split
are stored once as safetensors under ``<data>/../attribute_crops/`` keyed by the sha256 of ``scenes.json``, the
crop geometry and ``min_part_pixels``, so retraining and evaluating read them back in a second.

**Training.** One step = one batch of objects and a proportional batch of parts (one pass over each per epoch),
cross entropy on every head (part colour and material on recoloured parts only), AdamW with a one-cycle schedule.
Augmentation: horizontal flips (attributes are mirror-invariant; the geometry's x terms are mirrored too) and
one-pixel dilation or erosion of the mask channels (the parser's masks will not be the ground truth's). The part
head's object reference is the ground truth's colour and material, smoothed. Image order and augmentation come
from one ``torch.Generator`` seeded by ``TrainConfig.seed``, initialisation from ``torch.manual_seed(seed)``: the
same seed, data and thread count give bit-identical weights.

**Calibration.** After training, one temperature per head is fitted on the validation split's crops, with the
part head's reference taken from the object head's own (calibrated) output, as at inference.

**Measured** (the shipped weights; ``docs/perception.md`` has the table per category and the command): trained on
the train and test splits of seeds 711 and 714 (4,635 objects) in 563 s on one thread, calibrated on 711's val
split; on all 120 images of seed 713 with ground-truth masks, subtype 0.861, colour 0.980, material 0.962, size
1.000, part style (plain / colour / material) 0.958.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F

from po3d_ppl import ontology
from po3d_ppl.errors import InputError
from po3d_ppl.model_store import sha256_file
from po3d_ppl.perception.attributes import (
    DENSE_MIRROR,
    OBJECT_HEADS,
    PART_HEADS,
    AttributeConfig,
    AttributeNet,
    AttributeReader,
    crop_values,
    mask_boxes,
    mirror_object_geometry,
    mirror_part_geometry,
    object_inputs,
    part_inputs,
)
from po3d_ppl.perception.calibration import top_label_ece

#: Parts smaller than this (visible pixels) are not trained on.
MIN_TRAIN_PART_PIXELS = 5
#: Parts are measured from this many visible pixels: the world's ``SceneConfig.min_part_pixels``, the smallest part
#: it may recolour.
MEASURE_PART_PIXELS = 20
CACHE_FORMAT = 2


# --- crops of a dataset ----------------------------------------------------------------------------------------------


@dataclass
class AttributeData:
    """Crops and labels of one split. Objects: ``object_crops`` uint8 [No, 4, s, s], ``object_geometry`` [No, 6],
    ``object_labels`` [No, 4] (subtype, colour, material, size ids), ``object_image`` [No], ``object_parts`` uint8
    [No, s/8, s/8] (the dense auxiliary target, ``attributes.DENSE_CLASSES``). Parts: ``part_crops``
    uint8 [Np, 5, s', s'], ``part_geometry`` [Np, 5], ``part_labels`` [Np, 3] (recoloured, colour, material; -1 for
    the colour and material of plain parts), ``part_owner`` [Np] (row in the objects), ``part_pixels`` [Np]."""

    object_crops: torch.Tensor
    object_geometry: torch.Tensor
    object_labels: torch.Tensor
    object_image: torch.Tensor
    object_parts: torch.Tensor
    part_crops: torch.Tensor
    part_geometry: torch.Tensor
    part_labels: torch.Tensor
    part_owner: torch.Tensor
    part_pixels: torch.Tensor

    @property
    def num_objects(self) -> int:
        return int(self.object_labels.shape[0])

    @property
    def num_parts(self) -> int:
        return int(self.part_labels.shape[0])

    def object_label(self, head: str) -> torch.Tensor:
        return self.object_labels[:, list(OBJECT_HEADS).index(head)]

    def part_label(self, head: str) -> torch.Tensor:
        return self.part_labels[:, list(PART_HEADS).index(head)]

    @classmethod
    def concat(cls, items: Sequence[AttributeData]) -> AttributeData:
        offsets = np.cumsum([0] + [d.num_objects for d in items])[:-1]
        out = {}
        for f in fields(cls):
            parts = [getattr(d, f.name) for d in items]
            if f.name == "part_owner":
                parts = [p + int(o) for p, o in zip(parts, offsets)]
            out[f.name] = torch.cat(parts)
        return cls(**out)


def _uint8(x: torch.Tensor) -> torch.Tensor:
    return (x.clamp(0, 1) * 255).round().to(torch.uint8)


def scene_masks(scene, height: int, width: int) -> tuple[torch.Tensor, list[tuple[int, str, torch.Tensor]]]:
    """Ground-truth visible masks of a scene's objects ``[N, H, W]`` and of its parts (object row, raw name, mask),
    decoded from the scene file's RLE."""
    from po3d_ppl.world import rle

    objects, parts = [], []
    for i, obj in enumerate(scene.objects):
        if obj.annotation is None or obj.annotation.visible_mask is None:
            raise InputError("scene", f"{scene.image_filename}: object {i} has no visible mask; attribute training "
                                      "needs scenes written by `po3d dataset build`")
        objects.append(torch.from_numpy(rle.decode(obj.annotation.visible_mask, height, width)))
        for raw in ontology.PARTS[obj.subtype]:
            ann = obj.part_annotations.get(raw)
            if ann is not None and ann.visible_mask is not None and ann.visible_pixels > 0:
                parts.append((i, raw, torch.from_numpy(rle.decode(ann.visible_mask, height, width))))
    stacked = torch.stack(objects) if objects else torch.zeros((0, height, width), dtype=torch.bool)
    return stacked, parts


@dataclass(frozen=True)
class ProjectionJitter:
    """How far the part masks of training crops are moved from the truth, as the parser's projection moves them:
    every object is re-rendered at a yaw off by N(0, ``yaw_deg``) (uniform over the circle with probability
    ``flip_rate``, the parser's gross pose errors) and a ground position off by N(0, ``position``) per axis, and
    its part masks are read off that rendering (visible pixels among the other jittered objects). The labels stay
    the truth's: a part the jittered mask points at but that the image hides is plain, as the world only recolours
    parts it shows. The defaults match the parser's part masks on seed 716 (IoU with the true visible part, 10th /
    25th / 50th / 75th / 90th percentile: parser 0.06 / 0.37 / 0.66 / 0.84 / 0.92, jitter 0.14 / 0.39 / 0.65 / 0.81 /
    0.90 on seed 711)."""

    yaw_deg: float = 3.0
    position: float = 0.02
    flip_rate: float = 0.05
    seed: int = 0


def jittered_part_masks(scene, jitter: ProjectionJitter, image: int) -> list[tuple[int, str, torch.Tensor]]:
    """(object row, raw part name, mask) of every part that shows in the scene re-rendered under ``jitter``
    (drawn from ``jitter.seed`` and the image index, so a crop cache is reproducible)."""
    from po3d_ppl.world import renderer
    from po3d_ppl.world.sampler import ObjectSpec

    rng = np.random.default_rng([jitter.seed, image])
    specs = []
    for obj in scene.objects:
        rotation = obj.rotation + rng.normal(0.0, jitter.yaw_deg)
        if rng.random() < jitter.flip_rate:
            rotation = rng.uniform(0.0, 360.0)
        # the scene stores the box centre; the renderer places the mesh's origin
        at_origin = renderer.place_meshes([ObjectSpec(obj.subtype, obj.color, obj.material, obj.size,
                                                      obj.rotation % 360.0, 0.0, 0.0, parts={})])[0]
        x, y = np.asarray(obj.position[:2]) - at_origin.box_centre[:2] + rng.normal(0.0, jitter.position, 2)
        specs.append(ObjectSpec(obj.subtype, obj.color, obj.material, obj.size, float(rotation % 360.0), float(x),
                                float(y), parts={}))
    gbuffer, _ = renderer.render_geometry(renderer.place_meshes(specs), scene.camera)
    seen = gbuffer.geometry.reshape(gbuffer.height, gbuffer.width)
    part_ids = torch.from_numpy(gbuffer.part_ids.reshape(gbuffer.height, gbuffer.width).astype(np.int64))
    out = []
    for i, obj in enumerate(scene.objects):
        own = torch.from_numpy(seen == i)
        for p, raw in enumerate(ontology.PARTS[obj.subtype]):
            mask = own & (part_ids == p)
            if bool(mask.any()):
                out.append((i, raw, mask))
    return out


def scene_data(pixels: torch.Tensor, scene, config: AttributeConfig, image: int = 0,
               min_part_pixels: int = MIN_TRAIN_PART_PIXELS, jitter: ProjectionJitter | None = None
               ) -> AttributeData:
    """Crops and labels of one image (``pixels`` float [3, H, W] in [0, 1]); with ``jitter``, part crops are cut
    around jittered projections (:class:`ProjectionJitter`) instead of the true visible masks."""
    h, w = pixels.shape[1:]
    masks, parts = scene_masks(scene, h, w)
    objs = object_inputs(pixels, masks, config)
    n = len(scene.objects)
    dense = masks.to(torch.uint8)  # 1 = the object's body, then its raw parts
    for i, raw, mask in parts:
        dense[i][mask] = 2 + ontology.RAW_PART_NAMES.index(raw)
    cells, inside = crop_values(dense, torch.arange(n), objs.windows, config.object_size // 8)
    dense_crops = torch.where(inside, cells, torch.zeros_like(cells))
    if jitter is not None:
        parts = jittered_part_masks(scene, jitter, image)
    parts = [p for p in parts if int(p[2].sum()) >= min_part_pixels]
    labels = torch.tensor([[ontology.SUBTYPES.index(o.subtype), ontology.COLORS.index(o.color),
                            ontology.MATERIALS.index(o.material), ontology.SIZES.index(o.size)]
                           for o in scene.objects], dtype=torch.long).reshape(n, len(OBJECT_HEADS))
    if parts:
        part_masks = torch.stack([p[2] for p in parts])
        owner = torch.tensor([p[0] for p in parts])
        boxes, counts = mask_boxes(part_masks)
        idx = torch.arange(len(parts))
        crops, geometry = part_inputs(pixels, part_masks, idx, torch.ones_like(idx, dtype=torch.bool), boxes, counts,
                                      objs, masks, owner, config)
        plabels = []
        for i, raw, _ in parts:
            style = scene.objects[i].parts.get(raw)
            plabels.append([1, ontology.COLORS.index(style.color), ontology.MATERIALS.index(style.material)]
                           if style else [0, -1, -1])
        plabels = torch.tensor(plabels, dtype=torch.long)
    else:
        s = config.part_size
        crops, geometry = torch.zeros((0, 5, s, s)), torch.zeros((0, 5))
        owner, counts, plabels = (torch.zeros(0, dtype=torch.long), torch.zeros(0, dtype=torch.long),
                                  torch.zeros((0, 3), dtype=torch.long))
    return AttributeData(_uint8(objs.crops), objs.geometry.float(), labels, torch.full((n,), image), dense_crops,
                         _uint8(crops), geometry.float(), plabels, owner, counts.long())


def _dataset_root(data: Path | str) -> Path:
    root = Path(data)
    for needed in ("scenes.json", "splits.json", "images"):
        if not (root / needed).exists():
            raise InputError("--data", f"{root} has no {needed}; build a dataset with "
                                       f"`po3d dataset build --out {root}`")
    return root


def split_indices(data: Path | str, splits: Sequence[str]) -> list[int]:
    root = _dataset_root(data)
    split_map = json.loads((root / "splits.json").read_text())
    unknown = [s for s in splits if s not in split_map]
    if unknown:
        raise InputError("splits", f"{unknown} not in {root / 'splits.json'} (it has {sorted(split_map)})")
    return sorted(i for s in splits for i in split_map[s])


def _cache_path(root: Path, split: str, config: AttributeConfig, min_part_pixels: int, cache: Path | None,
                jitter: ProjectionJitter | None = None) -> Path:
    scenes = sha256_file(root / "scenes.json")
    geometry = {k: v for k, v in config.to_dict().items() if not k.endswith("widths") and k != "hidden"}
    identity = [CACHE_FORMAT, scenes, geometry, min_part_pixels]
    if jitter is not None:  # the truth's crops keep their old key
        identity.append(asdict(jitter))
    key = hashlib.sha256(json.dumps(identity, sort_keys=True).encode()).hexdigest()[:16]
    directory = Path(cache) if cache is not None else root.resolve().parent / "attribute_crops"
    return directory / f"{root.resolve().name}-{split}-{key}.safetensors"


def load_split(data: Path | str, split: str, config: AttributeConfig | None = None, *,
               min_part_pixels: int = MIN_TRAIN_PART_PIXELS, cache: Path | str | None = None, use_cache: bool = True,
               progress: Callable[[int, int], None] | None = None, jitter: ProjectionJitter | None = None
               ) -> AttributeData:
    """The crops of one split of a dataset directory, from the cache or cut (and cached) now; part crops around
    jittered projections when ``jitter`` is given (:func:`scene_data`)."""
    from safetensors.torch import load_file, save_file

    from po3d_ppl.perception.image_input import load_image
    from po3d_ppl.world.scene_io import load_scenes

    config = config or AttributeConfig()
    root = _dataset_root(data)
    indices = split_indices(root, [split])
    path = _cache_path(root, split, config, min_part_pixels, Path(cache) if cache is not None else None, jitter)
    if use_cache and path.exists():
        tensors = load_file(str(path))
        if progress is not None:
            progress(len(indices), len(indices))
        return AttributeData(**{f.name: tensors[f.name] for f in fields(AttributeData)})
    scenes = load_scenes(root / "scenes.json")
    items = []
    for n, i in enumerate(indices):
        scene = scenes[i]
        image = load_image(root / "images" / scene.image_filename, size=_native_size(scene))
        items.append(scene_data(image.pixels, scene, config, i, min_part_pixels, jitter))
        if progress is not None:
            progress(n + 1, len(indices))
    out = AttributeData.concat(items) if items else scene_data(torch.zeros(3, 8, 8), _empty_scene(), config)
    if use_cache:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp")
        save_file({f.name: getattr(out, f.name).contiguous() for f in fields(AttributeData)}, str(tmp),
                  metadata={"data": str(root.resolve()), "split": split, "config": json.dumps(config.to_dict()),
                            "min_part_pixels": str(min_part_pixels),
                            "jitter": json.dumps(asdict(jitter) if jitter is not None else None)})
        tmp.replace(path)
    return out


def _native_size(scene) -> tuple[int, int]:
    """(width, height) the scene was rendered at (its masks' size): images are read at it, never resized."""
    from po3d_ppl.perception.image_input import WORKING_SIZE

    return (scene.camera.width, scene.camera.height) if scene.camera is not None else WORKING_SIZE


def _empty_scene():
    from po3d_ppl.world.scene import Scene

    return Scene(objects=(), directions={}, relationships={})


# --- training --------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class TrainConfig:
    """Training settings (all stored in the model's manifest entry)."""

    seed: int = 0
    epochs: int = 28
    #: Objects per step; each step also takes ceil(part_fraction * parts / steps) parts.
    batch_size: int = 32
    #: Fraction of the parts seen per epoch (a random subset each epoch: parts outnumber objects 12 to 1).
    part_fraction: float = 0.25
    lr: float = 3e-3
    weight_decay: float = 1e-4
    #: The ground-truth object look given to the part head is (1 - smoothing) one-hot + smoothing / K.
    reference_smoothing: float = 0.1
    flip: bool = True
    #: Probability of dilating (and, separately, of eroding) a crop's mask channels by one pixel.
    mask_jitter: float = 0.25
    #: Weight of the object network's dense part-segmentation loss (auxiliary shape supervision).
    dense_weight: float = 0.5
    #: Object windows are scaled by up to +-this fraction and shifted by up to +-this fraction of half their side.
    window_jitter: float = 0.08
    #: Part crops: the image and object-mask channels are moved against the part mask by up to +-this fraction of
    #: the crop side on each axis. A projected part mask is not where the part is: on seed 716 the projected part's
    #: centroid is off the true one by 0.11 (median) to 0.62 (90th percentile) of the part's sqrt-area, about 0.05
    #: to 0.25 of a crop side, and a network trained on exact masks read only 0.69 of the recoloured parts as
    #: recoloured through such masks (0.99 through exact ones).
    part_shift: float = 0.12
    max_steps: int | None = None
    net: AttributeConfig = field(default_factory=AttributeConfig)

    def __post_init__(self) -> None:
        for name in ("epochs", "batch_size"):
            if getattr(self, name) < 1:
                raise InputError(name, f"must be at least 1, got {getattr(self, name)}")
        if not 0 < self.part_fraction <= 1:
            raise InputError("part_fraction", f"must be in (0, 1], got {self.part_fraction}")
        if not 0 <= self.reference_smoothing < 1:
            raise InputError("reference_smoothing", f"must be in [0, 1), got {self.reference_smoothing}")

    def to_dict(self) -> dict:
        d = asdict(self)
        d["net"] = self.net.to_dict()
        return d


def augment_crops(crops: torch.Tensor, geometry: torch.Tensor, mirror: Callable[[torch.Tensor], torch.Tensor],
             config: TrainConfig, g: torch.Generator) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Random flips (geometry mirrored by ``mirror``) and one-pixel mask dilation/erosion, per sample; and which
    samples were flipped."""
    b = crops.shape[0]
    flip = torch.zeros(b, dtype=torch.bool)
    if config.flip:
        flip = torch.rand(b, generator=g) < 0.5
        crops = torch.where(flip[:, None, None, None], crops.flip(-1), crops)
        geometry = torch.where(flip[:, None], mirror(geometry), geometry)
    if config.mask_jitter > 0:
        u = torch.rand(b, generator=g)
        masks = crops[:, 3:]
        grown = F.max_pool2d(masks, 3, 1, 1)
        shrunk = -F.max_pool2d(-masks, 3, 1, 1)
        masks = torch.where((u < config.mask_jitter)[:, None, None, None], grown,
                            torch.where((u > 1 - config.mask_jitter)[:, None, None, None], shrunk, masks))
        crops = torch.cat([crops[:, :3], masks], 1)
    return crops, geometry, flip


def jitter_windows(crops: torch.Tensor, dense: torch.Tensor, config: TrainConfig, g: torch.Generator
            ) -> tuple[torch.Tensor, torch.Tensor]:
    """Random scale and shift of object crops (the parser's boxes will not sit where the ground truth's do), the
    dense target moved with them (nearest; cells pushed out of the crop become "not this object")."""
    b = crops.shape[0]
    if config.window_jitter <= 0 or b == 0:
        return crops, dense
    scale = 1 + (torch.rand(b, generator=g) * 2 - 1) * config.window_jitter
    shift = (torch.rand(b, 2, generator=g) * 2 - 1) * config.window_jitter
    theta = torch.zeros(b, 2, 3)
    theta[:, 0, 0] = theta[:, 1, 1] = scale
    theta[:, :, 2] = shift
    grid = F.affine_grid(theta, list(crops.shape), align_corners=False)
    rgb = F.grid_sample(crops[:, :3], grid, mode="bilinear", padding_mode="zeros", align_corners=False)
    masks = F.grid_sample(crops[:, 3:], grid, mode="nearest", padding_mode="zeros", align_corners=False)
    cells = F.affine_grid(theta, [b, 1, *dense.shape[1:]], align_corners=False)
    moved = F.grid_sample(dense[:, None].float(), cells, mode="nearest", padding_mode="zeros", align_corners=False)
    return torch.cat([rgb, masks], 1), moved[:, 0].round().long()


def shift_part_context(crops: torch.Tensor, config: TrainConfig, g: torch.Generator) -> torch.Tensor:
    """Part crops with their image and object mask moved by a random translation (``config.part_shift``), the part
    mask kept: the part is no longer exactly under its mask, as under a projected mask at inference."""
    b = crops.shape[0]
    if config.part_shift <= 0 or b == 0:
        return crops
    theta = torch.zeros(b, 2, 3)
    theta[:, 0, 0] = theta[:, 1, 1] = 1.0
    theta[:, :, 2] = (torch.rand(b, 2, generator=g) * 2 - 1) * 2 * config.part_shift  # [-1, 1] spans the side
    grid = F.affine_grid(theta, list(crops.shape), align_corners=False)
    rgb = F.grid_sample(crops[:, :3], grid, mode="bilinear", padding_mode="border", align_corners=False)
    owner = F.grid_sample(crops[:, 4:], grid, mode="nearest", padding_mode="zeros", align_corners=False)
    return torch.cat([rgb, crops[:, 3:4], owner], 1)


def ground_truth_reference(data: AttributeData, owner: torch.Tensor, smoothing: float) -> torch.Tensor:
    """Smoothed one-hot colour and material of each part's object ``[M, REFERENCE]``."""
    color = F.one_hot(data.object_label("color")[owner], len(ontology.COLORS)).float()
    material = F.one_hot(data.object_label("material")[owner], len(ontology.MATERIALS)).float()
    color = color * (1 - smoothing) + smoothing / len(ontology.COLORS)
    material = material * (1 - smoothing) + smoothing / len(ontology.MATERIALS)
    return torch.cat([color, material], 1)


def _losses(net: AttributeNet, data: AttributeData, objects: torch.Tensor, parts: torch.Tensor, config: TrainConfig,
            g: torch.Generator, device: torch.device) -> dict[str, torch.Tensor]:
    crops, geom, flip = augment_crops(data.object_crops[objects].float() / 255, data.object_geometry[objects],
                                 mirror_object_geometry, config, g)
    dense = data.object_parts[objects].long()
    dense = torch.where(flip[:, None, None], DENSE_MIRROR[dense.flip(-1)], dense)
    crops, dense = jitter_windows(crops, dense, config, g)
    out = net.object_logits(crops.to(device), geom.to(device))
    labels = data.object_labels[objects].to(device)
    losses = {f"object.{h}": F.cross_entropy(out[h], labels[:, i]) for i, h in enumerate(OBJECT_HEADS)}
    if config.dense_weight > 0 and "dense" in out:
        losses["object.dense"] = config.dense_weight * F.cross_entropy(out["dense"], dense.to(device))
    if parts.numel():
        crops, geom, _ = augment_crops(data.part_crops[parts].float() / 255, data.part_geometry[parts],
                                  mirror_part_geometry, config, g)
        crops = shift_part_context(crops, config, g)
        ref = ground_truth_reference(data, data.part_owner[parts], config.reference_smoothing)
        out = net.part_logits(crops.to(device), geom.to(device), ref.to(device))
        labels = data.part_labels[parts].to(device)
        for i, h in enumerate(PART_HEADS):
            keep = labels[:, i] >= 0
            losses[f"part.{h}"] = (F.cross_entropy(out[h][keep], labels[keep, i]) if keep.any()
                                   else out[h].sum() * 0)
    return losses


@dataclass
class TrainedAttributes:
    net: AttributeNet
    history: list[dict]
    seconds: float
    step_seconds: float
    steps: int


@dataclass
class OneCycleRun:
    """What :func:`train_one_cycle` did: the per-epoch mean losses, wall seconds and steps."""

    history: list[dict]
    seconds: float
    steps: int


def train_one_cycle(net: torch.nn.Module, config, steps_per_epoch: int,
                    epoch: Callable[[], Callable[[int], dict[str, torch.Tensor]]],
                    progress: Callable[[int, int, dict], None] | None = None) -> OneCycleRun:
    """AdamW with a one-cycle schedule over ``config.epochs`` epochs (at most ``config.max_steps`` steps), shared
    by the crop networks. ``epoch()`` starts an epoch (e.g. draws its sample order) and returns ``losses(k)``, the
    named losses of its k-th step; their sum is minimised. The history holds each epoch's mean of every loss."""
    total = steps_per_epoch * config.epochs
    if config.max_steps is not None:
        total = min(total, config.max_steps)
    opt = torch.optim.AdamW(net.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=config.lr, total_steps=total, pct_start=0.15)
    history: list[dict] = []
    start, step, running, count = time.perf_counter(), 0, {}, 0
    net.train()
    while step < total:
        losses_of = epoch()
        for k in range(steps_per_epoch):
            if step >= total:
                break
            losses = losses_of(k)
            loss = sum(losses.values())
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            sched.step()
            step += 1
            count += 1
            for name, v in {**losses, "loss": loss}.items():
                running[name] = running.get(name, 0.0) + float(v.detach())
            if step % steps_per_epoch == 0 or step == total:
                history.append({k: v / count for k, v in running.items()} |
                               {"step": step, "epoch": step / steps_per_epoch,
                                "seconds": round(time.perf_counter() - start, 1)})
                running, count = {}, 0
            if progress is not None:
                progress(step, total, {"epoch": step / steps_per_epoch,
                                       "loss": history[-1]["loss"] if history else float(loss.detach())})
    net.eval()
    return OneCycleRun(history, time.perf_counter() - start, step)


def train_attributes(data: AttributeData, config: TrainConfig = TrainConfig(), *, device: torch.device | str = "cpu",
                     progress: Callable[[int, int, dict], None] | None = None) -> TrainedAttributes:
    """Train an :class:`AttributeNet` from scratch on ``data`` (temperatures stay 1; see :func:`calibrate`)."""
    if data.num_objects == 0:
        raise InputError("data", "has no objects to train on")
    device = torch.device(device)
    torch.manual_seed(config.seed)
    net = AttributeNet(config.net).to(device)
    recoloured = data.part_label("recoloured")
    if recoloured.numel():
        rate = float(recoloured.float().mean())
        net.part_prior.copy_(torch.tensor([1 - rate, rate]))
    g = torch.Generator().manual_seed(config.seed)
    steps_per_epoch = math.ceil(data.num_objects / config.batch_size)
    part_batch = math.ceil(config.part_fraction * data.num_parts / steps_per_epoch) if data.num_parts else 0

    def epoch() -> Callable[[int], dict[str, torch.Tensor]]:
        obj_order = torch.randperm(data.num_objects, generator=g)
        part_order = torch.randperm(data.num_parts, generator=g)
        return lambda k: _losses(net, data, obj_order[k * config.batch_size:(k + 1) * config.batch_size],
                                 part_order[k * part_batch:(k + 1) * part_batch], config, g, device)

    run = train_one_cycle(net, config, steps_per_epoch, epoch, progress)
    return TrainedAttributes(net, run.history, run.seconds, run.seconds / max(run.steps, 1), run.steps)


# --- calibration and measurement on cached crops -------------------------------------------------------------------


@torch.no_grad()
def crop_logits(net: AttributeNet, data: AttributeData, chunk: int = 512
                ) -> tuple[dict[str, torch.Tensor], dict[str, torch.Tensor]]:
    """Uncalibrated logits of every object and part of ``data``; the part head's reference is the object head's
    calibrated output for the part's object (as at inference)."""
    net.eval()
    device = net.device
    obj: dict[str, list[torch.Tensor]] = {h: [] for h in OBJECT_HEADS}
    for i in range(0, data.num_objects, chunk):
        out = net.object_logits(data.object_crops[i:i + chunk].to(device).float() / 255,
                                data.object_geometry[i:i + chunk].to(device))
        for h in OBJECT_HEADS:
            obj[h].append(out[h].cpu())
    objects = {h: torch.cat(v) if v else torch.zeros(0, len(OBJECT_HEADS[h])) for h, v in obj.items()}
    reference = net.reference({h: v.to(device) for h, v in net.calibrate(
        {h: v.to(device) for h, v in objects.items()}, "object").items()}).cpu()
    part: dict[str, list[torch.Tensor]] = {h: [] for h in PART_HEADS}
    for i in range(0, data.num_parts, chunk):
        owner = data.part_owner[i:i + chunk]
        out = net.part_logits(data.part_crops[i:i + chunk].to(device).float() / 255,
                              data.part_geometry[i:i + chunk].to(device), reference[owner].to(device))
        for h in PART_HEADS:
            part[h].append(out[h].cpu())
    parts = {h: torch.cat(v) if v else torch.zeros(0, len(PART_HEADS[h])) for h, v in part.items()}
    return objects, parts


def calibrate(net: AttributeNet, val: AttributeData) -> dict[str, Any]:
    """Fit the temperatures on ``val`` and report each head's ECE and NLL before and after."""
    net.object_temperature.fill_(1.0)
    net.part_temperature.fill_(1.0)
    objects, parts = crop_logits(net, val)
    obj_labels = {h: val.object_label(h) for h in OBJECT_HEADS}
    part_labels = {h: val.part_label(h) for h in PART_HEADS}
    before = calibration_report(net, objects, obj_labels, parts, part_labels)
    temps = net.fit_temperatures(objects, obj_labels, parts, part_labels)
    objects, parts = crop_logits(net, val)  # the part reference now uses the calibrated object head
    after = calibration_report(net, objects, obj_labels, parts, part_labels)
    return {"temperatures": temps, "val_before": before, "val_after": after}


def calibration_report(net: AttributeNet, objects: Mapping[str, torch.Tensor], obj_labels: Mapping[str, torch.Tensor],
                       parts: Mapping[str, torch.Tensor], part_labels: Mapping[str, torch.Tensor],
                       calibrated: bool = True) -> dict[str, dict[str, float]]:
    """ECE and NLL per head of logits (with the net's current temperatures, or T = 1)."""
    out = {}
    for level, logits, labels in (("object", objects, obj_labels), ("part", parts, part_labels)):
        logp = net.calibrate({h: v.to(net.device) for h, v in logits.items()}, level, calibrated)
        for h, lp in logp.items():
            y = labels[h].to(lp.device)
            keep = y >= 0
            nll = float(F.nll_loss(lp[keep], y[keep])) if keep.any() else float("nan")
            out[f"{level}.{h}"] = {"ece": round(top_label_ece(lp, y), 4), "nll": round(nll, 4)}
    return out


# --- measurement through the public API ------------------------------------------------------------------------------


@dataclass
class _Tally:
    """Correct / total counts keyed by measure and group."""

    counts: dict[str, dict[str, list[int]]] = field(default_factory=dict)

    def add(self, measure: str, group: str, correct: torch.Tensor) -> None:
        slot = self.counts.setdefault(measure, {}).setdefault(group, [0, 0])
        slot[0] += int(correct.sum())
        slot[1] += int(correct.numel())

    def report(self) -> dict[str, dict[str, float | int]]:
        return {m: {g: round(c / t, 4) if t else float("nan") for g, (c, t) in groups.items()} |
                {f"n_{g}": t for g, (_, t) in groups.items() if g == "all"} for m, groups in self.counts.items()}


def evaluate_dataset(net: AttributeReader, data: Path | str, splits: Sequence[str] = ("train", "val", "test"),
                     limit: int | None = None, progress: Callable[[int, int], None] | None = None) -> dict[str, Any]:
    """Accuracy of every head on the images of ``splits`` (all of them by default) through the public API, with
    the ground-truth visible masks as the parser's masks: objects per category; parts over visible parts with
    >= ``MEASURE_PART_PIXELS`` pixels (and, separately, all visible parts), per category. ECE of every head with
    T = 1 and with the fitted temperatures."""
    from po3d_ppl.perception.image_input import load_image
    from po3d_ppl.world.scene_io import load_scenes

    root = _dataset_root(data)
    indices = split_indices(root, splits)[:limit]
    scenes = load_scenes(root / "scenes.json")
    tally = _Tally()
    collected: dict[str, dict[str, list[torch.Tensor]]] = {"raw": {}, "calibrated": {}, "label": {}}
    start = time.perf_counter()
    for n, i in enumerate(indices):
        scene = scenes[i]
        image = load_image(root / "images" / scene.image_filename, size=_native_size(scene), device=net.device)
        h, w = image.pixels.shape[1:]
        masks, parts = scene_masks(scene, h, w)
        cats = [ontology.CATEGORY_OF[o.subtype] for o in scene.objects]
        raw = net.object_loglik(image, masks, calibrated=False)
        logp = net.object_loglik(image, masks)  # an ensemble calibrates each member before mixing them
        for k, head in enumerate(OBJECT_HEADS):
            truth = torch.tensor([[ontology.SUBTYPES.index(o.subtype), ontology.COLORS.index(o.color),
                                   ontology.MATERIALS.index(o.material), ontology.SIZES.index(o.size)][k]
                                  for o in scene.objects])
            correct = logp[head].argmax(-1).cpu() == truth
            _collect(collected, f"object.{head}", raw[head], logp[head], truth)
            tally.add(f"object.{head}", "all", correct)
            for c in set(cats):
                tally.add(f"object.{head}", c, correct[torch.tensor([x == c for x in cats])])
        if parts:
            part_masks = torch.stack([p[2] for p in parts])
            owner = torch.tensor([p[0] for p in parts])
            praw = net.part_loglik(image, part_masks, masks, owner, calibrated=False)
            plogp = net.part_loglik(image, part_masks, masks, owner)
            _tally_parts(tally, collected, scene, parts, praw, plogp)
        if progress is not None:
            progress(n + 1, len(indices))
    ece = {}
    for name, raws in collected["raw"].items():
        y = torch.cat(collected["label"][name])
        ece[name] = {"before": round(top_label_ece(torch.cat(raws), y), 4),
                     "after": round(top_label_ece(torch.cat(collected["calibrated"][name]), y), 4)}
    return {"images": len(indices), "objects": tally.report(), "ece": ece, "temperatures": net.temperatures(),
            "masks": "ground-truth visible masks (object and part) stand in for the parser's",
            "measured_part_pixels": MEASURE_PART_PIXELS, "seconds": round(time.perf_counter() - start, 1)}


def _collect(collected, name: str, raw: torch.Tensor, calibrated: torch.Tensor, truth: torch.Tensor) -> None:
    collected["raw"].setdefault(name, []).append(raw.cpu())
    collected["calibrated"].setdefault(name, []).append(calibrated.cpu())
    collected["label"].setdefault(name, []).append(truth)


def _tally_parts(tally: _Tally, collected, scene, parts, praw, plogp) -> None:
    """Part measures: the look (plain vs recoloured), colour and material of recoloured parts, and the whole style
    (plain, or recoloured with the right colour and material; the posterior's argmax over the 17 styles)."""
    pixels = torch.tensor([int(p[2].sum()) for p in parts])
    styles = [scene.objects[i].parts.get(raw) for i, raw, _ in parts]
    look = torch.tensor([int(s is not None) for s in styles])
    color = torch.tensor([ontology.COLORS.index(s.color) if s else -1 for s in styles])
    material = torch.tensor([ontology.MATERIALS.index(s.material) if s else -1 for s in styles])
    cats = [ontology.CATEGORY_OF[scene.objects[i].subtype] for i, _, _ in parts]
    lp = {h: v.cpu() for h, v in plogp.items()}
    pred_look = lp["recoloured"].argmax(-1)
    pred_color, pred_material = lp["color"].argmax(-1), lp["material"].argmax(-1)
    # posterior argmax over the 17 styles: plain, or the best (colour, material) if recoloured wins
    best_rec = lp["recoloured"][:, 1] + lp["color"].max(-1).values + lp["material"].max(-1).values
    plain = lp["recoloured"][:, 0] >= best_rec
    style_ok = torch.where(look == 0, plain, ~plain & (pred_color == color) & (pred_material == material))
    measured = pixels >= MEASURE_PART_PIXELS
    rec = look == 1
    for suffix, keep in (("", measured), ("_all_visible", torch.ones_like(measured))):
        for name, correct, sel in (("part.look", pred_look == look, keep),
                                   ("part.color", pred_color == color, keep & rec),
                                   ("part.material", pred_material == material, keep & rec),
                                   ("part.style", style_ok, keep)):
            tally.add(name + suffix, "all", correct[sel])
            for c in set(cats):
                tally.add(name + suffix, c, correct[sel & torch.tensor([x == c for x in cats])])
    for head, truth in (("recoloured", look), ("color", color), ("material", material)):
        keep = measured.to(praw[head].device)
        _collect(collected, f"part.{head}", praw[head][keep], plogp[head][keep], truth[measured])

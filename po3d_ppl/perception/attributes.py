"""The attribute network (issue "Perception II", item 2): object subtype, colour, material and size, and each part's
look (plain, or recoloured with which colour and material), read from crops of the image around the masks the
object parser produced. Trained from scratch (:mod:`~po3d_ppl.perception.train_attributes`); no pretrained weights.

**Inputs are pixels and masks only.** :meth:`AttributeNet.object_loglik` takes the image and one visible mask per
proposal; :meth:`AttributeNet.part_loglik` takes part masks (or part-id maps, as a mesh projection gives them) and
the masks of the objects they belong to. Nothing reads a scene file: training builds its crops from ground-truth
masks with exactly these functions, and the lead's parser passes its own masks.

**Crops.** An object is cut out as a square window around its mask's box (``object_context`` times the longer
side) resampled to ``object_size`` pixels, with the mask as a fourth channel: the network sees the object, its
outline and what occludes it. A square window loses absolute scale, which *size* needs, so each object also gets
its box and mask area in image units (``OBJECT_GEOMETRY``; the camera prior makes pixel size and image row a
proxy for depth). A part is cut out around its own box (``part_context`` times its longer side, at least
``min_part_window`` pixels) at ``part_size`` pixels, with the part mask and its object's mask as channels.
Whether a part is *recoloured* means "does it differ from its object's look", which a part crop alone does not
show when the object's body is out of the window; so the part head also receives its object's colour and
material probabilities (the object head's calibrated output at inference; the ground truth, smoothed, in training).

**Outputs are log-probabilities** over the orderings of :mod:`po3d_ppl.ontology` (``OBJECT_HEADS``,
``PART_HEADS``), each head divided by its own temperature, fitted on a validation split
(:meth:`AttributeNet.fit_temperatures`). For the evidence contract, :meth:`AttributeNet.style_loglik` turns a part's
three heads into the 17 styles of ``SceneEvidence.part_style_loglik`` (``evidence.style_index`` ordering) *as a
likelihood*: the training frequency of recoloured parts is divided out, since the scene model applies its own prior
(``ScenePriors.part_recoloured``). Object heads are trained on uniformly sampled attributes, so their posteriors
are already normalised likelihoods. :meth:`AttributeNet.part_style_table` fills the whole ``[N, 21, P, 17]``
table from per-(proposal, subtype hypothesis) part-id maps; slots without pixels stay 0 (uninformative; the
visibility table says they are hidden).

**Ensembles.** :class:`AttributeEnsemble` reads the same crops with several networks trained alike from different
seeds and mixes their calibrated probabilities; it answers the same calls (:class:`AttributeReader`), and one
weights file holds every member (its ``members`` metadata says how many). The shipped model is a two-member
ensemble (``po3d train attributes --members 2``).

Code runs on any device (inputs are moved to the module's). Loading goes through :mod:`po3d_ppl.model_store`
(sha256 and size against ``models/manifest.json``).
"""

from __future__ import annotations

import abc
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import torch
import torch.nn.functional as F
from torch import nn

from po3d_ppl import ontology
from po3d_ppl.errors import InputError, ModelFileError
from po3d_ppl.evidence import DTYPE, NUM_STYLES, P, S, style_index
from po3d_ppl.perception.calibration import fit_temperature

MODEL_NAME = "attributes"
WEIGHTS = "attributes.safetensors"
FORMAT = 1
RETRAIN = ("retrain it with `po3d train attributes --data /work/data/perc_train_s711 --out models/` (see "
           "docs/perception.md) or restore it with `git checkout models/`")

#: Object heads and their class orderings (from the ontology; never restated).
OBJECT_HEADS: Mapping[str, tuple[str, ...]] = {
    "subtype": ontology.SUBTYPES, "color": ontology.COLORS, "material": ontology.MATERIALS, "size": ontology.SIZES,
}
#: A part's look: the object's own, or recoloured (the public ``parts`` field lists only recoloured parts).
PART_LOOKS: tuple[str, ...] = ("plain", "recoloured")
#: Part heads. ``color`` and ``material`` are conditional on the part being recoloured.
PART_HEADS: Mapping[str, tuple[str, ...]] = {
    "recoloured": PART_LOOKS, "color": ontology.COLORS, "material": ontology.MATERIALS,
}
#: Scalars per object crop: box centre (x / W, y / H), box width and height / H, sqrt(mask area) / H, box bottom / H,
#: and the log of the box width, height and sqrt(area) in metres at the depth of the box's bottom centre on the
#: ground seen by the camera prior's base camera (size is a metric property; pixels alone confound it with depth).
OBJECT_GEOMETRY = 9
#: Scalars per part crop: side and area relative to the object's, log area, centre offset from the object's centre.
PART_GEOMETRY = 5
#: The object's look given to the part head: colour probabilities then material probabilities.
REFERENCE = len(ontology.COLORS) + len(ontology.MATERIALS)
#: Object channels: RGB, mask. Part channels: RGB, part mask, object mask.
OBJECT_CHANNELS, PART_CHANNELS = 4, 5
#: Classes of the object network's dense auxiliary head (training only): per feature cell, not this object (0), its
#: unlabelled body (1), or raw part ``2 + RAW_PART_NAMES.index(name)``. Shape supervision for the subtype head.
DENSE_CLASSES = 2 + len(ontology.RAW_PART_NAMES)


def _mirror_parts() -> torch.Tensor:
    """Dense class -> its mirror image's class (left and right parts swap when a crop is flipped)."""
    swap = {"left": "right", "right": "left"}
    out = list(range(DENSE_CLASSES))
    for k, name in enumerate(ontology.RAW_PART_NAMES):
        mirrored = "_".join(swap.get(t, t) for t in name.split("_"))
        if mirrored in ontology.RAW_PART_NAMES:
            out[2 + k] = 2 + ontology.RAW_PART_NAMES.index(mirrored)
    return torch.tensor(out)


DENSE_MIRROR = _mirror_parts()


def _style_columns() -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """For each recoloured style column of the contract: its column, colour id and material id."""
    cols, colors, materials = [], [], []
    for c, color in enumerate(ontology.COLORS):
        for m, material in enumerate(ontology.MATERIALS):
            cols.append(style_index(color, material))
            colors.append(c)
            materials.append(m)
    return torch.tensor(cols), torch.tensor(colors), torch.tensor(materials)


STYLE_COLUMN, STYLE_COLOR, STYLE_MATERIAL = _style_columns()


@dataclass(frozen=True)
class AttributeConfig:
    """Architecture and crop geometry (stored with the weights, so a saved model rebuilds itself)."""

    object_size: int = 64
    part_size: int = 32
    #: Channels of the four stages (strides 1, 2, 4, 8 of the crop).
    object_widths: tuple[int, int, int, int] = (16, 32, 64, 128)
    part_widths: tuple[int, int, int, int] = (16, 32, 64, 96)
    hidden: int = 128
    object_context: float = 1.15
    min_object_window: float = 24.0
    part_context: float = 2.0
    min_part_window: float = 12.0

    def __post_init__(self) -> None:
        for name in ("object_size", "part_size"):
            v = getattr(self, name)
            if not (isinstance(v, int) and v >= 8 and v % 8 == 0):
                raise InputError(f"AttributeConfig.{name}", f"must be a multiple of 8, >= 8, got {v!r}")
        for name in ("object_widths", "part_widths"):
            v = getattr(self, name)
            if len(v) != 4 or not all(isinstance(w, int) and w >= 4 for w in v):
                raise InputError(f"AttributeConfig.{name}", f"must be four integers >= 4, got {v!r}")

    def to_dict(self) -> dict:
        d = asdict(self)
        d["object_widths"], d["part_widths"] = list(self.object_widths), list(self.part_widths)
        return d

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> AttributeConfig:
        d = dict(data)
        d["object_widths"], d["part_widths"] = tuple(d["object_widths"]), tuple(d["part_widths"])
        return cls(**d)


# --- crops -----------------------------------------------------------------------------------------------------------


def mask_boxes(masks: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Boxes ``[N, 4]`` (x0, y0, x1, y1; pixel edges, x1/y1 exclusive; zeros when empty) and pixel counts ``[N]``
    of bool masks ``[N, H, W]``."""
    n, h, w = masks.shape
    rows, cols = masks.any(2), masks.any(1)
    ys = torch.arange(h, device=masks.device)
    xs = torch.arange(w, device=masks.device)
    y0 = torch.where(rows, ys, h).amin(1) if n else ys.new_zeros(0)
    y1 = torch.where(rows, ys + 1, 0).amax(1) if n else ys.new_zeros(0)
    x0 = torch.where(cols, xs, w).amin(1) if n else xs.new_zeros(0)
    x1 = torch.where(cols, xs + 1, 0).amax(1) if n else xs.new_zeros(0)
    boxes = torch.stack([x0, y0, x1, y1], -1).float()
    counts = masks.flatten(1).sum(1)
    return torch.where((counts > 0)[:, None], boxes, torch.zeros_like(boxes)), counts


def label_boxes(labels: torch.Tensor, num_labels: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Boxes ``[L, 4]`` and pixel counts ``[L]`` of every label ``0 .. L-1`` of an integer map ``[H, W]`` (-1 and
    labels outside the range are ignored): one pass, for part-id maps with many parts."""
    h, w = labels.shape
    flat = labels.reshape(-1)
    keep = (flat >= 0) & (flat < num_labels)
    ids = flat[keep].long()
    pix = torch.arange(h * w, device=labels.device)[keep]
    y, x = (pix // w).float(), (pix % w).float()
    big = float(max(h, w) + 1)
    out = []
    for coord, reduce, init in ((x, "amin", big), (y, "amin", big), (x + 1, "amax", 0.0), (y + 1, "amax", 0.0)):
        out.append(torch.full((num_labels,), init, device=labels.device).scatter_reduce(0, ids, coord, reduce))
    counts = torch.zeros(num_labels, dtype=torch.long, device=labels.device).scatter_add_(0, ids,
                                                                                         torch.ones_like(ids))
    boxes = torch.stack(out, -1)
    return torch.where((counts > 0)[:, None], boxes, torch.zeros_like(boxes)), counts


def square_windows(boxes: torch.Tensor, context: float, min_side: float) -> torch.Tensor:
    """Square windows ``[K, 3]`` (centre x, centre y, side) around boxes ``[K, 4]`` (x0, y0, x1, y1)."""
    cx, cy = (boxes[:, 0] + boxes[:, 2]) / 2, (boxes[:, 1] + boxes[:, 3]) / 2
    side = torch.maximum(boxes[:, 2] - boxes[:, 0], boxes[:, 3] - boxes[:, 1]) * context
    return torch.stack([cx, cy, side.clamp(min=min_side)], -1)


def _window_coords(windows: torch.Tensor, size: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Pixel coordinates (x [K, s], y [K, s]) of the sample centres of each window's ``size`` x ``size`` grid."""
    t = (torch.arange(size, device=windows.device, dtype=windows.dtype) + 0.5) / size - 0.5
    xs = windows[:, :1] + windows[:, 2:3] * t
    ys = windows[:, 1:2] + windows[:, 2:3] * t
    return xs, ys


def crop_pixels(pixels: torch.Tensor, windows: torch.Tensor, size: int) -> torch.Tensor:
    """Bilinear crops ``[K, C, size, size]`` of an image ``[C, H, W]`` (zeros outside it). All windows are sampled
    in one ``grid_sample`` call on the single image (a ``K * size`` tall grid), so nothing is copied per crop."""
    c, h, w = pixels.shape
    k = windows.shape[0]
    if k == 0:
        return pixels.new_zeros((0, c, size, size))
    xs, ys = _window_coords(windows.to(pixels.dtype), size)
    gx = (2 * xs / w - 1)[:, None, :].expand(k, size, size)
    gy = (2 * ys / h - 1)[:, :, None].expand(k, size, size)
    grid = torch.stack([gx, gy], -1).reshape(1, k * size, size, 2)
    out = F.grid_sample(pixels[None], grid, mode="bilinear", padding_mode="zeros", align_corners=False)
    return out[0].view(c, k, size, size).transpose(0, 1)


def crop_values(planes: torch.Tensor, plane_index: torch.Tensor, windows: torch.Tensor, size: int
                ) -> tuple[torch.Tensor, torch.Tensor]:
    """Nearest-pixel crops ``[K, size, size]`` of ``planes[plane_index[k]]`` and where they fall inside the image."""
    _, h, w = planes.shape
    xs, ys = _window_coords(windows.float(), size)
    ix, iy = torch.floor(xs).long(), torch.floor(ys).long()
    inside = ((iy >= 0) & (iy < h))[:, :, None] & ((ix >= 0) & (ix < w))[:, None, :]
    picked = planes[plane_index[:, None, None], iy.clamp(0, h - 1)[:, :, None], ix.clamp(0, w - 1)[:, None, :]]
    return picked, inside


def crop_labels(planes: torch.Tensor, plane_index: torch.Tensor, values: torch.Tensor, windows: torch.Tensor,
                size: int) -> torch.Tensor:
    """Nearest-pixel crops ``[K, size, size]`` (bool) of ``planes[plane_index[k]] == values[k]``: works for bool
    masks (values True) and for integer label maps (values = label ids) without expanding them to masks."""
    picked, inside = crop_values(planes, plane_index, windows, size)
    return (picked == values.to(planes.dtype)[:, None, None]) & inside


def as_pixels(image: Any, device: torch.device) -> torch.Tensor:
    """Float RGB ``[3, H, W]`` in [0, 1] from a tensor (float or uint8) or an ``ImageInput``."""
    pixels = getattr(image, "pixels", image)
    if not isinstance(pixels, torch.Tensor) or pixels.dim() != 3 or pixels.shape[0] != 3:
        got = tuple(pixels.shape) if isinstance(pixels, torch.Tensor) else type(pixels).__name__
        raise InputError("image", f"expected an RGB tensor [3, H, W] or an ImageInput, got {got}")
    if pixels.dtype == torch.uint8:
        return pixels.to(device=device, dtype=torch.float32) / 255.0
    return pixels.to(device=device, dtype=torch.float32)


def check_masks(masks: torch.Tensor, pixels: torch.Tensor, what: str) -> torch.Tensor:
    if not isinstance(masks, torch.Tensor) or masks.dim() != 3 or tuple(masks.shape[1:]) != tuple(pixels.shape[1:]):
        shape = tuple(masks.shape) if isinstance(masks, torch.Tensor) else type(masks).__name__
        raise InputError(what, f"expected bool masks [N, {pixels.shape[1]}, {pixels.shape[2]}], got {shape}")
    return masks.to(device=pixels.device, dtype=torch.bool)


@dataclass
class ObjectInputs:
    """What the object network reads: ``crops`` [N, 4, s, s] (RGB in [0, 1], mask in {0, 1}), ``geometry``
    [N, OBJECT_GEOMETRY], and the windows, boxes and pixel counts they came from (to crop parts against)."""

    crops: torch.Tensor
    geometry: torch.Tensor
    boxes: torch.Tensor
    counts: torch.Tensor
    windows: torch.Tensor


def object_inputs(pixels: torch.Tensor, masks: torch.Tensor, config: AttributeConfig) -> ObjectInputs:
    """Object crops of ``pixels`` [3, H, W] (float, [0, 1]) for bool ``masks`` [N, H, W]."""
    h, w = pixels.shape[1:]
    boxes, counts = mask_boxes(masks)
    win = square_windows(boxes, config.object_context, config.min_object_window)
    rgb = crop_pixels(pixels, win, config.object_size)
    n = masks.shape[0]
    idx = torch.arange(n, device=masks.device)
    mask = crop_labels(masks, idx, torch.ones(n, dtype=torch.bool, device=masks.device), win, config.object_size)
    crops = torch.cat([rgb, mask[:, None].to(rgb.dtype)], 1)
    metres = _metres_per_pixel(boxes, h, w)
    dims = torch.stack([boxes[:, 2] - boxes[:, 0], boxes[:, 3] - boxes[:, 1], counts.float().sqrt()], -1)
    geometry = torch.cat([torch.stack([(boxes[:, 0] + boxes[:, 2]) / (2 * w), (boxes[:, 1] + boxes[:, 3]) / (2 * h),
                                       (boxes[:, 2] - boxes[:, 0]) / h, (boxes[:, 3] - boxes[:, 1]) / h,
                                       counts.float().sqrt() / h, boxes[:, 3] / h], -1),
                          torch.log((dims * metres[:, None]).clamp(min=1e-3))], -1)
    return ObjectInputs(crops, geometry.to(rgb.dtype), boxes, counts, win)


#: Depth (m) assumed for a box whose bottom lies above the horizon of the base camera.
_FAR = 40.0


def _metres_per_pixel(boxes: torch.Tensor, height: int, width: int) -> torch.Tensor:
    """Metres per pixel at the depth of each box's bottom centre, taken as a ground point seen by the camera
    prior's base camera (the world's jitter of +-0.5 m moves this by a few percent; sizes differ by 2x)."""
    from po3d_ppl.perception.image_input import CameraPrior, backproject_to_plane, project_points

    camera = CameraPrior(width, height).base
    bottom = torch.stack([(boxes[:, 0] + boxes[:, 2]) / 2, boxes[:, 3]], -1).double()
    ground = backproject_to_plane(camera, bottom)
    depth = project_points(camera, ground)[:, 2]
    depth = torch.where(torch.isfinite(depth) & (depth > 0), depth, torch.full_like(depth, _FAR)).clamp(max=_FAR)
    return (depth / float(camera.K[1, 1])).to(boxes.dtype)


def part_inputs(pixels: torch.Tensor, planes: torch.Tensor, plane_index: torch.Tensor, values: torch.Tensor,
                part_boxes: torch.Tensor, part_counts: torch.Tensor, objects: ObjectInputs, object_masks: torch.Tensor,
                owner: torch.Tensor, config: AttributeConfig) -> tuple[torch.Tensor, torch.Tensor]:
    """Part crops ``[M, 5, s, s]`` (RGB, part mask, owner's mask) and geometry ``[M, PART_GEOMETRY]``. Part m is
    ``planes[plane_index[m]] == values[m]`` with box ``part_boxes[m]``; ``owner[m]`` is its object's row."""
    win = square_windows(part_boxes, config.part_context, config.min_part_window)
    s = config.part_size
    rgb = crop_pixels(pixels, win, s)
    part = crop_labels(planes, plane_index, values, win, s)
    obj = crop_labels(object_masks, owner, torch.ones_like(owner, dtype=torch.bool), win, s)
    crops = torch.cat([rgb, part[:, None].to(rgb.dtype), obj[:, None].to(rgb.dtype)], 1)
    ob = objects.boxes[owner]
    oside = torch.maximum(ob[:, 2] - ob[:, 0], ob[:, 3] - ob[:, 1]).clamp(min=1.0)
    pside = torch.maximum(part_boxes[:, 2] - part_boxes[:, 0], part_boxes[:, 3] - part_boxes[:, 1])
    oarea = objects.counts[owner].float().clamp(min=1.0)
    geometry = torch.stack([pside / oside, part_counts.float() / oarea, torch.log1p(part_counts.float()) / 8,
                            ((part_boxes[:, 0] + part_boxes[:, 2]) - (ob[:, 0] + ob[:, 2])) / (2 * oside),
                            ((part_boxes[:, 1] + part_boxes[:, 3]) - (ob[:, 1] + ob[:, 3])) / (2 * oside)], -1)
    return crops, geometry.to(rgb.dtype)


# --- networks --------------------------------------------------------------------------------------------------------


def mirror_object_geometry(geometry: torch.Tensor) -> torch.Tensor:
    """Object scalars of the horizontally mirrored crop (the box centre's x moves to 1 - x)."""
    out = geometry.clone()
    out[:, 0] = 1 - out[:, 0]
    return out


def mirror_part_geometry(geometry: torch.Tensor) -> torch.Tensor:
    """Part scalars of the mirrored crop (the offset from the object's centre changes sign in x)."""
    out = geometry.clone()
    out[:, 3] = -out[:, 3]
    return out


def _conv(cin: int, cout: int, stride: int = 1) -> nn.Sequential:
    return nn.Sequential(nn.Conv2d(cin, cout, 3, stride, 1, bias=False), nn.BatchNorm2d(cout), nn.ReLU(inplace=True))


class CropNet(nn.Module):
    """A crop (uint8-range channels scaled to [0, 1]) and scalars -> one logit vector per head.

    Four conv stages (stride 1, 2, 4, 8), global mean and max pooling (max keeps small bright details such as a
    metal highlight or a thin recoloured part), the scalars concatenated, one hidden layer, a linear layer per head.
    """

    def __init__(self, channels: int, widths: tuple[int, int, int, int], scalars: int, hidden: int,
                 heads: Mapping[str, int], dense: int = 0):
        super().__init__()
        w0, w1, w2, w3 = widths
        self.trunk = nn.Sequential(_conv(channels, w0), _conv(w0, w1, 2), _conv(w1, w1), _conv(w1, w2, 2),
                                   _conv(w2, w2), _conv(w2, w3, 2), _conv(w3, w3))
        self.mlp = nn.Sequential(nn.Linear(2 * w3 + scalars, hidden), nn.ReLU(inplace=True))
        self.heads = nn.ModuleDict({name: nn.Linear(hidden, k) for name, k in heads.items()})
        #: Optional per-cell classifier on the stride-8 map (an auxiliary training target; ``dense`` in the output).
        self.dense = nn.Conv2d(w3, dense, 1) if dense else None

    def forward(self, crops: torch.Tensor, scalars: torch.Tensor) -> dict[str, torch.Tensor]:
        x = crops.clone()
        x[:, :3] = (x[:, :3] - 0.5) / 0.25
        x[:, 3:] = x[:, 3:] * 2 - 1
        fmap = self.trunk(x.contiguous(memory_format=torch.channels_last))  # ~20% faster on CPU
        f = torch.cat([fmap.mean((2, 3)), fmap.amax((2, 3)), scalars], 1)
        h = self.mlp(f)
        out = {name: head(h) for name, head in self.heads.items()}
        if self.dense is not None and self.training:
            out["dense"] = self.dense(fmap)
        return out


def _head_sizes(heads: Mapping[str, tuple[str, ...]]) -> dict[str, int]:
    return {name: len(classes) for name, classes in heads.items()}


class AttributeReader(abc.ABC):
    """The public inference of :class:`AttributeNet` and of :class:`AttributeEnsemble`: both cut the same crops
    and differ only in how :meth:`read_objects` and :meth:`read_parts` turn them into log-probabilities."""

    config: AttributeConfig

    @property
    @abc.abstractmethod
    def device(self) -> torch.device:
        """Where the weights are (inputs are moved there)."""

    @abc.abstractmethod
    def temperatures(self) -> dict[str, float]:
        """Every fitted temperature by name."""

    @abc.abstractmethod
    def read_objects(self, inputs: ObjectInputs, calibrated: bool) -> dict[str, torch.Tensor]:
        """Object log-probabilities per head from prepared crops (:func:`object_inputs`)."""

    @abc.abstractmethod
    def read_parts(self, crops: torch.Tensor, geometry: torch.Tensor, object_logp: Mapping[str, torch.Tensor],
                   owner: torch.Tensor, calibrated: bool) -> dict[str, torch.Tensor]:
        """Part log-probabilities per head and ``style`` from prepared crops (:func:`part_inputs`), given the
        objects' reading ``object_logp`` (part m belongs to object ``owner[m]``)."""

    def num_parameters(self) -> int:
        return sum(p.numel() for p in self.parameters())

    def _objects(self, pixels: torch.Tensor, masks: torch.Tensor, calibrated: bool
                 ) -> tuple[dict[str, torch.Tensor], ObjectInputs]:
        inputs = object_inputs(pixels, masks, self.config)
        return self.read_objects(inputs, calibrated), inputs

    def _parts(self, pixels, planes, plane_index, values, boxes, counts, object_masks, owner, calibrated,
               objects: tuple[dict[str, torch.Tensor], ObjectInputs] | None = None) -> dict[str, torch.Tensor]:
        obj_logp, obj_inputs = objects or self._objects(pixels, object_masks, True)
        crops, geometry = part_inputs(pixels, planes, plane_index, values, boxes, counts, obj_inputs, object_masks,
                                      owner, self.config)
        return self.read_parts(crops, geometry, obj_logp, owner, calibrated)

    # -- public inference ---------------------------------------------------------------------------------------------

    @torch.no_grad()
    def object_loglik(self, image: Any, masks: torch.Tensor, calibrated: bool = True) -> dict[str, torch.Tensor]:
        """Per-proposal log-probabilities ``{head: [N, K]}`` (``OBJECT_HEADS`` orderings) from the image
        (``[3, H, W]`` float in [0, 1] or uint8, or an ``ImageInput``) and one bool visible mask per proposal."""
        pixels = as_pixels(image, self.device)
        masks = check_masks(masks, pixels, "masks")
        return self._objects(pixels, masks, calibrated)[0]

    @torch.no_grad()
    def part_loglik(self, image: Any, part_masks: torch.Tensor, object_masks: torch.Tensor, owner: torch.Tensor,
                    calibrated: bool = True) -> dict[str, torch.Tensor]:
        """Per-part log-probabilities ``{"recoloured": [M, 2], "color": [M, 8], "material": [M, 2],
        "style": [M, 17]}``: part m is the bool mask ``part_masks[m]`` ([M, H, W]) of object ``owner[m]`` (a row
        of ``object_masks`` [N, H, W]). ``color``/``material`` are conditional on recoloured; ``style`` is
        :meth:`style_loglik`, ready for ``SceneEvidence.part_style_loglik``."""
        pixels = as_pixels(image, self.device)
        part_masks = check_masks(part_masks, pixels, "part_masks")
        object_masks = check_masks(object_masks, pixels, "object_masks")
        owner = torch.as_tensor(owner, dtype=torch.long, device=self.device).reshape(-1)
        if owner.shape[0] != part_masks.shape[0] or (owner.numel() and not
                                                     (0 <= int(owner.min()) and int(owner.max()) < len(object_masks))):
            raise InputError("owner", f"expected {part_masks.shape[0]} object rows in 0..{len(object_masks) - 1}")
        boxes, counts = mask_boxes(part_masks)
        idx = torch.arange(part_masks.shape[0], device=self.device)
        return self._parts(pixels, part_masks, idx, torch.ones_like(idx, dtype=torch.bool), boxes, counts,
                           object_masks, owner, calibrated)

    @torch.no_grad()
    def part_style_table(self, image: Any, object_masks: torch.Tensor,
                         part_maps: Mapping[tuple[int, int], torch.Tensor], min_pixels: int = 1) -> torch.Tensor:
        """``SceneEvidence.part_style_loglik`` ``[N, 21, P, 17]`` (float64, on this module's device).

        ``part_maps[(n, s)]`` is an integer map ``[H, W]`` of the part ids (``ontology.PARTS[SUBTYPES[s]]``
        positions; -1 elsewhere) that proposal n's mesh shows under subtype hypothesis s (visible pixels only).
        Slots with fewer than ``min_pixels`` pixels, and hypotheses not in ``part_maps``, stay 0 (no reading)."""
        return self.part_style_tables(image, object_masks, [part_maps], min_pixels)[0]

    @torch.no_grad()
    def part_style_tables(self, image: Any, object_masks: torch.Tensor,
                          part_map_sets: Sequence[Mapping[tuple[int, int], torch.Tensor]], min_pixels: int = 1
                          ) -> list[torch.Tensor]:
        """One :meth:`part_style_table` per set of part maps (e.g. one set per pose hypothesis), in one batch: the
        objects, whose looks the part head is given, are read once for all the sets."""
        pixels = as_pixels(image, self.device)
        object_masks = check_masks(object_masks, pixels, "object_masks")
        n = object_masks.shape[0]
        tables = torch.zeros((len(part_map_sets), n, S, P, NUM_STYLES), dtype=DTYPE, device=self.device)
        keys = [(g, ni, si) for g, maps in enumerate(part_map_sets) for ni, si in sorted(maps)]
        if not keys or n == 0:
            return list(tables)
        for _, ni, si in keys:
            if not (0 <= ni < n and 0 <= si < S):
                raise InputError("part_maps", f"key {(ni, si)}: expected (proposal in 0..{n - 1}, subtype in "
                                              f"0..{S - 1})")
        planes = torch.stack([torch.as_tensor(part_map_sets[g][(ni, si)], device=self.device).long()
                              for g, ni, si in keys])
        if tuple(planes.shape[1:]) != tuple(pixels.shape[1:]):
            raise InputError("part_maps", f"expected [H, W] = {list(pixels.shape[1:])} maps, got "
                                          f"{list(planes.shape[1:])}")
        rows, boxes, counts = [], [], []
        for k, (_, _, si) in enumerate(keys):
            b, c = label_boxes(planes[k], len(ontology.PARTS[ontology.SUBTYPES[si]]))
            for p in torch.nonzero(c >= min_pixels).flatten().tolist():
                rows.append((k, p))
                boxes.append(b[p])
                counts.append(c[p])
        if not rows:
            return list(tables)
        plane_index = torch.tensor([r[0] for r in rows], device=self.device)
        values = torch.tensor([r[1] for r in rows], device=self.device)
        group, owner, subtype = (torch.tensor([keys[r[0]][i] for r in rows], device=self.device) for i in range(3))
        objects = self._objects(pixels, object_masks, True)
        logp = self._parts(pixels, planes, plane_index, values, torch.stack(boxes), torch.stack(counts),
                           object_masks, owner, True, objects)
        tables[group, owner, subtype, values] = logp["style"].to(DTYPE)
        return list(tables)


class AttributeNet(AttributeReader, nn.Module):
    """The object and part networks with their per-head temperatures and the part training prior.

    ``temperature`` buffers (one per head, ``object.<head>`` / ``part.<head>``) divide the logits; 1 until
    :meth:`fit_temperatures`. ``part_prior`` is the training frequency of (plain, recoloured), divided out by
    :meth:`style_loglik`.
    """

    def __init__(self, config: AttributeConfig = AttributeConfig()):
        super().__init__()
        self.config = config
        self.objects = CropNet(OBJECT_CHANNELS, config.object_widths, OBJECT_GEOMETRY, config.hidden,
                               _head_sizes(OBJECT_HEADS), dense=DENSE_CLASSES)
        self.parts = CropNet(PART_CHANNELS, config.part_widths, PART_GEOMETRY + REFERENCE, config.hidden,
                             _head_sizes(PART_HEADS))
        self.register_buffer("object_temperature", torch.ones(len(OBJECT_HEADS)))
        self.register_buffer("part_temperature", torch.ones(len(PART_HEADS)))
        self.register_buffer("part_prior", torch.full((len(PART_LOOKS),), 1.0 / len(PART_LOOKS)))

    @property
    def device(self) -> torch.device:
        return self.object_temperature.device

    def temperatures(self) -> dict[str, float]:
        out = {f"object.{h}": float(t) for h, t in zip(OBJECT_HEADS, self.object_temperature)}
        return out | {f"part.{h}": float(t) for h, t in zip(PART_HEADS, self.part_temperature)}

    # -- raw logits (training, calibration) -------------------------------------------------------------------------

    def object_logits(self, crops: torch.Tensor, geometry: torch.Tensor) -> dict[str, torch.Tensor]:
        """Logits of object crops; in eval mode the mean over the crop and its mirror image (attributes are
        mirror-invariant, and averaging the two readings costs one more pass of a small network)."""
        out = self.objects(crops, geometry)
        if not self.training:
            flipped = self.objects(crops.flip(-1), mirror_object_geometry(geometry))
            out = {h: (v + flipped[h]) / 2 for h, v in out.items()}
        return out

    def part_logits(self, crops: torch.Tensor, geometry: torch.Tensor, reference: torch.Tensor
                    ) -> dict[str, torch.Tensor]:
        """Logits of part crops (with their objects' looks); mirror-averaged in eval mode like objects."""
        out = self.parts(crops, torch.cat([geometry, reference], 1))
        if not self.training:
            flipped = self.parts(crops.flip(-1), torch.cat([mirror_part_geometry(geometry), reference], 1))
            out = {h: (v + flipped[h]) / 2 for h, v in out.items()}
        return out

    def calibrate(self, logits: Mapping[str, torch.Tensor], level: str, calibrated: bool = True
                  ) -> dict[str, torch.Tensor]:
        """Log-probabilities of ``level`` ("object" or "part") logits, divided by each head's temperature."""
        heads, temps = (OBJECT_HEADS, self.object_temperature) if level == "object" else \
            (PART_HEADS, self.part_temperature)
        return {h: F.log_softmax(logits[h] / (temps[i] if calibrated else 1.0), -1) for i, h in enumerate(heads)
                if h in logits}

    def reference(self, object_logp: Mapping[str, torch.Tensor]) -> torch.Tensor:
        """The part head's view of an object's look: its colour and material probabilities ``[N, REFERENCE]``."""
        return torch.cat([object_logp["color"].exp(), object_logp["material"].exp()], 1)

    def style_loglik(self, part_logp: Mapping[str, torch.Tensor]) -> torch.Tensor:
        """The 17 styles of the contract (0 plain, ``style_index(colour, material)`` recoloured) as a normalised
        log-likelihood ``[M, 17]``: log p(look | crop) minus the log training frequency of the look, plus the
        conditional colour and material log-probabilities, plus log 16.

        The colour and material heads give posteriors under a uniform prior over the 16 looks (they sum to 1 over
        them), so a look's likelihood is 16 times its posterior share: without that factor, the scene model's
        prior (recoloured r, spread as r / 16 per look) would weigh "recoloured" 16 times too low."""
        look = part_logp["recoloured"] - self.part_prior.log()
        out = look.new_empty((look.shape[0], NUM_STYLES))
        out[:, 0] = look[:, 0]
        cols = STYLE_COLUMN.to(look.device)
        out[:, cols] = (look[:, 1:2] + part_logp["color"][:, STYLE_COLOR.to(look.device)]
                        + part_logp["material"][:, STYLE_MATERIAL.to(look.device)] + math.log(NUM_STYLES - 1))
        return torch.log_softmax(out, -1)

    def read_objects(self, inputs: ObjectInputs, calibrated: bool) -> dict[str, torch.Tensor]:
        self.eval()
        return self.calibrate(self.object_logits(inputs.crops, inputs.geometry), "object", calibrated)

    def read_parts(self, crops: torch.Tensor, geometry: torch.Tensor, object_logp: Mapping[str, torch.Tensor],
                   owner: torch.Tensor, calibrated: bool) -> dict[str, torch.Tensor]:
        self.eval()
        logp = self.calibrate(self.part_logits(crops, geometry, self.reference(object_logp)[owner]), "part",
                              calibrated)
        logp["style"] = self.style_loglik(logp)
        return logp

    # -- calibration --------------------------------------------------------------------------------------------------

    def fit_temperatures(self, object_logits: Mapping[str, torch.Tensor], object_labels: Mapping[str, torch.Tensor],
                         part_logits: Mapping[str, torch.Tensor], part_labels: Mapping[str, torch.Tensor]
                         ) -> dict[str, float]:
        """Fit one temperature per head by minimising the NLL of held-out logits (labels -1 are skipped, e.g. the
        colour of a plain part), and store them. Returns the temperatures."""
        for i, h in enumerate(OBJECT_HEADS):
            self.object_temperature[i] = fit_temperature(object_logits[h], object_labels[h])
        for i, h in enumerate(PART_HEADS):
            self.part_temperature[i] = fit_temperature(part_logits[h], part_labels[h])
        return self.temperatures()


def log_mean_exp(tables: Sequence[torch.Tensor]) -> torch.Tensor:
    """log of the mean of ``exp(tables)``: the equal-weight mixture of log-probability tables."""
    return torch.logsumexp(torch.stack(list(tables)), 0) - math.log(len(tables))


class AttributeEnsemble(AttributeReader, nn.Module):
    """Attribute networks trained alike from different seeds, read as one: each head's output is the equal mixture of
    the members' calibrated probabilities (a deep ensemble; on the part looks of seeds 712 and 716 through jittered
    projections, two members read about half a point more parts right than either alone, with a lower NLL:
    docs/perception.md). Every member's part head is given the *ensemble's* reading of the object's look, so the
    members differ only in how they read the crop."""

    def __init__(self, members: Sequence[AttributeNet]):
        super().__init__()
        if len(members) < 2:
            raise InputError("members", f"an ensemble needs at least two attribute networks, got {len(members)}")
        if any(m.config != members[0].config for m in members):
            raise InputError("members", "the members were built with different AttributeConfigs; an ensemble reads "
                                        "one set of crops, so train them with the same options")
        self.config = members[0].config
        self.members = nn.ModuleList(members)

    @property
    def device(self) -> torch.device:
        return self.members[0].device

    def temperatures(self) -> dict[str, float]:
        return {f"member{k}.{name}": t for k, m in enumerate(self.members) for name, t in m.temperatures().items()}

    def read_objects(self, inputs: ObjectInputs, calibrated: bool) -> dict[str, torch.Tensor]:
        readings = [m.read_objects(inputs, calibrated) for m in self.members]
        return {h: log_mean_exp([r[h] for r in readings]) for h in readings[0]}

    def read_parts(self, crops: torch.Tensor, geometry: torch.Tensor, object_logp: Mapping[str, torch.Tensor],
                   owner: torch.Tensor, calibrated: bool) -> dict[str, torch.Tensor]:
        readings = [m.read_parts(crops, geometry, object_logp, owner, calibrated) for m in self.members]
        return {h: log_mean_exp([r[h] for r in readings]) for h in readings[0]}


# --- files -----------------------------------------------------------------------------------------------------------


def save_attribute_net(net: AttributeReader, directory: Path | str, **manifest: Any) -> Path:
    """Write ``net`` (one network or an ensemble, whose member count goes into the metadata) to
    ``directory/attributes.safetensors`` and record it (this key only) in the directory's manifest with
    ``manifest`` (command, data seed, metrics ...)."""
    from safetensors.torch import save_file

    from po3d_ppl.model_store import write_entry

    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    tensors = {k: v.detach().cpu().contiguous() for k, v in net.state_dict().items()}
    meta = {"format": str(FORMAT), "config": json.dumps(net.config.to_dict()),
            "heads": json.dumps({"object": dict(OBJECT_HEADS), "part": dict(PART_HEADS)}),
            "members": str(len(net.members) if isinstance(net, AttributeEnsemble) else 1)}
    path = directory / WEIGHTS
    save_file(tensors, str(path), metadata=meta)
    path.chmod(0o644)
    write_entry(MODEL_NAME, [path], directory, **manifest)
    return path


def load_attribute_net(directory: Path | str | None = None, device: torch.device | str = "cpu") -> AttributeReader:
    """The shipped attribute network or ensemble (or the one in ``directory``), checked against the manifest
    (sha256, size) and against today's ontology (head orderings); in eval mode on ``device``."""
    from po3d_ppl.model_store import load_tensors

    path, meta, tensors = load_tensors(MODEL_NAME, directory, RETRAIN, str(FORMAT))
    try:
        heads = json.loads(meta["heads"])
        now = {"object": {k: list(v) for k, v in OBJECT_HEADS.items()},
               "part": {k: list(v) for k, v in PART_HEADS.items()}}
        if heads != now:
            raise ModelFileError(f"{path}: trained on other class orderings than po3d_ppl.ontology's today; {RETRAIN}")
        config = AttributeConfig.from_dict(json.loads(meta["config"]))
        members = int(meta.get("members", "1"))  # files written before ensembles hold one network
        net = AttributeNet(config) if members == 1 else AttributeEnsemble([AttributeNet(config)
                                                                           for _ in range(members)])
        net.load_state_dict(tensors)
    except ModelFileError:
        raise
    except (OSError, ValueError, KeyError, TypeError, RuntimeError) as exc:
        raise ModelFileError(f"cannot load the attribute network from {path} ({exc}); {RETRAIN}") from None
    return net.to(device).eval()

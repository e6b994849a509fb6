"""The background model: what the bare ground looks like at every pixel, lit and in shadow, learnt from images.

The world's ground is uniform and its lights are directional, so the ground's image depends on the camera's
rotation and intrinsics only, which jitter does not change (a translated camera sees the same ground to within one
grey level). A per-pixel median over training images is therefore the bare ground (objects cover any one pixel in
few images), and a key-light shadow divides the ground's linear radiance by one constant, fitted from the pixels of
training images that no object covers and that are darker than the median. A pixel is *foreground* when it is
far from both the lit and the shadowed ground.

Why here: render-and-compare's silhouettes are stride-8 cells of a category mesh that encloses every subtype, so
its masks overshoot; the foreground cuts an object's mask to its pixels at full resolution, which the detection
boxes and the attribute crops read. This is the clutter model's job at pixel level, not a substitute for it (it
says "something is here", not what).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from po3d_ppl.errors import InputError, ModelFileError

MODEL_NAME = "background"
WEIGHTS = "background.safetensors"
RETRAIN = "refit it with `po3d train background --data DIR` (a dataset from `po3d dataset build`)"


def _linear(srgb: np.ndarray) -> np.ndarray:
    c = srgb.astype(np.float64) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _srgb(linear: np.ndarray) -> np.ndarray:
    c = np.clip(linear, 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055) * 255.0


@dataclass(frozen=True, eq=False)
class BackgroundModel:
    """``ground`` [H, W, 3] uint8 (RGB) and the shadow's linear-radiance ratio."""

    ground: np.ndarray
    shadow_ratio: float
    #: A pixel farther than this (max over channels, grey levels) from both the lit and the shadowed ground is
    #: foreground (6: IoU 0.944 with the true object pixels on 20 images of seed 712, 0.2% of foreground pixels
    #: false; 10: 0.920; 16: 0.896).
    threshold: float = 6.0
    min_blob: int = 8

    def __post_init__(self) -> None:
        if self.ground.ndim != 3 or self.ground.shape[2] != 3 or self.ground.dtype != np.uint8:
            raise InputError("BackgroundModel.ground", f"expected [H, W, 3] uint8, got {self.ground.shape} "
                                                       f"{self.ground.dtype}")
        if not 0.0 < self.shadow_ratio <= 1.0:
            raise InputError("BackgroundModel.shadow_ratio", f"must be in (0, 1], got {self.shadow_ratio}")

    @property
    def shadow(self) -> np.ndarray:
        return _srgb(_linear(self.ground) * self.shadow_ratio)

    def foreground(self, rgb: np.ndarray) -> np.ndarray:
        """[H, W] bool: pixels of ``rgb`` (HxWx3 uint8 at the model's size) unlike the ground, lit or shadowed,
        without specks (connected groups under ``min_blob`` pixels). Not an opening: that erases the thin frames
        of bicycles, whose boxes then shrink (measured: 5 of 153 objects fell below IoU 0.5)."""
        import cv2

        if rgb.shape != self.ground.shape:
            raise InputError("image", f"the background model is {self.ground.shape[1]}x{self.ground.shape[0]}, "
                                      f"the image {rgb.shape[1]}x{rgb.shape[0]}")
        image = rgb.astype(np.float64)
        lit = np.abs(image - self.ground).max(-1)
        dark = np.abs(image - self.shadow).max(-1)
        mask = ((lit > self.threshold) & (dark > self.threshold)).astype(np.uint8)
        _, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
        keep = stats[:, cv2.CC_STAT_AREA] >= self.min_blob
        keep[0] = False
        return keep[labels]

    def save(self, directory: Path) -> Path:
        from safetensors.torch import save_file

        path = Path(directory) / WEIGHTS
        save_file({"ground": torch.from_numpy(np.ascontiguousarray(self.ground)),
                   "shadow_ratio": torch.tensor([self.shadow_ratio], dtype=torch.float64),
                   "threshold": torch.tensor([self.threshold], dtype=torch.float64)}, str(path),
                  metadata={"format": "1"})
        return path


def fit_background(images: list[np.ndarray], object_masks: list[np.ndarray]) -> BackgroundModel:
    """The median ground of ``images`` (RGB uint8, one size) and the shadow ratio of their uncovered pixels
    (``object_masks[i]`` [H, W] bool: any object's pixels, from the training annotations)."""
    if len(images) < 5:
        raise InputError("images", f"need at least 5 images to fit a background, got {len(images)}")
    ground = _ground_median(images, object_masks)
    g = _linear(ground).mean(-1)
    ratios = []
    for image, covered in zip(images, object_masks, strict=True):
        r = _linear(image).mean(-1) / np.maximum(g, 1e-6)
        ratios.append(r[~covered & (r < 0.8)])
    dark = np.concatenate(ratios)
    if dark.size < 100:
        raise InputError("images", "too few shadowed ground pixels to fit the shadow ratio")
    return BackgroundModel(ground, float(np.median(dark)))


def _ground_median(images: list[np.ndarray], object_masks: list[np.ndarray], rows: int = 48) -> np.ndarray:
    """Per pixel (and channel) the median over the images where no object covers it (all images where every one
    covers it), in blocks of ``rows`` rows to bound memory. Masking matters: a per-channel median over images
    that show objects mixes colours where objects are common."""
    height = images[0].shape[0]
    ground = np.empty(images[0].shape, dtype=np.uint8)
    for top in range(0, height, rows):
        block = np.stack([im[top:top + rows] for im in images]).astype(np.float32)
        covered = np.stack([m[top:top + rows] for m in object_masks])
        masked = np.where(covered[..., None], np.nan, block)
        never = covered.all(0)
        with np.errstate(all="ignore"):
            median = np.nanmedian(masked, axis=0)
        median[never] = np.median(block, axis=0)[never]
        ground[top:top + rows] = median.round().astype(np.uint8)
    return ground


def load_background(directory: Path | str | None = None) -> BackgroundModel | None:
    """The shipped background model (checked against the manifest), or None when none is listed."""
    from po3d_ppl.model_store import load_tensors, models_dir, read_manifest

    directory = Path(directory) if directory is not None else models_dir()
    if MODEL_NAME not in read_manifest(directory):
        return None
    path, _, tensors = load_tensors(MODEL_NAME, directory, RETRAIN, "1")
    try:
        return BackgroundModel(tensors["ground"].numpy(), float(tensors["shadow_ratio"][0]),
                               float(tensors["threshold"][0]))
    except (ValueError, KeyError, TypeError, InputError) as exc:
        raise ModelFileError(f"cannot load the background model from {path} ({exc}); {RETRAIN}") from None

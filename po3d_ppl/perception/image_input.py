"""Image input and the camera prior: what perception may assume about an image before it looks at the objects.

:func:`load_image` turns a file, a numpy array or a PIL image into one canonical form (float32 RGB in [0, 1], a
torch tensor ``[3, H, W]`` at the working size, 640x480 like the world's renders) and refuses what it cannot read
with an :class:`~po3d_ppl.errors.ImageError` that says why. A 4:3 image of another size is resized, and the
intrinsics it carries are scaled with it, so a 1280x960 render of a world scene gets exactly the intrinsics of a
640x480 render.

:class:`CameraPrior` is the one piece of scene knowledge perception may use: the world's documented intrinsics
(``world.sampler.clevr_intrinsics``) and its camera-pose prior, the base CLEVR pose with uniform jitter of
``SceneConfig.camera_jitter`` on each coordinate of the location and the rotation unchanged
(``world.sampler.sample_camera``). Whatever varies per image is estimated; the prior lists the candidates.

:func:`project_points` and :func:`backproject_to_plane` are the ground-plane geometry perception needs (placing a
proposal on z = 0 from its pixel, projecting mesh vertices). They take numpy arrays (float64) or torch tensors
(differentiable, on the tensor's device and dtype) and agree with ``Camera.project`` to 1e-6.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch

from po3d_ppl.errors import ImageError, InputError
from po3d_ppl.world.sampler import BASE_CAMERA_LOCATION, SceneConfig, clevr_intrinsics, make_camera
from po3d_ppl.world.scene import Camera

#: The world's render size: images are brought to it (the camera prior and the trained models assume it).
WORKING_SIZE: tuple[int, int] = (640, 480)
#: Smallest and largest accepted side, in pixels, of an input image (before resizing).
MIN_SIDE, MAX_SIDE = 32, 4096
#: A resized image's aspect ratio may differ from the working size's by at most this fraction.
ASPECT_TOLERANCE = 0.01
#: Transparent pixels of an RGBA image are composited over this grey (close to the world's ground colour), so
#: whatever colour a fully transparent pixel stores does not leak into the features.
RGBA_BACKGROUND = 0.5

Array = np.ndarray | torch.Tensor


@dataclass(frozen=True, eq=False)
class ImageInput:
    """An image in perception's canonical form.

    ``pixels``: float32 RGB in [0, 1], ``[3, H, W]`` at the working size. ``original_size``: (width, height) as
    given. ``intrinsics``: the 3x3 intrinsics of ``pixels``, i.e. the world's intrinsics at the original size scaled
    by the resize (equal to ``clevr_intrinsics(640, 480)`` for any exact 4:3 image). ``source``: the file, or a
    description of the object, for messages.
    """

    pixels: torch.Tensor
    original_size: tuple[int, int]
    intrinsics: tuple[tuple[float, ...], ...]
    source: str

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) of ``pixels``."""
        return int(self.pixels.shape[2]), int(self.pixels.shape[1])

    @property
    def resized(self) -> bool:
        return self.size != self.original_size

    @property
    def scale(self) -> tuple[float, float]:
        """(sx, sy): working pixel coordinates = original ones times these."""
        (w, h), (w0, h0) = self.size, self.original_size
        return w / w0, h / h0

    @property
    def K(self) -> np.ndarray:
        return np.asarray(self.intrinsics, dtype=np.float64)

    def to_original(self, xy: np.ndarray) -> np.ndarray:
        """Working-image pixel coordinates (..., 2) -> coordinates in the image as given (to draw on it)."""
        return np.asarray(xy, dtype=np.float64) / np.asarray(self.scale)


def load_image(image: Any, *, size: tuple[int, int] = WORKING_SIZE, device: torch.device | str | None = None
               ) -> ImageInput:
    """Read ``image`` (a path, a numpy HWC/HW array of uint8, uint16 or floats in [0, 1], or a PIL image) into
    an :class:`ImageInput` at ``size`` (width, height). Grayscale and RGBA become RGB. An :class:`ImageInput`
    already at ``size`` is returned as it is.

    Raises :class:`ImageError` for unreadable files, arrays of the wrong dtype or shape, NaN or out-of-range
    values, sides outside [MIN_SIDE, MAX_SIDE], and aspect ratios that differ from ``size``'s by more than 1%.
    """
    if isinstance(image, ImageInput) and image.size == tuple(size):
        return image if device is None else dataclasses.replace(image, pixels=image.pixels.to(device))
    source, raw, bgr = _read_any(image)
    _check_shape(raw, source)
    h0, w0 = raw.shape[:2]
    _check_resolution(w0, h0, source)  # before any conversion, so a huge image costs nothing
    _check_aspect(w0, h0, size, source)
    work = _resize(_to_rgb(raw, source, bgr), size)
    pixels = torch.from_numpy(np.ascontiguousarray(work.transpose(2, 0, 1))).to(device=device)
    return ImageInput(pixels, (w0, h0), _scaled_intrinsics((w0, h0), size), source)


def _read_any(image: Any) -> tuple[str, np.ndarray, bool]:
    """(source description, the raw pixel array, whether its channels are in OpenCV's BGR order)."""
    if isinstance(image, (str, Path)):
        return str(image), _read_file(Path(image)), True
    if _looks_like_pil(image):
        return f"PIL image ({image.mode}, {image.size[0]}x{image.size[1]})", _pil_array(image), False
    if isinstance(image, np.ndarray):
        return f"array {tuple(image.shape)} {image.dtype}", image, False
    if isinstance(image, torch.Tensor):
        raise ImageError(f"image: got a torch tensor {tuple(image.shape)}; pass a numpy HWC array "
                         "(tensor.permute(1, 2, 0).cpu().numpy() for a [3, H, W] tensor), a file path or a PIL image")
    raise ImageError(f"image: expected a file path, a numpy array (H, W[, C]) or a PIL image, "
                     f"got {type(image).__name__}")


def _read_file(path: Path) -> np.ndarray:
    import cv2

    if not path.exists():
        raise ImageError(f"{path}: no such image file")
    if not path.is_file():
        raise ImageError(f"{path}: is not a file")
    try:
        data = np.fromfile(path, dtype=np.uint8)  # imdecode, unlike imread, reads any file name
    except OSError as exc:
        raise ImageError(f"{path}: cannot be read ({exc.strerror or exc})") from exc
    decoded = cv2.imdecode(data, cv2.IMREAD_UNCHANGED) if data.size else None
    if decoded is None:
        raise ImageError(f"{path}: not a readable image (empty, corrupt or an unsupported format; "
                         "PNG, JPEG, BMP, TIFF and WebP are read)")
    return decoded


def _looks_like_pil(obj: Any) -> bool:
    """Duck-typed, so PIL is neither a dependency nor imported unless the caller already uses it."""
    return type(obj).__module__.startswith("PIL.") and hasattr(obj, "mode") and hasattr(obj, "convert")


def _pil_array(image: Any) -> np.ndarray:
    if image.mode not in ("RGB", "RGBA", "L"):
        has_alpha = "A" in image.mode or "transparency" in getattr(image, "info", {})
        image = image.convert("RGBA" if has_alpha else "RGB")
    return np.asarray(image)


def _check_shape(array: np.ndarray, what: str) -> None:
    if array.ndim == 2 or (array.ndim == 3 and array.shape[2] in (1, 3, 4)):
        return
    hint = "; channels first? transpose to (H, W, C)" if array.ndim == 3 and array.shape[0] in (1, 3, 4) else ""
    raise ImageError(f"{what}: expected shape (H, W), (H, W, 1), (H, W, 3) or (H, W, 4), "
                     f"got {tuple(array.shape)}{hint}")


def _to_rgb(array: np.ndarray, what: str, bgr: bool = False) -> np.ndarray:
    """HxW, HxWx1, HxWx3 or HxWx4 of uint8/uint16/float -> float32 HxWx3 RGB in [0, 1]."""
    values = _normalise_values(array, what)
    if values.ndim == 2:
        values = values[:, :, None]
    if values.shape[2] == 1:
        return np.repeat(values, 3, axis=2)
    rgb = values[:, :, 2::-1] if bgr else values[:, :, :3]
    if values.shape[2] == 4:
        alpha = values[:, :, 3:4]
        rgb = rgb * alpha + RGBA_BACKGROUND * (1.0 - alpha)
    return np.ascontiguousarray(rgb, dtype=np.float32)


def _normalise_values(array: np.ndarray, what: str) -> np.ndarray:
    """Integers scaled by their range, floats checked to be finite and in [0, 1]; float32 out."""
    if array.dtype == np.uint8:
        return array.astype(np.float32) / 255.0
    if array.dtype == np.uint16:
        return array.astype(np.float32) / 65535.0
    if array.dtype.kind != "f":
        raise ImageError(f"{what}: expected dtype uint8, uint16 or float (values in [0, 1]), got {array.dtype}")
    if array.size and not np.isfinite(array).all():
        bad = int(np.count_nonzero(~np.isfinite(array)))
        raise ImageError(f"{what}: {bad} NaN or infinite value(s); every pixel must be a finite number in [0, 1]")
    if array.size and (array.min() < 0.0 or array.max() > 1.0):
        hint = " (0-255 floats? divide by 255)" if array.max() > 1.0 else ""
        raise ImageError(f"{what}: float values must lie in [0, 1], got [{float(array.min()):.4g}, "
                         f"{float(array.max()):.4g}]{hint}")
    return array.astype(np.float32)


def _check_resolution(width: int, height: int, source: str) -> None:
    if min(width, height) < MIN_SIDE or max(width, height) > MAX_SIDE:
        raise ImageError(f"{source}: resolution {width}x{height} is outside the accepted range: each side must be "
                         f"between {MIN_SIDE} and {MAX_SIDE} pixels")


def _check_aspect(width: int, height: int, size: tuple[int, int], source: str) -> None:
    """Resizing to another aspect ratio would stretch the objects, and the camera prior's intrinsics (square pixels,
    the world's field of view) would no longer describe the image, so it is refused rather than guessed."""
    want, got = size[0] / size[1], width / height
    if abs(got / want - 1.0) > ASPECT_TOLERANCE:
        raise ImageError(f"{source}: aspect ratio {width}x{height} ({got:.3f}) differs from the working size "
                         f"{size[0]}x{size[1]} ({want:.3f}) by {abs(got / want - 1.0):.1%} (at most "
                         f"{ASPECT_TOLERANCE:.0%} is accepted): the camera prior assumes the world's frame; "
                         "crop or pad the image to that aspect ratio first")


def _resize(rgb: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """Area averaging when shrinking (no aliasing), bilinear when enlarging; clipped back into [0, 1]."""
    import cv2

    h0, w0 = rgb.shape[:2]
    if (w0, h0) == tuple(size):
        return rgb
    shrink = size[0] * size[1] < w0 * h0
    out = cv2.resize(rgb, tuple(size), interpolation=cv2.INTER_AREA if shrink else cv2.INTER_LINEAR)
    return np.clip(out, 0.0, 1.0, out=out)


def _scaled_intrinsics(original: tuple[int, int], size: tuple[int, int]) -> tuple[tuple[float, ...], ...]:
    """The world's intrinsics at the original size, scaled per axis onto the working size (pixel corners map to
    pixel corners, so the principal point scales with the image)."""
    sx, sy = size[0] / original[0], size[1] / original[1]
    K = np.asarray(clevr_intrinsics(*original), dtype=np.float64)
    K = np.diag([sx, sy, 1.0]) @ K
    return tuple(tuple(float(v) for v in row) for row in K)


# --- the camera prior --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CameraPrior:
    """The world's camera-pose prior: the base CLEVR location plus an offset uniform on ``[-jitter, jitter]^3``,
    the rotation always the base one (CLEVR's jitter moves the camera without turning it), intrinsics fixed.

    ``intrinsics`` defaults to ``clevr_intrinsics(width, height)``; :meth:`for_image` takes an image's (possibly
    resize-adjusted) intrinsics.
    """

    width: int = WORKING_SIZE[0]
    height: int = WORKING_SIZE[1]
    jitter: float = SceneConfig().camera_jitter
    intrinsics: tuple[tuple[float, ...], ...] | None = None

    def __post_init__(self) -> None:
        if self.intrinsics is None:
            object.__setattr__(self, "intrinsics", clevr_intrinsics(self.width, self.height))
        ok = isinstance(self.jitter, (int, float)) and not isinstance(self.jitter, bool)
        if not (ok and math.isfinite(self.jitter) and self.jitter >= 0.0):
            raise InputError("CameraPrior.jitter", f"must be a finite number >= 0, got {self.jitter!r}")

    @classmethod
    def for_image(cls, image: ImageInput, config: SceneConfig | None = None) -> CameraPrior:
        """The prior for a loaded image: its working size and intrinsics, the jitter of ``config`` (default the
        world's default scene config)."""
        jitter = (config or SceneConfig()).camera_jitter
        return cls(image.size[0], image.size[1], jitter, image.intrinsics)

    @property
    def base_location(self) -> np.ndarray:
        return np.asarray(BASE_CAMERA_LOCATION, dtype=np.float64)

    @property
    def base(self) -> Camera:
        """The camera at the prior's centre (no jitter)."""
        return self.camera((0.0, 0.0, 0.0))

    def camera(self, offset: tuple[float, float, float] | np.ndarray) -> Camera:
        """The camera moved by ``offset`` from the base location, built like the world builds it (same rounding)."""
        cam = make_camera(self.width, self.height, tuple(float(v) for v in np.asarray(offset).reshape(3)))
        return dataclasses.replace(cam, intrinsics=self.intrinsics)

    def offset_of(self, camera: Camera) -> np.ndarray:
        """The location offset of ``camera`` from the base location."""
        return camera.location - self.base_location

    def contains(self, camera: Camera, tol: float = 1e-6) -> bool:
        """Whether ``camera`` has positive prior density: its offset within the jitter box, its rotation the
        base one."""
        rotation_ok = np.allclose(camera.matrix_world[:3, :3], self.base.matrix_world[:3, :3], atol=1e-6)
        return bool(rotation_ok and np.all(np.abs(self.offset_of(camera)) <= self.jitter + tol))

    def log_prob(self, offset: np.ndarray) -> np.ndarray:
        """Log density of location offsets (..., 3): uniform on the jitter box, ``-inf`` outside (a point mass at
        the base location, ``0`` there, when ``jitter`` is 0)."""
        offset = np.asarray(offset, dtype=np.float64)
        inside = np.all(np.abs(offset) <= self.jitter + 1e-12, axis=-1)
        density = 0.0 if self.jitter == 0 else -3.0 * math.log(2.0 * self.jitter)
        return np.where(inside, density, -np.inf)

    def candidate_offsets(self, steps: int = 2) -> np.ndarray:
        """A grid over the jitter box: ``steps`` = 2 gives the centre and the 8 corners (9 offsets), ``steps`` = 3
        the 27 points of a 3x3x3 grid (corners, edge and face centres, centre), in general ``steps`` evenly spaced
        values per axis plus the centre. The centre comes first."""
        if steps < 1:
            raise InputError("steps", f"must be >= 1, got {steps!r}")
        values = np.linspace(-self.jitter, self.jitter, steps) if steps > 1 else np.zeros(1)
        grid = [np.zeros(3)] + [np.array(p) for p in itertools.product(values, repeat=3) if np.any(p)]
        if self.jitter == 0:
            grid = grid[:1]
        return np.stack(grid)

    def candidates(self, steps: int = 2) -> list[Camera]:
        """The cameras of :meth:`candidate_offsets`, for a coarse search over the unknown jitter."""
        return [self.camera(o) for o in self.candidate_offsets(steps)]


# --- ground-plane geometry ----------------------------------------------------------------------------------------


def _camera_tensors(camera: Camera, like: Array) -> tuple[Array, Array, Array]:
    """(K, world-to-camera rotation, translation) as arrays of ``like``'s kind (numpy float64, or torch on its
    device and dtype)."""
    w2c = camera.world_to_camera()
    K, R, t = camera.K, w2c[:3, :3], w2c[:3, 3]
    if isinstance(like, torch.Tensor):
        dtype = like.dtype if like.is_floating_point() else torch.float64
        return tuple(torch.as_tensor(a, dtype=dtype, device=like.device) for a in (K, R, t))
    return K, R, t


def _as_points(points: Array) -> Array:
    if isinstance(points, torch.Tensor):
        return points if points.is_floating_point() else points.to(torch.float64)
    return np.asarray(points, dtype=np.float64)


def project_points(camera: Camera, points: Array) -> Array:
    """World points (..., 3) -> (..., 3) of (x pixel, y pixel from the top, depth along the viewing axis), exactly
    ``Camera.project`` but also for torch tensors (differentiable). Points behind the camera get depth <= 0."""
    pts = _as_points(points)
    K, R, t = _camera_tensors(camera, pts)
    cam = pts @ R.T + t
    depth = -cam[..., 2]
    x = K[0, 0] * cam[..., 0] / depth + K[0, 2]
    y = -K[1, 1] * cam[..., 1] / depth + K[1, 2]
    stack = torch.stack if isinstance(pts, torch.Tensor) else np.stack
    return stack([x, y, depth], -1)


def pixel_directions(camera: Camera, pixels: Array) -> Array:
    """Unit world directions (..., 3) of the rays through image points ``pixels`` (..., 2) (pixel units, origin at
    the top-left corner, y down: the centre of pixel (u, v) is (u + 0.5, v + 0.5), as in ``world.raycast``)."""
    px = _as_points(pixels)
    K, R, _ = _camera_tensors(camera, px)
    ones = torch.ones_like(px[..., 0]) if isinstance(px, torch.Tensor) else np.ones_like(px[..., 0])
    stack = torch.stack if isinstance(px, torch.Tensor) else np.stack
    local = stack([(px[..., 0] - K[0, 2]) / K[0, 0], -(px[..., 1] - K[1, 2]) / K[1, 1], -ones], -1)
    d = local @ R  # camera-to-world rotation is R.T, applied to row vectors
    norm = torch.linalg.norm(d, dim=-1, keepdim=True) if isinstance(d, torch.Tensor) else np.linalg.norm(
        d, axis=-1, keepdims=True)
    return d / norm


def backproject_to_plane(camera: Camera, pixels: Array, height: float | Array = 0.0) -> Array:
    """World points (..., 3) where the rays through ``pixels`` (..., 2) meet the horizontal plane z = ``height``
    (a number, or an array broadcasting with ``pixels[..., 0]``: e.g. an object's base or centre height).

    Where a ray is parallel to the plane or meets it behind the camera the result is NaN: the pixel shows no point
    of that plane (above the horizon, for the ground).
    """
    d = pixel_directions(camera, pixels)
    origin = camera.location
    if isinstance(d, torch.Tensor):
        o = torch.as_tensor(origin, dtype=d.dtype, device=d.device)
        h = torch.as_tensor(height, dtype=d.dtype, device=d.device)
        dz = d[..., 2]
        safe = torch.where(dz.abs() > 1e-12, dz, torch.ones_like(dz))
        s = (h - o[2]) / safe
        ok = (dz.abs() > 1e-12) & (s > 0)
        out = o + s[..., None] * d
        return torch.where(ok[..., None], out, torch.full_like(out, float("nan")))
    h = np.asarray(height, dtype=np.float64)
    dz = d[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (h - origin[2]) / dz
    ok = (np.abs(dz) > 1e-12) & (s > 0)
    out = origin + s[..., None] * d
    return np.where(ok[..., None], out, np.nan)


__all__ = [
    "ASPECT_TOLERANCE",
    "MAX_SIDE",
    "MIN_SIDE",
    "WORKING_SIZE",
    "CameraPrior",
    "ImageInput",
    "backproject_to_plane",
    "load_image",
    "pixel_directions",
    "project_points",
]

"""Image input (files, arrays, PIL; bad input refused with a typed error) and the camera prior with its
ground-plane geometry, checked against the world's own camera (``Camera.project``)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from po3d_ppl.errors import ImageError, InputError, Po3dError
from po3d_ppl.perception.image_input import (
    MAX_SIDE,
    MIN_SIDE,
    CameraPrior,
    backproject_to_plane,
    load_image,
    pixel_directions,
    project_points,
)
from po3d_ppl.world.sampler import SceneConfig, clevr_intrinsics, make_camera, sample_camera

cv2 = pytest.importorskip("cv2")


def _gradient(h: int = 48, w: int = 64) -> np.ndarray:
    """A uint8 RGB test image whose three channels differ (so a BGR/RGB mix-up shows)."""
    y, x = np.mgrid[0:h, 0:w]
    return np.stack([x * 255 // (w - 1), y * 255 // (h - 1), np.full_like(x, 40)], axis=-1).astype(np.uint8)


# --- reading ------------------------------------------------------------------------------------------------------


def test_a_png_file_reads_as_rgb_in_unit_range(tmp_path):
    rgb = _gradient(480, 640)
    path = tmp_path / "im.png"
    cv2.imwrite(str(path), rgb[..., ::-1])
    for source in (path, str(path)):
        im = load_image(source)
        assert im.pixels.shape == (3, 480, 640) and im.pixels.dtype == torch.float32
        assert not im.resized and im.original_size == (640, 480) and str(path) in im.source
        np.testing.assert_allclose(im.pixels.permute(1, 2, 0).numpy(), rgb / 255.0, atol=1e-6)
        assert im.intrinsics == clevr_intrinsics(640, 480)


def test_uint8_and_float_arrays_agree():
    rgb = _gradient(480, 640)
    a, b = load_image(rgb), load_image(rgb.astype(np.float64) / 255.0)
    torch.testing.assert_close(a.pixels, b.pixels)
    assert float(a.pixels.min()) >= 0.0 and float(a.pixels.max()) <= 1.0


@pytest.mark.parametrize("shape", [(480, 640), (480, 640, 1)])
def test_grayscale_becomes_rgb(shape):
    gray = np.linspace(0, 1, 480 * 640, dtype=np.float32).reshape(shape)
    im = load_image(gray)
    assert im.pixels.shape == (3, 480, 640)
    torch.testing.assert_close(im.pixels[0], im.pixels[2])
    torch.testing.assert_close(im.pixels[1], torch.from_numpy(gray.reshape(480, 640)))


def test_rgba_is_composited_over_grey(tmp_path):
    rgba = np.zeros((480, 640, 4), np.uint8)
    rgba[..., 0], rgba[:240, :, 3], rgba[240:, :, 3] = 255, 255, 0
    im = load_image(rgba)
    assert im.pixels.shape == (3, 480, 640)
    torch.testing.assert_close(im.pixels[:, 0, 0], torch.tensor([1.0, 0.0, 0.0]))   # opaque: its own colour
    torch.testing.assert_close(im.pixels[:, -1, 0], torch.tensor([0.5, 0.5, 0.5]))  # transparent: background
    path = tmp_path / "rgba.png"
    cv2.imwrite(str(path), rgba[..., [2, 1, 0, 3]])
    torch.testing.assert_close(load_image(path).pixels, im.pixels)


def test_16_bit_grayscale_png(tmp_path):
    gray = (np.arange(480 * 640).reshape(480, 640) % 65536).astype(np.uint16)
    path = tmp_path / "g16.png"
    cv2.imwrite(str(path), gray)
    im = load_image(path)
    np.testing.assert_allclose(im.pixels[1].numpy(), gray / 65535.0, atol=1e-6)


def test_pil_images_of_every_common_mode():
    Image = pytest.importorskip("PIL.Image")
    rgb = _gradient(480, 640)
    base = Image.fromarray(rgb)
    want = load_image(rgb).pixels
    torch.testing.assert_close(load_image(base).pixels, want)
    torch.testing.assert_close(load_image(base.convert("RGBA")).pixels, want)
    for mode in ("L", "P", "LA", "1", "CMYK"):
        im = load_image(base.convert(mode))
        assert im.pixels.shape == (3, 480, 640) and "PIL image" in im.source


# --- resizing -----------------------------------------------------------------------------------------------------


def test_a_larger_4_3_image_is_resized_with_its_intrinsics():
    im = load_image(np.zeros((960, 1280, 3), np.uint8))
    assert im.size == (640, 480) and im.original_size == (1280, 960) and im.resized
    np.testing.assert_allclose(im.K, np.asarray(clevr_intrinsics(640, 480)), atol=1e-9)
    np.testing.assert_allclose(im.to_original(np.array([[320.0, 240.0]])), [[640.0, 480.0]])


def test_resized_intrinsics_match_where_the_world_puts_points():
    """A point the world's 320x240 camera sees at pixel p appears at p * 2 in the working image, which is where
    the prior's camera for that image projects it."""
    small = make_camera(320, 240, (0.2, -0.1, 0.3))
    im = load_image(np.zeros((240, 320, 3), np.uint8))
    prior = CameraPrior.for_image(im)
    cam = prior.camera((0.2, -0.1, 0.3))
    points = np.random.default_rng(0).uniform(-3, 3, size=(50, 3)) * [1, 1, 0.3]
    np.testing.assert_allclose(cam.project(points)[:, :2], small.project(points)[:, :2] * 2, atol=1e-9)


def test_aspect_within_one_percent_is_resized_per_axis():
    im = load_image(np.zeros((481, 643, 3), np.uint8))  # 1.3368 vs 4:3: 0.26% off
    sx, sy = 640 / 643, 480 / 481
    K0 = np.asarray(clevr_intrinsics(643, 481))
    np.testing.assert_allclose(im.K, np.diag([sx, sy, 1.0]) @ K0)
    assert im.size == (640, 480)


def test_a_loaded_image_passes_through():
    im = load_image(_gradient(480, 640))
    assert load_image(im) is im


def test_a_smaller_working_size():
    im = load_image(_gradient(480, 640), size=(160, 120))
    assert im.pixels.shape == (3, 120, 160)
    np.testing.assert_allclose(im.K, np.asarray(clevr_intrinsics(160, 120)), atol=1e-9)


# --- bad input ----------------------------------------------------------------------------------------------------


def _refused(image, *words, **kwargs) -> str:
    with pytest.raises(ImageError) as err:
        load_image(image, **kwargs)
    assert isinstance(err.value, Po3dError) and isinstance(err.value, ValueError)
    text = str(err.value)
    for word in words:
        assert word in text, text
    return text


def test_missing_corrupt_and_non_image_files_name_the_file(tmp_path):
    _refused(tmp_path / "nope.png", "nope.png", "no such")
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"\x89PNG\r\n\x1a\n" + b"garbage" * 10)
    _refused(bad, "bad.png", "not a readable image")
    empty = tmp_path / "empty.jpg"
    empty.write_bytes(b"")
    _refused(empty, "empty.jpg")
    _refused(tmp_path, str(tmp_path), "not a file")


def test_truncated_png_is_refused_or_read_but_never_crashes(tmp_path):
    path = tmp_path / "full.png"
    cv2.imwrite(str(path), _gradient(480, 640))
    cut = tmp_path / "cut.png"
    cut.write_bytes(path.read_bytes()[:200])
    _refused(cut, "cut.png")


@pytest.mark.parametrize("array, words", [
    (np.zeros((480, 640, 3), np.int64), ("dtype", "uint8", "int64")),
    (np.zeros((480, 640, 3), bool), ("dtype", "bool")),
    (np.zeros((480, 640, 5), np.uint8), ("expected shape", "(480, 640, 5)")),
    (np.zeros((3, 480, 640), np.uint8), ("channels first",)),
    (np.zeros((480,), np.uint8), ("expected shape",)),
    (np.full((480, 640, 3), 255.0), ("[0, 1]", "divide by 255")),
    (np.full((480, 640, 3), -0.1), ("[0, 1]",)),
])
def test_bad_arrays_say_what_was_expected(array, words):
    _refused(array, *words)


def test_nan_is_refused():
    a = np.zeros((480, 640, 3), np.float32)
    a[3, 4, 1] = np.nan
    _refused(a, "NaN")


@pytest.mark.parametrize("shape", [(24, 32), (15, 20, 3), (4104, 5472)])
def test_extreme_resolutions_are_refused_with_the_limits(shape):
    _refused(np.zeros(shape, np.uint8), str(MIN_SIDE), str(MAX_SIDE))


@pytest.mark.parametrize("shape", [(360, 640, 3), (640, 480, 3), (480, 660, 3)])
def test_other_aspect_ratios_are_refused_saying_why(shape):
    _refused(np.zeros(shape, np.uint8), "aspect ratio", "crop or pad")


def test_unsupported_objects():
    _refused(torch.zeros(3, 480, 640), "torch tensor", "permute")
    _refused([[0, 1], [2, 3]], "expected a file path")


# --- camera prior -------------------------------------------------------------------------------------------------


def test_the_prior_is_the_worlds_camera_distribution():
    prior = CameraPrior()
    assert prior.base == make_camera(640, 480)
    assert prior.jitter == SceneConfig().camera_jitter
    rng = np.random.default_rng(7)
    for _ in range(20):
        cam = sample_camera(rng, SceneConfig())
        assert prior.contains(cam)
        assert math.isfinite(float(prior.log_prob(prior.offset_of(cam))))
    assert not prior.contains(make_camera(640, 480, (0.6, 0.0, 0.0)))
    assert prior.log_prob(np.array([0.0, 0.0, 0.7])) == -np.inf
    assert np.isclose(prior.log_prob(np.zeros(3)), -3 * math.log(1.0))


def test_candidate_grid():
    prior = CameraPrior()
    cams = prior.candidates()
    assert len(cams) == 9 and cams[0] == prior.base and all(prior.contains(c) for c in cams)
    offsets = np.stack([prior.offset_of(c) for c in cams])
    np.testing.assert_allclose(np.abs(offsets[1:]), 0.5, atol=1e-6)
    assert len(prior.candidates(3)) == 27 and len(prior.candidates(1)) == 1
    assert len(CameraPrior(jitter=0.0).candidates(3)) == 1
    with pytest.raises(InputError):
        prior.candidates(0)
    with pytest.raises(InputError, match="jitter"):
        CameraPrior(jitter=-1.0)


# --- geometry -----------------------------------------------------------------------------------------------------


def _cameras():
    return [make_camera(640, 480), make_camera(640, 480, (0.5, -0.5, 0.3)), make_camera(320, 240, (-0.4, 0.2, -0.5))]


def test_project_points_matches_camera_project_for_numpy_and_torch():
    points = np.random.default_rng(1).uniform(-3, 3, size=(200, 3)) * [1, 1, 0.5] + [0, 0, 0.5]
    for cam in _cameras():
        want = cam.project(points)
        np.testing.assert_allclose(project_points(cam, points), want, atol=1e-9)
        got = project_points(cam, torch.from_numpy(points))
        assert got.dtype == torch.float64
        np.testing.assert_allclose(got.numpy(), want, atol=1e-9)


@pytest.mark.parametrize("height", [0.0, 0.35])
def test_backprojection_onto_a_plane_round_trips(height):
    rng = np.random.default_rng(2)
    for cam in _cameras():
        ground = np.concatenate([rng.uniform(-3, 3, size=(300, 2)), np.full((300, 1), height)], axis=1)
        px = cam.project(ground)[:, :2]
        back = backproject_to_plane(cam, px, height)
        np.testing.assert_allclose(back, ground, atol=1e-6)
        np.testing.assert_allclose(project_points(cam, back)[:, :2], px, atol=1e-6)
        back_t = backproject_to_plane(cam, torch.from_numpy(px), height)
        np.testing.assert_allclose(back_t.numpy(), ground, atol=1e-6)


def test_per_point_heights_and_pixel_directions():
    cam = make_camera(640, 480, (0.1, 0.2, -0.3))
    pts = np.array([[0.5, -1.0, 0.0], [1.0, 2.0, 0.4], [-2.0, 0.5, 1.2]])
    px = cam.project(pts)[:, :2]
    np.testing.assert_allclose(backproject_to_plane(cam, px, pts[:, 2]), pts, atol=1e-6)
    d = pixel_directions(cam, px)
    want = (pts - cam.location) / np.linalg.norm(pts - cam.location, axis=1, keepdims=True)
    np.testing.assert_allclose(d, want, atol=1e-9)


def test_pixels_above_the_horizon_give_nan():
    cam = make_camera(640, 480)
    out = backproject_to_plane(cam, np.array([[320.0, -5000.0], [320.0, 400.0]]))
    assert np.isnan(out[0]).all() and np.isfinite(out[1]).all()
    out_t = backproject_to_plane(cam, torch.tensor([[320.0, -5000.0], [320.0, 400.0]], dtype=torch.float64))
    assert torch.isnan(out_t[0]).all() and torch.isfinite(out_t[1]).all()


def test_gradients_flow_through_the_geometry():
    cam = make_camera(640, 480)
    px = torch.tensor([[300.0, 350.0]], dtype=torch.float64, requires_grad=True)
    ground = backproject_to_plane(cam, px, 0.0)
    ground[..., :2].sum().backward()
    assert px.grad is not None and torch.isfinite(px.grad).all() and px.grad.abs().sum() > 0
    pts = torch.tensor([[0.3, 0.2, 0.1]], dtype=torch.float32, requires_grad=True)
    out = project_points(cam, pts)
    assert out.dtype == torch.float32
    out[..., 0].sum().backward()
    assert torch.isfinite(pts.grad).all()
    np.testing.assert_allclose(out.detach().numpy(), cam.project(pts.detach().numpy().astype(np.float64)), atol=1e-3)

"""The viewpoint network: bins and their mirror map, soft targets, mirror-equivariant inference, the product with
the render-and-compare pose table, a tiny seeded training run that learns, save/load with checksums, and the
shipped weights through the scene parser. Tiny configurations, except the shipped-weights test."""

from __future__ import annotations

import json
import math

import pytest
import torch

from po3d_ppl import ontology
from po3d_ppl.errors import InputError, ModelFileError
from po3d_ppl.perception.train_attributes import scene_data
from po3d_ppl.perception.train_viewpoint import (
    ViewpointData,
    ViewpointTrainConfig,
    angular_error,
    calibrate_viewpoint,
    crop_logits,
    cut_masks,
    measure,
    train_viewpoint,
)
from po3d_ppl.perception.viewpoint import (
    WEIGHTS,
    ViewpointConfig,
    ViewpointNet,
    combine_pose,
    load_viewpoint_net,
    mirror_bins,
    save_viewpoint_net,
    soft_azimuth_targets,
)

TINY = ViewpointConfig(azimuth_bins=12, object_size=16, object_widths=(4, 8, 8, 8), hidden=16)


def test_mirror_bins_is_an_involution_fixing_front_and_back():
    m = mirror_bins(24)
    assert torch.equal(m[m], torch.arange(24))
    assert int(m[0]) == 0 and int(m[12]) == 12  # seen from behind / from the front: a mirror keeps them
    assert int(m[6]) == 18  # 90 degrees clockwise -> 270


def test_soft_targets_split_between_the_two_nearest_bins():
    t = soft_azimuth_targets(torch.tensor([0.0, 7.5, 352.5, 30.0, -15.0]), 24)
    assert torch.allclose(t.sum(-1), torch.ones(5))
    assert float(t[0, 0]) == 1.0
    assert float(t[1, 0]) == pytest.approx(0.5) and float(t[1, 1]) == pytest.approx(0.5)
    assert float(t[2, 23]) == pytest.approx(0.5) and float(t[2, 0]) == pytest.approx(0.5)
    assert float(t[3, 2]) == 1.0 and float(t[4, 23]) == 1.0


def test_eval_logits_are_mirror_equivariant(torch_one_thread):
    torch.manual_seed(0)
    net = ViewpointNet(TINY).eval()
    crops, geometry = torch.rand(3, 4, 16, 16), torch.rand(3, 9)
    geometry_mirror = geometry.clone()
    geometry_mirror[:, 0] = 1 - geometry_mirror[:, 0]
    direct = net.logits(crops, geometry)
    mirrored = net.logits(crops.flip(-1), geometry_mirror)
    assert torch.allclose(mirrored, direct[:, mirror_bins(TINY.azimuth_bins)], atol=1e-5)


def test_combine_pose_is_a_normalised_product():
    rc = torch.log_softmax(torch.randn(2, 5, 12, dtype=torch.float64), -1)
    support = (torch.arange(12, dtype=torch.float64) * 30.0).expand(2, 12)
    vp = torch.log_softmax(torch.randn(2, 12), -1)
    out = combine_pose(rc, support, vp)
    assert out.shape == (2, 5, 12)
    assert torch.allclose(out.exp().sum(-1), torch.ones(2, 5, dtype=torch.float64))
    expected = torch.log_softmax(rc[1, 3] + vp[1].double(), -1)
    assert torch.allclose(out[1, 3], expected)
    assert torch.allclose(combine_pose(rc, support, vp, weight=0.0), rc)
    tempered = combine_pose(rc, support, vp, weight=0.5, temperature=2.0)
    assert torch.allclose(tempered[0, 1], torch.log_softmax((rc[0, 1] + 0.5 * vp[0].double()) / 2.0, -1))
    with pytest.raises(InputError, match="temperature"):
        combine_pose(rc, support, vp, temperature=0.0)
    with pytest.raises(InputError, match="viewpoint_loglik"):
        combine_pose(rc, support, vp[:, :6])
    with pytest.raises(InputError, match="bins"):
        combine_pose(rc, support + 7.0, vp)


def test_angular_error_wraps():
    assert angular_error(torch.tensor([350.0, 10.0, 180.0]), torch.tensor([10.0, 350.0, 0.0])).tolist() == \
        [20.0, 20.0, 180.0]


def test_cut_masks_removes_one_side_of_the_mask_and_keeps_the_image():
    crops = torch.rand(8, 4, 24, 24)
    crops[:, 3] = 0.0
    crops[:, 3, 4:20, 2:22] = 1.0
    crops[7, 3] = 0.0  # an empty mask stays empty
    config = ViewpointTrainConfig(mask_cut=1.0, mask_cut_share=(0.2, 0.4))
    cut = cut_masks(crops, config, torch.Generator().manual_seed(0))
    assert torch.equal(cut[:, :3], crops[:, :3])
    kept = cut[:7, 3].sum((1, 2)) / crops[:7, 3].sum((1, 2))
    assert bool(((kept >= 0.58) & (kept <= 0.82)).all()), kept
    assert bool((cut[:, 3] <= crops[:, 3]).all()) and float(cut[7, 3].sum()) == 0.0
    untouched = cut_masks(crops, ViewpointTrainConfig(mask_cut=0.0), torch.Generator().manual_seed(0))
    assert torch.equal(untouched, crops)
    with pytest.raises(InputError, match="mask_cut"):
        ViewpointTrainConfig(mask_cut=1.5)


@pytest.fixture(scope="module")
def data(torch_one_thread):
    from po3d_ppl.world import SceneConfig, generate_scene

    config = SceneConfig(width=320, height=240, max_objects=5, min_objects=4)
    items = []
    for i, seed in enumerate((41, 42, 43)):
        rendered = generate_scene(seed, config)
        pixels = torch.from_numpy(rendered.image).permute(2, 0, 1).float() / 255
        objects = rendered.scene.objects
        items.append(ViewpointData(
            scene_data(pixels, rendered.scene, TINY.crops, i),
            torch.tensor([float(o.pose_degree) for o in objects], dtype=torch.float64),
            torch.tensor([ontology.CATEGORIES.index(o.category) for o in objects]),
            torch.tensor([int(o.annotation.visible_pixels) for o in objects])))
    return ViewpointData.concat(items)


def test_tiny_training_is_seeded_and_learns(data):
    config = ViewpointTrainConfig(seed=3, epochs=40, batch_size=8, lr=1e-2, flip=False, mask_jitter=0.0,
                                  window_jitter=0.0, net=TINY)
    first = train_viewpoint(data, config)
    again = train_viewpoint(data, config)
    for a, b in zip(first.net.state_dict().values(), again.net.state_dict().values()):
        assert torch.equal(a, b)
    assert first.history[-1]["azimuth"] < first.history[0]["azimuth"] - 1.0
    assert first.steps == 40 * math.ceil(data.num_objects / 8)
    calibration = calibrate_viewpoint(first.net, data)
    assert 0.25 <= calibration["temperature"] <= 1000
    report = measure(first.net, data, min_pixels=0)
    assert report["objects"] == data.num_objects and 0.0 <= report["within_30"] <= 1.0
    assert crop_logits(first.net, data).shape == (data.num_objects, TINY.azimuth_bins)


def test_save_load_round_trip_and_checksum(tmp_path, torch_one_thread):
    torch.manual_seed(1)
    net = ViewpointNet(TINY)
    net.temperature.fill_(2.5)
    save_viewpoint_net(net, tmp_path, command="test", data_seed=0)
    loaded = load_viewpoint_net(tmp_path)
    assert float(loaded.temperature) == 2.5 and loaded.config == TINY
    crops, geometry = torch.rand(2, 4, 16, 16), torch.rand(2, 9)
    assert torch.allclose(loaded.logits(crops, geometry), net.eval().logits(crops, geometry))
    entry = json.loads((tmp_path / "manifest.json").read_text())["viewpoint"]
    assert entry["command"] == "test" and WEIGHTS in entry["files"]
    with open(tmp_path / WEIGHTS, "r+b") as f:
        f.seek(-4, 2)
        f.write(b"\0\0\0\0")
    with pytest.raises(ModelFileError, match="sha256"):
        load_viewpoint_net(tmp_path)


def test_azimuth_loglik_reads_masks_and_refuses_bad_ones(torch_one_thread):
    net = ViewpointNet(TINY).eval()
    image = torch.rand(3, 40, 60)
    masks = torch.zeros(2, 40, 60, dtype=torch.bool)
    masks[0, 5:20, 5:30] = True
    masks[1, 20:35, 30:55] = True
    out = net.azimuth_loglik(image, masks)
    assert out.shape == (2, TINY.azimuth_bins)
    assert torch.allclose(out.exp().sum(-1), torch.ones(2), atol=1e-5)
    assert net.azimuth_loglik(image, masks[:0]).shape == (0, TINY.azimuth_bins)
    with pytest.raises(InputError, match="masks"):
        net.azimuth_loglik(image, masks[:, :10])

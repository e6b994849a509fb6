"""The centre head: targets, loss, peaks, training and its files (perception/centres.py, train_centres.py)."""

from __future__ import annotations

import math
import shutil

import pytest
import torch

from po3d_ppl.errors import InputError, ModelFileError
from po3d_ppl.perception.centres import (
    CentreConfig,
    CentreNet,
    centre_peaks,
    load_centre_net,
    save_centre_net,
)
from po3d_ppl.perception.train_centres import (
    CentreData,
    CentreTrainConfig,
    centre_targets,
    focal_loss,
    measure,
    train_centres,
)


def _objects(rows):
    """Object rows (image, base x, base y, visible px, occluded, box w, box h, index)."""
    return torch.tensor(rows, dtype=torch.float32).reshape(-1, 8)


def test_targets_peak_at_each_visible_objects_cell_and_leave_out_barely_visible_ones():
    objects = _objects([[0, 8 * 5 + 4, 8 * 3 + 4, 900, 0, 40, 40, 0],   # cell (row 3, col 5)
                        [0, 8 * 12 + 4, 8 * 6 + 4, 20, 1, 10, 10, 1],   # 20 visible pixels: no positive
                        [1, 8 * 2 + 4, 8 * 7 + 4, 400, 1, 20, 20, 0]])
    target, weight = centre_targets(objects, images=2, size=(10, 16), min_pixels=50)
    assert target[0, 3, 5] == 1.0 and target[1, 7, 2] == 1.0
    assert int((target == 1.0).sum()) == 2  # one exact peak per positive
    assert 0 < target[0, 3, 6] < 1.0  # a Gaussian around it
    assert target[0, 6, 12] < 0.01 and weight[0, 6, 12] == 0.0  # the faint object is neither positive nor negative
    assert weight[0, 0, 0] == 1.0 and weight[1].min() == 1.0


def test_focal_loss_is_lower_for_logits_that_agree_with_the_targets():
    objects = _objects([[0, 36, 28, 900, 0, 40, 40, 0]])
    target, weight = centre_targets(objects, 1, (8, 8), 50)
    good = torch.where(target >= 1.0, torch.tensor(4.0), torch.tensor(-6.0))
    assert focal_loss(good, target, weight) < 0.1 * focal_loss(torch.zeros_like(good), target, weight)


def test_peaks_are_local_maxima_over_the_threshold_most_probable_first_at_cell_centres():
    heat = torch.zeros(6, 8)
    heat[1, 2], heat[4, 6], heat[4, 5], heat[0, 7] = 0.6, 0.9, 0.8, 0.2
    peaks = centre_peaks(heat, 0.3)
    assert len(peaks) == 2  # (4, 5) is next to the higher (4, 6); (0, 7) is under the threshold
    assert peaks.probabilities.tolist() == pytest.approx([0.9, 0.6])
    assert peaks.pixels.tolist() == [[6 * 8 + 4, 4 * 8 + 4], [2 * 8 + 4, 1 * 8 + 4]]
    assert len(centre_peaks(heat, 0.95)) == 0
    with pytest.raises(InputError, match="heatmap"):
        centre_peaks(heat[None], 0.3)


def test_the_net_maps_features_to_one_logit_per_cell_and_rejects_other_shapes():
    net = CentreNet(CentreConfig(feature_dim=8, width=8, dilations=(1, 2)))
    assert net(torch.randn(2, 8, 5, 7)).shape == (2, 5, 7)
    heat = net.heatmap(torch.randn(8, 5, 7))
    assert heat.shape == (5, 7) and float(heat.min()) >= 0.0 and float(heat.max()) <= 1.0
    with pytest.raises(InputError, match="features"):
        net(torch.randn(2, 6, 5, 7))
    with pytest.raises(InputError, match="CentreConfig.dilations"):
        CentreConfig(dilations=())


def _toy_data(images: int = 12) -> CentreData:
    """Features that carry a bump where each object stands: a head can learn it in a few steps."""
    g = torch.Generator().manual_seed(3)
    features = 0.1 * torch.randn(images, 8, 8, 10, generator=g)
    rows = []
    for i in range(images):
        r, c = int(torch.randint(1, 7, (1,), generator=g)), int(torch.randint(1, 9, (1,), generator=g))
        features[i, 0, r, c] += 3.0
        rows.append([i, 8 * c + 4, 8 * r + 4, 500, float(i % 2), 30, 30, 0])
    return CentreData(features.half(), _objects(rows), torch.arange(images))


def test_training_learns_the_toy_centres_and_is_reproducible_from_its_seed():
    data = _toy_data()
    config = CentreTrainConfig(epochs=30, batch_size=4, lr=0.01, net=CentreConfig(feature_dim=8, width=8,
                                                                                   dilations=(1, 1)))
    torch.set_num_threads(1)
    first = train_centres(data, config)
    again = train_centres(data, config)
    assert first.history[-1]["focal"] < 0.5 * first.history[0]["focal"]
    for name, value in first.net.state_dict().items():
        assert torch.equal(value, again.net.state_dict()[name]), name
    report = measure(first.net, data, thresholds=(0.3,), min_pixels=200)
    assert report["objects"] == 12 and report["occluded_objects"] == 6
    assert report["threshold_0.3"]["recall"] >= 0.9


def test_the_saved_head_loads_only_beside_the_features_it_was_trained_on(tmp_path):
    from po3d_ppl.model_store import models_dir
    from po3d_ppl.perception.centres import features_sha256

    shutil.copy(models_dir() / "perception_features.safetensors", tmp_path)
    shutil.copy(models_dir() / "manifest.json", tmp_path)
    net = CentreNet(CentreConfig(feature_dim=64, width=8, dilations=(1,)))
    save_centre_net(net, tmp_path, features_sha256(tmp_path), command="test")
    loaded = load_centre_net(tmp_path)
    for name, value in net.state_dict().items():
        assert torch.equal(value, loaded.state_dict()[name]), name
    save_centre_net(net, tmp_path, "0" * 64, command="test")  # trained on other features
    with pytest.raises(ModelFileError, match="trained on features"):
        load_centre_net(tmp_path)
    (tmp_path / "centres.safetensors").write_bytes(b"corrupt")
    with pytest.raises(ModelFileError, match="sha256|bytes"):
        load_centre_net(tmp_path)


def test_the_log_prior_reads_the_heatmap_between_cell_centres_with_a_floor():
    """log_centre_prior: at a cell centre the log of that cell, halfway between two cells the log of their mean
    (bilinear), and never below log(floor)."""
    from po3d_ppl.perception.centres import log_centre_prior

    heat = torch.zeros(3, 4)
    heat[1, 1], heat[1, 2] = 0.8, 0.4
    pixels = torch.tensor([[12.0, 12.0], [16.0, 12.0], [28.0, 4.0]])  # cell (1, 1); between (1, 1) and (1, 2); far
    got = log_centre_prior(heat, pixels, floor=1e-3)
    assert got[0] == pytest.approx(math.log(0.8), abs=1e-5)
    assert got[1] == pytest.approx(math.log(0.6), abs=1e-5)
    assert got[2] == pytest.approx(math.log(1e-3), abs=1e-5)

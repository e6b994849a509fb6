"""The feature extractor, the neural meshes and their contrastive training (issue "Perception I", items 3-4): shapes
and normalisation, determinism, a tiny run that learns, save/load with checksums, and the supervision's geometry
against the world's annotations. Tiny configurations only (the suite has no GPU and little time)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from po3d_ppl import ontology
from po3d_ppl.errors import InputError, ModelFileError
from po3d_ppl.perception.features import FeatureConfig, FeatureExtractor, extract_features, feature_map_size
from po3d_ppl.perception.neural_mesh import (
    MODEL_NAME,
    WEIGHTS,
    FeatureModel,
    NeuralMeshes,
    load_feature_model,
    save_feature_model,
)
from po3d_ppl.perception.train_features import (
    TrainConfig,
    evaluate_features,
    fit_textures,
    project_scene_vertices,
    roc_auc,
    train_features,
    training_image,
)

TINY = FeatureConfig(dim=16, widths=(8, 8, 16, 16, 16))


def tiny_config(**kw) -> TrainConfig:
    base = {"seed": 3, "epochs": 50, "batch_size": 2, "crop": (96, 128), "clutter_size": 64,
            "clutter_per_image": 8, "max_anchors_per_object": 32, "max_steps": 12, "feature": TINY}
    return TrainConfig(**{**base, **kw})


@pytest.fixture(scope="module")
def rendered():
    from po3d_ppl.world import SceneConfig, generate_scene

    config = SceneConfig(width=320, height=240, max_objects=5, min_objects=4)
    return [generate_scene(seed, config) for seed in (21, 22)]


@pytest.fixture(scope="module")
def images(rendered, torch_one_thread):
    return [training_image(torch.from_numpy(r.image).permute(2, 0, 1).contiguous(), r.scene, f"s{i}")
            for i, r in enumerate(rendered)]


def test_features_have_stride_8_and_unit_length(torch_one_thread):
    torch.manual_seed(0)
    net = FeatureExtractor(TINY)
    out = net(torch.rand(2, 3, 64, 96))
    assert out.shape == (2, 16, 8, 12)
    assert torch.allclose(out.norm(dim=1), torch.ones(2, 8, 12), atol=1e-5)
    single = extract_features(net, torch.rand(3, 70, 90))     # sizes that are not multiples of 8 round up
    assert single.shape == (16, *feature_map_size(70, 90)) == (16, 9, 12)
    assert feature_map_size(480, 640) == (60, 80)
    with pytest.raises(InputError, match="images"):
        net(torch.rand(3, 64, 64))
    with pytest.raises(InputError, match="dim"):
        FeatureConfig(dim=2)


def test_supervision_matches_the_worlds_annotations(rendered, images):
    from scipy.ndimage import binary_dilation

    for r, image in zip(rendered, images):
        objects, owner = project_scene_vertices(r.scene, vis_stride=2)
        # the posed category meshes cover the world's objects, and the z-buffer gives most pixels to the right one
        # (not all: a nearer object's category mesh, which wraps all its category's subtypes, overhangs its subtype
        # and may cover a farther object's pixels)
        world = r.object_ids[1::2, 1::2]
        seen = world >= 0
        assert (owner[seen] >= 0).mean() >= 0.97
        assert (owner[seen] == world[seen]).mean() >= 0.85
        own = []
        for i, obj in enumerate(objects):
            vis = obj.visible
            assert 20 <= vis.sum() < 0.8 * vis.size, (i, vis.sum())       # back faces are never visible
            px = np.floor(obj.xy[vis]).astype(int)
            ids = r.object_ids[px[:, 1], px[:, 0]]
            own.append(ids[ids >= 0] == i)
            # a visible vertex is not behind the world's surface at its pixel (hidden vertices were dropped)
            depth = r.depth[px[:, 1], px[:, 0]]
            assert (obj.depth[vis] <= depth + 0.25).mean() >= 0.97, i
        # a visible vertex over some object's pixel is mostly over its own (others: its category mesh overhangs a
        # farther object; vertices over the ground: the mesh wraps every subtype of the category)
        assert np.concatenate(own).mean() >= 0.75
        # the anchors of training: visible vertices over their own object's mask (grown by MASK_SLACK pixels)
        for i, obj in enumerate(image.objects):
            mask = binary_dilation(r.object_ids == i, iterations=2)
            assert obj.usable.sum() > 0 and not (obj.usable & ~obj.visible).any()
            upx = np.floor(obj.xy[obj.usable]).astype(int)
            assert mask[upx[:, 1], upx[:, 0]].all()
        assert image.background.shape == feature_map_size(240, 320)
        assert not (image.background & (image.object_fraction > 0)).any()


def test_training_is_deterministic_and_the_loss_falls(images, torch_one_thread):
    a = train_features(images, tiny_config(max_steps=40), log_every=10)
    losses = [h["loss"] for h in a.history]
    assert losses[-1] < losses[0] - 0.5, losses
    b = train_features(images, tiny_config(max_steps=3), log_every=1)
    c = train_features(images, tiny_config(max_steps=3), log_every=1)
    d = train_features(images, tiny_config(max_steps=3, seed=4), log_every=1)
    for (k, v), w in zip(b.model.extractor.state_dict().items(), c.model.extractor.state_dict().values()):
        assert torch.equal(v, w), k
    assert all(torch.equal(b.model.meshes.textures[k], c.model.meshes.textures[k]) for k in ontology.CATEGORIES)
    assert torch.equal(b.model.meshes.clutter, c.model.meshes.clutter)
    assert [h["loss"] for h in b.history] == [h["loss"] for h in c.history]
    assert not torch.equal(b.model.meshes.clutter, d.model.meshes.clutter)
    tex = a.model.meshes.textures["car"]
    assert torch.allclose(tex.norm(dim=1), torch.ones(len(tex)), atol=1e-4)


def test_measurement_runs_and_is_bounded(images, torch_one_thread):
    torch.manual_seed(0)
    net = FeatureExtractor(TINY).eval()
    metrics = evaluate_features(FeatureModel(net, fit_textures(net, images, clutter_size=32)), images)
    for key in ("within_exact", "within_radius", "across_exact", "across_radius", "category_top1", "fg_bg_auc"):
        assert 0.0 <= metrics[key] <= 1.0, key
    assert metrics["within_exact"] <= metrics["within_radius"]
    assert metrics["across_radius"] <= metrics["within_radius"] + 1e-9
    assert metrics["visible_vertices"] > 100


def test_roc_auc():
    assert roc_auc(np.array([2.0, 3.0]), np.array([0.0, 1.0])) == 1.0
    assert roc_auc(np.array([0.0]), np.array([1.0])) == 0.0
    assert roc_auc(np.array([1.0, 1.0]), np.array([1.0])) == 0.5


def _model(seed: int = 0) -> FeatureModel:
    from po3d_ppl.perception.category_meshes import category_mesh

    torch.manual_seed(seed)
    g = torch.Generator().manual_seed(seed)
    textures = {c: torch.nn.functional.normalize(torch.randn(category_mesh(c).num_vertices, TINY.dim, generator=g),
                                                 dim=1) for c in ontology.CATEGORIES}
    return FeatureModel(FeatureExtractor(TINY).eval(), NeuralMeshes(textures, torch.randn(8, TINY.dim, generator=g)))


def test_save_load_round_trip_and_checksums(tmp_path, torch_one_thread):
    (tmp_path / "manifest.json").write_text(json.dumps({"other": {"files": {}, "command": "keep me"}}))
    model = _model()
    path = save_feature_model(model, tmp_path, command="test", data_seed=[1], metrics={"x": 1})
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    assert manifest["other"]["command"] == "keep me"
    assert manifest[MODEL_NAME]["command"] == "test" and WEIGHTS in manifest[MODEL_NAME]["files"]
    loaded = load_feature_model(tmp_path)
    x = torch.rand(1, 3, 48, 64)
    assert torch.equal(loaded.extractor(x), model.extractor(x))
    for c in ontology.CATEGORIES:
        assert torch.equal(loaded.meshes.textures[c], model.meshes.textures[c])
    assert torch.equal(loaded.meshes.clutter, model.meshes.clutter)
    data = bytearray(path.read_bytes())
    data[-5] ^= 0xFF
    path.write_bytes(bytes(data))
    with pytest.raises(ModelFileError, match="sha256"):
        load_feature_model(tmp_path)
    path.unlink()
    with pytest.raises(ModelFileError, match="missing"):
        load_feature_model(tmp_path)


def test_textures_must_match_the_meshes(tmp_path):
    model = _model()
    bad = NeuralMeshes({**model.meshes.textures, "car": model.meshes.textures["car"][:-1]}, model.meshes.clutter)
    with pytest.raises(InputError, match="car"):
        save_feature_model(FeatureModel(model.extractor, bad), tmp_path)
    with pytest.raises(InputError, match="missing"):
        NeuralMeshes({"car": model.meshes.textures["car"]}, model.meshes.clutter)


def test_cli_trains_records_and_evaluates(tmp_path, torch_one_thread):
    import typer
    from typer.testing import CliRunner

    from po3d_ppl.cli.perception import register
    from po3d_ppl.questions.dataset import BuildConfig, build_dataset

    data = tmp_path / "data"
    build_dataset(data, BuildConfig(scenes=3, seed=5, min_objects=3, max_objects=4))
    app, train_app, eval_app = typer.Typer(), typer.Typer(), typer.Typer()
    app.add_typer(train_app, name="train")
    app.add_typer(eval_app, name="eval")
    register(app, train_app, eval_app)
    out = tmp_path / "models"
    result = CliRunner().invoke(app, ["train", "perception", "--data", str(data), "--out", str(out), "--seed", "1",
                                      "--max-steps", "2", "--batch-size", "1", "--crop", "64x96", "--dim", "8",
                                      "--splits", "train,val,test", "--eval-data", str(data), "--eval-limit", "1"])
    assert result.exit_code == 0, result.output
    entry = json.loads((out / "manifest.json").read_text())[MODEL_NAME]
    assert entry["data_seed"] == [5] and "--max-steps 2" in entry["command"]
    assert set(entry["metrics"]["eval_seed5"]) >= {"trained", "untrained_fitted_textures"}
    assert load_feature_model(out).extractor.config.dim == 8
    result = CliRunner().invoke(app, ["eval", "perception", "--data", str(data), "--model-dir", str(out),
                                      "--limit", "1", "--record"])
    assert result.exit_code == 0, result.output
    assert "command" in json.loads((out / "manifest.json").read_text())[MODEL_NAME]["metrics"]["eval_seed5"]


def test_textures_of_other_meshes_are_refused(tmp_path):
    from po3d_ppl.perception import neural_mesh

    path = save_feature_model(_model(), tmp_path)
    header = neural_mesh._mesh_header()
    header["bus"] = {**header["bus"], "digest": "0" * 16}
    with pytest.raises(ModelFileError, match="bus.*retrain"):
        neural_mesh._check_meshes(header, path)


def test_the_shipped_model_loads_and_runs(torch_one_thread):
    from po3d_ppl.model_store import read_manifest

    if MODEL_NAME not in read_manifest():
        pytest.skip("no shipped perception features in models/ yet")
    model = load_feature_model()
    feats = extract_features(model.extractor, torch.rand(3, 480, 640))
    assert feats.shape == (model.meshes.dim, 60, 80)
    assert torch.allclose(feats.norm(dim=0), torch.ones(60, 80), atol=1e-4)

"""The attribute network (issue "Perception II", item 2): head orderings from the ontology, crops, normalised
log-probabilities and the evidence table layout, a tiny training run that learns (and is deterministic),
temperature fitting, save/load with checksums, and the shipped weights on rendered objects. Tiny configurations
only, except the last test, which runs the shipped weights on two renders."""

from __future__ import annotations

import json

import pytest
import torch

from po3d_ppl import ontology
from po3d_ppl.errors import InputError, ModelFileError
from po3d_ppl.evidence import NUM_STYLES, P, S, style_index
from po3d_ppl.perception.attributes import (
    MODEL_NAME,
    OBJECT_HEADS,
    PART_HEADS,
    STYLE_COLOR,
    STYLE_COLUMN,
    STYLE_MATERIAL,
    WEIGHTS,
    AttributeConfig,
    AttributeEnsemble,
    AttributeNet,
    crop_labels,
    label_boxes,
    load_attribute_net,
    log_mean_exp,
    mask_boxes,
    save_attribute_net,
    square_windows,
)
from po3d_ppl.perception.calibration import fit_temperature, top_label_ece
from po3d_ppl.perception.train_attributes import (
    AttributeData,
    ProjectionJitter,
    TrainConfig,
    calibrate,
    jittered_part_masks,
    scene_data,
    scene_masks,
    train_attributes,
)

TINY = AttributeConfig(object_size=16, part_size=8, object_widths=(4, 8, 8, 8), part_widths=(4, 4, 8, 8), hidden=16)


def _pixels(rendered) -> torch.Tensor:
    return torch.from_numpy(rendered.image).permute(2, 0, 1).float() / 255


@pytest.fixture(scope="module")
def rendered():
    from po3d_ppl.world import SceneConfig, generate_scene

    config = SceneConfig(width=320, height=240, max_objects=5, min_objects=4)
    return [generate_scene(seed, config) for seed in (31, 32)]


@pytest.fixture(scope="module")
def data(rendered, torch_one_thread):
    return AttributeData.concat([scene_data(_pixels(r), r.scene, TINY, i) for i, r in enumerate(rendered)])


def test_orderings_come_from_the_ontology_and_the_contract():
    assert OBJECT_HEADS["subtype"] == ontology.SUBTYPES and OBJECT_HEADS["color"] == ontology.COLORS
    assert OBJECT_HEADS["material"] == ontology.MATERIALS and OBJECT_HEADS["size"] == ontology.SIZES
    assert PART_HEADS["color"] == ontology.COLORS and PART_HEADS["material"] == ontology.MATERIALS
    for col, c, m in zip(STYLE_COLUMN.tolist(), STYLE_COLOR.tolist(), STYLE_MATERIAL.tolist()):
        assert col == style_index(ontology.COLORS[c], ontology.MATERIALS[m])
    assert sorted(STYLE_COLUMN.tolist()) == list(range(1, NUM_STYLES))


def test_boxes_and_crops_of_masks_and_label_maps_agree():
    masks = torch.zeros(2, 20, 30, dtype=torch.bool)
    masks[0, 3:7, 10:15] = True
    masks[1, 12:20, 0:4] = True
    boxes, counts = mask_boxes(masks)
    assert boxes.tolist() == [[10, 3, 15, 7], [0, 12, 4, 20]] and counts.tolist() == [20, 32]
    labels = torch.full((20, 30), -1)
    labels[masks[0]] = 0
    labels[masks[1]] = 1
    lboxes, lcounts = label_boxes(labels, 3)
    assert torch.equal(lboxes[:2], boxes) and lcounts.tolist() == [20, 32, 0] and lboxes[2].tolist() == [0] * 4
    windows = square_windows(boxes, 2.0, 4.0)
    from_masks = crop_labels(masks, torch.arange(2), torch.ones(2, dtype=torch.bool), windows, 8)
    from_labels = crop_labels(labels[None], torch.zeros(2, dtype=torch.long), torch.arange(2), windows, 8)
    assert torch.equal(from_masks, from_labels) and from_masks.any((1, 2)).all()


def test_scene_data_labels_match_the_scene(rendered, data):
    r = rendered[0]
    n = len(r.scene.objects)
    assert data.object_crops.dtype == torch.uint8 and data.object_crops.shape[1:] == (4, 16, 16)
    assert [ontology.SUBTYPES[i] for i in data.object_labels[:n, 0]] == [o.subtype for o in r.scene.objects]
    rec = data.part_label("recoloured")
    assert ((data.part_label("color") >= 0) == (rec == 1)).all()
    masks, parts = scene_masks(r.scene, 240, 320)
    assert masks.shape == (n, 240, 320) and masks.flatten(1).sum(1).min() >= 1
    assert sum(1 for _, raw, m in parts if int(m.sum()) >= 5) == int((data.part_owner < n).sum())


def test_log_probabilities_normalise_and_fill_the_evidence_table(rendered, torch_one_thread):
    torch.manual_seed(0)
    net = AttributeNet(TINY).eval()
    r = rendered[0]
    masks, parts = scene_masks(r.scene, 240, 320)
    pixels = _pixels(r)
    out = net.object_loglik(pixels, masks)
    n = masks.shape[0]
    for head, classes in OBJECT_HEADS.items():
        assert out[head].shape == (n, len(classes))
        assert torch.allclose(out[head].logsumexp(-1), torch.zeros(n), atol=1e-5)
    part_masks = torch.stack([m for _, _, m in parts[:6]])
    owner = torch.tensor([i for i, _, _ in parts[:6]])
    read = net.part_loglik((pixels * 255).to(torch.uint8), part_masks, masks, owner)
    assert read["style"].shape == (6, NUM_STYLES) and read["recoloured"].shape == (6, 2)
    for v in read.values():
        assert torch.allclose(v.logsumexp(-1), torch.zeros(6), atol=1e-4)
    # the whole table from part-id maps: filled rows normalise, the rest stays 0 (no reading)
    obj = r.scene.objects[0]
    s = ontology.SUBTYPES.index(obj.subtype)
    ids = torch.full((240, 320), -1)
    for p, raw in enumerate(ontology.PARTS[obj.subtype]):
        ann = obj.part_annotations.get(raw)
        if ann is not None and ann.visible_pixels:
            from po3d_ppl.world import rle

            ids[torch.from_numpy(rle.decode(ann.visible_mask, 240, 320))] = p
    ids[0, 0] = len(ontology.PARTS[obj.subtype])  # an id the subtype lacks: ignored
    table = net.part_style_table(pixels, masks, {(0, s): ids})
    assert table.shape == (n, S, P, NUM_STYLES) and table.dtype == torch.float64
    filled = table.abs().sum(-1) > 0
    assert filled[0, s].any() and not filled[1:].any() and not filled[0, :s].any()
    assert torch.allclose(table[filled].logsumexp(-1), torch.zeros(int(filled.sum()), dtype=torch.float64), atol=1e-5)
    assert not filled[0, s, len(ontology.PARTS[obj.subtype]):].any()
    with pytest.raises(InputError, match="owner"):
        net.part_loglik(pixels, part_masks, masks, owner[:2])
    with pytest.raises(InputError, match="masks"):
        net.object_loglik(pixels, masks[:, :10])


def test_training_learns_and_is_deterministic(data, torch_one_thread):
    config = TrainConfig(seed=5, epochs=12, batch_size=4, lr=1e-2, net=TINY)
    a = train_attributes(data, config)
    assert a.history[-1]["loss"] < 0.9 * a.history[0]["loss"]
    assert 0 < float(a.net.part_prior[1]) < 1
    b = train_attributes(data, TrainConfig(seed=5, epochs=12, batch_size=4, lr=1e-2, net=TINY, max_steps=a.steps))
    for (k, v), w in zip(a.net.state_dict().items(), b.net.state_dict().values()):
        assert torch.equal(v, w), k
    report = calibrate(a.net, data)
    assert set(report["temperatures"]) == {f"object.{h}" for h in OBJECT_HEADS} | {f"part.{h}" for h in PART_HEADS}
    assert report["val_after"]["object.color"]["nll"] <= report["val_before"]["object.color"]["nll"] + 1e-6


def test_part_shift_moves_the_image_against_the_part_mask():
    from po3d_ppl.perception.train_attributes import shift_part_context

    crops = torch.zeros(64, 5, 16, 16)
    crops[:, :3, 6:10, 6:10] = 1.0  # the part's pixels, under its mask
    crops[:, 3, 6:10, 6:10] = 1.0
    crops[:, 4, 4:12, 4:12] = 1.0
    moved = shift_part_context(crops, TrainConfig(part_shift=0.2), torch.Generator().manual_seed(0))
    assert torch.equal(moved[:, 3], crops[:, 3])  # the mask stays where the projection put it
    rgb_under_mask = (moved[:, 0] * crops[:, 3]).sum((1, 2)) / crops[:, 3].sum((1, 2))
    assert (rgb_under_mask < 0.99).float().mean() > 0.5  # most samples: the part is no longer exactly under it
    assert torch.equal(shift_part_context(crops, TrainConfig(part_shift=0.0), torch.Generator()), crops)


def test_jittered_part_masks_are_the_truth_without_jitter_and_move_with_it(rendered):
    scene = rendered[0].scene
    h, w = scene.camera.height, scene.camera.width
    _, truth = scene_masks(scene, h, w)
    exact = jittered_part_masks(scene, ProjectionJitter(0.0, 0.0, 0.0), 0)
    assert [(i, raw) for i, raw, _ in exact] == [(i, raw) for i, raw, _ in truth]
    assert all(torch.equal(a, b) for (_, _, a), (_, _, b) in zip(exact, truth))
    moved = {(i, raw): m for i, raw, m in jittered_part_masks(scene, ProjectionJitter(6.0, 0.05, 0.0, seed=1), 0)}
    ious = [float((m & moved[key]).sum() / (m | moved[key]).sum()) for key, m in
            (((i, raw), m) for i, raw, m in truth) if key in moved]
    assert ious and max(ious) <= 1.0 and sum(ious) / len(ious) < 0.95
    again = {(i, raw): m for i, raw, m in jittered_part_masks(scene, ProjectionJitter(6.0, 0.05, 0.0, seed=1), 0)}
    assert again.keys() == moved.keys() and all(torch.equal(again[k], moved[k]) for k in moved)  # seeded


def test_temperature_fit_recovers_a_known_scale_and_ece_is_bounded():
    g = torch.Generator().manual_seed(0)
    logits = torch.randn(4000, 5, generator=g) * 2
    labels = torch.distributions.Categorical(logits=logits).sample()
    assert fit_temperature(logits * 3, labels) == pytest.approx(3.0, rel=0.1)
    lp = torch.log_softmax(logits, -1)
    assert top_label_ece(lp, labels) < 0.05
    assert top_label_ece(torch.log_softmax(logits * 4, -1), labels) > 0.1


def test_save_load_round_trip_and_checksums(tmp_path, torch_one_thread):
    torch.manual_seed(1)
    net = AttributeNet(TINY)
    net.object_temperature.fill_(1.5)
    path = save_attribute_net(net, tmp_path, command="po3d train attributes --test", data_seed=1)
    assert path.name == WEIGHTS
    entry = json.loads((tmp_path / "manifest.json").read_text())[MODEL_NAME]
    assert entry["command"] == "po3d train attributes --test" and entry["files"][WEIGHTS]["bytes"] > 0
    loaded = load_attribute_net(tmp_path)
    assert loaded.config == TINY and not loaded.training
    for k, v in net.state_dict().items():
        assert torch.equal(v, loaded.state_dict()[k]), k
    raw = bytearray(path.read_bytes())
    raw[-10] ^= 0xFF
    path.write_bytes(bytes(raw))
    with pytest.raises(ModelFileError, match=r"attributes\.safetensors.*sha256.*po3d train attributes"):
        load_attribute_net(tmp_path)
    path.unlink()
    with pytest.raises(ModelFileError, match=r"attributes\.safetensors is missing.*po3d train attributes"):
        load_attribute_net(tmp_path)


def test_an_ensemble_mixes_its_members_and_round_trips(rendered, tmp_path, torch_one_thread):
    r = rendered[0]
    masks, parts = scene_masks(r.scene, 240, 320)
    pixels = _pixels(r)
    part_masks = torch.stack([m for _, _, m in parts[:5]])
    owner = torch.tensor([i for i, _, _ in parts[:5]])
    members = []
    for seed in (0, 1):
        torch.manual_seed(seed)
        members.append(AttributeNet(TINY).eval())
    members[1].part_temperature.fill_(2.0)
    ensemble = AttributeEnsemble(members).eval()
    # objects: the equal mixture of the members' calibrated probabilities
    read = ensemble.object_loglik(pixels, masks)
    alone = [m.object_loglik(pixels, masks) for m in members]
    for head in OBJECT_HEADS:
        assert torch.allclose(read[head], log_mean_exp([a[head] for a in alone]), atol=1e-5)
        assert not torch.allclose(read[head], alone[0][head], atol=1e-3)
    parts_read = ensemble.part_loglik(pixels, part_masks, masks, owner)
    for v in parts_read.values():
        assert torch.allclose(v.logsumexp(-1), torch.zeros(5), atol=1e-4)
    # a network beside its own copy reads exactly as it does alone (the members are given the ensemble's objects)
    copy = AttributeNet(TINY).eval()
    copy.load_state_dict(members[0].state_dict())
    twins = AttributeEnsemble([members[0], copy])
    single = members[0].part_loglik(pixels, part_masks, masks, owner)
    for head, v in twins.part_loglik(pixels, part_masks, masks, owner).items():
        assert torch.allclose(v, single[head], atol=1e-5), head
    # one file holds every member; loading rebuilds the ensemble and its readings
    save_attribute_net(ensemble, tmp_path, command="po3d train attributes --members 2 --test", data_seed=1)
    loaded = load_attribute_net(tmp_path)
    assert isinstance(loaded, AttributeEnsemble) and len(loaded.members) == 2
    assert set(loaded.temperatures()) == {f"member{k}.{name}" for k in (0, 1) for name in members[0].temperatures()}
    again = loaded.part_loglik(pixels, part_masks, masks, owner)
    for head, v in parts_read.items():
        assert torch.allclose(again[head], v, atol=1e-6), head
    with pytest.raises(InputError, match="at least two"):
        AttributeEnsemble(members[:1])
    with pytest.raises(InputError, match="AttributeConfig"):
        AttributeEnsemble([members[0], AttributeNet(AttributeConfig(part_size=16, object_size=16,
                                                                    object_widths=(4, 8, 8, 8),
                                                                    part_widths=(4, 4, 8, 8), hidden=16))])


def test_cli_trains_and_evaluates(tmp_path, torch_one_thread):
    import typer
    from typer.testing import CliRunner

    from po3d_ppl.cli.attributes import register
    from po3d_ppl.questions.dataset import BuildConfig, build_dataset

    data = tmp_path / "data"
    build_dataset(data, BuildConfig(scenes=3, seed=5, min_objects=3, max_objects=4, width=320, height=240))
    app, train_app, eval_app = typer.Typer(), typer.Typer(), typer.Typer()
    app.add_typer(train_app, name="train")
    app.add_typer(eval_app, name="eval")
    register(app, train_app, eval_app)
    out = tmp_path / "models"
    result = CliRunner().invoke(app, ["train", "attributes", "--data", str(data), "--out", str(out), "--seed", "1",
                                      "--max-steps", "2", "--batch-size", "4", "--splits", "train,test",
                                      "--cache", str(tmp_path / "cache")])
    assert result.exit_code == 0, result.output
    entry = json.loads((out / "manifest.json").read_text())[MODEL_NAME]
    assert entry["data_seed"] == 5 and "--max-steps 2" in entry["command"]
    assert "temperatures" in entry["metrics"]["calibration"]
    result = CliRunner().invoke(app, ["eval", "attributes", "--data", str(data), "--model-dir", str(out),
                                      "--limit", "2", "--record", "--json", str(tmp_path / "r.json")])
    assert result.exit_code == 0, result.output
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["images"] == 2 and "object.subtype" in report["objects"] and "part.look" in report["objects"]
    assert "eval_seed5" in json.loads((out / "manifest.json").read_text())[MODEL_NAME]["metrics"]


def test_cli_trains_on_several_datasets(tmp_path, torch_one_thread):
    import typer
    from typer.testing import CliRunner

    from po3d_ppl.cli.attributes import register
    from po3d_ppl.questions.dataset import BuildConfig, build_dataset

    first, second = tmp_path / "a", tmp_path / "b"
    for data, seed in ((first, 5), (second, 6)):
        build_dataset(data, BuildConfig(scenes=2, seed=seed, min_objects=3, max_objects=3, width=320, height=240))
    app, train_app, eval_app = typer.Typer(), typer.Typer(), typer.Typer()
    app.add_typer(train_app, name="train")
    app.add_typer(eval_app, name="eval")
    register(app, train_app, eval_app)
    out = tmp_path / "models"
    result = CliRunner().invoke(app, ["train", "attributes", "--data", str(first), "--data", str(second),
                                      "--out", str(out), "--max-steps", "1", "--batch-size", "4",
                                      "--splits", "train,val,test", "--val-split", "train",
                                      "--cache", str(tmp_path / "cache")])
    assert result.exit_code == 0, result.output
    entry = json.loads((out / "manifest.json").read_text())[MODEL_NAME]
    assert entry["data_seed"] == [5, 6] and entry["metrics"]["train_objects"] == 12
    assert f"--data {first} --data {second}" in entry["command"] and len(entry["data_commands"]) == 2
    assert isinstance(load_attribute_net(out), AttributeNet)
    result = CliRunner().invoke(app, ["train", "attributes", "--data", str(first), "--out", str(out), "--max-steps",
                                      "1", "--batch-size", "4", "--splits", "train,test", "--val-split", "val",
                                      "--members", "2", "--eval-data", str(second),
                                      "--cache", str(tmp_path / "cache")])
    assert result.exit_code == 0, result.output
    entry = json.loads((out / "manifest.json").read_text())[MODEL_NAME]
    assert "--members 2" in entry["command"] and [m["seed"] for m in entry["metrics"]["members"]] == [0, 1]
    assert "object.subtype" in entry["metrics"]["eval_seed6"]["objects"]
    ensemble = load_attribute_net(out)
    assert isinstance(ensemble, AttributeEnsemble) and len(ensemble.members) == 2
    first, second = (m.parts.heads["color"].weight for m in ensemble.members)
    assert not torch.equal(first, second)  # seeds --seed and --seed + 1


def test_the_shipped_weights_load_and_beat_chance(torch_one_thread):
    from po3d_ppl.model_store import read_manifest
    from po3d_ppl.world import generate_scene

    if MODEL_NAME not in read_manifest():
        pytest.skip("no shipped attribute network in models/ yet")
    net = load_attribute_net()
    correct = {h: 0 for h in OBJECT_HEADS}
    total = 0
    for seed in (3, 4):
        r = generate_scene(seed)
        masks, _ = scene_masks(r.scene, *r.image.shape[:2])
        out = net.object_loglik(_pixels(r), masks)
        for h in OBJECT_HEADS:
            truth = [OBJECT_HEADS[h].index(getattr(o, h)) for o in r.scene.objects]
            correct[h] += int((out[h].argmax(-1) == torch.tensor(truth)).sum())
        total += len(r.scene.objects)
    assert correct["color"] >= 0.8 * total and correct["subtype"] >= 0.5 * total
    assert correct["material"] >= 0.7 * total and correct["size"] >= 0.7 * total

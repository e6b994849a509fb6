"""Scene priors fitted to the world: the rates of the scene model's binary latents, counted as the sensor reads them."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from po3d_ppl import ontology
from po3d_ppl.cli import app
from po3d_ppl.errors import InputError, ModelFileError
from po3d_ppl.evidence import ScenePriors
from po3d_ppl.perception.priors import count_rates, fit_priors
from po3d_ppl.questions.toy_scenes import toy_object, toy_scene


def test_rates_count_what_the_toy_scene_holds():
    # object 1 is occluded by object 0; the suv has its hood recoloured and its roof hidden behind object 1
    scene = toy_scene([toy_object("suv", parts={"hood": ("blue", "metal")}, part_occluded_by={"roof": (1,)}),
                       toy_object("sedan", position=(3.0, 0.0, 0.0), occluded_by=(0,))])
    slots = len(ontology.PARTS["suv"]) + len(ontology.PARTS["sedan"])
    rates = count_rates([scene]).rates
    assert (rates["occluded"].hits, rates["occluded"].total) == (1, 2)
    assert (rates["occludes"].hits, rates["occludes"].total) == (1, 2)  # ordered pairs (i, j), i != j
    assert rates["part_visible"].total == slots and rates["part_visible"].hits >= 1
    assert rates["part_recoloured"].hits == 1 and rates["part_recoloured"].total == rates["part_visible"].hits
    assert (rates["part_occluded"].hits, rates["part_occluded"].total) == (1, slots)
    assert (rates["part_occludes"].hits, rates["part_occludes"].total) == (1, slots)
    fitted, counted = fit_priors([scene])
    assert fitted.occluded == pytest.approx(2 / 4) and fitted.exists == ScenePriors().exists
    # toy objects show only their recoloured parts: one recoloured of one visible, none of none
    assert counted.max_recoloured == 1 and counted.count_rule_objects.hits == counted.count_rule_objects.total == 2
    assert fitted.max_recoloured_parts == 1 and fitted.recoloured_unlike_body
    # one object with two visible parts and none recoloured breaks "exactly min(1, visible)": no rule then
    counted.recoloured_counts[(0, 2)] += 1
    assert counted.priors().max_recoloured_parts is None and not counted.priors().recoloured_unlike_body
    assert all(0 < getattr(fitted, name) < 1 for name in ("occludes", "part_visible", "part_recoloured",
                                                           "part_occluded", "part_occludes"))


def test_no_scenes_is_a_typed_error():
    with pytest.raises(InputError, match="no scenes"):
        fit_priors([])


def test_cli_prints_writes_and_ships_the_rates(shared_dataset, tmp_path):
    from po3d_ppl.model_store import read_manifest
    from po3d_ppl.perception.priors import PRIORS_FILE, load_priors

    root, _, _ = shared_dataset
    assert load_priors(tmp_path) == ScenePriors()  # none listed: the hand-set defaults
    result = CliRunner().invoke(app, ["train", "priors", "--data", str(root), "--split", "val", "--out",
                                      str(tmp_path)])
    assert result.exit_code == 0, result.output
    assert "part_recoloured" in result.output and "hand-set" in result.output
    entry = read_manifest(tmp_path)["priors"]
    assert entry["metrics"]["scenes"] == 33 and set(entry["metrics"]["counts"]) >= {"occluded", "part_occludes"}
    assert "--split val" in entry["command"]
    fitted = load_priors(tmp_path)
    # the world is far from the hand-set priors (docs/reasoning.md measured 0.47 recoloured given visible)
    assert fitted.part_recoloured > 2 * ScenePriors().part_recoloured
    assert json.loads((tmp_path / PRIORS_FILE).read_text())["part_recoloured"] == fitted.part_recoloured
    # the generator recolours exactly min(3, visible parts) per object, in colours unlike the body
    assert fitted.max_recoloured_parts == 3 and fitted.recoloured_unlike_body
    assert entry["metrics"]["recolouring_rule"]["objects"][0] == entry["metrics"]["recolouring_rule"]["objects"][1]
    (tmp_path / PRIORS_FILE).write_text((tmp_path / PRIORS_FILE).read_text().replace("0.", "0.9", 1))
    with pytest.raises(ModelFileError, match="priors"):
        load_priors(tmp_path)


def test_the_recolouring_rule_is_validated():
    with pytest.raises(InputError, match="max_recoloured_parts"):
        ScenePriors(max_recoloured_parts=0)
    with pytest.raises(InputError, match="max_recoloured_parts"):
        ScenePriors(max_recoloured_parts=2.5)
    with pytest.raises(InputError, match="set max_recoloured_parts"):
        ScenePriors(recoloured_unlike_body=True)
    assert ScenePriors(max_recoloured_parts=3, recoloured_unlike_body=True).max_recoloured_parts == 3

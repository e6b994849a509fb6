"""``po3d_ppl.answer(image, question)``: pixels in, an answer distribution out, with the shipped models."""

from __future__ import annotations

import warnings

import pytest

from po3d_ppl.perception.image_input import CameraPrior
from po3d_ppl.world.generate import render_layout
from po3d_ppl.world.sampler import ObjectSpec


@pytest.fixture(scope="module")
def pipeline():
    import po3d_ppl

    return po3d_ppl.load_pipeline()


@pytest.fixture(scope="module")
def two_vehicles():
    specs = [ObjectSpec("school", "yellow", "rubber", "large", 30.0, -0.5, 0.5),
             ObjectSpec("sedan", "red", "metal", "large", 100.0, 1.2, -1.0)]
    return render_layout(specs, CameraPrior(640, 480).base).image


def test_answers_come_from_the_pixels(pipeline, two_vehicles):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cars, buses, planes, occluded = pipeline.answer_many([two_vehicles], [
            "How many cars are there?", "Is there a bus?", "Is there an aeroplane?", "Is the bus occluded?"])[0]
    assert cars.top == 1 and cars.top_probability > 0.5
    assert buses.top is True
    assert planes.top is False
    assert occluded.top is True


def test_top_level_answer_takes_an_array_and_rejects_a_string_list(pipeline, two_vehicles):
    from po3d_ppl.errors import InputError

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        dist = pipeline.answer(two_vehicles, "How many buses are there?")
    assert dist.top == 1
    with pytest.raises(InputError, match="list of questions"):
        pipeline.answer_many([two_vehicles], "How many buses are there?")


def test_po3d_answer_reads_an_image(tmp_path, two_vehicles):
    import json

    import cv2
    from typer.testing import CliRunner

    from po3d_ppl.cli import app

    path = tmp_path / "two.png"
    cv2.imwrite(str(path), two_vehicles[..., ::-1])
    runner = CliRunner()
    result = runner.invoke(app, ["answer", "--image", str(path), "How many buses are there?", "--json"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.output[result.output.index("{"):])["top"] == 1
    both = runner.invoke(app, ["answer", "--image", str(path), "--scene", str(path), "How many buses are there?"])
    assert both.exit_code != 0 and "exactly one of a scene file or an image" in str(both.exception)

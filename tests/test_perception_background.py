"""The background model: fitted from a few renders it separates objects from the ground, lit or shadowed."""

from __future__ import annotations

import numpy as np
import pytest

from po3d_ppl.errors import InputError, ModelFileError
from po3d_ppl.perception.background import BackgroundModel, fit_background, load_background
from po3d_ppl.world import generate_scene
from po3d_ppl.world.sampler import SceneConfig


@pytest.fixture(scope="module")
def renders():
    config = SceneConfig(width=160, height=120)
    return [generate_scene(seed, config) for seed in range(16)]


def test_fitted_background_finds_the_objects_of_an_unseen_render(renders):
    model = fit_background([r.image for r in renders[:15]], [r.object_ids >= 0 for r in renders[:15]])
    assert 0.3 < model.shadow_ratio < 0.7  # the key light's shadow darkens the ground, not blackens it
    held_out = renders[15]
    found, truth = model.foreground(held_out.image), held_out.object_ids >= 0
    assert (found & truth).sum() / (found | truth).sum() > 0.85
    assert (found & ~truth).sum() < 0.02 * found.sum()  # shadows are not objects


def test_bad_sizes_and_too_few_images_are_refused(renders):
    model = BackgroundModel(renders[0].image.copy(), 0.5)
    with pytest.raises(InputError, match="160x120"):
        model.foreground(np.zeros((10, 10, 3), dtype=np.uint8))
    with pytest.raises(InputError, match="at least 5"):
        fit_background([renders[0].image], [renders[0].object_ids >= 0])


def test_shipped_background_is_checksummed(tmp_path):
    import shutil

    from po3d_ppl.model_store import models_dir

    shipped = load_background()
    assert shipped is not None and shipped.ground.shape == (480, 640, 3)
    for name in ("manifest.json", "background.safetensors"):
        shutil.copy(models_dir() / name, tmp_path / name)
    with open(tmp_path / "background.safetensors", "r+b") as f:
        f.seek(-1, 2)
        f.write(b"\x00")
    with pytest.raises(ModelFileError, match="background.safetensors"):
        load_background(tmp_path)

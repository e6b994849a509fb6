"""Scene generation: sample -> ray-cast -> reject -> annotate -> shade.

:func:`generate_scene` is deterministic in its seed: attempt ``k`` draws everything from
``numpy.random.default_rng([seed, k])``, and an attempt is rejected (and ``k`` incremented) when the layout cannot
be placed without intersections or some object shows fewer than ``min_object_pixels`` pixels. Rejection happens
right after the ray casting, before annotation and shading.
:func:`render_layout` renders a given layout (hand-made test scenes, re-rendering imported scenes).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from po3d_ppl.errors import InputError, Po3dError
from po3d_ppl.world import annotate, renderer, sampler, shading
from po3d_ppl.world.sampler import ObjectSpec, SceneConfig
from po3d_ppl.world.scene import Camera, Scene


@dataclass(frozen=True)
class RenderedScene:
    """A rendered image with its exact scene record and per-pixel maps ([H, W], row 0 at the top)."""

    image: np.ndarray
    scene: Scene
    #: Object index per pixel, -1 where no object is seen.
    object_ids: np.ndarray
    #: Part id (index in ``ontology.PARTS[subtype]``) per pixel, -1 on an object's body or off objects.
    part_ids: np.ndarray
    #: Depth along the camera's viewing axis of the first surface, ground included (inf where nothing is hit).
    depth: np.ndarray
    #: Layouts tried before this one was accepted (1 = first try).
    attempts: int = 1


class GenerationError(Po3dError):
    """No acceptable layout was found within the configured number of attempts."""


@contextmanager
def _timed(timings: dict[str, float] | None, stage: str):
    """Add the stage's process CPU time to ``timings[stage]`` (CPU time: robust on a shared machine)."""
    start = time.process_time()
    yield
    if timings is not None:
        timings[stage] = timings.get(stage, 0.0) + time.process_time() - start


def _finish(specs: Sequence[ObjectSpec], meshes, gbuffer, views, camera: Camera, config: SceneConfig,
            rng: np.random.Generator, image_index: int, timings: dict[str, float] | None,
            attempts: int) -> RenderedScene:
    with _timed(timings, "annotate"):
        measures = annotate.measure(gbuffer, views, specs)
        styles = [annotate.choose_recoloured_parts(s, m, rng, config.max_recoloured_parts, config.min_part_pixels)
                  for s, m in zip(specs, measures)]
        scene = annotate.build_scene(specs, meshes, measures, styles, camera, image_index)
    with _timed(timings, "shade"):
        looks = [shading.object_look(s, {k: (v.color, v.material) for k, v in st.items()})
                 for s, st in zip(specs, styles)]
        image = shading.shade(gbuffer, meshes, looks, camera, shadows=config.shadows)
        depth = renderer.depth_map(gbuffer, camera)
    return RenderedScene(image, scene, gbuffer.object_ids, gbuffer.part_ids, depth, attempts)


def render_layout(objects: Sequence[ObjectSpec], camera: Camera, config: SceneConfig = SceneConfig(), *,
                  seed: int = 0, image_index: int = 0,
                  timings: dict[str, float] | None = None) -> RenderedScene:
    """Render and annotate a given layout, with no rejection. The image size is the camera's.

    Objects whose ``parts`` is ``None`` get recoloured parts by the public rule, drawn from ``seed``.
    ``timings``, if given, accumulates CPU seconds per stage (place, cast, annotate, shade).
    """
    if not objects or not all(isinstance(o, ObjectSpec) for o in objects):
        raise InputError("objects", "expected a non-empty sequence of ObjectSpec")
    if not isinstance(camera, Camera):
        raise InputError("camera", f"expected a Camera, got {type(camera).__name__}")
    with _timed(timings, "place"):
        meshes = renderer.place_meshes(list(objects))
    with _timed(timings, "cast"):
        gbuffer, views = renderer.render_geometry(meshes, camera)
    rng = np.random.default_rng(_check_seed(seed))
    return _finish(list(objects), meshes, gbuffer, views, camera, config, rng, image_index, timings, 1)


def _check_seed(seed: int) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError("seed", f"must be a non-negative integer, got {seed!r}")
    return int(seed)


def generate_scene(seed: int, config: SceneConfig = SceneConfig(), *, image_index: int | None = None,
                   timings: dict[str, float] | None = None) -> RenderedScene:
    """Sample, render and annotate a random scene. Same seed and config -> identical result.

    ``image_index`` (default: the seed) names the image ``superCLEVR_new_%06d.png`` as in the public data.
    ``timings``, if given, accumulates CPU seconds per stage over all attempts (sample, place, cast, annotate,
    shade).
    """
    seed = _check_seed(seed)
    if not isinstance(config, SceneConfig):
        raise InputError("config", f"expected a SceneConfig, got {type(config).__name__}")
    index = seed if image_index is None else int(image_index)
    for attempt in range(config.max_attempts):
        rng = np.random.default_rng([seed, attempt])
        with _timed(timings, "sample"):
            camera = sampler.sample_camera(rng, config)
            specs = sampler.sample_objects(rng, config)
        if specs is None:
            continue
        with _timed(timings, "place"):
            meshes = renderer.place_meshes(specs)
        with _timed(timings, "cast"):
            gbuffer, views = renderer.render_geometry(meshes, camera)
        if (gbuffer.pixel_counts(len(specs)) < config.min_object_pixels).any():
            continue
        return _finish(specs, meshes, gbuffer, views, camera, config, rng, index, timings, attempt + 1)
    raise GenerationError(
        f"no acceptable layout for seed {seed} in {config.max_attempts} attempts (objects must not intersect and "
        f"each must show >= {config.min_object_pixels} pixels); lower max_objects or min_object_pixels"
    )

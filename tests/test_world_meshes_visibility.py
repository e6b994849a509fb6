"""Every listed part is real, visible geometry: >= 20 pixels (the public visibility threshold) in at least one of
8 canonical views of the object at size "large", like a scene camera sees it."""

from __future__ import annotations

import numpy as np
import pytest

from po3d_ppl import ontology
from po3d_ppl.world.meshes import vehicle_mesh
from po3d_ppl.world.raycast import RayCaster, look_at_camera, pixel_rays
from po3d_ppl.world.scene import MIN_VISIBLE_BEFORE_PIXELS

AZIMUTHS = np.arange(0, 360, 45)
ELEVATION = 30.0
DISTANCE = 10.0


def part_pixels(subtype: str) -> np.ndarray:
    """[8 views, P] pixel count of each part."""
    vm = vehicle_mesh(subtype)
    mesh = vm.mesh.copy()
    mesh.apply_scale(ontology.SIZE_SCALE["large"])
    centre = np.array([0.0, 0.0, mesh.extents[2] / 2])
    caster = RayCaster([mesh])
    counts = np.zeros((len(AZIMUTHS), len(vm.part_names)), dtype=np.int64)
    e = np.radians(ELEVATION)
    for k, az in enumerate(np.radians(AZIMUTHS)):
        eye = centre + DISTANCE * np.array([np.cos(az) * np.cos(e), np.sin(az) * np.cos(e), np.sin(e)])
        camera = look_at_camera(eye, centre)
        # only the pixels inside the projected bounding box can see the object
        px = camera.project(mesh.bounding_box.vertices)
        x0, y0 = np.clip(np.floor(px[:, :2].min(0)).astype(int), 0, [camera.width, camera.height])
        x1, y1 = np.clip(np.ceil(px[:, :2].max(0)).astype(int), 0, [camera.width, camera.height])
        v, u = np.mgrid[y0:y1, x0:x1]
        hits = caster.cast(*pixel_rays(camera, u.ravel() + 0.5, v.ravel() + 0.5))
        parts = vm.face_parts[hits.face[hits.hit]]
        counts[k] = np.bincount(parts[parts >= 0], minlength=len(vm.part_names))
    return counts


@pytest.mark.slow
@pytest.mark.parametrize("subtype", ontology.SUBTYPES)
def test_every_part_is_visible_in_some_canonical_view(subtype):
    counts = part_pixels(subtype)
    best = counts.max(axis=0)
    names = ontology.PARTS[subtype]
    hidden = {names[i]: int(best[i]) for i in np.flatnonzero(best < MIN_VISIBLE_BEFORE_PIXELS)}
    assert not hidden, f"parts of {subtype} below {MIN_VISIBLE_BEFORE_PIXELS} px in every view: {hidden}"


def test_sides_are_seen_from_their_side():
    """From the left (+y, azimuth 90) the left door is visible and the right door is not; vice versa."""
    counts = part_pixels("sedan")
    names = ontology.PARTS["sedan"]
    left, right = names.index("front_left_door"), names.index("front_right_door")
    az = list(AZIMUTHS)
    assert counts[az.index(90), left] > 200 and counts[az.index(90), right] == 0
    assert counts[az.index(270), right] > 200 and counts[az.index(270), left] == 0
    front, back = names.index("front_license_plate"), names.index("back_license_plate")
    assert counts[az.index(0), front] > 20 and counts[az.index(0), back] == 0
    assert counts[az.index(180), back] > 20 and counts[az.index(180), front] == 0

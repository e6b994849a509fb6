"""Structure and geometry of the procedural vehicle meshes: labels, frame, size, part placement, determinism."""

from __future__ import annotations

import numpy as np
import pytest

from po3d_ppl import ontology
from po3d_ppl.errors import UnknownNameError
from po3d_ppl.world.meshes import FINISHES, all_vehicle_meshes, canonical_extents, vehicle_mesh
from po3d_ppl.world.meshes.assembly import Assembly
from po3d_ppl.world.meshes.registry import BUILDERS

SUBTYPES = ontology.SUBTYPES
DIRECTIONS = {"front", "back", "mid", "left", "right", "center", "head", "tail"}


def tokens(name: str) -> list[str]:
    """Name tokens, with the ``head``/``tail`` prefixes of lights split off (``headlight`` -> head light)."""
    out = []
    for t in name.split("_"):
        for prefix in ("head", "tail", "rear"):
            if t.startswith(prefix) and t != prefix:
                out += [prefix, t[len(prefix):]]
                break
        else:
            out.append(t)
    return out


@pytest.fixture(scope="module")
def meshes():
    return all_vehicle_meshes()


def test_every_subtype_has_a_builder():
    assert set(BUILDERS) == set(SUBTYPES)


@pytest.mark.parametrize("subtype", SUBTYPES)
def test_part_ids_are_exactly_the_listed_parts(meshes, subtype):
    vm = meshes[subtype]
    used = set(np.unique(vm.face_parts).tolist()) - {-1}
    assert used == set(range(len(ontology.PARTS[subtype])))
    assert vm.face_parts.dtype == np.int16 and vm.face_parts.shape == (len(vm.mesh.faces),)
    assert vm.face_finish.shape == vm.face_parts.shape
    assert set(np.unique(vm.face_finish).tolist()) <= set(range(len(FINISHES)))
    assert (vm.face_parts == -1).any(), "a vehicle has unlabelled body/frame geometry"


@pytest.mark.parametrize("subtype", SUBTYPES)
def test_canonical_frame_and_size(meshes, subtype):
    vm = meshes[subtype]
    lo, hi = vm.mesh.bounds
    assert lo[2] == pytest.approx(0.0, abs=1e-9), "rests on z = 0"
    assert (lo[0] + hi[0]) / 2 == pytest.approx(0.0, abs=1e-9)
    assert (lo[1] + hi[1]) / 2 == pytest.approx(0.0, abs=1e-9)
    np.testing.assert_allclose(hi - lo, canonical_extents(subtype), rtol=1e-6)
    box = ontology.INFO_BOX[subtype]
    length, width = (box[0], box[1]) if ontology.CATEGORY_OF[subtype] == "bicycle" else (box[1], box[0])
    np.testing.assert_allclose(hi - lo, [length, width, box[2]], rtol=0.15)
    # the builder's design already had the public proportions: normalising distorted no axis by more than 15%
    assert np.all(np.abs(np.asarray(vm.axis_scale) - 1.0) < 0.15), vm.axis_scale


@pytest.mark.parametrize("subtype", SUBTYPES)
def test_budget_and_closed_outward_surface(meshes, subtype):
    vm = meshes[subtype]
    assert len(vm.mesh.faces) <= 6000
    assert vm.mesh.is_watertight
    assert vm.mesh.volume > 0


@pytest.mark.parametrize("subtype", SUBTYPES)
def test_left_parts_on_plus_y_right_parts_on_minus_y(meshes, subtype):
    vm = meshes[subtype]
    half_width = vm.extents[1] / 2
    checked = 0
    for pid, name in enumerate(vm.part_names):
        t = tokens(name)
        y = vm.part_centroids[pid][1]
        if "left" in t:
            assert y > 0.05 * half_width, f"{name} centroid y={y:.4f}"
            checked += 1
        elif "right" in t:
            assert y < -0.05 * half_width, f"{name} centroid y={y:.4f}"
            checked += 1
        elif "center" in t or name in ("roof", "hood", "trunk", "fin", "propeller", "seat", "saddle",
                                       "gas_tank", "windscreen", "license_plate"):
            assert abs(y) < 0.1 * half_width, f"{name} should be centred, y={y:.4f}"
    assert checked or subtype == "tandem"


def _same_kind(a: str, b: str) -> bool:
    """Same kind of part on the same side (or either one unsided): front_left_door ~ back_left_door."""
    def strip(n):
        return [t for t in tokens(n) if t not in DIRECTIONS]

    def side(n):
        return [t for t in tokens(n) if t in ("left", "right")]

    return strip(a) == strip(b) and (side(a) == side(b) or not side(a) or not side(b))


@pytest.mark.parametrize("subtype", SUBTYPES)
def test_front_parts_ahead_of_back_parts(meshes, subtype):
    vm = meshes[subtype]
    rank = {"front": 2, "head": 2, "mid": 1, "back": 0, "tail": 0, "rear": 0}
    names = vm.part_names
    pairs = 0
    for i, a in enumerate(names):
        for j, b in enumerate(names):
            ra = [rank[t] for t in tokens(a) if t in rank]
            rb = [rank[t] for t in tokens(b) if t in rank]
            if ra and rb and ra[0] > rb[0] and _same_kind(a, b):
                assert vm.part_centroids[i][0] > vm.part_centroids[j][0], f"{a} should be ahead of {b}"
                pairs += 1
    # absolute placement: front-named parts in the front half, back-named parts in the back half
    for pid, name in enumerate(names):
        t = tokens(name)
        x = vm.part_centroids[pid][0]
        if "front" in t or "head" in t:
            assert x > 0, f"{name} x={x:.3f}"
        if "back" in t or "tail" in t or "rear" in t or name == "trunk":
            assert x < 0, f"{name} x={x:.3f}"
    assert pairs > 0 or subtype in ("fighter", "biplane")


@pytest.mark.parametrize("subtype", SUBTYPES)
def test_wheels_touch_the_ground(meshes, subtype):
    vm = meshes[subtype]
    wheels = [n for n in vm.part_names if "wheel" in tokens(n)]
    if ontology.CATEGORY_OF[subtype] != "aeroplane":
        assert len(wheels) >= 2
    for name in wheels:
        part = vm.part_mesh(name)
        assert part.bounds[0][2] == pytest.approx(0.0, abs=0.01 * vm.extents[2]), name
        assert part.bounds[1][2] < 0.75 * vm.extents[2], f"{name} reaches too high"


@pytest.mark.parametrize("subtype", ["suv", "wagon", "minivan", "sedan", "truck"])
def test_car_layout(meshes, subtype):
    vm = meshes[subtype]
    c = dict(zip(vm.part_names, vm.part_centroids))
    L, W, H = vm.extents
    assert c["roof"][2] > c["hood"][2] and c["roof"][2] > 0.8 * H
    assert c["hood"][0] > 0.2 * L and c["trunk"][0] < -0.25 * L
    assert c["front_bumper"][2] < 0.35 * H and c["back_bumper"][2] < 0.35 * H
    for side in ("left", "right"):
        mirror = c[f"{side}_mirror"]
        door = c[f"front_{side}_door"]
        assert abs(mirror[1]) > abs(door[1]), "mirrors stick out of the doors"
        assert mirror[0] > door[0] - 0.1 * L, "mirrors sit by the front doors"


def _side_glass_rows(vm) -> int:
    """Number of separate horizontal bands of side windows (glass faces facing +-y)."""
    glass = vm.face_finish == FINISHES.index("glass")
    centre = vm.mesh.triangles_center
    side = (np.abs(vm.mesh.face_normals[:, 1]) > 0.9) & (np.abs(centre[:, 0]) < 0.45 * vm.extents[0])
    tri = vm.mesh.triangles[glass & side & (vm.face_parts == -1)][..., 2]
    intervals = sorted(zip(tri.min(1), tri.max(1)))
    rows, reach = 1, intervals[0][1]
    for lo, hi in intervals[1:]:  # merge overlapping height intervals
        if lo > reach + 1e-6:
            rows += 1
        reach = max(reach, hi)
    return rows


def _principal_tilt(points: np.ndarray) -> float:
    """Angle (degrees) between the main axis of points in the xz plane and the vertical."""
    xz = points[:, [0, 2]] - points[:, [0, 2]].mean(0)
    axis = np.linalg.svd(xz, full_matrices=False)[2][0]
    return float(np.degrees(np.arccos(abs(axis[1]))))


def test_bus_signatures(meshes):
    assert _side_glass_rows(meshes["double"]) == 2
    for subtype in ("regular", "articulated", "school"):
        assert _side_glass_rows(meshes[subtype]) == 1, subtype
    # the articulated bus has a third, unlabelled axle between its front and back wheels
    art = meshes["articulated"]
    c = dict(zip(art.part_names, art.part_centroids))
    centres = art.mesh.triangles_center
    between = (centres[:, 0] < c["wheel_front_left"][0] - 0.1 * art.extents[0]) & (
        centres[:, 0] > c["wheel_back_left"][0] + 0.1 * art.extents[0])
    tyres = (art.face_parts == -1) & (art.face_finish == FINISHES.index("rubber")) & between
    assert tyres.any() and centres[tyres, 2].min() < 0.05 * art.extents[2]
    # the school bus has a bonnet: its front end is well below the roof; the regular bus's front is full height
    for subtype, low in (("school", True), ("regular", False)):
        vm = meshes[subtype]
        v = vm.mesh.vertices
        nose = v[v[:, 0] > v[:, 0].max() - 0.06 * vm.extents[0]]
        assert (nose[:, 2].max() < 0.7 * vm.extents[2]) == low, subtype


def test_car_signatures(meshes):
    # the pickup's trunk (bed floor + tailgate) lies a cab's height below its roof
    tr = meshes["truck"]
    c = dict(zip(tr.part_names, tr.part_centroids))
    assert c["roof"][2] - c["trunk"][2] > 0.3 * tr.extents[2]
    # the sedan's trunk lid is on top of a rear deck; hatchbacks' trunks are (near-)vertical tailgates
    for subtype in ("sedan", "suv", "wagon", "minivan"):
        vm = meshes[subtype]
        up = vm.mesh.face_normals[vm.part_faces("trunk"), 2]
        area = vm.mesh.area_faces[vm.part_faces("trunk")]
        facing_up = float((area * (up > 0.7)).sum() / area.sum())
        assert (facing_up > 0.3) == (subtype == "sedan"), (subtype, facing_up)


def test_two_wheeler_signatures(meshes):
    tilt = {s: _principal_tilt(meshes[s].part_mesh("fork").vertices) for s in ("chopper", "dirtbike", "cruiser")}
    assert tilt["chopper"] > 35 and tilt["dirtbike"] < 30, tilt
    wheel = {s: meshes[s].part_mesh("wheel_front").extents[2] / meshes[s].extents[2]
             for s in ("chopper", "dirtbike", "scooter", "cruiser")}
    assert wheel["scooter"] < min(v for k, v in wheel.items() if k != "scooter"), wheel
    def tyre_width(vm):
        faces = vm.part_faces("wheel_front")
        faces = faces[vm.face_finish[faces] == FINISHES.index("rubber")]
        return np.ptp(vm.mesh.triangles[faces][..., 1]) / vm.extents[0]

    tyre = {s: tyre_width(meshes[s]) for s in ("road", "mountain")}
    assert tyre["mountain"] > 1.5 * tyre["road"], tyre
    # drop bars reach down below the bar top; flat bars do not
    drop = {s: meshes[s].part_mesh("handle_left").extents[2] / meshes[s].extents[2] for s in ("road", "mountain")}
    assert drop["road"] > 2 * drop["mountain"], drop


def test_aeroplane_signatures(meshes):
    # the biplane's wings are stacked: wing faces at two clearly separated heights
    bi = meshes["biplane"]
    z = bi.mesh.triangles_center[bi.part_faces("wing_left"), 2]
    assert np.ptp(z) > 0.45 * bi.extents[2]
    # airliner engines hang under the wings; jet engines sit on the rear fuselage above the wings
    for subtype, under in (("airliner", True), ("jet", False)):
        vm = meshes[subtype]
        c = dict(zip(vm.part_names, vm.part_centroids))
        assert (c["engine_left"][2] < c["wing_left"][2]) == under, subtype
        assert (c["engine_left"][0] < c["wing_left"][0]) != under, subtype
    fighter = meshes["fighter"]
    c = dict(zip(fighter.part_names, fighter.part_centroids))
    assert c["engine_left"][0] < 0 and c["engine_right"][0] < 0, "engines at the back"


def test_meshes_are_deterministic():
    for subtype in ("sedan", "cruiser", "airliner", "tandem", "articulated"):
        a = BUILDERS[subtype]().finish()
        b = BUILDERS[subtype]().finish()
        np.testing.assert_array_equal(a.mesh.vertices, b.mesh.vertices)
        np.testing.assert_array_equal(a.mesh.faces, b.mesh.faces)
        np.testing.assert_array_equal(a.face_parts, b.face_parts)


def test_vehicle_mesh_is_cached_and_read_only():
    vm = vehicle_mesh("suv")
    assert vehicle_mesh("suv") is vm
    with pytest.raises(ValueError):
        vm.face_parts[0] = 3


def test_unknown_subtype_is_a_typed_error():
    with pytest.raises(UnknownNameError) as err:
        vehicle_mesh("sedna")
    assert "sedan" in str(err.value)
    with pytest.raises(UnknownNameError):
        vehicle_mesh("addi")  # public metadata name that is never rendered


def test_assembly_rejects_foreign_labels_and_missing_parts():
    from po3d_ppl.world.meshes import primitives as P

    asm = Assembly("tandem")
    with pytest.raises(ValueError, match="not a part of tandem"):
        asm.add("saddle", P.box((0, 0, 0), (1, 1, 1)))
    asm.add("fork", P.box((0, 0, 0), (1, 1, 1)))
    with pytest.raises(ValueError, match="did not build parts"):
        asm.finish()
    inverted = P.box((0, 0, 0), (1, 1, 1))
    inverted.invert()
    with pytest.raises(ValueError, match="outward"):
        asm.add("fork", inverted)

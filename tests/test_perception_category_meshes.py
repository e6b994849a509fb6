"""Category-level meshes: about 1,000 vertices, closed, enclosing every subtype of their category, deterministic,
posed like the world places objects, and covering each subtype's silhouette at the same pose."""

from __future__ import annotations

import numpy as np
import pytest
import torch
import trimesh

from po3d_ppl import ontology
from po3d_ppl.errors import InputError, UnknownNameError
from po3d_ppl.perception.category_meshes import (
    all_category_meshes,
    build_category_mesh,
    category_mesh,
    category_sheet,
    distance_to_surface,
    pose_category_mesh,
    pose_matrix,
    pose_vertices_torch,
    subtypes_of,
    surface_nets,
)
from po3d_ppl.world.meshes import vehicle_mesh
from po3d_ppl.world.raycast import RayCaster, camera_rays
from po3d_ppl.world.renderer import place_meshes
from po3d_ppl.world.sampler import ObjectSpec, canonical_bounds, make_camera

#: A subtype vertex counts as enclosed if inside the category mesh or this close to it (0.5% of a vehicle's length).
TOLERANCE = 0.005


@pytest.fixture(scope="module")
def meshes():
    return all_category_meshes()


def test_one_closed_mesh_of_about_1000_vertices_per_category(meshes):
    assert tuple(meshes) == ontology.CATEGORIES
    for category, cm in meshes.items():
        assert cm.category == category and cm.subtypes == subtypes_of(category)
        assert 800 <= cm.num_vertices <= 1200, (category, cm.num_vertices)
        assert cm.vertices.dtype == np.float32 and cm.faces.dtype == np.int64 and cm.vertex_normals.dtype == np.float32
        assert not cm.vertices.flags.writeable
        tm = cm.trimesh()
        assert tm.is_watertight and tm.is_winding_consistent and tm.volume > 0, category
        assert tm.body_count == 1, category
        np.testing.assert_allclose(np.linalg.norm(cm.vertex_normals, axis=1), 1.0, atol=1e-5)


def test_every_subtype_is_enclosed(meshes):
    for cm in meshes.values():
        tm = cm.trimesh()
        for subtype in cm.subtypes:
            v = np.asarray(vehicle_mesh(subtype).mesh.vertices)
            inside = tm.contains(v)
            near = distance_to_surface(v[~inside], cm.vertices, cm.faces) <= TOLERANCE
            enclosed = (inside.sum() + near.sum()) / len(v)
            assert enclosed >= 0.99, (subtype, enclosed)


def test_base_on_the_ground_centred_and_near_uniform_spacing(meshes):
    for category, cm in meshes.items():
        lo, hi = cm.bounds
        assert abs(lo[2]) < 1e-6, category
        assert np.all(np.abs((lo + hi)[:2] / 2) < cm.spacing), category
        union_lo = np.min([canonical_bounds(s)[0] for s in cm.subtypes], axis=0)
        union_hi = np.max([canonical_bounds(s)[1] for s in cm.subtypes], axis=0)
        assert np.all(lo <= union_lo + 1e-6) and np.all(hi >= union_hi - 1e-6), category
        assert np.all(hi - lo <= (union_hi - union_lo) + 4 * cm.spacing), category  # a wrap, not a blob
        edges = cm.edge_lengths()
        assert 0.6 * cm.spacing < edges.mean() < 1.4 * cm.spacing and edges.std() / edges.mean() < 0.4, category


def test_deterministic_and_cached(meshes):
    again = build_category_mesh("bicycle")
    np.testing.assert_array_equal(again.vertices, meshes["bicycle"].vertices)
    np.testing.assert_array_equal(again.faces, meshes["bicycle"].faces)
    assert category_mesh("bicycle") is meshes["bicycle"]


def test_posing_follows_the_worlds_object_placement(meshes):
    rng = np.random.default_rng(4)
    for subtype in ontology.SUBTYPES:
        x, y = rng.uniform(-3, 3, size=2)
        spec = ObjectSpec(subtype, "red", "metal", "small", float(rng.uniform(0, 360)), float(x), float(y), 0.4)
        M = pose_matrix(spec.x, spec.y, spec.rotation, spec.scale, spec.elevation)
        np.testing.assert_allclose(M, spec.transform(canonical_bounds(subtype)), atol=1e-6)
    cm = meshes["car"]
    verts, normals = pose_category_mesh(cm, 1.0, -2.0, 30.0, "large")
    tverts = pose_vertices_torch(torch.from_numpy(cm.vertices.astype(np.float64)), 1.0, -2.0, 30.0,
                                 ontology.SIZE_SCALE["large"])
    np.testing.assert_allclose(tverts.numpy(), verts, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-5)
    batch = pose_vertices_torch(cm.tensors()[0], torch.zeros(2, 3), torch.zeros(2, 3),
                                torch.linspace(0, 300, 6).reshape(2, 3), 1.8)
    assert batch.shape == (2, 3, cm.num_vertices, 3)


def test_posing_gradients_flow():
    cm = category_mesh("bus")
    rot = torch.tensor(45.0, requires_grad=True)
    x = torch.tensor(0.5, requires_grad=True)
    pose_vertices_torch(cm.tensors()[0], x, 0.0, rot, 3.5).sum().backward()
    assert torch.isfinite(rot.grad) and rot.grad != 0 and torch.isfinite(x.grad)


def test_the_posed_category_silhouette_covers_each_subtypes(meshes):
    camera = make_camera(320, 240, (0.3, -0.2, 0.1))
    origins, dirs = camera_rays(camera)
    rng = np.random.default_rng(11)
    for subtype in ontology.SUBTYPES:
        x, y = rng.uniform(-2.5, 2.5, size=2)
        spec = ObjectSpec(subtype, "red", "rubber", ("large", "small")[len(subtype) % 2], float(rng.uniform(0, 360)),
                          float(x), float(y))
        placed = place_meshes([spec])[0]
        sub = trimesh.Trimesh(placed.vertices, np.asarray(vehicle_mesh(subtype).mesh.faces), process=False)
        cm = meshes[ontology.CATEGORY_OF[subtype]]
        verts, _ = pose_category_mesh(cm, spec.x, spec.y, spec.rotation, spec.scale)
        cat = trimesh.Trimesh(verts, cm.faces, process=False)
        s_hit = RayCaster([sub]).cast(origins, dirs).hit
        c_hit = RayCaster([cat]).cast(origins, dirs).hit
        assert s_hit.sum() > 50, subtype
        coverage = (s_hit & c_hit).sum() / s_hit.sum()
        assert coverage >= 0.95, (subtype, coverage)
        # the same through Camera.project: the subtype's vertices land on the category's silhouette (one pixel of
        # slack for vertices on the outline)
        px = np.floor(camera.project(placed.vertices)[:, :2]).astype(int)
        seen = (px[:, 0] >= 0) & (px[:, 0] < 320) & (px[:, 1] >= 0) & (px[:, 1] < 240)
        mask = c_hit.reshape(240, 320)
        grown = mask | np.roll(mask, 1, 0) | np.roll(mask, -1, 0) | np.roll(mask, 1, 1) | np.roll(mask, -1, 1)
        assert grown[px[seen, 1], px[seen, 0]].mean() >= 0.99, subtype


def test_bad_names_and_scales():
    with pytest.raises(UnknownNameError, match="did you mean 'car'"):
        category_mesh("cars")
    cm = category_mesh("car")
    with pytest.raises(UnknownNameError):
        pose_category_mesh(cm, 0, 0, 0, "huge")
    with pytest.raises(InputError, match="scale"):
        pose_category_mesh(cm, 0, 0, 0, -1.0)


def test_surface_nets_of_small_lattices_are_closed_and_outward():
    one = np.zeros((3, 3, 3), bool)
    one[1, 1, 1] = True
    block = np.zeros((6, 5, 5), bool)
    block[1:5, 1:4, 1:4] = True
    for occ in (one, block):
        verts, faces = surface_nets(occ)
        tm = trimesh.Trimesh(verts, faces, process=False)
        assert tm.is_watertight and tm.is_winding_consistent and tm.volume > 0
    assert len(surface_nets(one)[0]) == 8


def test_distance_to_surface_of_a_box():
    box = trimesh.creation.box()
    d = distance_to_surface(np.array([[0, 0, 0], [2, 0, 0], [1, 1, 1], [0.5, 0.5, 2]]), box.vertices, box.faces)
    np.testing.assert_allclose(d, [0.5, 1.5, np.sqrt(3) / 2, 1.5])


def test_contact_sheet(tmp_path):
    sheet = category_sheet(tile=(80, 60))
    assert sheet.shape == (5 * 60, 6 * 80, 3) and sheet.dtype == np.uint8
    assert (sheet < 250).any()

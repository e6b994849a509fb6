"""The ray-casting core: camera rays agree with Camera.project, first hits are exact, ids survive subsets."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from po3d_ppl.errors import InputError
from po3d_ppl.world.raycast import MISS, RayCaster, camera_rays, look_at_camera, pixel_rays
from po3d_ppl.world.scene import Camera


def skewed_camera() -> Camera:
    """A camera with unequal focal lengths and an off-centre principal point, looking down at the origin."""
    base = look_at_camera((6.0, -5.0, 4.0), (0.2, 0.1, 0.3), width=320, height=200)
    K = ((300.0, 0.0, 150.0), (0.0, 280.0, 110.0), (0.0, 0.0, 1.0))
    return Camera(320, 200, K, base.camera_to_world)


@pytest.mark.parametrize("camera", [look_at_camera((7.5, -6.5, 5.3)), skewed_camera()])
def test_pixel_centre_rays_project_back_to_their_pixels(camera):
    origins, dirs = camera_rays(camera)
    assert origins.shape == dirs.shape == (camera.width * camera.height, 3)
    assert origins.dtype == dirs.dtype == np.float32
    np.testing.assert_allclose(np.linalg.norm(dirs, axis=1), 1.0, atol=1e-6)
    rng = np.random.default_rng(0)
    idx = rng.choice(len(dirs), 500, replace=False)
    depth = rng.uniform(1.0, 30.0, len(idx))
    points = origins[idx].astype(np.float64) + dirs[idx].astype(np.float64) * depth[:, None]
    px = camera.project(points)
    row, col = np.divmod(idx, camera.width)  # row-major, row 0 at the top
    np.testing.assert_allclose(px[:, 0], col + 0.5, atol=2e-3)
    np.testing.assert_allclose(px[:, 1], row + 0.5, atol=2e-3)
    assert np.all(px[:, 2] > 0), "rays go forward, in front of the camera"


def test_projected_points_lie_on_their_pixel_rays():
    camera = skewed_camera()
    rng = np.random.default_rng(1)
    points = rng.uniform(-2, 2, (300, 3))
    px = camera.project(points)
    o, d = pixel_rays(camera, px[:, 0], px[:, 1])
    rel = points - o.astype(np.float64)
    along = np.sum(rel * d, axis=1)
    off_ray = np.linalg.norm(rel - along[:, None] * d, axis=1)
    assert np.all(along > 0)
    forward = -camera.matrix_world[:3, 2]
    np.testing.assert_allclose(along * (d @ forward), px[:, 2], rtol=1e-5)  # depth along the viewing axis
    assert off_ray.max() < 1e-5


def test_look_at_camera_looks_at_its_target_with_up_up():
    camera = look_at_camera((3.0, 4.0, 5.0), (1.0, 1.0, 0.5), width=640, height=480)
    centre = camera.project(np.array([1.0, 1.0, 0.5]))
    np.testing.assert_allclose(centre[:2], [320.0, 240.0], atol=1e-9)
    above = camera.project(np.array([1.0, 1.0, 1.5]))
    assert above[1] < centre[1], "world up is image up"
    with pytest.raises(InputError):
        look_at_camera((0, 0, 1), (0, 0, 1))
    with pytest.raises(InputError):
        look_at_camera((0, 0, 5), (0, 0, 0))  # looking straight down: up is ambiguous


def two_boxes() -> list[trimesh.Trimesh]:
    near = trimesh.creation.box(extents=(1, 1, 1))
    far = trimesh.creation.box(extents=(2, 2, 2))
    far.apply_translation((0, 0, -5))
    return [near, far]


def test_first_hit_geometry_face_distance_and_normal():
    near, far = two_boxes()
    caster = RayCaster([near, far])
    origins = np.array([[0, 0, 10], [0.8, 0.8, 10], [3, 3, 10], [0.1, 0.2, -10]], dtype=np.float32)
    dirs = np.array([[0, 0, -1], [0, 0, -1], [0, 0, -1], [0, 0, 1]], dtype=np.float32)
    hits = caster.cast(origins, dirs)
    np.testing.assert_array_equal(hits.geometry, [0, 1, MISS, 1])
    np.testing.assert_allclose(hits.distance[[0, 1, 3]], [9.5, 14.0, 4.0], atol=1e-5)
    assert np.isinf(hits.distance[2]) and hits.face[2] == -1
    np.testing.assert_allclose(hits.normal[0], [0, 0, 1], atol=1e-6)
    np.testing.assert_allclose(hits.normal[3], [0, 0, -1], atol=1e-6)
    np.testing.assert_array_equal(hits.normal[2], [0, 0, 0])
    # the reported face contains the hit point
    points = hits.points(origins, dirs)
    for r, mesh in ((0, near), (1, far), (3, far)):
        tri = mesh.triangles[hits.face[r]]
        bary = trimesh.triangles.points_to_barycentric(tri[None], points[r][None])[0]
        assert np.all(bary > -1e-5), (r, bary)
    assert np.isnan(points[2]).all()


def test_subset_keeps_the_callers_ids_and_sees_through_removed_meshes():
    near, far = two_boxes()
    caster = RayCaster([near, far], ids=[7, 3])
    o = np.array([[0, 0, 10]], dtype=np.float32)
    d = np.array([[0, 0, -1]], dtype=np.float32)
    assert caster.cast(o, d).geometry[0] == 7
    only_far = caster.subset([1])
    hits = only_far.cast(o, d)
    assert hits.geometry[0] == 3 and hits.distance[0] == pytest.approx(14.0)
    assert caster.subset([]).cast(o, d).geometry[0] == MISS
    with pytest.raises(InputError):
        caster.subset([2])


def test_empty_meshes_and_bad_input():
    empty = trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64))
    near, far = two_boxes()
    caster = RayCaster([empty, far])
    hits = caster.cast(np.array([[0, 0, 10]], np.float32), np.array([[0, 0, -1]], np.float32))
    assert hits.geometry[0] == 1, "ids count empty meshes too"
    assert len(caster.cast(np.zeros((0, 3)), np.zeros((0, 3)))) == 0
    with pytest.raises(InputError, match="shape"):
        caster.cast(np.zeros((4, 2)), np.zeros((4, 2)))
    with pytest.raises(InputError, match="ids"):
        RayCaster([near], ids=[1, 2])
    with pytest.raises(InputError, match="expected trimesh"):
        RayCaster([np.zeros((3, 3))])
    with pytest.raises(InputError, match="same length"):
        pixel_rays(look_at_camera((1, 2, 3)), [1.0, 2.0], [1.0])


def test_full_image_of_a_vehicle_matches_trimesh_reference():
    """Against trimesh's own (slower) embree wrapper: the same first-hit faces."""
    from po3d_ppl.world.meshes import vehicle_mesh

    mesh = vehicle_mesh("sedan").mesh.copy()
    mesh.apply_scale(3.5)
    camera = look_at_camera((6.0, 5.0, 4.0), (0, 0, 0.5), width=160, height=120)
    o, d = camera_rays(camera)
    hits = RayCaster([mesh]).cast(o, d)
    from trimesh.ray.ray_pyembree import RayMeshIntersector

    ref = RayMeshIntersector(mesh).intersects_first(o.astype(np.float64), d.astype(np.float64))
    assert (hits.face >= 0).sum() > 1000
    agree = np.mean(hits.face == ref)
    assert agree > 0.995, agree

"""The torch rasteriser agrees with the world's embree renderer (silhouettes, faces, depth) for every subtype and
view, batches exactly, leaves empty / off-screen / behind-camera meshes as background, is watertight, and its
barycentrics carry exact gradients to the vertices (finite differences)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from po3d_ppl import ontology
from po3d_ppl.errors import InputError
from po3d_ppl.perception.rasterizer import (
    Fragments,
    camera_tensors,
    pad_meshes,
    project_vertices,
    rasterize,
    rasterize_camera,
)
from po3d_ppl.world.meshes import vehicle_mesh
from po3d_ppl.world.renderer import PlacedMesh, cast_alone, pixel_directions, place_meshes
from po3d_ppl.world.sampler import POSITION_RANGE, ObjectSpec, make_camera
from po3d_ppl.world.scene import Camera

pytestmark = pytest.mark.usefixtures("torch_one_thread")

#: Equal resolution for both renderers: a quarter of the world's 640x480 keeps the 168 views fast while small
#: objects still cover a few hundred pixels.
WIDTH, HEIGHT = 320, 240
VIEWS = 8


def views_of(subtype: str, seed: int) -> tuple[Camera, list[PlacedMesh]]:
    """A world-like camera (CLEVR's, jittered) and the subtype at 8 yaws 45 degrees apart (8 azimuths), at a
    random position and size."""
    rng = np.random.default_rng(seed)
    camera = make_camera(WIDTH, HEIGHT, tuple(rng.uniform(-0.5, 0.5, 3)))
    x, y = (float(v) for v in rng.uniform(-0.6 * POSITION_RANGE, 0.6 * POSITION_RANGE, 2))
    size = ("large", "small")[seed % 2]
    yaw0 = float(rng.uniform(0.0, 45.0))
    specs = [ObjectSpec(subtype, "gray", "rubber", size, yaw0 + 45.0 * k, x, y) for k in range(VIEWS)]
    return camera, place_meshes(specs)


def embree_view(mesh: PlacedMesh, camera: Camera) -> tuple[np.ndarray, np.ndarray]:
    """Face index (-1 background) and view depth (inf background) from the world's ray caster."""
    solo = cast_alone(mesh, camera)
    h, w = solo.face.shape
    face = np.full((camera.height, camera.width), -1, dtype=np.int64)
    dist = np.full((camera.height, camera.width), np.inf)
    face[solo.y0:solo.y0 + h, solo.x0:solo.x0 + w] = solo.face
    dist[solo.y0:solo.y0 + h, solo.x0:solo.x0 + w] = solo.distance
    forward = -camera.matrix_world[:3, 2]
    cosine = (pixel_directions(camera) @ forward).reshape(camera.height, camera.width)
    return face, dist * cosine


def faces_of(subtype: str) -> torch.Tensor:
    return torch.as_tensor(np.asarray(vehicle_mesh(subtype).mesh.faces), dtype=torch.int64)


def stacked(meshes: list[PlacedMesh], dtype=torch.float32) -> torch.Tensor:
    return torch.as_tensor(np.stack([m.vertices for m in meshes]), dtype=dtype)


@pytest.fixture(scope="module")
def comparisons():
    """Per subtype: (embree faces [8, H, W], embree depth, raster faces, raster depth)."""
    out = {}
    for k, subtype in enumerate(ontology.SUBTYPES):
        camera, meshes = views_of(subtype, k)
        frags = rasterize_camera(stacked(meshes), faces_of(subtype), camera)
        ref = [embree_view(m, camera) for m in meshes]
        out[subtype] = (np.stack([r[0] for r in ref]), np.stack([r[1] for r in ref]),
                        frags.face_map.numpy(), frags.depth_map.numpy())
    return out


def test_silhouettes_match_embree_for_every_subtype_and_view(comparisons):
    ious = {}
    for subtype, (ref_face, _, face, _) in comparisons.items():
        a, b = ref_face >= 0, face >= 0
        assert a.sum(axis=(1, 2)).min() > 100, f"{subtype}: too few pixels for a meaningful IoU"
        ious[subtype] = (a & b).sum(axis=(1, 2)) / (a | b).sum(axis=(1, 2))
    worst = min(ious, key=lambda s: ious[s].min())
    assert ious[worst].min() >= 0.98, f"{worst}: IoU {ious[worst].round(4)}"


def test_depth_and_faces_match_the_ray_cast_on_the_silhouette(comparisons):
    errors, same_face, total = [], 0, 0
    for ref_face, ref_depth, face, depth in comparisons.values():
        both = (ref_face >= 0) & (face >= 0)
        errors.append(np.abs(depth[both] - ref_depth[both]) / ref_depth[both])
        same_face += int((face[both] == ref_face[both]).sum())
        total += int(both.sum())
    rel = np.concatenate(errors)
    assert np.median(rel) < 1e-6 and np.quantile(rel, 0.999) < 1e-4 and rel.max() < 1e-2
    assert same_face / total > 0.999, "the nearest triangle is the one embree hits"


def test_batching_over_poses_and_meshes_equals_one_at_a_time():
    camera, meshes = views_of("chopper", 3)
    verts, faces = stacked(meshes[:4]), faces_of("chopper")
    together = rasterize_camera(verts, faces, camera)
    for i in range(4):
        alone = rasterize_camera(verts[i:i + 1], faces, camera)
        assert torch.equal(together.face_map[i], alone.face_map[0])
        torch.testing.assert_close(together.depth_map[i], alone.depth_map[0])
        torch.testing.assert_close(together.bary_map[i], alone.bary_map[0])
    # different meshes in one batch, padded; and tiny chunks of candidates give the same buffer
    _, other = views_of("biplane", 5)
    packed_v, packed_f = pad_meshes([(verts[0], faces), (stacked(other[:1])[0], faces_of("biplane"))])
    cam = camera_tensors(camera)
    mixed = rasterize(packed_v, packed_f, cam.intrinsics, cam.image_size, cam.world_to_camera, max_candidates=4096)
    assert torch.equal(mixed.face_map[0], together.face_map[0])
    alone = rasterize(stacked(other[:1]), faces_of("biplane"), cam.intrinsics, cam.image_size, cam.world_to_camera)
    assert torch.equal(mixed.face_map[1], alone.face_map[0])
    torch.testing.assert_close(mixed.interpolate(packed_v)[1], alone.interpolate(stacked(other[:1]))[0])


def test_per_item_cameras_and_strides():
    camera, meshes = views_of("sedan", 7)
    verts, faces = stacked(meshes[:2]), faces_of("sedan")
    cam = camera_tensors(camera)
    one = rasterize(verts, faces, cam.intrinsics, cam.image_size, cam.world_to_camera)
    per_item = rasterize(verts, faces, cam.intrinsics.expand(2, 3, 3), cam.image_size,
                         cam.world_to_camera.expand(2, 4, 4))
    assert torch.equal(one.face_map, per_item.face_map)
    # a stride-8 feature map of the camera is the same camera at 1/8 of the resolution
    coarse = rasterize_camera(verts, faces, camera, stride=8)
    small = Camera(WIDTH // 8, HEIGHT // 8, tuple(tuple(v / 8 if i < 2 else v for v in row) for i, row in
                                                  enumerate(camera.intrinsics)), camera.camera_to_world)
    assert (coarse.height, coarse.width) == (HEIGHT // 8, WIDTH // 8)
    assert torch.equal(coarse.face_map, rasterize_camera(verts, faces, small).face_map)
    assert coarse.mask.any()


def test_projection_matches_camera_project():
    camera = make_camera(640, 480, (0.3, -0.2, 0.1))
    points = np.random.default_rng(0).uniform(-3, 3, (50, 3))
    cam = camera_tensors(camera, dtype=torch.float64)
    ours = project_vertices(torch.as_tensor(points)[None], cam.intrinsics, cam.world_to_camera)[0].numpy()
    np.testing.assert_allclose(ours, camera.project(points), rtol=1e-9, atol=1e-9)


def test_interpolated_positions_lie_on_the_pixel_rays_at_the_depth():
    """Perspective-correct barycentrics: the interpolated world point of a pixel projects to its centre."""
    camera, meshes = views_of("jet", 11)
    verts = stacked(meshes[:2], torch.float64)
    frags = rasterize_camera(verts, faces_of("jet"), camera)
    points = frags.interpolate_sparse(verts)
    uvz = camera.project(points.numpy())
    within = frags.pixel.numpy() % (camera.width * camera.height)
    np.testing.assert_allclose(uvz[:, 0], within % camera.width + 0.5, atol=1e-6)
    np.testing.assert_allclose(uvz[:, 1], within // camera.width + 0.5, atol=1e-6)
    np.testing.assert_allclose(uvz[:, 2], frags.depth.numpy(), rtol=1e-9)
    assert frags.bary.min() >= -1e-9 and (frags.bary.sum(1) - 1).abs().max() < 1e-9


@pytest.mark.parametrize("subtype", ["road", "tandem", "truck"])
def test_back_face_culling_keeps_closed_silhouettes(subtype):
    """The vehicles are closed and outward-wound, so a ray's first hit is a front face: culling keeps every
    silhouette and (but for grazing ties) every face."""
    camera, meshes = views_of(subtype, 2)
    verts, faces = stacked(meshes), faces_of(subtype)
    full, culled = rasterize_camera(verts, faces, camera), rasterize_camera(verts, faces, camera, cull_backfaces=True)
    assert torch.equal(full.mask, culled.mask)
    assert (full.face == culled.face).double().mean() > 0.995


def grid_mesh(n: int) -> tuple[torch.Tensor, torch.Tensor]:
    """An n x n vertex grid (2 (n-1)^2 triangles, diagonals both ways) in the plane z = -2 of the camera frame."""
    u, v = torch.meshgrid(torch.arange(n, dtype=torch.float64), torch.arange(n, dtype=torch.float64), indexing="ij")
    verts = torch.stack([u.reshape(-1), v.reshape(-1), torch.full((n * n,), -2.0)], dim=1)
    quads = torch.arange(n * n).view(n, n)[:-1, :-1].reshape(-1)
    a, b, c, d = quads, quads + 1, quads + n, quads + n + 1
    faces = torch.cat([torch.stack([a, b, d], 1)[::2], torch.stack([a, b, c], 1)[1::2],
                       torch.stack([a, d, c], 1)[::2], torch.stack([b, d, c], 1)[1::2]])
    return verts[None], faces


def test_no_cracks_where_pixel_centres_lie_on_shared_edges():
    """Grid vertices project onto every other pixel centre, so every centre in the grid lies on an edge (the
    quads' centres on their diagonals) or a vertex: each must be covered, and nothing outside."""
    n = 12
    verts, faces = grid_mesh(n)
    side = 2 * (n - 1) + 1
    # at depth 2 with f = 4, grid steps are 2 pixels; x = 2 u + 3.5 and y = -2 v + side + 0.5
    K = torch.tensor([[4.0, 0.0, 3.5], [0.0, 4.0, side + 0.5], [0.0, 0.0, 1.0]], dtype=torch.float64)
    mask = rasterize(verts, faces, K, (side + 4, side + 6)).mask[0]
    assert int(mask.sum()) == side * side
    assert mask[1:1 + side, 3:3 + side].all()


def test_empty_offscreen_and_behind_camera_meshes_are_background():
    camera = make_camera(160, 120)
    _, meshes = views_of("suv", 1)
    verts, faces = stacked(meshes[:1]), faces_of("suv")
    eye = torch.as_tensor(camera.location, dtype=torch.float32)
    forward = torch.as_tensor(-camera.matrix_world[:3, 2], dtype=torch.float32)
    right = torch.as_tensor(camera.matrix_world[:3, 0], dtype=torch.float32)
    centre = verts[0].mean(0)
    behind = verts - centre + eye - 3.0 * forward
    aside = verts - centre + eye + 10.0 * forward + 40.0 * right
    across = verts - centre + eye  # straddles the camera: every triangle near it is dropped, none drawn wrongly
    batch = torch.cat([behind, aside, across])
    frags = rasterize_camera(batch, faces, camera)
    assert not frags.mask[:2].any() and torch.isinf(frags.depth_map[:2]).all()
    assert (frags.depth_map[2][frags.mask[2]] >= 1e-3).all()
    feats = torch.randn(verts.shape[1], 4)
    assert (frags.interpolate(feats, background=-1.0)[:2] == -1.0).all()
    empty = rasterize_camera(verts, torch.zeros((0, 3), dtype=torch.int64), camera)
    assert not empty.mask.any() and empty.interpolate(feats).shape == (1, 120, 160, 4)
    nothing = rasterize_camera(torch.zeros((1, 0, 3)), torch.zeros((0, 3), dtype=torch.int64), camera)
    assert nothing.face_map.eq(-1).all()


def test_gradients_match_finite_differences():
    """Two overlapping triangles at different depths; features and depth of every covered pixel as a function of
    the vertex positions, the intrinsics and the camera pose, checked by torch's finite-difference gradcheck."""
    verts = torch.tensor([[[-1.0, -0.8, -3.0], [1.2, -0.5, -3.5], [0.1, 1.1, -2.5],
                           [-0.6, 0.2, -2.0], [0.9, 0.6, -2.2], [0.3, -0.9, -1.9]]], dtype=torch.float64)
    faces = torch.tensor([[0, 1, 2], [3, 4, 5]])
    K = torch.tensor([[20.0, 0.0, 16.0], [0.0, 20.0, 12.0], [0.0, 0.0, 1.0]], dtype=torch.float64)
    w2c = torch.eye(4, dtype=torch.float64)  # a small rotation and shift of the camera frame
    w2c[:3, :3] = torch.linalg.matrix_exp(torch.tensor([[0.0, -0.02, 0.01], [0.02, 0.0, -0.03], [-0.01, 0.03, 0.0]],
                                                        dtype=torch.float64))
    w2c[:3, 3] = torch.tensor([0.05, -0.02, 0.1])
    feats = torch.randn(1, 6, 2, dtype=torch.float64, generator=torch.Generator().manual_seed(0))
    frags = rasterize(verts, faces, K, (24, 32), w2c)
    assert frags.mask.sum() > 50 and set(frags.face.tolist()) == {0, 1}

    def render(v: torch.Tensor, k: torch.Tensor, pose: torch.Tensor) -> torch.Tensor:
        f = rasterize(v, faces, k, (24, 32), pose)
        assert torch.equal(f.pixel, frags.pixel) and torch.equal(f.face, frags.face)
        return torch.cat([f.interpolate_sparse(feats).reshape(-1), f.depth])

    inputs = tuple(t.clone().requires_grad_() for t in (verts, K, w2c))
    assert torch.autograd.gradcheck(render, inputs, eps=1e-6, atol=1e-6)


def test_pose_gradients_reach_the_yaw_through_a_vehicle_render():
    camera = make_camera(160, 120)
    _, meshes = views_of("sedan", 4)
    base = torch.as_tensor(meshes[0].vertices, dtype=torch.float64)
    centre = base.mean(0)
    yaw = torch.tensor(0.0, dtype=torch.float64, requires_grad=True)
    c, s = torch.cos(yaw), torch.sin(yaw)
    zero, one = torch.zeros((), dtype=torch.float64), torch.ones((), dtype=torch.float64)
    R = torch.stack([torch.stack([c, -s, zero]), torch.stack([s, c, zero]), torch.stack([zero, zero, one])])
    verts = ((base - centre) @ R.T + centre)[None]
    frags = rasterize_camera(verts, faces_of("sedan"), camera)
    feats = torch.as_tensor(np.random.default_rng(0).normal(size=(base.shape[0], 3)))
    loss = frags.interpolate(feats).square().sum() + frags.depth.sum()
    (grad,) = torch.autograd.grad(loss, yaw)
    assert torch.isfinite(grad) and grad.abs() > 0


def test_bad_inputs_raise_input_errors_naming_the_argument():
    verts, faces = grid_mesh(3)
    K = torch.eye(3, dtype=torch.float64)
    bad = [
        ({"vertices": verts[0]}, "vertices"),
        ({"vertices": verts.long()}, "vertices"),
        ({"vertices": verts.clone().index_fill_(1, torch.tensor([0]), float("nan"))}, "vertices"),
        ({"faces": faces.double()}, "faces"),
        ({"faces": faces[:, :2]}, "faces"),
        ({"faces": faces + 100}, "faces"),
        ({"intrinsics": torch.eye(4, dtype=torch.float64)}, "intrinsics"),
        ({"world_to_camera": torch.eye(3, dtype=torch.float64)}, "world_to_camera"),
        ({"image_size": (0, 5)}, "image_size"),
        ({"image_size": (4.5, 5)}, "image_size"),
    ]
    for change, field in bad:
        args = {"vertices": verts, "faces": faces, "intrinsics": K, "image_size": (8, 8)} | change
        with pytest.raises(InputError) as err:
            rasterize(**args)
        assert err.value.field == field, change
    frags = rasterize(verts, faces, K, (8, 8))
    with pytest.raises(InputError, match="features"):
        frags.interpolate(torch.zeros(2, 9, 3))
    with pytest.raises(InputError, match="stride"):
        camera_tensors(make_camera(), stride=0)


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA device")
def test_cuda_matches_cpu():
    camera, meshes = views_of("mountain", 6)
    verts, faces = stacked(meshes), faces_of("mountain")
    cpu = rasterize_camera(verts, faces, camera)
    gpu_verts = verts.to("cuda").requires_grad_()
    gpu = rasterize_camera(gpu_verts, faces.to("cuda"), camera)
    assert isinstance(gpu, Fragments) and gpu.pixel.device.type == "cuda"
    assert torch.equal(gpu.face_map.cpu(), cpu.face_map)
    torch.testing.assert_close(gpu.depth.cpu(), cpu.depth)
    gpu.interpolate(gpu_verts).sum().backward()
    assert gpu_verts.grad is not None and torch.isfinite(gpu_verts.grad).all()

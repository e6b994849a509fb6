"""The image's SceneEvidence: a hand-built occlusion read from pixels, empty images, and the calibration record."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
import torch

from po3d_ppl import ontology
from po3d_ppl.errors import ModelFileError
from po3d_ppl.evidence import SceneEvidence
from po3d_ppl.perception.calibration import TableCalibration, load_calibration
from po3d_ppl.perception.image_input import CameraPrior
from po3d_ppl.perception.scene_parser import SceneParserConfig, parse_scene
from po3d_ppl.world.generate import render_layout
from po3d_ppl.world.sampler import ObjectSpec


@pytest.fixture(scope="module")
def bus_behind_car():
    """A sedan in front of a school bus (the bus partly hidden), base camera."""
    specs = [ObjectSpec("school", "yellow", "rubber", "large", 30.0, -0.5, 0.5),
             ObjectSpec("sedan", "red", "metal", "large", 100.0, 1.2, -1.0)]
    return render_layout(specs, CameraPrior(640, 480).base)


@pytest.fixture(scope="module")
def parsed(bus_behind_car):
    return parse_scene(bus_behind_car.image)


def _nearest(evidence: SceneEvidence, xy) -> int:
    return int(np.argmin(np.linalg.norm(evidence.positions[:, :2].numpy() - np.asarray(xy), axis=1)))


def test_occlusion_is_read_by_projection(bus_behind_car, parsed):
    truth = bus_behind_car.scene.objects
    assert truth[0].occluded_by == (1,)  # the layout is what the test says
    ev = parsed.evidence
    assert ev.num_objects == 2
    bus, car = _nearest(ev, truth[0].position[:2]), _nearest(ev, truth[1].position[:2])
    assert bus != car
    assert ev.occluded_logodds[bus] > 0 > ev.occluded_logodds[car]
    assert ev.occludes_logodds[bus, car] > 0 > ev.occludes_logodds[car, bus]
    for i, obj in ((bus, truth[0]), (car, truth[1])):
        assert np.linalg.norm(ev.positions[i, :2].numpy() - np.asarray(obj.position[:2])) < 0.5


def test_evidence_fills_the_contract_from_pixels(bus_behind_car, parsed):
    ev = parsed.evidence
    ev.validate()
    assert ev.directions["left"].tolist() == pytest.approx(list(ev.camera.ground_directions()["left"]))
    # pose tables are P(azimuth | category), the category evidence sits in the subtype table only
    assert torch.allclose(torch.logsumexp(ev.pose_loglik, -1), torch.zeros(2, 5, dtype=torch.float64))
    # every projected hypothesis is recorded with its weight; per proposal the weights sum to one
    for i in range(ev.num_objects):
        assert sum(p.weight for p in parsed.projections if p.proposal == i) == pytest.approx(1.0)
    assert {"objects.coarse", "projection", "total"} <= set(parsed.timings)


def test_evidence_boxes_are_the_objects_visible_boxes(bus_behind_car, parsed):
    from po3d_ppl.evaluation.objects import box_iou

    ev = parsed.evidence
    for obj in bus_behind_car.scene.objects:
        box = ev.boxes[_nearest(ev, obj.position[:2])].tolist()
        assert box_iou(box, obj.annotation.bbox) > 0.7
    assert not (ev.masks[0] & ev.masks[1]).any()  # one owner per pixel


def test_seen_ownership_gives_pixels_to_the_proposal_the_scene_shows_there():
    from po3d_ppl.errors import InputError
    from po3d_ppl.perception.object_parser import ownership_masks
    from po3d_ppl.perception.scene_parser import seen_ownership

    ownership = torch.full((4, 6), -1, dtype=torch.long)
    ownership[:, :4] = 0  # proposal 0's category mesh spills over columns 2-3
    ownership[:, 4:] = 1
    ids = np.full((4, 6), -1)
    ids[:, :2] = 0
    ids[:, 2:5] = 1  # the aligned silhouettes: proposal 1 is seen from column 2 (not on column 5)
    out = ownership_masks(seen_ownership(ownership, ids), 2)
    assert out[0].sum() == 8 and out[0, :, :2].all()
    assert out[1, :, 2:].all()  # its spilled columns, and column 5 it keeps where nothing else is seen
    assert not (out[0] & out[1]).any()
    with pytest.raises(InputError, match="object_ids"):
        seen_ownership(ownership, ids[:3])


def test_an_image_without_vehicles_gives_empty_evidence():
    """The world's bare ground (the one object stands behind the camera, out of view)."""
    behind = ObjectSpec("sedan", "red", "metal", "large", 0.0, 20.0, -20.0)
    bare = render_layout([behind], CameraPrior(640, 480).base)
    assert (bare.object_ids < 0).all()
    parsed = parse_scene(bare.image)
    ev = parsed.evidence
    assert ev.num_objects == 0
    assert ev.part_occludes_logodds.shape == (0, 21, ev.part_visible_logodds.shape[-1], 0)


def test_config_is_checked():
    with pytest.raises(Exception, match="projection_floor"):
        SceneParserConfig(projection_floor=0.7)
    with pytest.raises(Exception, match="merge_max_distance"):
        SceneParserConfig(merge_max_distance=0.0)
    with pytest.raises(Exception, match="height_shift_px"):
        SceneParserConfig(height_shift_px=-1)


def test_calibration_round_trips_and_is_checksummed(tmp_path):
    from po3d_ppl.model_store import write_entry
    from po3d_ppl.perception.calibration import MODEL_NAME

    fitted = TableCalibration(2.5, 7.0, 0.03, -0.4)
    write_entry(MODEL_NAME, [fitted.save(tmp_path)], tmp_path, command="test")
    assert load_calibration(tmp_path, required=True) == fitted
    path = tmp_path / "object_calibration.safetensors"
    data = bytearray(path.read_bytes())
    data[-1] ^= 0xFF
    path.write_bytes(bytes(data))
    with pytest.raises(ModelFileError, match="object_calibration.safetensors"):
        load_calibration(tmp_path, required=True)
    assert load_calibration(tmp_path / "nowhere") == TableCalibration()  # nothing shipped there: raw scores


@dataclass
class _OneProposal:
    """What :func:`silhouette_subtype_loglik` reads of the object parser's proposals."""

    masks: torch.Tensor
    ownership: torch.Tensor
    pose_support: torch.Tensor

    def __len__(self) -> int:
        return 1


def test_silhouette_term_prefers_the_rendered_subtype():
    """Each of three cars, rendered alone, read with the car category sure and the true pose: its outline term
    ranks its own subtype first among the cars, and the unrendered categories get the lowest term."""
    from po3d_ppl import ontology
    from po3d_ppl.perception.object_parser import yaw_of
    from po3d_ppl.perception.scene_parser import SUBTYPE_CATEGORY, SUBTYPES, silhouette_subtype_loglik

    camera = CameraPrior(640, 480).base
    support = torch.arange(24, dtype=torch.float64)[None] * 15.0
    config = SceneParserConfig()
    car = ontology.CATEGORIES.index("car")
    for subtype in ("truck", "sedan", "suv"):
        x, y = 0.3, 0.4
        # the pose bin whose world yaw is the object's rotation
        bin_ = int(np.argmin([abs((yaw_of(camera, x, y, a) - 40.0 + 180.0) % 360.0 - 180.0)
                              for a in support[0].tolist()]))
        rotation = yaw_of(camera, x, y, float(support[0, bin_]))
        shot = render_layout([ObjectSpec(subtype, "gray", "rubber", "large", rotation, x, y)], camera)
        mask = torch.from_numpy(shot.object_ids == 0)
        proposals = _OneProposal(mask[None], torch.where(mask, 0, -1), support)
        subtype_ll = torch.where(SUBTYPE_CATEGORY == car, 0.0, -30.0).double()[None]
        pose_ll = torch.full((1, 5, 24), -30.0, dtype=torch.float64)
        pose_ll[0, :, bin_] = 0.0
        size_ll = torch.tensor([[0.0, -30.0]], dtype=torch.float64)
        terms = silhouette_subtype_loglik(proposals, [[x, y]], [0.0], subtype_ll, size_ll, pose_ll, camera, config)[0]
        cars = [s for s in range(len(SUBTYPES)) if int(SUBTYPE_CATEGORY[s]) == car]
        assert max(cars, key=lambda s: float(terms[s])) == SUBTYPES.index(subtype)
        assert float(terms[SUBTYPES.index(subtype)]) > 0.9 * config.silhouette_weight
        others = [s for s in range(len(SUBTYPES)) if s not in cars]
        assert torch.all(terms[others] == terms[cars].min())


class _FixedLooks:
    """An attribute network whose part-style table is given per pose hypothesis."""

    def __init__(self, tables):
        self.tables = tables

    def part_style_tables(self, img, masks, part_maps, min_pixels=1):
        return self.tables[:len(part_maps)]


def test_part_looks_are_read_under_the_kept_pose_hypotheses():
    """A less likely pose reads the part's pixels of another (plain) part: mixed in at its weight it drags a clear
    recoloured reading to even odds; reading the most likely pose only keeps it."""
    from po3d_ppl.evidence import NUM_STYLES
    from po3d_ppl.perception.scene_parser import _mixed_styles

    n, s_count, p_count = 1, len(ontology.SUBTYPES), max(len(v) for v in ontology.PARTS.values())
    recoloured = torch.full((n, s_count, p_count, NUM_STYLES), -9.0, dtype=torch.float64)
    recoloured[..., 5] = 0.0  # one look, sure
    plain = torch.full_like(recoloured, -9.0)
    plain[..., 0] = 0.0
    looks = _FixedLooks([recoloured.log_softmax(-1), plain.log_softmax(-1)])
    maps = [{(0, 0): torch.zeros(4, 4, dtype=torch.long)}, {(0, 0): torch.zeros(4, 4, dtype=torch.long)}]
    weights = torch.zeros(2, n, s_count, dtype=torch.float64)
    weights[:, 0, 0] = torch.tensor([0.86, 0.14])
    masks = torch.ones(n, 4, 4, dtype=torch.bool)
    mixed = _mixed_styles(looks, None, masks, maps, weights).exp()[0, 0, 0]
    top = _mixed_styles(looks, None, masks, maps, weights, kept=1).exp()[0, 0, 0]
    assert mixed[0] == pytest.approx(0.14, abs=5e-3) and mixed[5] == pytest.approx(0.86, abs=5e-3)
    assert top[5] > 0.99
    unshown = _mixed_styles(looks, None, masks, maps, weights, kept=1)[0, 1]
    assert torch.equal(unshown, torch.zeros_like(unshown))  # a hypothesis without weight reads nothing


def test_style_pose_hypotheses_is_checked():
    with pytest.raises(Exception, match="style_pose_hypotheses"):
        SceneParserConfig(style_pose_hypotheses=0)
    assert SceneParserConfig(style_pose_hypotheses=None).style_pose_hypotheses is None


def _strip_proposals(n: int, ownership: torch.Tensor):
    from po3d_ppl.perception.object_parser import ObjectProposals, ownership_masks, xywh_boxes

    masks = ownership_masks(ownership, n)
    return ObjectProposals(
        existence_logodds=torch.arange(n, dtype=torch.float64), category_loglik=torch.zeros(n, 5, dtype=torch.float64),
        pose_support=torch.zeros(n, 4, dtype=torch.float64), pose_loglik=torch.zeros(n, 5, 4, dtype=torch.float64),
        size_loglik=torch.zeros(n, 2, dtype=torch.float64),
        positions=torch.arange(3 * n, dtype=torch.float64).reshape(n, 3), depths=torch.arange(n, dtype=torch.float64),
        rotations=torch.zeros(n, dtype=torch.float64), boxes=xywh_boxes(masks), masks=masks, ownership=ownership,
        camera=CameraPrior(640, 480).base, from_region=torch.arange(n) == n - 1, poses=["a", "b", "c"][:n])


def test_merged_proposals_pool_their_pixels_and_drop_the_folded_rows():
    from po3d_ppl.errors import InputError
    from po3d_ppl.perception.object_parser import merge_proposals

    ownership = torch.full((4, 9), -1, dtype=torch.long)
    ownership[:, 0:3], ownership[:, 3:6], ownership[1:3, 6:9] = 0, 1, 2  # 1 is the second half of 2's object
    merged = merge_proposals(_strip_proposals(3, ownership), [0, 2, 2])
    assert len(merged) == 2 and merged.poses == ["a", "c"] and merged.from_region.tolist() == [False, True]
    assert merged.existence_logodds.tolist() == [0.0, 2.0] and merged.depths.tolist() == [0.0, 2.0]
    assert (merged.ownership[:, 3:6] == 1).all() and (merged.ownership[:, :3] == 0).all()
    assert merged.boxes[1].tolist() == [3.0, 0.0, 6.0, 4.0]  # the union of the two halves
    assert (merged.ownership == -1).sum() == (ownership == -1).sum()
    with pytest.raises(InputError, match="into"):
        merge_proposals(_strip_proposals(3, ownership), [1, 2, 2])  # 1 is folded into 2, so nothing may go to 1


def _strip_evidence(colours: list[int], ground_x: list[float]):
    """Three proposals side by side on a strip: 0 | 1 | 2, each touching the next (a stand-in for SceneEvidence)."""
    from types import SimpleNamespace

    from po3d_ppl.perception.object_parser import ownership_masks

    ownership = torch.full((4, 12), -1, dtype=torch.long)
    ownership[:, 0:4], ownership[:, 4:8], ownership[:, 8:12] = 0, 1, 2
    sedan = ontology.SUBTYPES.index("sedan")
    subtype = torch.full((3, len(ontology.SUBTYPES)), -20.0, dtype=torch.float64)
    subtype[:, sedan] = 0.0
    colour = torch.full((3, len(ontology.COLORS)), -20.0, dtype=torch.float64)
    colour[torch.arange(3), torch.tensor(colours)] = 0.0
    positions = torch.tensor([[x, 0.0, 0.0] for x in ground_x], dtype=torch.float64)
    return SimpleNamespace(num_objects=3, subtype_loglik=subtype, color_loglik=colour, positions=positions,
                           exist_logodds=torch.tensor([0.5, 3.0, 1.0], dtype=torch.float64),
                           masks=ownership_masks(ownership, 3))


def test_touching_proposals_of_one_category_and_colour_close_on_the_ground_are_one_object():
    from po3d_ppl.perception.scene_parser import one_object_merges

    config = SceneParserConfig()
    # 0 and 1: red sedans 0.8 apart -> one object, kept as 1 (more likely to exist); 2 is blue
    assert one_object_merges(_strip_evidence([0, 0, 3], [0.0, 0.8, 1.6]), config) == [1, 1, 2]
    # all red: 0, 1 and 2 chain into the likeliest
    assert one_object_merges(_strip_evidence([0, 0, 0], [0.0, 0.8, 1.6]), config) == [1, 1, 1]
    # two red sedans side by side, farther apart than one object's halves: kept apart
    assert one_object_merges(_strip_evidence([0, 0, 3], [0.0, 2.0, 4.0]), config) is None
    assert one_object_merges(_strip_evidence([0, 0, 0], [0.0, 0.8, 1.6]),
                             SceneParserConfig(merge_max_distance=None)) is None


@dataclass
class _PlacedProposals(_OneProposal):
    """What :func:`estimate_camera_height` reads besides: ground positions under the base camera, and that camera."""

    positions: torch.Tensor
    camera: object

    def __len__(self) -> int:
        return int(self.masks.shape[0])


def test_camera_height_is_read_from_object_sizes_despite_misplaced_bases():
    """Two large trucks rendered with the camera 0.3 above its base height, their proposals' base points 4 px
    off (as the object parser leaves them): the estimate lands near 0.3 when each candidate's silhouette is
    compared at its best shift, and further off when it is compared where the base point puts it."""
    from po3d_ppl.perception.image_input import backproject_to_plane
    from po3d_ppl.perception.object_parser import yaw_of
    from po3d_ppl.perception.scene_parser import SUBTYPES, estimate_camera_height, project_points

    prior = CameraPrior(640, 480)
    camera, base = prior.camera((0.0, 0.0, 0.3)), prior.base
    support = torch.arange(24, dtype=torch.float64)[None].repeat(2, 1) * 15.0
    places = [(1.0, -1.5, 3), (-1.5, 1.0, 20)]  # x, y, pose bin
    specs = [ObjectSpec("truck", "gray", "rubber", "large", yaw_of(camera, x, y, float(support[0, k])), x, y)
             for x, y, k in places]
    shot = render_layout(specs, camera)
    masks = torch.stack([torch.from_numpy(shot.object_ids == j) for j in range(2)])
    pixels = project_points(camera, torch.tensor([[x, y, 0.0] for x, y, _ in places], dtype=torch.float64))[:, :2]
    pixels = pixels + torch.tensor([[4.0, -3.0], [-4.0, 3.0]], dtype=torch.float64)
    positions = torch.as_tensor(backproject_to_plane(base, pixels), dtype=torch.float64)
    proposals = _PlacedProposals(masks, torch.from_numpy(shot.object_ids.astype(np.int64)), support, positions,
                                 base)
    subtype_ll = torch.full((2, len(SUBTYPES)), -30.0, dtype=torch.float64)
    subtype_ll[:, SUBTYPES.index("truck")] = 0.0
    size_ll = torch.tensor([[0.0, -30.0]] * 2, dtype=torch.float64)
    pose_ll = torch.full((2, 5, 24), -30.0, dtype=torch.float64)
    for i, (_, _, k) in enumerate(places):
        pose_ll[i, :, k] = 0.0

    @dataclass
    class _Image:
        size: tuple[int, int]
        intrinsics: tuple

    img = _Image((640, 480), prior.intrinsics)
    errors = {}
    for shift in (10, 0):
        found, _ = estimate_camera_height(proposals, subtype_ll, size_ll, pose_ll, img,
                                          SceneParserConfig(height_shift_px=shift))
        errors[shift] = abs(found.camera_to_world[2][3] - camera.camera_to_world[2][3])
    assert errors[10] < 0.05
    assert errors[0] > errors[10]


def test_post_filter_lowers_existence_by_at_most_the_bound_where_the_attributes_disagree():
    from po3d_ppl import ontology
    from po3d_ppl.perception.scene_parser import post_filter

    categories = list(ontology.CATEGORIES)
    category_logp = torch.full((2, 5), -9.0, dtype=torch.float64)
    category_logp[:, categories.index("car")] = 0.0  # render-and-compare reads a car twice
    subtype = torch.full((2, len(ontology.SUBTYPES)), -20.0, dtype=torch.float64)
    subtype[0, ontology.SUBTYPES.index("sedan")] = 0.0  # the attributes agree ...
    subtype[1, ontology.SUBTYPES.index("airliner")] = 0.0  # ... and strongly disagree
    existence = torch.tensor([2.0, 2.0], dtype=torch.float64)
    bounded = post_filter(existence, category_logp, subtype, 1.0)
    unbounded = post_filter(existence, category_logp, subtype, None)
    assert bounded[0] == pytest.approx(2.0, abs=1e-6) and bounded[1] == pytest.approx(1.0)
    assert float(unbounded[1]) < -10.0 and unbounded[0] == pytest.approx(2.0, abs=1e-6)
    with pytest.raises(Exception, match="post_filter_max_nats"):
        SceneParserConfig(post_filter_max_nats=-1.0)


def test_the_most_likely_subtypes_are_projected_however_unlikely(parsed):
    """A misread object's true subtype is often far below the top one; its slot must hold a projection, not the
    floor ("not visible") that an unprojected hypothesis keeps."""
    from po3d_ppl.perception.projection_calibration import edge_logodds

    evidence, config = parsed.evidence, SceneParserConfig()
    floor = -edge_logodds(config.projection_floor)
    for i in range(evidence.num_objects):
        probs = torch.softmax(evidence.subtype_loglik[i], -1)
        top = torch.argsort(probs, descending=True)[: config.max_subtypes]
        assert float(probs[top[-1]]) < 0.002  # the table is sharp: the old weight threshold dropped these
        for s in top.tolist():
            parts = len(ontology.PARTS[ontology.SUBTYPES[s]])
            shown = evidence.part_visible_logodds[i, s, :parts]
            assert float(shown.max()) > floor + 1e-3, (i, ontology.SUBTYPES[s])
        projected = {p.subtype for p in parsed.projections if p.proposal == i}
        assert projected == set(top.tolist())

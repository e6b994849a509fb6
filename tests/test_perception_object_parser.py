"""The object parser: finds a rendered object where it is, proposes nothing on bare ground, fills the contract's
shapes, and is deterministic."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from po3d_ppl import ontology
from po3d_ppl.perception.object_parser import (
    CATEGORIES,
    Hypothesis,
    ObjectProposals,
    ParserConfig,
    footprints_overlap,
    parse_objects,
)
from po3d_ppl.world import generate_scene
from po3d_ppl.world.sampler import SceneConfig


@pytest.fixture(scope="module")
def one_object():
    """A one-object scene without camera jitter (the parser assumes the base camera), rendered at 320x240 (the
    parser brings it to the working size, intrinsics scaled)."""
    config = SceneConfig(min_objects=1, max_objects=1, width=320, height=240, camera_jitter=0.0)
    return generate_scene(4, config)


@pytest.fixture(scope="module")
def parsed(one_object) -> ObjectProposals:
    return parse_objects(one_object.image)


def test_one_object_found_with_its_category_near_its_position(one_object, parsed):
    obj = one_object.scene.objects[0]
    confident = parsed.existence_logodds > 0
    assert int(confident.sum()) == 1
    i = int(torch.nonzero(confident)[0])
    assert parsed.categories[i] == obj.category
    err = float(np.linalg.norm(parsed.positions[i, :2].numpy() - np.asarray(obj.position[:2])))
    assert err < 0.5, err


def test_record_has_the_contract_shapes(parsed):
    n, k = len(parsed), ParserConfig().azimuth_bins
    assert parsed.category_loglik.shape == (n, len(ontology.CATEGORIES))
    assert parsed.pose_loglik.shape == (n, len(ontology.CATEGORIES), k)
    assert parsed.pose_support.shape == (n, k)
    assert parsed.size_loglik.shape == (n, 2)
    assert parsed.positions.shape == (n, 3) and parsed.depths.shape == (n,)
    assert parsed.boxes.shape == (n, 4)
    assert parsed.masks.shape == (n, 480, 640) and parsed.masks.dtype == torch.bool
    assert parsed.ownership.shape == (480, 640)
    for t in (parsed.existence_logodds, parsed.category_loglik, parsed.pose_loglik, parsed.positions):
        assert t.dtype == torch.float64 and torch.isfinite(t).all()
    # Pose tables are conditional on the category: normalised over azimuths (the category table is the evidence).
    assert torch.allclose(torch.logsumexp(parsed.pose_loglik, -1), torch.zeros(n, len(ontology.CATEGORIES),
                                                                                dtype=torch.float64))
    # Each proposal's visible mask is exactly the pixels it owns.
    for i in range(n):
        assert torch.equal(parsed.masks[i], parsed.ownership == i)


def test_bare_ground_gives_no_confident_proposal(one_object):
    """The scene's own background colour, with noise, and nothing on it."""
    image = one_object.image
    ground = np.median(image[one_object.object_ids < 0].reshape(-1, 3), axis=0)
    rng = np.random.default_rng(0)
    bare = np.clip(ground + rng.normal(0, 3, size=(240, 320, 3)), 0, 255).astype(np.uint8)
    record = parse_objects(bare)
    assert int((record.existence_logodds > 0).sum()) == 0


def test_parsing_is_deterministic(one_object, parsed):
    again = parse_objects(one_object.image)
    for name in ("existence_logodds", "category_loglik", "pose_loglik", "positions", "boxes", "ownership"):
        assert torch.equal(getattr(parsed, name), getattr(again, name)), name


def test_footprints_overlap_only_when_they_intersect():
    def hyp(x: float, y: float, rotation: float) -> Hypothesis:
        return Hypothesis(0, CATEGORIES.index("bus"), 0, 0, x, y, rotation, 10.0, 0.0)

    assert footprints_overlap(hyp(0, 0, 0), hyp(1.0, 0, 0), 0.7)  # one large bus is ~3.5 long
    assert not footprints_overlap(hyp(0, 0, 0), hyp(0, 1.2, 0), 0.7)  # side by side
    assert footprints_overlap(hyp(0, 0, 0), hyp(0, 1.2, 90), 0.7)  # crossing


def test_crowded_scene_proposals_do_not_overlap():
    """Objects do not interpenetrate: after re-search and refinement no two proposals' footprints intersect (seed 3
    had a pair before moves were undone), and each pixel has at most one owner."""
    config = SceneConfig(min_objects=6, width=320, height=240, camera_jitter=0.0)
    rendered = generate_scene(3, config)
    record = parse_objects(rendered.image)
    assert len(record) >= 4
    poses = record.poses
    assert len(poses) == len(record)
    for i in range(len(poses)):
        for j in range(i):
            assert not footprints_overlap(poses[i], poses[j], ParserConfig().footprint_shrink), (i, j)
    assert int(record.masks.sum(0).max()) <= 1


def test_a_mesh_hides_only_its_solid_cells():
    """Where the nearer proposal's own evidence is below ``solid_threshold`` (its category mesh overshooting), the
    farther proposal it overlaps in the image keeps the pixels; with -inf the nearer mesh owns all it covers."""
    from po3d_ppl.perception.image_input import CameraPrior
    from po3d_ppl.perception.object_parser import _ownership

    camera = CameraPrior(320, 240).base
    car = CATEGORIES.index("car")
    near = Hypothesis(0, car, 0, 0, 0.0, -1.0, 0.0, 9.0, 0.0)
    far = Hypothesis(0, car, 0, 0, 0.0, 1.5, 0.0, 11.0, 0.0)
    cells = (240 // 8, 320 // 8)
    fg = torch.stack([torch.full(cells, -5.0), torch.full(cells, 5.0)])  # the near one explains nothing
    hard, _ = _ownership([near, far], camera, ParserConfig(solid_threshold=-float("inf"), mask_stride=2), (320, 240),
                         fg)
    solid, _ = _ownership([near, far], camera, ParserConfig(solid_threshold=0.0, mask_stride=2), (320, 240), fg)
    both = (hard == 0) & (solid == 1)  # pixels the near mesh covered in front of the far one
    assert int(both.sum()) > 100
    assert int((solid == 0).sum()) < int((hard == 0).sum())
    assert int(((hard == 1) & (solid != 1)).sum()) == 0  # the far one loses nothing


def test_slivers_of_a_neighbour_are_dropped():
    """A proposal whose final mask holds under ``min_visible_fraction`` of its own silhouette is dropped; one
    that keeps its silhouette stays."""
    from po3d_ppl.perception import object_parser
    from po3d_ppl.perception.image_input import CameraPrior

    camera = CameraPrior(320, 240).base
    car = CATEGORIES.index("car")
    whole = Hypothesis(0, car, 0, 0, 0.0, 0.0, 0.0, 10.0, 0.0)
    sliver = Hypothesis(0, car, 0, 0, 1.6, 0.0, 0.0, 10.0, 0.0)
    config = ParserConfig(mask_stride=2)
    alone, _ = object_parser._ownership([whole], camera, config, (320, 240))
    _, silhouette = object_parser._ownership([whole, sliver], camera, config, (320, 240))
    ownership = alone.clone()
    ownership[0, :10] = 1  # ten pixels for the second proposal, far less than 5% of its silhouette
    assert object_parser._not_fragments(ownership, silhouette, config.min_visible_fraction) == [0]
    keep_all = ParserConfig(mask_stride=2, min_visible_fraction=0.0)
    assert object_parser._not_fragments(ownership, silhouette, keep_all.min_visible_fraction) == [0, 1]

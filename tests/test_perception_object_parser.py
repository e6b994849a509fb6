"""The object parser: finds a rendered object where it is, proposes nothing on bare ground, fills the contract's
shapes, and is deterministic."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from po3d_ppl import ontology
from po3d_ppl.perception.object_parser import (
    CATEGORIES,
    SIZES,
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


def test_keep_apart_sends_back_a_better_proposal_that_moved_onto_a_worse_ones_place():
    """keep_apart: a worse proposal's move into a better one is undone (the first pass), and so is a better
    proposal's move onto a worse one that did not move (it cannot go back further); moves that meet nothing stay."""
    from dataclasses import replace

    from po3d_ppl.perception.object_parser import keep_apart

    def bus(x: float, y: float, score: float) -> Hypothesis:
        return Hypothesis(0, CATEGORIES.index("bus"), 0, 0, x, y, 0.0, 10.0, score)

    config = ParserConfig()
    accepted = [bus(0.0, 0.0, 200.0), bus(0.0, 1.3, 60.0), bus(0.0, -3.0, 100.0)]
    moved = [replace(accepted[0], y=0.8), accepted[1], replace(accepted[2], y=-2.6)]
    assert footprints_overlap(moved[0], moved[1], config.footprint_shrink)
    kept = keep_apart(moved, accepted, config)
    assert kept == [accepted[0], accepted[1], moved[2]]
    worse_moves = [accepted[0], replace(accepted[1], y=0.4), accepted[2]]
    assert keep_apart(worse_moves, accepted, config) == accepted


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
    plain = ParserConfig(solid_threshold=-float("inf"), mask_stride=2, contest_margin=None)  # a plain z-buffer
    hard, _, _ = _ownership([near, far], camera, plain, (320, 240), fg)
    solid, _, _ = _ownership([near, far], camera, ParserConfig(solid_threshold=0.0, mask_stride=2), (320, 240), fg)
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
    alone, _, _ = object_parser._ownership([whole], camera, config, (320, 240))
    _, silhouette, _ = object_parser._ownership([whole, sliver], camera, config, (320, 240))
    ownership = alone.clone()
    ownership[0, :10] = 1  # ten pixels for the second proposal, far less than 5% of its silhouette
    assert object_parser._not_fragments(ownership, silhouette, config.min_visible_fraction) == [0]
    keep_all = ParserConfig(mask_stride=2, min_visible_fraction=0.0)
    assert object_parser._not_fragments(ownership, silhouette, keep_all.min_visible_fraction) == [0, 1]


def _search_state(image):
    """What :func:`parse_objects` computes before its 3D-NMS: features, cell evidence, templates, base camera."""
    from po3d_ppl.perception.features import extract_features
    from po3d_ppl.perception.image_input import CameraPrior, load_image
    from po3d_ppl.perception.object_parser import _cached_templates, _default_model, cell_evidence

    config = ParserConfig(merge_penalty=0.0)
    img = load_image(image)
    model = _default_model()
    meshes = model.meshes.normalised().to("cpu")
    features = extract_features(model.extractor, img.pixels).cpu()
    evidence, clutter = cell_evidence(features, meshes, config.kappa)
    templates = _cached_templates((img.size[0], img.size[1], img.intrinsics), config)
    return config, img, meshes, features, evidence, clutter, templates, CameraPrior.for_image(img).base


def test_an_object_proposed_as_two_fragments_is_merged():
    """A long object accepted as two shorter proposals, one at each end (what the coarse search's peaks do to an
    airliner or a bus), becomes one proposal of its category near it; without merging both stay."""
    from po3d_ppl.perception.object_parser import merge_fragments

    config = SceneConfig(min_objects=1, max_objects=1, camera_jitter=0.0)
    rendered = next(r for seed in range(60) if (o := (r := generate_scene(seed, config)).scene.objects[0]).category
                    == "bus" and o.size == "large" and o.color != "gray")
    obj = rendered.scene.objects[0]
    config, img, meshes, features, evidence, clutter, templates, camera = _search_state(rendered.image)
    bus, small = CATEGORIES.index("bus"), SIZES.index("small")
    axis = np.array([np.cos(np.radians(obj.rotation)), np.sin(np.radians(obj.rotation))])
    ends = [np.asarray(obj.position[:2]) + sign * 0.9 * axis for sign in (-1, 1)]
    fragments = [Hypothesis(-1, bus, small, 0, float(x), float(y), obj.rotation, 10.0, 100.0) for x, y in ends]
    assert not footprints_overlap(*fragments, config.footprint_shrink)
    size_hw = (int(features.shape[1]), int(features.shape[2]))
    # the colour gate off (no chroma): this is the log-likelihood test; the gate has its own test below
    merged, scores = merge_fragments(fragments, [100.0, 100.0], features, clutter, meshes, evidence, size_hw,
                                     templates, camera, config)
    assert len(merged) == len(scores) == 1
    assert merged[0].category == bus
    assert float(np.linalg.norm(np.array([merged[0].x, merged[0].y]) - np.asarray(obj.position[:2]))) < 0.6
    kept, _ = merge_fragments(fragments, [100.0, 100.0], features, clutter, meshes, evidence, size_hw, templates,
                              camera, ParserConfig(merge_penalty=None))
    assert kept == fragments


def test_a_named_region_is_fitted_by_its_category_and_kept_clear_of_standing_footprints(one_object):
    """The second search's fresh look at a named region: over an object's visible pixels, the named category's
    best-fitting hypothesis stands near the object, its visible silhouette overlaps the region, and it has tables
    of the contract's shapes; with a proposal standing there, whatever it proposes keeps its footprint clear."""
    from po3d_ppl.perception.object_parser import _named_region_hypothesis, _region_cells, cell_scores, search_objects
    from po3d_ppl.world.rle import decode

    obj = one_object.scene.objects[0]
    search = search_objects(one_object.image)
    height, width = search.foreground.shape
    region = decode(obj.annotation.visible_mask, 240, 320)
    region = np.kron(region, np.ones((height // 240, width // 320), dtype=bool))  # to the parser's working size
    cells = _region_cells(region, search.feature_size, search.config.region_cell_share)
    nothing = torch.zeros(search.feature_size, dtype=torch.bool)
    category = CATEGORIES.index(obj.category)
    found = _named_region_hypothesis(search, region, cells, category, [], None, nothing)
    assert found is not None
    hyp, iou, (category_table, pose, size) = found.hypothesis, found.iou, found.tables
    assert hyp.category == category and iou > 0.3
    assert float(np.hypot(hyp.x - obj.position[0], hyp.y - obj.position[1])) < 0.8
    assert category_table.shape == (len(CATEGORIES),) and size.shape == (len(SIZES),) and torch.isfinite(pose).all()
    maps = cell_scores([hyp], search.features, search.clutter, search.meshes, search.camera, search.config)
    beside = _named_region_hypothesis(search, region, cells, category, [hyp], maps, cells)
    assert beside is None or not footprints_overlap(beside.hypothesis, hyp, search.config.footprint_shrink)


def test_fragments_of_different_colours_are_not_merged():
    """The colour gate: two proposals are one object only if their median chromas agree and are not grey."""
    from po3d_ppl.perception.object_parser import _chroma, proposal_chroma, _same_colour
    from po3d_ppl.perception.image_input import load_image

    h, w = 240, 320
    pixels = np.zeros((h, w, 3), dtype=np.uint8)
    pixels[:, : w // 2] = (200, 30, 30)  # red
    pixels[:, w // 2:] = (30, 30, 200)  # blue
    img = load_image(pixels)
    chroma = _chroma(img)
    hh, ww = img.size[1] // 8, img.size[0] // 8
    mask = torch.zeros(2, hh, ww, dtype=torch.bool)
    mask[0, :, : ww // 2] = True
    mask[1, :, ww // 2:] = True
    fg = torch.full((2, hh, ww), 5.0)
    depth = torch.full((2, hh, ww), 10.0)
    foreground = torch.ones(img.size[1], img.size[0], dtype=torch.bool)
    config = ParserConfig(merge_penalty=0.0)
    colours = proposal_chroma(fg, mask, depth, chroma, foreground, config)
    assert not _same_colour(colours[0], colours[1], config)
    assert _same_colour(colours[0], colours[0] + 3.0, config)
    grey = torch.tensor([128.0, 129.0])
    assert not _same_colour(grey, grey, config)  # grey bodies are not told apart by colour
    nothing = proposal_chroma(fg, mask, depth, chroma, torch.zeros_like(foreground), config)
    assert torch.isnan(nothing).all() and not _same_colour(nothing[0], nothing[1], config)


def test_a_near_mesh_hides_only_the_cells_its_evidence_wins():
    """The contest: a near mesh whose texture explains a cell much worse than a far mesh's (its category mesh's
    overshoot) does not hide that cell; without the contest (or inside the margin) it does."""
    from po3d_ppl.perception.object_parser import front_cells

    mask = torch.tensor([[[True, True, True]], [[False, True, True]]])
    depth = torch.tensor([[[5.0, 5.0, 5.0]], [[8.0, 8.0, 8.0]]])
    fg = torch.tensor([[[6.0, 1.0, 5.0]], [[0.0, 6.0, 6.0]]])
    contested = front_cells(fg, mask, depth, ParserConfig(contest_margin=2.0))
    assert contested[1, 0].tolist() == [False, True, False]  # cell 2: the near mesh's 5 is within 2 of 6
    assert contested[0, 0].tolist() == [True, True, True]  # the near mesh still scores its own nearest cells
    plain = front_cells(fg, mask, depth, ParserConfig(contest_margin=None))
    assert plain[1, 0].tolist() == [False, False, False]


def test_an_object_behind_an_overshooting_mesh_is_added_only_if_its_colour_differs(monkeypatch):
    """:func:`add_occluded` on cell maps given directly: two peaks lie behind an accepted mesh's overshoot and
    explain those cells better; the one showing another colour is accepted, the one of the accepted proposal's colour
    (a duplicate of it) is not, and nothing is added without the contest."""
    import cv2

    from po3d_ppl.perception import object_parser as op

    cells_h, cells_w = 4, 12
    pixels = np.zeros((cells_h * 8, cells_w * 8, 3), dtype=np.uint8)
    pixels[:, :32] = (200, 30, 30)  # the accepted object: red
    pixels[:, 32:64] = (30, 30, 200)  # what lies behind its right overshoot: blue
    pixels[:, 64:] = (200, 30, 30)  # ... and, further right, red again
    chroma = torch.from_numpy(cv2.cvtColor(pixels, cv2.COLOR_RGB2LAB)[..., 1:].astype(np.float32))
    foreground = torch.ones(chroma.shape[:2], dtype=torch.bool)

    def maps(cols_owned: slice, cols_covered: slice, depth_value: float, score: float, overshoot: float = 1.0):
        fg = torch.zeros(cells_h, cells_w)
        mask = torch.zeros(cells_h, cells_w, dtype=torch.bool)
        mask[:, cols_covered] = True
        fg[:, cols_covered] = overshoot
        fg[:, cols_owned] = score
        return fg, mask, torch.full((cells_h, cells_w), depth_value)

    accepted = Hypothesis(0, 0, 0, 0, 0.0, 0.0, 0.0, 5.0, 500.0)
    blue = Hypothesis(1, 1, 1, 0, 5.0, 0.0, 0.0, 8.0, 300.0)
    red = Hypothesis(2, 1, 1, 0, 9.0, 0.0, 0.0, 8.0, 200.0)
    table = {accepted: maps(slice(0, 4), slice(0, 12), 5.0, 6.0), blue: maps(slice(4, 8), slice(4, 8), 8.0, 6.0),
             red: maps(slice(8, 12), slice(8, 12), 8.0, 6.0)}

    def fake_cell_scores(hyps, *args):
        return tuple(torch.stack([table[h][n] for h in hyps]) for n in range(3))

    monkeypatch.setattr(op, "cell_scores", fake_cell_scores)
    config = ParserConfig(contest_margin=2.0, existence_threshold=20.0)
    kept, scores = op.add_occluded([accepted], [100.0], [accepted, blue, red], None, None, None, None, config,
                                   chroma, foreground)
    assert kept == [accepted, blue] and len(scores) == 2
    plain, _ = op.add_occluded([accepted], [100.0], [accepted, blue, red], None, None, None, None,
                               ParserConfig(contest_margin=None), chroma, foreground)
    assert plain == [accepted]


def test_pixels_two_meshes_cover_go_to_the_one_whose_colour_they_show():
    """:func:`_recolour`: the depth order gave a red proposal's overshoot the blue neighbour's pixels; those covered
    by the blue proposal's mesh move to it, those its mesh does not cover stay, and grey pixels (tyres, shading)
    near neither colour stay with their owner."""
    import cv2

    from po3d_ppl.perception.object_parser import _recolour

    h, w = 16, 32
    pixels = np.zeros((h, w, 3), dtype=np.uint8)
    pixels[:, :16] = (200, 30, 30)
    pixels[:, 16:] = (30, 30, 200)
    pixels[:, 30:] = (128, 128, 128)
    chroma = torch.from_numpy(cv2.cvtColor(pixels, cv2.COLOR_RGB2LAB)[..., 1:].astype(np.float32))
    ownership = torch.zeros(h, w, dtype=torch.long)
    ownership[:, 24:30] = 1  # the blue proposal owns only part of its body
    coverage = torch.zeros(2, h // 2, w // 2, dtype=torch.bool)  # meshes at stride 2
    coverage[0] = True
    coverage[1, :, 10:] = True  # the blue mesh covers columns 20 onwards
    out = _recolour(ownership, coverage, chroma, ParserConfig(mask_stride=2, colour_margin=10.0, colour_close=12.0))
    assert (out[:, :16] == 0).all()
    assert (out[:, 16:20] == 0).all()  # blue, but only the red mesh covers them
    assert (out[:, 20:30] == 1).all()
    assert (out[:, 30:] == 0).all()  # grey: near neither proposal's colour
    strict = ParserConfig(mask_stride=2, colour_margin=1000.0)  # no colour is that much nearer
    unchanged = _recolour(ownership, coverage, chroma, strict)
    assert torch.equal(unchanged, ownership)


@pytest.fixture(scope="module")
def three_apart():
    """Three objects well apart (base camera), and the object parser's search of the image."""
    from dataclasses import replace

    from po3d_ppl.perception.image_input import CameraPrior
    from po3d_ppl.perception.object_parser import search_objects
    from po3d_ppl.world.generate import render_layout
    from po3d_ppl.world.sampler import ObjectSpec

    specs = [ObjectSpec("school", "yellow", "rubber", "large", 30.0, -1.6, 0.8),
             ObjectSpec("sedan", "red", "metal", "large", 100.0, 1.4, -1.0),
             ObjectSpec("chopper", "blue", "metal", "large", 200.0, 1.2, 1.8)]
    rendered = render_layout(specs, CameraPrior(640, 480).base)
    search = search_objects(rendered.image, config=replace(ParserConfig(), region_min_score=30.0))
    return rendered, search


def test_a_missed_object_is_found_again_in_the_foreground_nothing_explains(three_apart):
    """The second search (add_region_proposals): with one located proposal taken out (a first reading that missed
    its object), the foreground it leaves unexplained raises a proposal there again; with every proposal in, or the
    second search off, nothing is added."""
    from dataclasses import replace

    from po3d_ppl.errors import InputError
    from po3d_ppl.perception.object_parser import add_region_proposals, record_objects

    rendered, search = three_apart
    assert len(search.located) == 3
    full = record_objects(search).ownership.numpy()
    assert add_region_proposals(search, full) is None  # everything is explained
    for k in range(3):
        kept = [i for i in range(3) if i != k]
        missed = replace(search, located=[search.located[i] for i in kept],
                         proposal_scores=[search.proposal_scores[i] for i in kept],
                         tables=[search.tables[i] for i in kept])
        explained = np.where(full == k, -1, full)
        grown = add_region_proposals(missed, explained)
        assert grown is not None and grown.from_regions == 1, k
        again = grown.located[-1]
        lost = search.located[k]
        assert np.hypot(again.x - lost.x, again.y - lost.y) < 0.5, k
        assert again.category == lost.category, k
        record = record_objects(grown)
        assert len(record) == 3 and record.existence_logodds.shape == (3,)
        assert add_region_proposals(replace(missed, config=replace(ParserConfig(), region_min_score=None)),
                                    explained) is None
    with pytest.raises(InputError, match="explained"):
        add_region_proposals(search, full[:10])


def test_a_centre_peak_where_no_proposal_stands_adds_one_there_and_only_there(three_apart):
    """add_centre_proposals: with one accepted proposal taken out, a centre-head peak at its object's base centre
    proposes it again (near its position, existence from the peak's probability); peaks on proposals that stand
    already, under the threshold or with the centre proposals off add nothing."""
    from dataclasses import replace

    from po3d_ppl.perception.calibration import TableCalibration
    from po3d_ppl.perception.centres import CentrePeaks
    from po3d_ppl.perception.image_input import project_points
    from po3d_ppl.perception.object_parser import _best_hypotheses, add_centre_proposals

    _, search = three_apart
    camera, grid = search.found_with, search.grid
    config = replace(search.config, centre_threshold=0.3, centre_existence=(1.0, 0.5))
    # the three objects as coarse grid hypotheses (the 3D-NMS's frame: the found-with camera)
    accepted = []
    for located in search.located:
        pixel = project_points(search.camera, np.array([located.x, located.y, 0.0]))[:2]
        at = int(torch.linalg.norm(grid.pixel.double() - torch.tensor(pixel), dim=-1).argmin())
        accepted.append(_best_hypotheses(search.scores, [at], grid, camera, config)[0])
    pixels = torch.stack([grid.pixel[h.position].double() for h in accepted])
    calibration = TableCalibration()
    lost = accepted[1]
    kept = [accepted[0], accepted[2]]
    peaks = CentrePeaks(pixels[[1, 0]], torch.tensor([0.8, 0.9]))
    grown, scores, added = add_centre_proposals(kept, [50.0, 50.0], peaks, search.scores, grid, camera, config,
                                                calibration)
    assert added == 1 and len(grown) == 3 and grown[-1].position == lost.position
    # the score the identity calibration maps to the log-odds 1.0 * logit(0.8) + 0.5
    assert scores[-1] == pytest.approx(config.existence_threshold + np.log(0.8 / 0.2) + 0.5)
    _, _, none = add_centre_proposals(accepted, [50.0] * 3, peaks, search.scores, grid, camera, config, calibration)
    assert none == 0  # every peak stands on an accepted footprint
    weak = CentrePeaks(pixels[[1]], torch.tensor([0.2]))
    assert add_centre_proposals(kept, [50.0] * 2, weak, search.scores, grid, camera, config, calibration)[2] == 0
    off = replace(config, centre_threshold=None)
    assert add_centre_proposals(kept, [50.0] * 2, peaks, search.scores, grid, camera, off, calibration)[2] == 0


def test_the_centre_heatmap_brings_a_misplaced_proposal_back_to_its_object(three_apart):
    """relocate: a proposal moved 1.2 units off its object stays off it without the centre head (its local points
    reach 12 px), and returns to the object, with its category, when the heatmap peaks at the object's base centre
    (the peak's points are searched and the log heatmap is a position prior)."""
    from dataclasses import replace

    from po3d_ppl.perception.centres import centre_peaks
    from po3d_ppl.perception.image_input import project_points
    from po3d_ppl.perception.object_parser import relocate

    _, search = three_apart
    config = replace(search.config, centre_threshold=0.3, centre_reach_px=80.0, centre_weight=5.0)
    true = search.located[1]
    off = replace(true, x=true.x + 1.0, y=true.y - 0.6)
    h, w = search.features.shape[1:]
    base = project_points(search.camera, np.array([true.x, true.y, 0.0]))[:2]
    rows, cols = torch.meshgrid(torch.arange(h) * 8.0 + 4.0, torch.arange(w) * 8.0 + 4.0, indexing="ij")
    heatmap = torch.exp(-((cols - base[0]) ** 2 + (rows - base[1]) ** 2) / (2 * 12.0**2))
    args = (search.evidence, search.feature_size, search.templates, search.camera, search.camera, config,
            search.scores, search.grid)
    (stays,), _ = relocate([off], *args)
    peaks = centre_peaks(heatmap, config.centre_threshold)
    (back,), (tables,) = relocate([off], *args, heatmap, peaks)
    assert np.hypot(stays.x - true.x, stays.y - true.y) > 0.4
    assert np.hypot(back.x - true.x, back.y - true.y) < 0.4, (back, true, stays)
    assert back.category == true.category and torch.isfinite(tables[0]).all()
    (kept,), _ = relocate([off], *args[:5], replace(config, centre_reach_px=0.0, centre_weight=0.0), *args[6:],
                          heatmap, peaks)
    assert (kept.x, kept.y) == (stays.x, stays.y)  # the prior off: as without the head


def test_the_local_search_ignores_the_cells_nearer_proposals_claim(three_apart):
    """cells_of_nearer gives each proposal the claimed cells of the proposals nearer the camera (none to the
    nearest); relocate scores a proposal on its other cells only: with every cell hidden from one proposal its
    tables say nothing (equal over categories), and the other proposals move exactly as without the mask."""
    from dataclasses import replace

    from po3d_ppl.perception.object_parser import cells_of_nearer, relocate

    _, search = three_apart
    h, w = search.features.shape[1:]
    claimed = torch.rand(3, h, w, generator=torch.Generator().manual_seed(0)) > 0.7
    hyps = [replace(hyp, depth=d) for hyp, d in zip(search.located, (11.0, 9.0, 10.0))]
    hidden = cells_of_nearer(hyps, claimed)
    assert not hidden[1].any()
    assert torch.equal(hidden[2], claimed[1]) and torch.equal(hidden[0], claimed[1] | claimed[2])

    config = replace(search.config, centre_reach_px=0.0, centre_weight=0.0)
    args = (search.evidence, search.feature_size, search.templates, search.camera, search.camera, config,
            search.scores, search.grid)
    free, free_tables = relocate(hyps, *args)
    mask = torch.zeros(3, h, w, dtype=torch.bool)
    mask[1] = True
    moved, tables = relocate(hyps, *args, None, None, mask)
    assert moved[0] == free[0] and moved[2] == free[2]
    assert torch.equal(tables[0][0], free_tables[0][0])
    category = tables[1][0]
    assert torch.allclose(category, category[0].expand_as(category))  # no evidence for any category
    assert not torch.allclose(free_tables[1][0], free_tables[1][0][0].expand_as(free_tables[1][0]))


def test_a_region_proposal_owns_the_pixels_of_its_region_that_its_mesh_covers():
    """A nearer proposal's category mesh overshoots the region a hidden object was proposed for; the region's
    pixels go to the region proposal where its own mesh covers them, and nowhere else."""
    from po3d_ppl.perception.object_parser import _claim_regions

    config = ParserConfig(mask_stride=2)
    height, width = 8, 12
    ownership = torch.zeros(height, width, dtype=torch.long)  # the front proposal 0 owns everything
    ownership[:, -2:] = -1  # background
    coverage = torch.zeros(2, height // 2, width // 2, dtype=torch.bool)
    coverage[0] = True
    coverage[1, :, :3] = True  # proposal 1's mesh covers the left half (pixels x < 6)
    region = np.zeros((height, width), dtype=bool)
    region[2:6, 3:9] = True  # its region straddles that edge
    owned = _claim_regions(ownership, coverage, [None, region], config)
    assert (owned[2:6, 3:6] == 1).all()  # claimed and covered
    assert (owned[2:6, 6:9] == 0).all()  # claimed but outside its mesh: the front proposal keeps them
    assert (owned[:2] == ownership[:2]).all() and (owned[6:] == ownership[6:]).all()
    assert (owned[:, -2:] == -1).all()


def test_unexplained_thin_structure_is_one_region_of_its_own_pixels():
    """A see-through object (a wheel of spokes) left unexplained: opening alone erases its one-pixel lines, so the
    second search never sees it; closed first, its lines join into one region that holds only their pixels (not
    the ground between them). A one-pixel sliver along an outline stays dropped either way."""
    from dataclasses import replace

    import cv2

    from po3d_ppl.errors import InputError
    from po3d_ppl.perception.object_parser import unexplained_regions

    foreground = np.zeros((120, 160), dtype=np.uint8)
    for angle in np.linspace(0.0, np.pi, 10, endpoint=False):  # a 40-pixel wheel of 10 spokes and its rim
        dx, dy = 20 * np.cos(angle), 20 * np.sin(angle)
        cv2.line(foreground, (int(50 - dx), int(60 - dy)), (int(50 + dx), int(60 + dy)), 1, 1)
    cv2.circle(foreground, (50, 60), 20, 1, 1)
    foreground[10, 100:150] = 1  # a sliver along some outline
    foreground = foreground.astype(bool)
    explained = np.full(foreground.shape, -1)
    config = replace(ParserConfig(), region_min_pixels=100)
    assert unexplained_regions(foreground, explained, replace(config, region_close_px=0)) == []
    regions = unexplained_regions(foreground, explained, config)
    assert len(regions) == 1
    assert not (regions[0] & ~foreground).any()  # only the wheel's own pixels
    assert regions[0][60, 30:71].sum() > 0 and not regions[0][10].any()
    explained[:, :] = 0  # a proposal explains every pixel: nothing is left
    assert unexplained_regions(foreground, explained, config) == []
    with pytest.raises(InputError, match="region_close_px"):
        ParserConfig(region_close_px=-3)

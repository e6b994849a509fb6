"""The image's :class:`~po3d_ppl.evidence.SceneEvidence` (issue "Perception II"): object proposals from
render-and-compare, then parts and occlusion by projecting the world's part-labelled subtype meshes.

Pixels in, evidence out (:func:`parse_scene`, or :class:`ImageParser` behind the
:class:`~po3d_ppl.perception.EvidenceSource` interface). Nothing here reads a scene file.

**Parts and occlusion by projection** (paper §4.2: the CAD part meshes projected at the estimated pose). Each
proposal is rendered as the world renders objects (embree, :mod:`po3d_ppl.world.renderer`), under each subtype
hypothesis that has weight and each of its top azimuth hypotheses, in one z-buffer with the other proposals at
their most likely subtype and pose; the world's own annotation rules (:func:`po3d_ppl.world.annotate.measure`:
part visible at >= 20 pixels, the public occlusion level, occluders hiding >= 16 pixels) are read off every
rendering. A table entry is the weighted frequency of the event over the hypotheses (pose uncertainty enters the
part tables: they average over poses rather than trusting one) and over small shifts of the proposal's rendering
against the others' (:mod:`po3d_ppl.perception.occlusion`: a rule on pixel counts read off one rendering is a yes
or a no that a few pixels of placement error flip), squashed into log-odds with a floor
``projection_floor`` on each side, since a projection can be wrong in ways its hypotheses do not cover. Re-using
the world's renderer and rules, rather than re-implementing them on the torch rasteriser, means perception and
the world agree by construction on what "visible" and "occluded" mean.

**Pose before projection.** The object parser's pose table is multiplied by the viewpoint network's whole-object
azimuth reading (:mod:`po3d_ppl.perception.viewpoint`) when one is shipped, before anything is projected: a
flipped azimuth would put every projected part on the wrong pixels (left for right, front for back).

**Tables without an attribute reader.** Colour, material and part-style tables are uninformative (zeros: the
scene model's prior decides) and subtypes of one category tie, until an attribute network is given
(``attributes=``); :attr:`ParsedScene.notes` says so.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import torch

from po3d_ppl import ontology
from po3d_ppl.errors import InputError
from po3d_ppl.evidence import DTYPE, NUM_STYLES, P, S, SceneEvidence, ScenePriors
from po3d_ppl.perception.alignment import AlignmentConfig, align_silhouette, best_shift
from po3d_ppl.perception.image_input import ImageInput, load_image, project_points
from po3d_ppl.perception.object_parser import (
    add_region_proposals,
    merge_proposals,
    ownership_masks,
    record_objects,
    search_objects,
    xywh_boxes,
    yaw_of,
)
from po3d_ppl.perception.occlusion import GradedOcclusion, ShiftGrid, graded_occlusion
from po3d_ppl.perception.simulated import VISIBLE_PART_PIXELS
from po3d_ppl.world.scene import Camera

if TYPE_CHECKING:
    from po3d_ppl.perception.attributes import AttributeReader
    from po3d_ppl.perception.projection_calibration import ProjectionCalibration
    from po3d_ppl.perception.viewpoint import ViewpointNet

CATEGORIES = tuple(ontology.CATEGORIES)
SUBTYPES = tuple(ontology.SUBTYPES)
#: [21] category index of every subtype.
SUBTYPE_CATEGORY = torch.tensor([CATEGORIES.index(ontology.CATEGORY_OF[s]) for s in SUBTYPES])


@dataclass(frozen=True)
class SceneParserConfig:
    """Settings of :func:`parse_scene` beyond the object parser's."""

    #: Azimuth hypotheses per proposal projected for the part and occlusion tables (the most likely ones).
    pose_hypotheses: int = 2
    #: Subtype hypotheses with at least this posterior weight (at most ``max_subtypes``) are projected. The
    #: evaluation reads the true subtype's slot, and reasoning conditions on a subtype when a question names it, so
    #: an unprojected slot (no reading: every part "not visible, not occluded" at the floor) costs even at low
    #: weight: on seed 716, 0.02 / 5 left 17 of 221 occluded parts unprojected; 0.002 / 8 raised part-occlusion F1
    #: 0.564 -> 0.579. Since the outline's subtype evidence sharpened the table, a misread object's true subtype
    #: mostly falls below 0.002: on seed 712, 22 of the 82 missed occluded parts sat on such never-projected slots.
    #: 0 projects the ``max_subtypes`` most likely always (on 716, with the tables calibrated on 712: part-visibility
    #: NLL 0.118 -> 0.107, part-occlusion F1 0.748 -> 0.755; the object tables unchanged; about 1 s more an image).
    min_subtype_weight: float = 0.0
    max_subtypes: int = 8
    #: Probability floor on each side of a projected event, before log-odds.
    projection_floor: float = 0.05
    #: Estimate the camera's height from the objects' sizes (needs the attribute network's subtypes), over this
    #: many candidates across the prior's jitter, from proposals with at least this many visible pixels.
    estimate_height: bool = True
    height_candidates: int = 21
    min_height_pixels: int = 200
    #: Each candidate height's silhouette is compared at its best image shift within this many pixels (0: where
    #: its base pixel puts it). The proposals' base pixels are off by a few pixels, and unshifted that error
    #: outweighs the size change between neighbouring heights: on 27 images of seed 712 the mean error of the
    #: height offset fell from 0.106 to 0.046 with 10 (the camera's distance 2% -> 0.9% off).
    height_shift_px: int = 10
    #: The viewpoint network's azimuth reading multiplies the render-and-compare pose table
    #: (:func:`~po3d_ppl.perception.viewpoint.combine_pose`): its exponent, and the temperature of the product,
    #: chosen on seed 712 by ``benchmarks/viewpoint_weight.py`` (lowest NLL of the true bin).
    viewpoint_weight: float = 1.0
    pose_temperature: float = 2.15
    #: Align each proposal's subtype silhouette to its visible mask (yaw and pixel shift) before projecting parts
    #: (:mod:`po3d_ppl.perception.alignment`); ``None`` keeps the object parser's pose.
    alignment: AlignmentConfig | None = field(default_factory=AlignmentConfig)
    #: Subtype evidence from the outline (:func:`silhouette_subtype_loglik`): every subtype of the proposal's likely
    #: categories (probability >= ``silhouette_min_category``; the best one always) is rendered at the aligned pose,
    #: within ``silhouette_yaw_offsets`` degrees and ``silhouette_shift_px`` pixels, and adds ``silhouette_weight``
    #: x its best IoU with the visible mask to its log-likelihood. 0 turns it off. Chosen on 60 images of seed 712
    #: (subtype accuracy 0.882 -> 0.917, NLL 0.426 -> 0.378 at 20).
    silhouette_weight: float = 20.0
    silhouette_yaw_offsets: tuple[float, ...] = (-6.0, 0.0, 6.0)
    silhouette_shift_px: int = 6
    silhouette_min_category: float = 0.05
    #: The occlusion and visibility tables average the world's rule over shifts of each hypothesis's rendering
    #: against the others' (:mod:`po3d_ppl.perception.occlusion`): a Gaussian grid of this spread in pixels and
    #: ``2 * steps + 1`` points a side (0: the unshifted rendering alone). Chosen on seed 716 with the tables
    #: Platt-scaled on 712 (0 / 2 / 3 / 4 / 6 px: pair-occlusion F1 0.840 / 0.845 / 0.843 / 0.826 / 0.818; the NLL
    #: of every occlusion table falls with the spread, e.g. pairs 0.051 / 0.044 / 0.042 / 0.041 / 0.041).
    occlusion_shift_px: float = 2.0
    occlusion_shift_steps: int = 2
    #: The part-style table reads each part where the most likely pose hypotheses put it (this many; None: all of
    #: ``pose_hypotheses``, mixed by weight). A less likely pose puts the part on pixels that, if the likely pose is
    #: right, belong to another part, mostly a plain one (two parts in three are): mixed in at its weight (0.14 for a
    #: bicycle seen side on), its reading dragged a clearly recoloured fender to even odds. On 40 images of seed
    #: 712, one hypothesis read 455 of 599 recoloured parts right instead of 385 (plain parts 1,220 against 1,223).
    style_pose_hypotheses: int | None = 1
    #: Two proposals read as one object are merged after the last reading (:func:`one_object_merges`): masks
    #: touching within ``merge_touch_px`` pixels, the same category with probability above ``merge_min_category``
    #: and the same colour above ``merge_min_colour`` (their tables' agreement), ground positions closer than
    #: ``merge_max_distance`` world units. ``merge_max_distance`` None turns it off. Chosen on seeds 712 and 716
    #: by simulating merges on their cached boxes (docs/perception.md, "Proposals read as one object").
    merge_touch_px: int = 2
    merge_min_category: float = 0.5
    merge_min_colour: float = 0.1
    merge_max_distance: float | None = 1.5
    #: Post-filtering as evidence (paper section 4.2) lowers a proposal's existence log-odds by the attribute
    #: reading's log-probability of the render-and-compare category, by at most this many nats (None: no bound).
    #: Unbounded, the penalty reaches 10 nats, and it falls mostly on hidden objects, whose few visible pixels the
    #: attribute network reads poorly: on seed 712, 15 of the 18 proposals it lowered by more than 2 nats were
    #: objects (existence NLL over its 658 proposals: 0.268 unbounded, 0.123 without the post-filter, 0.122 at 1
    #: nat). 1 nat was chosen on 712; 716's existence NLL went 0.260 -> 0.093 (``docs/perception.md``, "The
    #: post-filter bounded").
    post_filter_max_nats: float | None = 1.0

    def __post_init__(self) -> None:
        if not (isinstance(self.pose_hypotheses, int) and self.pose_hypotheses >= 1):
            raise InputError("SceneParserConfig.pose_hypotheses", f"must be an integer >= 1, got {self.pose_hypotheses!r}")
        if not (isinstance(self.height_shift_px, int) and self.height_shift_px >= 0):
            raise InputError("SceneParserConfig.height_shift_px", f"must be an integer >= 0, got {self.height_shift_px!r}")
        if not 0.0 < self.projection_floor < 0.5:
            raise InputError("SceneParserConfig.projection_floor", f"must be in (0, 0.5), got {self.projection_floor}")
        if self.style_pose_hypotheses is not None and not (isinstance(self.style_pose_hypotheses, int)
                                                           and 1 <= self.style_pose_hypotheses):
            raise InputError("SceneParserConfig.style_pose_hypotheses", "must be None or an integer >= 1, got "
                             f"{self.style_pose_hypotheses!r}")
        if self.occlusion_shift_px < 0 or not (isinstance(self.occlusion_shift_steps, int)
                                               and self.occlusion_shift_steps >= 0):
            raise InputError("SceneParserConfig.occlusion_shift_px", "the shift spread must be >= 0 and the steps an "
                             f"integer >= 0, got {self.occlusion_shift_px!r}, {self.occlusion_shift_steps!r}")
        if self.post_filter_max_nats is not None and not self.post_filter_max_nats >= 0:
            raise InputError("SceneParserConfig.post_filter_max_nats", "must be >= 0 nats or None (no bound), got "
                             f"{self.post_filter_max_nats!r}")
        if not (isinstance(self.merge_touch_px, int) and self.merge_touch_px >= 0) \
                or not 0.0 <= self.merge_min_category < 1.0 or not 0.0 <= self.merge_min_colour < 1.0 \
                or (self.merge_max_distance is not None and self.merge_max_distance <= 0):
            raise InputError("SceneParserConfig.merge_*", "merge_touch_px must be an integer >= 0, the agreements in "
                             "[0, 1) and merge_max_distance > 0 or None, got "
                             f"{self.merge_touch_px!r}, {self.merge_min_category!r}, {self.merge_min_colour!r}, "
                             f"{self.merge_max_distance!r}")


@dataclass
class Projection:
    """One proposal rendered under one (subtype, azimuth) hypothesis among the others: its object and part
    annotations (the world's :class:`~po3d_ppl.world.annotate.ObjectMeasure`, occluders as proposal indices)."""

    proposal: int
    subtype: int
    azimuth_bin: int
    weight: float
    measure: object
    occluders: tuple[int, ...]
    part_occluders: tuple[tuple[int, ...], ...]


@dataclass
class ParsedScene:
    """Everything :func:`parse_scene` read from one image."""

    evidence: SceneEvidence
    proposals: object
    projections: list[Projection]
    timings: dict[str, float] = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    #: The most likely scene rendered: per pixel the proposal seen (-1 none) and its part id (-1 body or none),
    #: [H, W] int arrays (for overlays; the tables average over more hypotheses than this one).
    object_ids: np.ndarray | None = None
    part_ids: np.ndarray | None = None


def category_marginal(subtype_loglik: torch.Tensor) -> torch.Tensor:
    """[N, 5] log-sum-exp of a subtype table [N, 21] over each category's subtypes."""
    return torch.stack([torch.logsumexp(subtype_loglik[:, SUBTYPE_CATEGORY == c], -1)
                        for c in range(len(CATEGORIES))], -1)


def _logodds(p: np.ndarray, floor: float) -> np.ndarray:
    q = np.clip(p, floor, 1.0 - floor)
    return np.log(q) - np.log1p(-q)


def _spec(subtype: str, size: str, x: float, y: float, rotation: float):
    from po3d_ppl.world.sampler import ObjectSpec

    # colour and material do not change geometry; the renderer needs some
    return ObjectSpec(subtype, ontology.COLORS[0], ontology.MATERIALS[0], size, float(rotation % 360.0), x, y,
                      parts={})


class _Projector:
    """Renders hypotheses of one proposal among the others' most likely ones (solo views composited)."""

    def __init__(self, camera: Camera, specs: list, grid: ShiftGrid):
        from po3d_ppl.world import renderer

        self.camera = camera
        self.grid = grid
        self.meshes = renderer.place_meshes(specs)
        self.views = [renderer.cast_alone(m, camera) for m in self.meshes]

    def measure(self, i: int, spec) -> tuple[object, tuple[int, ...], tuple[tuple[int, ...], ...], object,
                                             GradedOcclusion]:
        """(measure of proposal ``i`` rendered as ``spec``, its occluders, each part's occluders, the gbuffer, and
        the occlusion tables graded over the shift grid, the others in proposal order without ``i``)."""
        from po3d_ppl.world import annotate, renderer

        mesh = renderer.place_meshes([spec])[0]
        view = renderer.cast_alone(mesh, self.camera)
        others = [j for j in range(len(self.meshes)) if j != i]
        gbuffer = renderer.composite([view] + [self.views[j] for j in others],
                                     [mesh] + [self.meshes[j] for j in others], self.camera)
        measure = annotate.measure(gbuffer, [view], [spec])[0]
        graded = graded_occlusion(view, [self.views[j] for j in others], len(measure.parts), self.grid,
                                  VISIBLE_PART_PIXELS)

        def back(local: tuple[int, ...]) -> tuple[int, ...]:
            return tuple(others[k - 1] for k in local if k >= 1)

        return (measure, back(measure.obj.occlusion.occluded_by),
                tuple(back(p.occlusion.occluded_by) for p in measure.parts), gbuffer, graded)


def _subtype_weights(subtype_loglik: torch.Tensor, config: SceneParserConfig) -> list[list[tuple[int, float]]]:
    """Per proposal, the subtype hypotheses to project and their renormalised weights."""
    probs = torch.softmax(subtype_loglik, -1)
    out = []
    for row in probs:
        order = torch.argsort(row, descending=True)[: config.max_subtypes].tolist()
        keep = [s for s in order if float(row[s]) >= config.min_subtype_weight] or order[:1]
        total = float(sum(row[s] for s in keep))
        out.append([(s, float(row[s]) / total) for s in keep])
    return out


def parse_scene(image, *, object_model=None, attributes: AttributeReader | None = None,
                viewpoint: ViewpointNet | None = None, projection_calibration: ProjectionCalibration | None = None,
                config: SceneParserConfig | None = None, parser_config=None, object_calibration=None,
                background=None, centres=None) -> ParsedScene:
    """Read ``image`` (a path, HWC array or PIL image) into :class:`SceneEvidence` with every table filled from
    pixels. An image without vehicles gives empty evidence (N = 0), which reasoning answers (count 0, ...).
    ``viewpoint`` (optional) sharpens the pose table with a whole-object azimuth reading before the parts are
    projected (:mod:`po3d_ppl.perception.viewpoint`); ``projection_calibration`` rescales the projected tables
    (:mod:`po3d_ppl.perception.projection_calibration`). ``object_model``, ``parser_config``,
    ``object_calibration``, ``background`` and ``centres`` go to the object parser (default: the shipped ones).
    The scene is read once from the object parser's proposals (:func:`read_scene`) and, where that reading leaves
    foreground unexplained and a second search adds proposals there
    (:func:`~po3d_ppl.perception.object_parser.add_region_proposals`), once more with them. The evidence's masks
    and boxes are then redrawn by that reading's most likely scene (:func:`seen_ownership`)."""
    config = config or SceneParserConfig()
    start = time.perf_counter()
    img: ImageInput = load_image(image)
    search = search_objects(img, object_model, parser_config, object_calibration, background, centres)
    parsed = read_scene(img, record_objects(search), attributes, viewpoint, projection_calibration, config)
    # second search: foreground the most likely scene leaves unexplained (object_parser.add_region_proposals)
    t0 = time.perf_counter()
    def name_regions(masks: torch.Tensor) -> torch.Tensor:
        """[K, 5] category probabilities of regions [K, H, W] read by the attribute network."""
        subtype = attributes.object_loglik(img, masks)["subtype"].exp().cpu()
        return subtype.new_zeros(len(subtype), len(CATEGORIES)).index_add_(1, SUBTYPE_CATEGORY, subtype)

    grown = add_region_proposals(search, parsed.object_ids, name_regions if attributes is not None else None)
    if grown is not None:
        first = parsed.timings
        parsed = read_scene(img, record_objects(grown), attributes, viewpoint, projection_calibration, config)
        parsed.timings.update({f"first_reading.{k}": v for k, v in first.items()})
        parsed.timings["objects.regions"] = time.perf_counter() - t0
        parsed.notes += (f"{grown.from_regions} proposal(s) from foreground the first reading left unexplained "
                         "(existence from their score there; pose not refined)",)
    parsed = seen_as_read(parsed)
    into = one_object_merges(parsed.evidence, config)
    if into is not None:  # read once more without the duplicates (their occlusion of the kept ones goes too)
        t0, before = time.perf_counter(), parsed
        parsed = seen_as_read(read_scene(img, merge_proposals(before.proposals, into), attributes, viewpoint,
                                         projection_calibration, config))
        parsed.timings.update({k: v for k, v in before.timings.items() if k not in parsed.timings})
        parsed.timings["merge"] = time.perf_counter() - t0
        parsed.notes = before.notes + (f"{len(into) - len(set(into))} proposal(s) merged into a touching one read "
                                       "as the same object",)
    parsed.timings["total"] = time.perf_counter() - start
    return parsed


def one_object_merges(evidence: SceneEvidence, config: SceneParserConfig) -> list[int] | None:
    """Per proposal of ``evidence`` (its masks as :func:`seen_as_read` redraws them), the proposal it is one object
    with (itself if none); None if no proposal merges.

    The search proposes one object twice in two ways: a second peak on part of an object already found (a
    *duplicate*), and an object split into two halves that each fit a smaller hypothesis (a jet's nose and tail,
    each half then too small a box to match). Both leave two proposals whose masks touch, that read as the same
    category and colour, and whose ground positions are closer than neighbours mostly stand. Pairs are merged
    nearest first; the one more likely to exist keeps its tables and takes the other's pixels.
    Seeds 712 / 716 (all 120 images each, ``po3d eval evidence``): precision 0.951 -> 0.969 / 0.957 -> 0.977,
    recall 0.946 -> 0.945 / 0.957 -> 0.960, duplicate false proposals 16 -> 6 / 10 -> 5. Simulated on their cached
    boxes beforehand, dropping the colour test lost recall (0.931 / 0.945: distinct objects of one category side
    by side), and a ground distance of 2 merged more of them too. About one wrong merge a seed remains (two brown
    school buses side by side on 712)."""
    n = evidence.num_objects
    if config.merge_max_distance is None or n < 2 or evidence.masks is None:
        return None
    masks = evidence.masks.float()
    reach = 2 * config.merge_touch_px + 1
    grown = torch.nn.functional.max_pool2d(masks[None], reach, stride=1, padding=config.merge_touch_px)[0]
    touching = (grown.flatten(1) @ masks.flatten(1).T) > 0  # [N, N]
    category = category_marginal(evidence.subtype_loglik).softmax(-1)
    colour = evidence.color_loglik.softmax(-1)
    ground = evidence.positions[:, :2]
    distance = torch.cdist(ground, ground)
    candidate = (touching | touching.T) & (category @ category.T > config.merge_min_category) \
        & (colour @ colour.T > config.merge_min_colour) & (distance < config.merge_max_distance)
    candidate = torch.triu(candidate, diagonal=1)
    if not bool(candidate.any()):
        return None
    into = list(range(n))

    def root(i: int) -> int:
        while into[i] != i:
            i = into[i]
        return i

    pairs = sorted(zip(*torch.nonzero(candidate, as_tuple=True)), key=lambda ij: float(distance[ij[0], ij[1]]))
    existence = evidence.exist_logodds
    for i, j in pairs:
        a, b = root(int(i)), root(int(j))
        if a != b:
            keep, drop = (a, b) if float(existence[a]) >= float(existence[b]) else (b, a)
            into[drop] = keep
    return [root(i) for i in range(n)]


def seen_ownership(ownership: torch.Tensor, object_ids: np.ndarray) -> torch.Tensor:
    """The object parser's ownership map [H, W] (proposal index, -1 none) with every owned pixel that the most
    likely scene (``object_ids`` [H, W], the aligned subtype silhouettes, -1 none) shows as another proposal
    given to that one.

    The ownership comes from the object parser's z-buffer of *category* meshes, which enclose every subtype, so a
    proposal's mask spills onto a neighbour its mesh overlaps, and an object behind keeps only what the
    overshoot leaves it; its box is then too large or too small to match. The aligned subtype silhouettes draw
    the boundary where the objects are. Pixels they do not explain stay with their owner (the silhouettes miss
    the edges of a slightly misplaced object). Seed 712 (120 images, chosen on): detection precision 0.945 ->
    0.951, recall 0.940 -> 0.946; keeping only the pixels both agree on fell to 0.928 / 0.924."""
    ids = torch.from_numpy(np.asarray(object_ids, dtype=np.int64)).to(ownership.device)
    if ids.shape != ownership.shape:
        raise InputError("object_ids", f"must be the ownership map's [H, W] {tuple(ownership.shape)}, got "
                                       f"{tuple(ids.shape)}")
    return torch.where((ownership >= 0) & (ids >= 0), ids, ownership)


def seen_as_read(parsed: ParsedScene) -> ParsedScene:
    """``parsed`` with its evidence's masks and boxes redrawn from :func:`seen_ownership` (the tables were read
    with the object parser's masks; ``parsed.proposals`` keeps those)."""
    evidence = parsed.evidence
    if parsed.object_ids is None or evidence.masks is None or evidence.num_objects == 0:
        return parsed
    masks = ownership_masks(seen_ownership(parsed.proposals.ownership, parsed.object_ids), evidence.num_objects)
    evidence = dataclasses.replace(evidence, masks=masks, boxes=xywh_boxes(masks).to(evidence.boxes.dtype))
    return dataclasses.replace(parsed, evidence=evidence)


def post_filter(existence: torch.Tensor, category_logp: torch.Tensor, attribute_subtype_loglik: torch.Tensor,
                max_nats: float | None) -> torch.Tensor:
    """Post-filtering as evidence (paper section 4.2): the existence log-odds [N] lowered by the attribute reading's
    log-probability of the render-and-compare category (its argmax of ``category_logp`` [N, 5]), by at most
    ``max_nats`` (``SceneParserConfig.post_filter_max_nats``); the proposal is kept."""
    attribute_category = category_marginal(torch.log_softmax(attribute_subtype_loglik, -1))
    penalty = torch.gather(attribute_category, 1, category_logp.argmax(-1, keepdim=True))[:, 0]
    return existence + (penalty if max_nats is None else penalty.clamp(min=-max_nats))


def read_scene(img: ImageInput, proposals, attributes: AttributeReader | None, viewpoint: ViewpointNet | None,
                projection_calibration: ProjectionCalibration | None, config: SceneParserConfig) -> ParsedScene:
    """Every table of the evidence from the object parser's proposals: attributes, viewpoint, camera height,
    alignment, silhouette subtypes, and parts and occlusion by projection."""
    timings: dict[str, float] = {f"objects.{k}": v for k, v in proposals.timings.items()}
    n = len(proposals)
    camera = proposals.camera
    notes = list(proposals.notes)

    # the object parser's tables come calibrated (po3d_ppl.perception.calibration); pose is P(azimuth | category)
    category_logp = torch.log_softmax(proposals.category_loglik, -1)
    subtype_ll = category_logp[:, SUBTYPE_CATEGORY]  # [N, 21]: each subtype carries its category's evidence
    size_ll = proposals.size_loglik.clone()
    color_ll = torch.zeros(n, len(ontology.COLORS), dtype=DTYPE)
    material_ll = torch.zeros(n, len(ontology.MATERIALS), dtype=DTYPE)
    exist = proposals.existence_logodds.clone()
    t0 = time.perf_counter()
    if attributes is not None and n:
        read = attributes.object_loglik(img, proposals.masks)
        subtype_ll = subtype_ll + read["subtype"].to(DTYPE)
        color_ll, material_ll = read["color"].to(DTYPE), read["material"].to(DTYPE)
        size_ll = size_ll + read["size"].to(DTYPE)
        exist = post_filter(exist, category_logp, read["subtype"].to(DTYPE), config.post_filter_max_nats)
    elif n:
        notes.append("no attribute reader: colour, material and part styles uninformative, subtypes of a "
                     "category tie")
    timings["attributes"] = time.perf_counter() - t0

    pose_ll = proposals.pose_loglik
    t0 = time.perf_counter()
    if viewpoint is not None and n:
        from po3d_ppl.perception.viewpoint import combine_pose

        pose_ll = combine_pose(pose_ll, proposals.pose_support, viewpoint.azimuth_loglik(img, proposals.masks),
                               config.viewpoint_weight, config.pose_temperature)
    timings["viewpoint"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    xy = proposals.positions[:, :2].tolist()
    if config.estimate_height and attributes is not None and n:
        camera, xy = estimate_camera_height(proposals, subtype_ll, size_ll, pose_ll, img, config)
    else:
        notes.append("camera height not estimated (the base camera's)")
    timings["camera"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    yaw_offsets = [0.0] * n
    if config.alignment is not None and n:
        xy, yaw_offsets = align_poses(proposals, xy, subtype_ll, size_ll, pose_ll, camera, config.alignment)
    timings["alignment"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    if config.silhouette_weight and n:
        subtype_ll = subtype_ll + silhouette_subtype_loglik(proposals, xy, yaw_offsets, subtype_ll, size_ll,
                                                            pose_ll, camera, config)
    timings["silhouette"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    tables, projections, positions, depths, best_view = _project(proposals, xy, yaw_offsets, subtype_ll, size_ll,
                                                                 pose_ll, camera, config, attributes, img)
    timings["projection"] = time.perf_counter() - t0
    evidence = SceneEvidence(
        exist_logodds=exist.to(DTYPE), subtype_loglik=subtype_ll.to(DTYPE), color_loglik=color_ll,
        material_loglik=material_ll, size_loglik=size_ll.to(DTYPE),
        pose_support=proposals.pose_support.to(DTYPE), pose_loglik=pose_ll.to(DTYPE),
        positions=positions, depths=depths,
        directions={k: torch.tensor(v, dtype=DTYPE) for k, v in camera.ground_directions().items()},
        boxes=proposals.boxes.to(DTYPE), masks=proposals.masks, camera=camera, **tables)
    if projection_calibration is not None:
        evidence = projection_calibration.apply(evidence)
    elif n:
        notes.append("projected tables uncalibrated (their probability floor is 0.05)")
    object_ids, part_ids = best_view if best_view is not None else (None, None)
    return ParsedScene(evidence, proposals, projections, timings, tuple(notes), object_ids, part_ids)


def _best_readings(subtype_ll: torch.Tensor, size_ll: torch.Tensor, pose_ll: torch.Tensor, support: torch.Tensor
                   ) -> list[tuple[int, str, float, float]]:
    """Per proposal: its most likely subtype, size and azimuth (degrees), and the subtype's probability."""
    probs = torch.softmax(subtype_ll, -1)
    out = []
    for i in range(subtype_ll.shape[0]):
        s = int(probs[i].argmax())
        k = int(pose_ll[i, int(SUBTYPE_CATEGORY[s])].argmax())
        out.append((s, ontology.SIZES[int(size_ll[i].argmax())], float(support[i, k]), float(probs[i, s])))
    return out


def _silhouette(spec, camera: Camera, shape: tuple[int, int]) -> np.ndarray:
    """[H, W] bool: the pixels the world's mesh of ``spec`` covers, alone (embree, cropped to its box)."""
    from po3d_ppl.world import renderer

    view = renderer.cast_alone(renderer.place_meshes([spec])[0], camera)
    out = np.zeros(shape, dtype=bool)
    h, w = view.present.shape
    out[view.y0:view.y0 + h, view.x0:view.x0 + w] = view.present
    return out


def estimate_camera_height(proposals, subtype_ll: torch.Tensor, size_ll: torch.Tensor, pose_ll: torch.Tensor,
                           img: ImageInput, config: SceneParserConfig) -> tuple[Camera, list[list[float]]]:
    """The camera's height offset that best fits the objects' sizes, and the proposals' ground positions under it.

    Scaling the scene about the camera leaves the image unchanged, so the height shows only through objects of
    known size: each proposal's most likely subtype mesh (exact dimensions, unlike the category mesh that encloses
    every subtype) is placed under the same image point and pose at every candidate height of the camera prior,
    and its silhouette compared (IoU, at its best shift within ``height_shift_px``) with the proposal's visible
    mask on the pixels no other proposal owns. The IoU curves, weighted by subtype confidence, are summed over
    proposals and the peak refined by a parabola. Measured on 27 images of seed 712 (21 candidates): mean error
    0.046 (0.106 unshifted; the base camera's is about 0.25)."""
    from po3d_ppl.perception.image_input import CameraPrior, backproject_to_plane

    prior = CameraPrior.for_image(img)
    base = proposals.camera
    offsets = np.linspace(-prior.jitter, prior.jitter, config.height_candidates)
    base_xyz = torch.cat([proposals.positions[:, :2], torch.zeros(len(proposals), 1, dtype=DTYPE)], -1)
    pixels = project_points(base, base_xyz)[:, :2]
    ownership = proposals.ownership.numpy()
    cameras = [prior.camera((0.0, 0.0, float(dz))) for dz in offsets]
    grounds = [backproject_to_plane(cam, pixels) for cam in cameras]
    total = np.zeros(len(offsets))
    for i, (s, size, azimuth, confidence) in enumerate(_best_readings(subtype_ll, size_ll, pose_ll,
                                                                       proposals.pose_support)):
        mask = proposals.masks[i].numpy()
        if mask.sum() < config.min_height_pixels:
            continue
        free = (ownership < 0) | (ownership == i)
        curve = np.zeros(len(offsets))
        for k, (cam, ground) in enumerate(zip(cameras, grounds)):
            x, y = float(ground[i, 0]), float(ground[i, 1])
            spec = _spec(SUBTYPES[s], size, x, y, yaw_of(cam, x, y, azimuth))
            curve[k] = best_shift(_silhouette(spec, cam, mask.shape), free, mask, config.height_shift_px)[1]
        total += confidence * curve
    if not total.any():
        return base, proposals.positions[:, :2].tolist()
    best = int(np.argmax(total))
    dz = float(offsets[best])
    if 0 < best < len(offsets) - 1:  # parabola through the peak and its neighbours
        left, mid, right = total[best - 1: best + 2]
        bend = left - 2 * mid + right
        if bend < 0:
            dz += float(0.5 * (left - right) / bend) * float(offsets[1] - offsets[0])
    camera = prior.camera((0.0, 0.0, dz))
    return camera, backproject_to_plane(camera, pixels)[:, :2].tolist()


def align_poses(proposals, xy: list[list[float]], subtype_ll: torch.Tensor, size_ll: torch.Tensor,
                pose_ll: torch.Tensor, camera: Camera, config: AlignmentConfig
                ) -> tuple[list[list[float]], list[float]]:
    """Ground positions and yaw offsets (degrees, added to every azimuth hypothesis) after aligning each proposal's
    most likely subtype silhouette with its visible mask (:func:`~po3d_ppl.perception.alignment.align_silhouette`);
    an image shift is carried to the ground through ``camera`` at the object's base point."""
    from po3d_ppl.perception.image_input import backproject_to_plane

    ownership = proposals.ownership.numpy()
    out_xy, offsets = [list(p) for p in xy], [0.0] * len(xy)
    for i, (s, size, azimuth, _) in enumerate(_best_readings(subtype_ll, size_ll, pose_ll, proposals.pose_support)):
        mask = proposals.masks[i].numpy()
        x, y = xy[i]
        yaw = yaw_of(camera, x, y, azimuth)

        def render(offset: float, x=x, y=y, yaw=yaw, s=s, size=size, shape=mask.shape) -> np.ndarray:
            return _silhouette(_spec(SUBTYPES[s], size, x, y, yaw + offset), camera, shape)

        found = align_silhouette(render, mask, (ownership < 0) | (ownership == i), config)
        offsets[i] = found.yaw_offset
        if found.shift != (0, 0):
            base = project_points(camera, np.array([[x, y, 0.0]]))[0, :2]
            moved = torch.tensor([[float(base[0]) + found.shift[0], float(base[1]) + found.shift[1]]],
                                 dtype=DTYPE)
            ground = backproject_to_plane(camera, moved)
            out_xy[i] = [float(ground[0, 0]), float(ground[0, 1])]
    return out_xy, offsets


def silhouette_subtype_loglik(proposals, xy: list[list[float]], yaw_offsets: list[float], subtype_ll: torch.Tensor,
                              size_ll: torch.Tensor, pose_ll: torch.Tensor, camera: Camera,
                              config: SceneParserConfig) -> torch.Tensor:
    """[N, 21] log-likelihood terms of each subtype from its outline: ``silhouette_weight`` x the best IoU of its
    mesh's silhouette (at the proposal's aligned position, best azimuth of its category and yaw offset, most likely
    size) with the visible mask, on the pixels no other proposal owns.

    The attribute network confuses subtypes whose looks differ mainly in shape at its crop's resolution (sedan and
    truck, SUV and wagon, airliner and jet: 0.85 of matched objects right on seed 716); their exact meshes' outlines
    differ by whole image regions. Subtypes of categories below ``silhouette_min_category`` are not rendered and
    get the lowest term of the proposal's rendered ones; proposals with fewer visible pixels than the alignment
    needs (``AlignmentConfig.min_pixels``) get no term."""
    n = len(proposals)
    terms = torch.zeros(n, len(SUBTYPES), dtype=DTYPE)
    category_p = torch.softmax(category_marginal(subtype_ll), -1)
    ownership = proposals.ownership.numpy()
    # the alignment's search at every yaw offset and shift; its best IoU is the subtype's fit (no gain threshold)
    search = AlignmentConfig(yaw_offsets=config.silhouette_yaw_offsets, max_shift_px=config.silhouette_shift_px,
                             min_gain=0.0)
    for i in range(n):
        mask = proposals.masks[i].numpy()
        free = (ownership < 0) | (ownership == i)
        x, y = xy[i]
        size = ontology.SIZES[int(size_ll[i].argmax())]
        best_category = int(category_p[i].argmax())
        rendered = [s for s in range(len(SUBTYPES)) if int(SUBTYPE_CATEGORY[s]) == best_category
                    or float(category_p[i, int(SUBTYPE_CATEGORY[s])]) >= config.silhouette_min_category]
        for s in rendered:
            c = int(SUBTYPE_CATEGORY[s])
            yaw = yaw_of(camera, x, y, float(proposals.pose_support[i, int(pose_ll[i, c].argmax())])) + yaw_offsets[i]

            def render(offset: float, s=s, size=size, x=x, y=y, yaw=yaw, shape=mask.shape) -> np.ndarray:
                return _silhouette(_spec(SUBTYPES[s], size, x, y, yaw + offset), camera, shape)

            terms[i, s] = config.silhouette_weight * align_silhouette(render, mask, free, search).iou_after
        others = [s for s in range(len(SUBTYPES)) if s not in rendered]
        terms[i, others] = terms[i, rendered].min()
    return terms


def _mixed_styles(attributes: AttributeReader, img: ImageInput, masks: torch.Tensor,
                  part_maps: list[dict[tuple[int, int], torch.Tensor]], weights: torch.Tensor,
                  kept: int | None = None) -> torch.Tensor:
    """The part-style table as a mixture over the ``kept`` most likely pose hypotheses (None: all; ``part_maps``
    and ``weights`` [hypotheses, N, S] are in rank order): each puts the parts elsewhere in the image (a front/back
    flip swaps left and right), so the attribute network reads each one's part pixels and the likelihoods are
    averaged with the hypotheses' renormalised weights. A slot a hypothesis does not show reads uniform."""
    part_maps, weights = part_maps[:kept], weights[:kept]
    weights = weights / weights.sum(0, keepdim=True).clamp_min(1e-300)
    n = masks.shape[0]
    mixture = torch.full((n, S, P, NUM_STYLES), -math.inf, dtype=DTYPE)
    uniform = -math.log(NUM_STYLES)
    tables = attributes.part_style_tables(img, masks, part_maps, min_pixels=VISIBLE_PART_PIXELS)
    for maps, w, table in zip(part_maps, weights, tables):
        if not maps:
            continue
        table = table.to(DTYPE).cpu()
        read = table.abs().sum(-1, keepdim=True) > 0
        table = torch.where(read, table, torch.full_like(table, uniform))
        mixture = torch.logaddexp(mixture, torch.log(w.clamp_min(1e-300))[:, :, None, None] + table)
    shown = torch.isfinite(mixture).all(-1, keepdim=True) & (weights.sum(0) > 0)[:, :, None, None]
    return torch.where(shown, mixture - torch.logsumexp(mixture, -1, keepdim=True), torch.zeros_like(mixture))


def _project(proposals, xy: list[list[float]], yaw_offsets: list[float], subtype_ll: torch.Tensor,
             size_ll: torch.Tensor, pose_ll: torch.Tensor, camera: Camera, config: SceneParserConfig,
             attributes: AttributeReader | None, img: ImageInput):
    """Occlusion and part tables by projection, and positions (box centres) and depths of the best hypotheses."""
    n = len(proposals)
    floor = config.projection_floor
    occluded = np.zeros(n)
    occludes = np.zeros((n, n))
    part_visible = np.zeros((n, S, P))
    part_occluded = np.zeros((n, S, P))
    part_occludes = np.zeros((n, S, P, n))
    part_style = torch.zeros(n, S, P, NUM_STYLES, dtype=DTYPE)
    positions = torch.zeros(n, 3, dtype=DTYPE)
    depths = torch.zeros(n, dtype=DTYPE)
    projections: list[Projection] = []
    if n == 0:
        tables = {"occluded_logodds": torch.zeros(0, dtype=DTYPE), "occludes_logodds": torch.zeros(0, 0, dtype=DTYPE),
                  "part_visible_logodds": torch.zeros(0, S, P, dtype=DTYPE), "part_style_loglik": part_style,
                  "part_occluded_logodds": torch.zeros(0, S, P, dtype=DTYPE),
                  "part_occludes_logodds": torch.zeros(0, S, P, 0, dtype=DTYPE)}
        return tables, projections, positions, depths, None
    sizes = [ontology.SIZES[int(i)] for i in size_ll.argmax(-1)]
    weights = _subtype_weights(subtype_ll, config)
    support = proposals.pose_support

    def pose_hypotheses(i: int, subtype: int) -> list[tuple[int, float]]:
        row = torch.softmax(pose_ll[i, int(SUBTYPE_CATEGORY[subtype])], -1)
        top = torch.argsort(row, descending=True)[: config.pose_hypotheses].tolist()
        total = float(row[top].sum())
        return [(k, float(row[k]) / total) for k in top]

    def spec(i: int, subtype: int, k: int):
        x, y = xy[i]
        return _spec(SUBTYPES[subtype], sizes[i], x, y, yaw_of(camera, x, y, float(support[i, k])) + yaw_offsets[i])

    best = [spec(i, weights[i][0][0], pose_hypotheses(i, weights[i][0][0])[0][0]) for i in range(n)]
    projector = _Projector(camera, best, ShiftGrid.gaussian(config.occlusion_shift_px, config.occlusion_shift_steps))
    for i, mesh in enumerate(projector.meshes):
        centre = mesh.box_centre
        positions[i] = torch.tensor(centre, dtype=DTYPE)
        depths[i] = float(project_points(camera, np.asarray(centre, dtype=np.float64))[2])
    looks_read = min(config.style_pose_hypotheses or config.pose_hypotheses, config.pose_hypotheses)
    part_maps: list[dict[tuple[int, int], torch.Tensor]] = [{} for _ in range(looks_read)]
    map_weights = torch.zeros(looks_read, n, S, dtype=DTYPE)
    for i in range(n):
        others = [j for j in range(n) if j != i]
        for s, w_sub in weights[i]:
            parts = len(ontology.PARTS[SUBTYPES[s]])
            for rank, (k, w_pose) in enumerate(pose_hypotheses(i, s)):
                measure, occluders, part_occluders, gbuffer, graded = projector.measure(i, spec(i, s, k))
                w = w_sub * w_pose
                projections.append(Projection(i, s, k, w, measure, occluders, part_occluders))
                occluded[i] += w * graded.occluded
                occludes[i, others] += w * graded.occludes
                part_visible[i, s, :parts] += w_pose * graded.part_visible
                part_occluded[i, s, :parts] += w_pose * graded.part_occluded
                part_occludes[i, s, :parts][:, others] += w_pose * graded.part_occludes
                if attributes is not None and rank < looks_read:  # the parts this hypothesis shows, for looks
                    own = gbuffer.geometry.reshape(gbuffer.height, gbuffer.width) == 0
                    part_maps[rank][(i, s)] = torch.from_numpy(np.where(own, gbuffer.part_ids, -1).astype(np.int64))
                    map_weights[rank, i, s] = w_pose
    if attributes is not None and any(part_maps):
        part_style = _mixed_styles(attributes, img, proposals.masks, part_maps, map_weights)
    eye = np.eye(n, dtype=bool)
    tables = {
        "occluded_logodds": torch.tensor(_logodds(occluded, floor), dtype=DTYPE),
        "occludes_logodds": torch.tensor(np.where(eye, 0.0, _logodds(occludes, floor)), dtype=DTYPE),
        "part_visible_logodds": torch.tensor(_logodds(part_visible, floor), dtype=DTYPE),
        "part_style_loglik": part_style,
        "part_occluded_logodds": torch.tensor(_logodds(part_occluded, floor), dtype=DTYPE),
        "part_occludes_logodds": torch.tensor(_logodds(part_occludes, floor), dtype=DTYPE),
    }
    from po3d_ppl.world.renderer import composite

    scene = composite(projector.views, projector.meshes, camera)
    seen = scene.object_ids.astype(np.int64)
    best_view = (seen, np.where(seen >= 0, scene.part_ids, -1).astype(np.int64))
    return tables, projections, positions, depths, best_view


@dataclass(frozen=True)
class ImageParser:
    """The render-and-compare back-end: ``ImageParser.load().evidence(image) -> SceneEvidence``."""

    object_model: object = None
    attributes: AttributeReader | None = None
    config: SceneParserConfig = field(default_factory=SceneParserConfig)
    viewpoint: ViewpointNet | None = None
    projection_calibration: ProjectionCalibration | None = None
    object_calibration: object = None
    background: object = None
    #: the object parser's settings (None: ``ParserConfig()``)
    parser_config: object = None
    #: the centre head (:mod:`po3d_ppl.perception.centres`; None: the shipped one)
    centres: object = None
    name = "render-and-compare"

    @classmethod
    def load(cls, models_dir=None, device=None, config: SceneParserConfig | None = None,
             calibrated_projection: bool = True) -> ImageParser:
        """The shipped models (or those of ``models_dir``), each checked against its sha256; the attribute and
        viewpoint networks and the projection calibration only if listed in the manifest (otherwise their tables
        stay uninformative, the pose table is render-and-compare's alone, the projected tables keep their floor).
        ``calibrated_projection=False`` does not read the projection calibration (refitting it reads raw tables)."""
        from po3d_ppl.model_store import read_manifest
        from po3d_ppl.perception.neural_mesh import load_feature_model

        device = device or "cpu"
        manifest = read_manifest(models_dir)
        attributes = viewpoint = None
        if "attributes" in manifest:
            from po3d_ppl.perception.attributes import load_attribute_net

            attributes = load_attribute_net(models_dir, device)
        if "viewpoint" in manifest:
            from po3d_ppl.perception.viewpoint import load_viewpoint_net

            viewpoint = load_viewpoint_net(models_dir, device)
        from po3d_ppl.perception.background import load_background
        from po3d_ppl.perception.calibration import load_calibration
        from po3d_ppl.perception.centres import load_centre_net
        from po3d_ppl.perception.projection_calibration import load_projection_calibration

        return cls(load_feature_model(models_dir, device), attributes, config or SceneParserConfig(), viewpoint,
                   load_projection_calibration(models_dir) if calibrated_projection else None,
                   load_calibration(models_dir), load_background(models_dir),
                   centres=load_centre_net(models_dir, device))

    def scene_priors(self, priors: ScenePriors) -> ScenePriors:
        """The scene model's priors for this parser's proposals: ``priors`` (the world's) with the projected
        tables' priors at their calibration's base rates (:meth:`ProjectionCalibration.proposal_priors`)."""
        calibration = self.projection_calibration
        return priors if calibration is None else calibration.proposal_priors(priors)

    def parse(self, image) -> ParsedScene:
        return parse_scene(image, object_model=self.object_model, attributes=self.attributes,
                           viewpoint=self.viewpoint, projection_calibration=self.projection_calibration,
                           config=self.config, parser_config=self.parser_config,
                           object_calibration=self.object_calibration, background=self.background,
                           centres=self.centres)

    def evidence(self, image) -> SceneEvidence:
        return self.parse(image).evidence

"""Multi-object render-and-compare parsing (paper §4.2; issue 11 items 5-6, a first version): pixels in,
:class:`ObjectProposals` out, through :func:`parse_objects`.

**Stages** (times: median per 640x480 image, see below).

1. *Features*: the shipped stride-8 extractor gives unit features ``f`` per cell.
2. *Coarse search per category* (:func:`coarse_scores`): every hypothesis (category, size, azimuth bin, ground
   position) is scored by the render-and-compare log-likelihood ratio against the clutter model,
   ``sum_v w_v (kappa f_cell(v) . m_v - clutter(f_cell(v)))`` over the mesh's visible vertices ``v``, with
   ``clutter(f) = log mean_k exp(kappa f . c_k)`` (the bank as a vMF mixture) and ``w_v`` = 1 / (visible vertices
   sharing v's cell), so a hypothesis is scored per covered cell as a rendered mask would be. Nothing is rendered
   per hypothesis: per (category, size, azimuth) the visible vertices (the rasteriser's z-buffer, as in training)
   are computed once at a few *reference depths* on the camera's central ray, as pixel offsets from the projected
   base centre, and scaled by ``reference depth / depth`` at each grid position. Azimuth bins are in the
   contract's frame (``pose_degree``: clockwise from the viewing ray), which is what a view depends on, so one
   template serves every column. Positions: every ``position_step``-th stride-8 cell back-projected onto z = 0
   with the camera prior's base camera. Peaks: greedy suppression within ``nms_radius`` on the ground.
3. *3D-NMS across categories* (:func:`accept_proposals`): each peak's best hypothesis is rasterised at stride 8
   (one batched call) and scored per cell. Candidates are taken best first on a z-buffer of the accepted meshes:
   each cell belongs to the nearest accepted mesh covering it, so a candidate is scored only on the cells where
   it would be in front (an occluded object on its visible cells; an accepted mesh hides only its *solid* cells,
   where its own score beats clutter, since the category mesh overshoots its subtype), and it is accepted when it
   raises the image's log-likelihood by ``existence_threshold`` and is in front on ``min_new_fraction`` of its
   footprint; footprints on the ground may not intersect (objects do not interpenetrate), so one object is not
   proposed twice.
   Accepting nearest first (what the issue sketched) was measured first: it took small hypotheses in front of
   large near objects (precision 0.55 on 3 images of seed 712), which the gain against the current owner rejects.
   *Fragments merged* (:func:`merge_fragments`): a long object accepted as two shorter proposals (an airliner's
   fuselage and wing, a bicycle seen end-on) is replaced by one hypothesis when that explains the image as well
   and the two proposals show one body colour. *Occluded objects added* (:func:`add_occluded`): from here on a
   mesh hides a cell only where its evidence is within ``contest_margin`` of the best covering mesh's
   (:func:`claimed_cells`), so a peak shut out by a near mesh's overshoot is accepted by the same rules when its
   colour differs from its neighbours'. *Centre proposals* (:func:`add_centre_proposals`): the centre head
   (:mod:`~po3d_ppl.perception.centres`, a small network on the same features) marks where objects stand, hidden
   or not; each of its peaks whose best grid hypothesis meets no accepted footprint is accepted too.
4. *Local re-search and refinement*: around each accepted proposal every hypothesis is re-scored on a finer grid
   of image points (``local_step_px``), which gives its tables; then ``refine_steps`` Adam steps on (x, y, yaw) of
   all proposals at once maximise the rasterised render-and-compare score on their unoccluded cells (the hard
   z-buffer gives gradients through the feature interpolation only; each keeps its best iterate); a move that
   makes two footprints intersect is undone (:func:`keep_apart`; the table's figures are the same with it).
   With the centre head the re-search also tries the points around the nearest centre peak (with the proposal's
   category) and ranks positions by score plus a weighted log heatmap (``centre_reach_px``, ``centre_weight``):
   a proposal the 3D-NMS left off its object moves back (``docs/perception.md`` has the figures). Each proposal
   is re-searched on the cells that no proposal nearer the camera claims (``relocate_unoccluded``): an object
   seen through a bicycle's frame otherwise re-searches into a second bicycle on its occluder's cells.
5. *Record*: tables are log-sum-exps of the scores over the other pose parameters (sizes, and positions within
   ``table_radius`` of the proposal), never argmaxes; ownership, masks and boxes come from a stride-2 z-buffer
   of the accepted meshes' solid pixels, cut to the background model's foreground (or where the cell evidence
   falls below clutter): the category mesh encloses every subtype, so its silhouette overshoots (aeroplane boxes
   were too large); pixels two meshes cover then go to the one whose colour they show (:func:`_recolour`). A
   proposal left with under ``min_visible_fraction`` of its own silhouette is a sliver of a neighbour and is
   dropped.
6. *Second search* (:func:`add_region_proposals`, run by the scene parser between two readings): foreground that
   the most likely parsed scene (aligned subtype silhouettes, tighter than the category meshes) leaves unexplained
   is cut into regions, and the best peak covering a region whose footprint meets no proposal's is added when it
   scores enough there. :func:`parse_objects` alone stops at stage 5: it has no aligned silhouettes.

**Measured** (``po3d eval objects --data /work/data/perc_test_s713``: dataset seed 713, 120 images, 639 objects
>= 200 px, held out from the features (seed 711) and from tuning and calibration (seed 712); ``docs/perception.md``
has the table): precision 0.914, recall 0.847 (2D IoU >= 0.5), category 0.985, azimuth within 30 degrees 0.730
(car 0.90, motorbike 0.93, bicycle 0.73, bus 0.49, aeroplane 0.50: most errors are front/back flips), median
position error 0.472 in the camera's ground frame (the scene parser's camera-height estimate brings it to 0.258),
depth order 0.980, category ECE 0.012; 2.6 s per image (coarse search 1.9 s). Refinement moves positions but not
the tables. Masks are cut to the background model's foreground when one is shipped (precision 0.900 -> 0.915,
recall 0.830 -> 0.843 on 30 images of seed 712).

**Known limits.** Camera jitter is not estimated: a camera moved in x-y without turning gives the same image as
every object moved the other way on the uniform ground, so absolute positions carry the jitter's x-y offset
(uniform +-0.5 per axis); positions relative to each other do not. Its height is observable only through object
size against depth, which the category meshes (enclosing every subtype) do not pin (``camera_steps`` > 1, off by
default); the scene parser estimates it with the subtypes' own meshes. Objects are assumed on the ground (no
elevated aeroplanes); the tables come from the local search, before refinement moves the pose, calibrated by the
shipped temperatures (:mod:`po3d_ppl.perception.calibration`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, fields, replace
from functools import lru_cache

import numpy as np
import torch
import torch.nn.functional as F

from po3d_ppl import ontology
from po3d_ppl.errors import InputError
from po3d_ppl.perception.background import BackgroundModel, load_background
from po3d_ppl.perception.calibration import TableCalibration, load_calibration
from po3d_ppl.perception.centres import CentreNet, CentrePeaks, centre_peaks, load_centre_net, log_centre_prior
from po3d_ppl.perception.features import STRIDE, extract_features
from po3d_ppl.perception.image_input import CameraPrior, ImageInput, backproject_to_plane, load_image, project_points
from po3d_ppl.perception.neural_mesh import FeatureModel, NeuralMeshes, load_feature_model
from po3d_ppl.world.scene import Camera

CATEGORIES = tuple(ontology.CATEGORIES)
SIZES = ("large", "small")
#: :func:`cell_scores` of B posed meshes: per cell score against clutter, coverage and depth ([B, h, w] each).
CellMaps = tuple[torch.Tensor, torch.Tensor, torch.Tensor]


@dataclass(frozen=True)
class ParserConfig:
    """Search and acceptance settings of :func:`parse_objects`."""

    azimuth_bins: int = 24
    #: vMF concentration of the feature likelihood (the training temperature was 0.07, i.e. ~14).
    kappa: float = 10.0
    #: Every ``position_step``-th feature cell (rows and columns) is a candidate ground position.
    position_step: int = 2
    #: View depths of the reference placements whose vertex projections are scaled to every position.
    reference_depths: tuple[float, ...] = (7.0, 9.5, 12.5, 16.0)
    #: Visible vertices kept per template (evenly spaced; weights rescaled to the full set's total).
    template_vertices: int = 192
    #: Ground positions are searched in [-extent, extent]^2 (the world draws objects in [-3, 3]^2).
    ground_extent: float = 3.6
    #: Peaks closer than this on the ground (world units) to a better one are suppressed.
    nms_radius: float = 0.6
    #: Peaks kept, best first. A large object raises many peaks around it (positions further than ``nms_radius``
    #: whose templates overlap it), which pushed small objects out of 24 (recall 0.827 -> 0.866 at 64 on the 120
    #: images of seed 712, with the threshold below).
    max_peaks: int = 64
    #: A proposal must be in front of every accepted mesh on at least this fraction of its footprint's cells.
    min_new_fraction: float = 0.35
    #: Minimum rise of the image's render-and-compare log-likelihood (against the cells' current owners, or
    #: clutter) for a proposal to be accepted; also the minimum score of its visible cells in the end. 50 rather
    #: than 20 with 64 peaks: precision 0.902 -> 0.923 at equal recall on 40 images of seed 712 (80: recall fell).
    existence_threshold: float = 50.0
    #: An accepted mesh hides what lies behind it only on the cells where its own evidence exceeds this (its
    #: category mesh encloses every subtype, so elsewhere it may be overshoot); -inf: everywhere it covers. 0
    #: rather than -inf (with ``grow_px`` 20): precision 0.906 -> 0.933, recall 0.866 -> 0.899 on the 120 images
    #: of seed 712 (-3: 0.921/0.908, 1.5: 0.922/0.922, 5: 0.829/0.922 on its first 30); seed 716, not used to
    #: choose: 0.942 -> 0.946, 0.897 -> 0.912.
    solid_threshold: float = 0.0
    #: After the 3D-NMS, a mesh hides a cell only where its score is also within this of the best covering mesh's
    #: (:func:`claimed_cells`), so a near mesh's overshoot does not hide the object behind it; None: no contest.
    #: Peaks shut out by such overshoot are then accepted if their colour differs (:func:`add_occluded`). 2 (with
    #: the footprints below): precision 0.956 -> 0.955, recall 0.899 -> 0.911 on the 120 images of seed 712 (on its
    #: first 40, 4: 0.944 / 0.922 against 2: 0.935 / 0.927 with footprints at 0.7); seed 716, not used to choose:
    #: 0.963 -> 0.962, 0.909 -> 0.915.
    contest_margin: float | None = 2.0
    #: Footprints of proposals accepted that way are not shrunk (an object's duplicate a little behind it, over a
    #: recoloured roof, passed at 0.7; precision 0.935 -> 0.948 on 712's first 40).
    occluded_footprint_shrink: float = 1.0
    #: Pixels covered by two meshes go to the one whose median chroma they show (:func:`_recolour`) when it is
    #: within ``colour_close`` of theirs and nearer than the owner's by this; None: masks from depth order alone.
    #: 10 and 12: precision 0.955 -> 0.959, recall 0.911 -> 0.915 on the 120 images of seed 712 (5 and 20, 10 and
    #: 25 the same on its first 40); seed 716, not used to choose: 0.962 -> 0.968, 0.915 -> 0.922.
    colour_margin: float | None = 10.0
    colour_close: float = 12.0
    #: Positions within this ground distance of a peak enter its tables' log-sum-exp.
    table_radius: float = 0.3
    #: Footprints (category mesh's ground rectangle, scaled) shrunk by this factor must not intersect: objects do
    #: not interpenetrate, so overlapping hypotheses are one object.
    footprint_shrink: float = 0.7
    #: Camera candidates per axis of the jitter box (``CameraPrior.candidate_offsets``; 1: the base camera only).
    #: Off by default: a camera moved in x-y without turning is the same image as all objects moved the other way
    #: on the uniform ground, so only its height is observable, through object size against depth, and that cue
    #: picked wrong candidates on seed 712 (4 of 5 images; the true camera scored below the base one in 2 of 4).
    camera_steps: int = 1
    #: Local search around each accepted proposal: image offsets of its base centre up to this radius, this step.
    local_radius_px: float = 12.0
    local_step_px: float = 6.0
    #: Gradient steps (Adam) on (x, y, yaw) of every accepted proposal; 0 keeps the searched pose.
    refine_steps: int = 8
    #: Adam step sizes: ground units for x and y, degrees for the yaw.
    refine_lr_xy: float = 0.03
    refine_lr_yaw: float = 3.0
    #: Visible masks keep only pixels where the owner's cell score (bilinear) exceeds ``mask_threshold`` (2 over 0:
    #: precision 0.933 -> 0.956, recall 0.84 -> 0.86 on 10 images of seed 712).
    mask_by_evidence: bool = True
    mask_threshold: float = 2.0
    #: Cut masks to the foreground of the shipped background model when there is one (else the evidence cut above):
    #: the category mesh's silhouette overshoots its object.
    use_background: bool = True
    #: Foreground pixels no mesh covers join the nearest owner within this many pixels (6 -> 20: a posed category
    #: mesh that misses part of a large object left its box too small; precision 0.907 -> 0.914, recall 0.895 ->
    #: 0.902 on 30 images of seed 712, the same at 40).
    grow_px: int = 20
    #: A proposal whose final mask holds less than this fraction of its own mesh's silhouette is dropped as a
    #: sliver of a neighbour (on the 120 images of seed 712: below 0.05 lay 8 of 43 false proposals and none of
    #: 603 true ones; below 0.1, 9 and 2).
    min_visible_fraction: float = 0.05
    #: Stride of the final z-buffer giving masks, boxes and the ownership map.
    mask_stride: int = 2
    #: Two accepted proposals whose masks touch and show one body colour are replaced by one hypothesis when that
    #: explains the image at least as well, less this allowance (:func:`merge_fragments`); None: never merged.
    #: 0 (with the colour gate below): precision 0.945 -> 0.956 at equal recall (0.899) on the 120 images of seed
    #: 712; seed 716, not used to choose: 0.955 -> 0.963, recall 0.912 -> 0.909 (two same-coloured neighbours
    #: merged). Without the gate, 50 and 0 cost recall (0.908 -> 0.826 and 0.862 on 712's first 40 images).
    merge_penalty: float | None = 0.0
    #: Merged hypotheses rendered per pair (the best by coarse score over the pair's neighbourhood).
    merge_candidates: int = 6
    #: Only proposals of one colour are merged: the distance of their median chroma (CIELAB a, b on OpenCV's 8-bit
    #: scale) over the foreground pixels of the cells they are in front on may be at most this.
    merge_colour_distance: float = 10.0
    #: ... and both must be coloured: a median chroma at least this far from grey (grey, black and white objects'
    #: chroma tells them apart no better than shading does).
    merge_min_chroma: float = 8.0
    #: The scene parser's second search (:func:`add_region_proposals`): regions of the background model's foreground
    #: that the most likely parsed scene leaves unexplained, closed with a ``region_close_px`` square (0: not closed)
    #: and opened with a ``region_open_px`` one, of at least ``region_min_pixels``; a region's cells are those
    #: ``region_cell_share`` of whose pixels it holds; a peak must cover ``region_min_cover`` of them and score over
    #: ``region_min_score`` there (None: no second search). Chosen on the first 60 images of seed 712 (prototype: 5
    #: regions of missed objects kept against 1 of a found one); the closing (7 px) on all 120 images of 712
    #: (:func:`unexplained_regions`); ``docs/perception.md`` has the measured figures.
    region_min_score: float | None = 30.0
    region_min_pixels: int = 200
    region_open_px: int = 5
    region_close_px: int = 7
    region_cell_share: float = 0.25
    region_min_cover: float = 0.5
    #: A region whose best peak is blocked or too weak is named by the attribute network (its category, when at
    #: least ``region_named_probability``) and searched afresh for that category's footprint-free hypothesis whose
    #: *visible* cells (behind the proposals standing in front) best fit the region's
    #: (:func:`_named_region_hypothesis`, ``region_candidates`` rendered): it is proposed when that IoU reaches
    #: ``region_named_iou`` (None: off) and its score over the region exceeds ``region_named_min_score``. Chosen on
    #: seed 712; on 716 (not used to choose) answers 86.29 -> 86.78%, objects >= 20% occluded found 0.439 -> 0.512,
    #: precision 0.960 -> 0.953 (``docs/perception.md``). The IoU was 0.5 until 2026-12-06: missed objects' fits
    #: on 712 reached 0.39-0.47 and picks over found objects 0.19-0.29 (0.35 and 0.30 pick the same ones there).
    region_named_iou: float | None = 0.35
    region_named_probability: float = 0.9
    region_named_min_score: float = 0.0
    region_candidates: int = 48
    #: Centre proposals (:func:`add_centre_proposals`): the centre head's peaks (:mod:`~po3d_ppl.perception.centres`)
    #: over ``centre_threshold`` propose an object where no accepted footprint stands (None: none). A peak takes the
    #: coarse grid position whose base centre is nearest, within ``centre_snap_px``, and there its best hypothesis.
    centre_threshold: float | None = 0.3
    centre_snap_px: float = 16.0
    #: A centre proposal's existence log-odds: ``a * logit(p) + b`` of its peak's probability p. Fitted on the 120
    #: images of seed 712: 14 of its 20 centre proposals matched an object, with no trend in p over the threshold,
    #: so a constant, logit(0.7).
    centre_existence: tuple[float, float] = (0.0, 0.85)
    #: The local re-search (:func:`relocate`) also tries the points around the centre peak nearest a proposal
    #: within ``centre_reach_px`` (when that proposal is the peak's nearest too), and ranks positions by score plus
    #: ``centre_weight`` times the log heatmap (0, 0: off). Chosen on seed 712; on 716 answers from the image
    #: 85.66 -> 86.26%, on held-out 720 84.46 -> 84.53% with precision 0.938 -> 0.947 (``docs/perception.md``).
    centre_reach_px: float = 48.0
    centre_weight: float = 5.0
    #: The local re-search scores each proposal only on the cells no proposal nearer the camera claims
    #: (:func:`cells_of_nearer`): behind a bicycle the frame's cells otherwise make a hidden car's best local
    #: hypothesis a second bicycle, which the record then drops as a sliver. False: every cell (as before).
    relocate_unoccluded: bool = True

    def __post_init__(self) -> None:
        if not (isinstance(self.azimuth_bins, int) and self.azimuth_bins >= 12):
            raise InputError("ParserConfig.azimuth_bins", f"must be an integer >= 12, got {self.azimuth_bins!r}")
        if not (self.kappa > 0 and self.position_step >= 1 and self.template_vertices >= 8):
            raise InputError("ParserConfig", "kappa > 0, position_step >= 1 and template_vertices >= 8 are needed")
        if not self.reference_depths or min(self.reference_depths) <= 0:
            raise InputError("ParserConfig.reference_depths", "needs at least one positive depth")
        for name in ("region_open_px", "region_close_px"):
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= 0):
                raise InputError(f"ParserConfig.{name}", f"must be a whole number of pixels >= 0, got {value!r}")

    @property
    def azimuths(self) -> np.ndarray:
        """Bin centres in degrees (``pose_degree`` frame)."""
        return np.arange(self.azimuth_bins) * (360.0 / self.azimuth_bins)


@dataclass(eq=False)
class ObjectProposals:
    """What the object parser read from one image (N accepted proposals; tables float64 on CPU).

    ``existence_logodds`` [N]: render-and-compare score of the cells it is in front on, minus the acceptance
    threshold (uncalibrated).
    ``category_loglik`` [N, 5] (``ontology.CATEGORIES`` order); ``pose_loglik`` [N, 5, K] over ``pose_support``
    [N, K] (degrees, ``pose_degree`` frame: clockwise from the viewing ray, 0 = back visible), per category and
    normalised over azimuths (log P(azimuth | category); the category evidence is ``category_loglik`` alone);
    ``size_loglik`` [N, 2] (large, small). ``positions`` [N, 3] world (z = 0), ``depths`` [N] view depth of the
    base centre; ``rotations`` [N] world yaw of the best hypothesis (degrees). ``boxes`` [N, 4] (x, y, w, h pixels);
    ``masks`` [N, H, W] bool visible masks; ``ownership`` [H, W] int64 (proposal index, -1 background).
    ``timings`` seconds per stage; ``notes`` what this version does not estimate.
    """

    existence_logodds: torch.Tensor
    category_loglik: torch.Tensor
    pose_support: torch.Tensor
    pose_loglik: torch.Tensor
    size_loglik: torch.Tensor
    positions: torch.Tensor
    depths: torch.Tensor
    rotations: torch.Tensor
    boxes: torch.Tensor
    masks: torch.Tensor
    ownership: torch.Tensor
    camera: Camera
    #: [N] bool: proposed by the second search, for foreground the first reading left unexplained
    #: (:func:`add_region_proposals`; its existence log-odds is its score over the region)
    from_region: torch.Tensor
    #: The posed category mesh of each proposal (category, size, x, y, yaw), to render it (overlays, parts).
    poses: list[Hypothesis] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)
    notes: tuple[str, ...] = ()

    def __len__(self) -> int:
        return int(self.existence_logodds.shape[0])

    @property
    def categories(self) -> list[str]:
        """Most likely category per proposal (for display; the tables are the output)."""
        return [CATEGORIES[i] for i in self.category_loglik.argmax(-1).tolist()]


NOTES = ("camera jitter not estimated (base camera: absolute positions carry its x-y offset)",
         "objects assumed on the ground plane", "tables from the local search, before the gradient refinement of the pose")
RAW_NOTE = "tables are raw render-and-compare scores (no calibration shipped: po3d train calibration)"


# --- templates: vertex projections at reference depths ---------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Templates:
    """Per (category, size, reference, azimuth): up to N visible vertices, as pixel offsets from the projected base
    centre at the reference depth, their texture row and cell weight (0 = padding). Shapes [5, 2, R, A, N(, 2)]."""

    offsets: torch.Tensor
    vertex: torch.Tensor
    weight: torch.Tensor
    depths: torch.Tensor


def _reference_points(camera: Camera, depths: tuple[float, ...]) -> np.ndarray:
    """Ground points on the vertical plane of the optical axis at the given view depths [R, 3]."""
    forward = -camera.matrix_world[:3, 2]
    loc = camera.location
    g = forward[:2] / np.linalg.norm(forward[:2])
    along = float(g @ forward[:2])
    t = (np.asarray(depths) + loc[2] * forward[2]) / along
    pts = np.zeros((len(depths), 3))
    pts[:, :2] = loc[:2] + t[:, None] * g
    return pts


def _view_azimuth(camera: Camera, xy: np.ndarray) -> np.ndarray:
    ray = np.asarray(xy)[..., :2] - camera.location[:2]
    return np.degrees(np.arctan2(ray[..., 1], ray[..., 0]))


def yaw_of(camera: Camera, x: float, y: float, pose_degree: float) -> float:
    """World yaw (degrees) of an object at ground (x, y) seen at ``pose_degree`` (the contract's frame: clockwise
    from the viewing ray to its front): pose_degree = view azimuth - yaw."""
    return float(_view_azimuth(camera, np.array([x, y])) - pose_degree) % 360.0


def build_templates(camera: Camera, config: ParserConfig) -> Templates:
    """Visible vertices of every category mesh at every (size, reference depth, azimuth), via the z-buffer."""
    from po3d_ppl.perception.category_meshes import category_mesh, pose_vertices_torch
    from po3d_ppl.perception.rasterizer import rasterize_camera

    refs = _reference_points(camera, config.reference_depths)
    az = torch.tensor(config.azimuths, dtype=torch.float64)
    n = config.template_vertices
    shape = (len(CATEGORIES), len(SIZES), len(refs), len(az), n)
    offsets, vertex, weight = torch.zeros(*shape, 2), torch.zeros(shape, dtype=torch.long), torch.zeros(shape)
    for c, cat in enumerate(CATEGORIES):
        mesh = category_mesh(cat)
        verts = torch.tensor(np.array(mesh.vertices), dtype=torch.float64)
        faces = torch.tensor(np.array(mesh.faces))
        for s, size in enumerate(SIZES):
            scale = float(ontology.SIZE_SCALE[size])
            for r, ref in enumerate(refs):
                rotation = _view_azimuth(camera, ref) - az  # pose_degree = view azimuth - yaw
                posed = pose_vertices_torch(verts, torch.full_like(az, ref[0]), torch.full_like(az, ref[1]),
                                            rotation, scale)
                vis, xy = _visible_vertices(posed, faces, camera, 1.5 * mesh.spacing * scale, rasterize_camera)
                centre = project_points(camera, ref)[:2]
                for a in range(len(az)):
                    o, v, w = _subsample(xy[a], vis[a], n)
                    k = len(v)
                    offsets[c, s, r, a, :k] = torch.as_tensor(o - centre, dtype=torch.float32)
                    vertex[c, s, r, a, :k] = torch.as_tensor(v)
                    weight[c, s, r, a, :k] = torch.as_tensor(w, dtype=torch.float32)
    depths = torch.tensor([project_points(camera, p)[2] for p in refs], dtype=torch.float32)
    return Templates(offsets, vertex, weight, depths)


def _visible_vertices(posed: torch.Tensor, faces: torch.Tensor, camera: Camera, tol: float, rasterize_camera
                      ) -> tuple[np.ndarray, np.ndarray]:
    """[B, V] visibility (own z-buffer at stride 2, as in training) and [B, V, 2] pixel coordinates."""
    stride = 2
    frags = rasterize_camera(posed.float(), faces, camera, stride=stride, cull_backfaces=True)
    depth_map = frags.depth_map.detach().numpy()
    p = project_points(camera, posed.numpy())
    xy, depth = p[..., :2], p[..., 2]
    b, h, w = depth_map.shape
    col = np.floor(xy[..., 0] / stride).astype(np.int64)
    row = np.floor(xy[..., 1] / stride).astype(np.int64)
    inside = (col >= 0) & (col < w) & (row >= 0) & (row < h) & (depth > 0)
    bi = np.arange(b)[:, None]
    seen = depth_map[bi, row.clip(0, h - 1), col.clip(0, w - 1)]
    return inside & (depth <= seen + tol), xy


def _subsample(xy: np.ndarray, visible: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Up to ``n`` evenly spaced visible vertices with weights 1 / (visible vertices in their stride-8 cell),
    rescaled so the kept weights sum to the number of covered cells."""
    ids = np.flatnonzero(visible)
    if ids.size == 0:
        return np.zeros((0, 2)), np.zeros(0, dtype=np.int64), np.zeros(0)
    cells = np.floor(xy[ids] / STRIDE).astype(np.int64)
    _, inverse, counts = np.unique(cells, axis=0, return_inverse=True, return_counts=True)
    w = 1.0 / counts[inverse.reshape(-1)]
    keep = np.unique(np.linspace(0, ids.size - 1, min(n, ids.size)).round().astype(np.int64))
    kept_w = w[keep] * (w.sum() / w[keep].sum())
    return xy[ids[keep]], ids[keep], kept_w


@lru_cache(maxsize=4)
def _cached_templates(camera_key: tuple, config: ParserConfig) -> Templates:
    width, height, intrinsics = camera_key
    prior = CameraPrior(width, height, intrinsics=intrinsics)
    return build_templates(prior.base, config)


# --- coarse search ---------------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Grid:
    """Candidate ground positions: ``ground`` [P, 3], ``pixel`` [P, 2] (projected base centre), ``depth`` [P],
    ``ref`` [P] nearest reference depth, ``scale`` [P] = reference depth / depth."""

    ground: torch.Tensor
    pixel: torch.Tensor
    depth: torch.Tensor
    ref: torch.Tensor
    scale: torch.Tensor


def position_grid(camera: Camera, feature_size: tuple[int, int], templates: Templates, config: ParserConfig) -> Grid:
    """Every ``position_step``-th cell centre back-projected onto the ground, kept inside the search extent."""
    h, w = feature_size
    rows, cols = torch.meshgrid(torch.arange(0, h, config.position_step), torch.arange(0, w, config.position_step),
                                indexing="ij")
    pix = torch.stack([cols.reshape(-1), rows.reshape(-1)], -1).double() * STRIDE + STRIDE / 2
    return grid_at_pixels(camera, pix, templates, config.ground_extent)[0]


def grid_at_pixels(camera: Camera, pix: torch.Tensor, templates: Templates, extent: float
                   ) -> tuple[Grid, torch.Tensor]:
    """The ground positions under ``camera`` of image points ``pix`` [P, 2] (base centres), and which were kept."""
    ground = backproject_to_plane(camera, pix.double())
    ok = torch.isfinite(ground).all(-1) & (ground[:, :2].abs() <= extent).all(-1)
    ground, pix = ground[ok], pix[ok]
    depth = project_points(camera, ground)[:, 2].float()
    logd = torch.log(templates.depths)[None, :] - torch.log(depth)[:, None]
    ref = logd.abs().argmin(-1)
    return Grid(ground.float(), pix.float(), depth, ref, templates.depths[ref] / depth), ok


def cell_evidence(features: torch.Tensor, meshes: NeuralMeshes, kappa: float) -> tuple[list[torch.Tensor], torch.Tensor]:
    """Per category [h*w + 1, V]: kappa f . m_v minus the clutter log-likelihood of the cell (the extra last row is
    0: vertices off the image carry no evidence); and the clutter log-likelihood [h*w]."""
    d = features.shape[0]
    flat = features.reshape(d, -1).T.float()
    clutter = torch.logsumexp(kappa * flat @ meshes.clutter.T, -1) - math.log(meshes.clutter.shape[0])
    out = []
    for c in CATEGORIES:
        e = kappa * flat @ meshes.textures[c].T - clutter[:, None]
        out.append(torch.cat([e, torch.zeros(1, e.shape[1])]))
    return out, clutter


def coarse_scores(evidence: list[torch.Tensor], feature_size: tuple[int, int], grid: Grid, templates: Templates,
                  cell_weight: torch.Tensor | None = None) -> torch.Tensor:
    """[P, 5, 2, A] render-and-compare log-likelihood ratios of every hypothesis against clutter; ``cell_weight``
    [P, h*w] (optional) weighs each cell's evidence per position (0: a cell the position may not use)."""
    return torch.stack([category_scores(e, c, feature_size, grid, templates, cell_weight)
                        for c, e in enumerate(evidence)], 1)


def category_scores(e: torch.Tensor, c: int, feature_size: tuple[int, int], grid: Grid, templates: Templates,
                    cell_weight: torch.Tensor | None = None) -> torch.Tensor:
    """[P, 2, A] scores of category ``c`` (its cell evidence ``e``) at the grid's positions."""
    h, w = feature_size
    ref = grid.ref
    scale = grid.scale[:, None, None, None]
    off = templates.offsets[c][:, ref].permute(1, 0, 2, 3, 4)  # [P, 2, A, N, 2]
    vid = templates.vertex[c][:, ref].permute(1, 0, 2, 3)
    wt = templates.weight[c][:, ref].permute(1, 0, 2, 3) * scale**2
    px = grid.pixel[:, None, None, None, :] + off * scale[..., None]
    col = torch.floor(px[..., 0] / STRIDE).long()
    row = torch.floor(px[..., 1] / STRIDE).long()
    inside = (col >= 0) & (col < w) & (row >= 0) & (row < h)
    cell = torch.where(inside, row * w + col, h * w)
    if cell_weight is not None:  # the off-image row carries no evidence, so its weight does not matter
        padded = torch.cat([cell_weight.to(wt.dtype), torch.ones(len(cell_weight), 1, dtype=wt.dtype)], 1)
        wt = wt * padded.gather(1, cell.reshape(len(cell), -1)).reshape(cell.shape)
    return (e.reshape(-1)[cell * e.shape[1] + vid] * wt).sum(-1)


def subset(grid: Grid, keep: torch.Tensor) -> Grid:
    return Grid(grid.ground[keep], grid.pixel[keep], grid.depth[keep], grid.ref[keep], grid.scale[keep])


def find_peaks(scores: torch.Tensor, grid: Grid, config: ParserConfig) -> list[int]:
    """Positions whose best hypothesis beats clutter, greedily suppressed within ``nms_radius`` on the ground."""
    best = scores.flatten(1).max(-1).values
    order = torch.argsort(best, descending=True, stable=True)
    order = order[best[order] > 0]
    xy = grid.ground[:, :2]
    taken: list[int] = []
    for p in order.tolist():
        if taken and (torch.linalg.norm(xy[taken] - xy[p], dim=-1) < config.nms_radius).any():
            continue
        taken.append(p)
        if len(taken) >= config.max_peaks:
            break
    return taken


# --- 3D-NMS: acceptance in depth order ------------------------------------------------------------------------------


@dataclass(frozen=True)
class Hypothesis:
    """One posed category mesh: ``position`` index in the grid, ground ``x``, ``y``, world ``rotation`` (deg)."""

    position: int
    category: int
    size: int
    azimuth: int
    x: float
    y: float
    rotation: float
    depth: float
    score: float


def _hypothesis_at(grid: Grid, p: int, category: int, size: int, azimuth: int, score: float, camera: Camera,
                   config: ParserConfig, position: int = -1) -> Hypothesis:
    """The (category, size, azimuth bin) hypothesis standing at ``grid`` position ``p``; its world yaw is the
    azimuth as seen from there. ``position``: the index it records (-1: not a coarse-grid peak)."""
    x, y = (float(v) for v in grid.ground[p, :2])
    return Hypothesis(position, int(category), int(size), int(azimuth), x, y,
                      yaw_of(camera, x, y, float(config.azimuths[azimuth])), float(grid.depth[p]), float(score))


def _best_hypotheses(scores: torch.Tensor, peaks: list[int], grid: Grid, camera: Camera, config: ParserConfig
                     ) -> list[Hypothesis]:
    out = []
    for p in peaks:
        flat = int(scores[p].flatten().argmax())
        c, s, a = np.unravel_index(flat, scores.shape[1:])
        out.append(_hypothesis_at(grid, p, c, s, a, float(scores[p].flatten()[flat]), camera, config, position=p))
    return out


def _posed_meshes(hyps: list[Hypothesis]) -> tuple[torch.Tensor, torch.Tensor, list[int]]:
    """Padded [B, Vmax, 3] world vertices, [B, Fmax, 3] faces (-1 padding) and each item's vertex count."""
    from po3d_ppl.perception.category_meshes import category_mesh, pose_vertices_torch
    from po3d_ppl.perception.rasterizer import pad_meshes

    items, counts = [], []
    for h in hyps:
        mesh = category_mesh(CATEGORIES[h.category])
        v = pose_vertices_torch(torch.tensor(np.array(mesh.vertices)), h.x, h.y, h.rotation,
                                float(ontology.SIZE_SCALE[SIZES[h.size]]))
        items.append((v.float(), torch.tensor(np.array(mesh.faces))))
        counts.append(int(v.shape[0]))
    verts, faces = pad_meshes(items)
    return verts, faces, counts


def accept_proposals(hyps: list[Hypothesis], features: torch.Tensor, clutter: torch.Tensor,
                     meshes: NeuralMeshes, camera: Camera, config: ParserConfig, maps: CellMaps | None = None
                     ) -> tuple[list[Hypothesis], list[float]]:
    """Greedy 3D-NMS on a z-buffer of the accepted meshes.

    Candidates are taken best coarse score first; each cell is owned by the nearest accepted mesh covering it (depth
    order), so a candidate is scored only on the cells where it would be in front. It is accepted when the
    log-likelihood of the image rises by ``existence_threshold`` or more (its cell scores minus those of the cells'
    current owners) and it is in front on at least ``min_new_fraction`` of its footprint. Plain depth order
    (nearest first, measured) accepted small hypotheses in front of large near objects; scoring the gain against
    the current owner rejects them. A last pass drops accepted proposals that nearer later ones hid. ``maps``:
    the hypotheses' :func:`cell_scores` when the caller has them.
    """

    if not hyps:
        return [], []
    fg, mask, depth = maps if maps is not None else cell_scores(hyps, features, clutter, meshes, camera, config)
    hh, ww = mask.shape[1:]
    footprint = mask.flatten(1).sum(-1).float()
    owner_depth = torch.full((hh, ww), float("inf"))
    owner_fg = torch.zeros(hh, ww)
    accepted: list[int] = []
    for i in sorted(range(len(hyps)), key=lambda i: -hyps[i].score):
        if any(footprints_overlap(hyps[i], hyps[j], config.footprint_shrink) for j in accepted):
            continue
        front = mask[i] & (depth[i] < owner_depth)
        if footprint[i] == 0 or float(front.sum()) < config.min_new_fraction * float(footprint[i]):
            continue
        gain = float((fg[i] - owner_fg)[front].sum())
        if gain < config.existence_threshold:
            continue
        accepted.append(i)
        solid = front & (fg[i] > config.solid_threshold)
        owner_depth = torch.where(solid, depth[i], owner_depth)
        owner_fg = torch.where(solid, fg[i], owner_fg)
    return _final_check(accepted, hyps, mask, depth, fg, footprint, config)


def _footprint(h: Hypothesis, shrink: float) -> np.ndarray:
    """[4, 2] ground corners of the hypothesis' mesh footprint (scaled, shrunk about its centre)."""
    from po3d_ppl.perception.category_meshes import category_mesh

    b = category_mesh(CATEGORIES[h.category]).bounds
    half = 0.5 * (b[1, :2] - b[0, :2]) * float(ontology.SIZE_SCALE[SIZES[h.size]]) * shrink
    corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * half
    th = math.radians(h.rotation)
    rot = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
    return corners @ rot.T + np.array([h.x, h.y])


def footprints_overlap(a: Hypothesis, b: Hypothesis, shrink: float) -> bool:
    """Separating-axis test of the two (shrunk) footprint rectangles."""
    pa, pb = _footprint(a, shrink), _footprint(b, shrink)
    for poly in (pa, pb):
        for k in range(4):
            edge = poly[(k + 1) % 4] - poly[k]
            axis = np.array([-edge[1], edge[0]])
            ra, rb = pa @ axis, pb @ axis
            if ra.max() < rb.min() or rb.max() < ra.min():
                return False
    return True


def cell_scores(hyps: list[Hypothesis], features: torch.Tensor, clutter: torch.Tensor, meshes: NeuralMeshes,
                camera: Camera, config: ParserConfig) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Each hypothesis rendered alone at stride 8: per cell its score ``kappa f . m`` (interpolated vertex features)
    minus the clutter log-likelihood, its coverage and its depth ([B, h, w] each)."""
    from po3d_ppl.perception.rasterizer import rasterize_camera

    verts, faces, counts = _posed_meshes(hyps)
    frags = rasterize_camera(verts, faces, camera, stride=STRIDE, cull_backfaces=True)
    tex = torch.zeros(len(hyps), verts.shape[1], meshes.dim)
    for i, h in enumerate(hyps):
        tex[i, : counts[i]] = meshes.textures[CATEGORIES[h.category]]
    with torch.no_grad():
        rendered = F.normalize(frags.interpolate(tex), dim=-1)  # [B, h, w, D]
        hh, ww = frags.height, frags.width
        f = features[:, :hh, :ww].permute(1, 2, 0)
        fg = config.kappa * (rendered * f[None]).sum(-1) - clutter.view(hh, ww)[None]
    return fg, frags.mask, frags.depth_map.detach()


def rows_of(maps: CellMaps, among: list[Hypothesis], wanted: list[Hypothesis]) -> CellMaps:
    """The cell maps of ``wanted`` taken from those of ``among`` (which holds every one of them): rendered once."""
    index = [among.index(h) for h in wanted]
    return tuple(t[index] for t in maps)


def _final_check(accepted: list[int], hyps: list[Hypothesis], mask: torch.Tensor, depth: torch.Tensor,
                 fg: torch.Tensor, footprint: torch.Tensor, config: ParserConfig
                 ) -> tuple[list[Hypothesis], list[float]]:
    """Keep accepted proposals still in front on enough of their footprint with enough score there."""
    if not accepted:
        return [], []
    front = front_cells(fg[accepted], mask[accepted], depth[accepted], config, contest=False)
    out, scores = [], []
    for n, i in enumerate(accepted):
        score = float(fg[i][front[n]].sum())
        if float(front[n].sum()) >= config.min_new_fraction * float(footprint[i]) and \
                score >= config.existence_threshold:
            out.append(hyps[i])
            scores.append(score)
    return out, scores


# --- merging fragments: one object proposed as two --------------------------------------------------------------


def front_cells(fg: torch.Tensor, mask: torch.Tensor, depth: torch.Tensor, config: ParserConfig,
                contest: bool = True) -> torch.Tensor:
    """[B, h, w] the cells each posed mesh covers where no other mesh's claimed cell (:func:`claimed_cells`; without
    ``contest``, every *solid* cell: score above ``solid_threshold``) is nearer: the 3D-NMS's rule, without its
    order. A mesh's own claimed cell is at its own depth, so taking the nearest claimed depth over all meshes (itself
    included) gives the same cells."""
    nearest = torch.where(claimed_cells(fg, mask, config, contest), depth, torch.full_like(depth, float("inf")))
    return mask & (depth <= nearest.min(0, keepdim=True).values)


def claimed_cells(fg: torch.Tensor, mask: torch.Tensor, config: ParserConfig, contest: bool = True) -> torch.Tensor:
    """[B, ...] where each posed mesh hides what lies behind it: its *solid* cells (score above
    ``solid_threshold``) whose score is within ``contest_margin`` of the best covering mesh's there. A category mesh
    encloses all its subtypes, so it overshoots its object, and any object's features beat clutter under any
    texture: without the contest a near mesh's overshoot hides the neighbour behind it."""
    solid = mask & (fg > config.solid_threshold)
    if config.contest_margin is None or not contest:
        return solid
    best = torch.where(mask, fg, torch.full_like(fg, -float("inf"))).max(0, keepdim=True).values
    return solid & (fg >= best - config.contest_margin)


def front_scores(fg: torch.Tensor, mask: torch.Tensor, depth: torch.Tensor, config: ParserConfig) -> torch.Tensor:
    """[B] each posed mesh's score on its :func:`front_cells`: the image log-likelihood ratio a set of proposals
    earns, as a sum over them."""
    return torch.where(front_cells(fg, mask, depth, config), fg, torch.zeros_like(fg)).flatten(1).sum(-1)


def _merge_candidates(a: Hypothesis, b: Hypothesis, evidence: list[torch.Tensor], feature_size: tuple[int, int],
                      templates: Templates, camera: Camera, config: ParserConfig) -> list[Hypothesis]:
    """Hypotheses of one object covering both ``a`` and ``b``: base centres every ``local_step_px`` along the
    segment between their projected base centres and up to ``local_radius_px`` either side of it, every category,
    size and azimuth scored by the coarse search; the best of each (category, size) and the ``merge_candidates``
    best overall."""
    centres = project_points(camera, torch.tensor([[a.x, a.y, 0.0], [b.x, b.y, 0.0]], dtype=torch.float64))[:, :2]
    span = centres[1] - centres[0]
    length = float(torch.linalg.norm(span))
    along = span / length if length > 0 else torch.tensor([1.0, 0.0], dtype=torch.float64)
    across = torch.stack([-along[1], along[0]])
    r, step = config.local_radius_px, config.local_step_px
    t = torch.arange(-r, length + r + 1e-6, step, dtype=torch.float64)
    u = torch.arange(-r, r + 1e-6, step, dtype=torch.float64)
    pix = (centres[0] + t[:, None, None] * along + u[None, :, None] * across).reshape(-1, 2)
    grid, _ = grid_at_pixels(camera, pix, templates, config.ground_extent + 1.0)
    if grid.ground.shape[0] == 0:
        return []
    scores = coarse_scores(evidence, feature_size, grid, templates)  # [P, 5, 2, A]
    flat = scores.flatten()
    picks = set(torch.topk(flat, min(config.merge_candidates, flat.numel())).indices.tolist())
    per_kind = scores.permute(1, 2, 0, 3).reshape(len(CATEGORIES) * len(SIZES), -1).argmax(-1)
    for k, idx in enumerate(per_kind.tolist()):
        p, az = divmod(idx, scores.shape[3])
        c, s_ = divmod(k, len(SIZES))
        picks.add(int(np.ravel_multi_index((p, c, s_, az), scores.shape)))
    out = []
    for idx in sorted(picks, key=lambda i: -float(flat[i])):
        p, c, s_, az = np.unravel_index(idx, scores.shape)
        out.append(_hypothesis_at(grid, int(p), c, s_, az, float(flat[idx]), camera, config))
    return out


def proposal_chroma(fg: torch.Tensor, mask: torch.Tensor, depth: torch.Tensor, chroma: torch.Tensor,
                    foreground: torch.Tensor, config: ParserConfig) -> torch.Tensor:
    """[B, 2] median chroma (``chroma`` [H, W, 2]) of each posed mesh's pixels: the foreground pixels of the solid
    cells among its :func:`front_cells` (NaN where it has none)."""
    own = front_cells(fg, mask, depth, config) & (fg > config.solid_threshold)
    h, w = chroma.shape[:2]
    out = torch.full((fg.shape[0], 2), float("nan"))
    for b, cells in enumerate(own):
        pixels = cells.repeat_interleave(STRIDE, 0).repeat_interleave(STRIDE, 1)[:h, :w]
        pixels = F.pad(pixels, (0, w - pixels.shape[1], 0, h - pixels.shape[0])) & foreground
        if bool(pixels.any()):
            out[b] = chroma[pixels].median(0).values
    return out


def _same_colour(a: torch.Tensor, b: torch.Tensor, config: ParserConfig) -> bool:
    """Two median chromas (OpenCV's a, b: grey at 128) of one coloured body; NaN (no pixels of its own) fails."""
    grey = torch.tensor([128.0, 128.0])
    return bool(torch.linalg.norm(a - b) <= config.merge_colour_distance
                and torch.linalg.norm(a - grey) >= config.merge_min_chroma
                and torch.linalg.norm(b - grey) >= config.merge_min_chroma)


def merge_fragments(hyps: list[Hypothesis], scores: list[float], features: torch.Tensor, clutter: torch.Tensor,
                    meshes: NeuralMeshes, evidence: list[torch.Tensor], feature_size: tuple[int, int],
                    templates: Templates, camera: Camera, config: ParserConfig,
                    chroma: torch.Tensor | None = None, foreground: torch.Tensor | None = None,
                    maps: CellMaps | None = None) -> tuple[list[Hypothesis], list[float]]:
    """Replace two accepted proposals by one when one posed mesh explains the image about as well.

    A long object (an airliner, an articulated bus, a bicycle end-on) is often accepted as two shorter proposals:
    the coarse search's best hypothesis covers one end and the rest raises a second peak whose footprint does not
    meet the first's. Each pair whose stride-8 masks touch is tested against the best one-object hypotheses over
    its neighbourhood (:func:`_merge_candidates`); the image's log-likelihood ratio with the pair replaced
    (:func:`front_scores`, summed over all proposals) may fall by at most ``merge_penalty`` (what the second
    object's existence costs), and the merged footprint may not meet another proposal's. The best merge is made
    and the test repeated until none passes. Returns the proposals and their front scores (merged ones new).

    The likelihood alone does not tell a split object from two neighbours: any object's features beat clutter under
    any category's texture, so one large mesh over two objects scores as well as the pair (seed 712, 120 images:
    precision 0.945 -> 0.955 but recall 0.899 -> 0.862 on its first 40; the gain of right and wrong merges
    overlapped, 58-834 against 58-296). With ``chroma`` [H, W, 2] and ``foreground`` [H, W] only pairs of one
    body colour are tested (:func:`_same_colour`; the world paints each object one colour, parts aside): of the
    touching proposal pairs on seed 712, 9 of 22 on one object and 19 of 231 on two were within 10. ``maps``: the
    proposals' :func:`cell_scores` when the caller has them."""
    if config.merge_penalty is None or len(hyps) < 2:
        return hyps, scores
    hyps, scores = list(hyps), list(scores)
    fg, mask, depth = maps if maps is not None else cell_scores(hyps, features, clutter, meshes, camera, config)
    # per pair: its one-object candidates and their cell maps (rendered once, kept across merges elsewhere)
    candidates: dict[tuple[Hypothesis, Hypothesis], tuple[list[Hypothesis], torch.Tensor, torch.Tensor,
                                                          torch.Tensor]] = {}
    while len(hyps) >= 2:
        total = float(front_scores(fg, mask, depth, config).sum())
        grown = F.max_pool2d(mask.float()[:, None], 3, stride=1, padding=1)[:, 0] > 0
        colour = proposal_chroma(fg, mask, depth, chroma, foreground, config) if chroma is not None else None
        best: tuple[float, int, int, Hypothesis, float] | None = None
        for i in range(len(hyps)):
            for j in range(i + 1, len(hyps)):
                if not bool((grown[i] & mask[j]).any()):
                    continue
                if colour is not None and not _same_colour(colour[i], colour[j], config):
                    continue
                others = [k for k in range(len(hyps)) if k not in (i, j)]
                key = (hyps[i], hyps[j])
                if key not in candidates:
                    cands = _merge_candidates(hyps[i], hyps[j], evidence, feature_size, templates, camera, config)
                    candidates[key] = (cands, *cell_scores(cands, features, clutter, meshes, camera, config)) \
                        if cands else ([], None, None, None)
                cands, cfg, cmask, cdepth = candidates[key]
                for n, m in enumerate(cands):
                    if any(footprints_overlap(m, hyps[k], config.footprint_shrink) for k in others):
                        continue
                    front = front_scores(torch.cat([fg[others], cfg[n:n + 1]]),
                                         torch.cat([mask[others], cmask[n:n + 1]]),
                                         torch.cat([depth[others], cdepth[n:n + 1]]), config)
                    change = float(front.sum()) - total
                    if change >= -config.merge_penalty and (best is None or change > best[0]):
                        best = (change, i, j, (key, n), float(front[-1]))
        if best is None:
            break
        _, i, j, (key, n), score = best
        cands, cfg, cmask, cdepth = candidates[key]
        keep = [k for k in range(len(hyps)) if k not in (i, j)]
        hyps = [hyps[k] for k in keep] + [cands[n]]
        scores = [scores[k] for k in keep] + [score]
        fg, mask, depth = (torch.cat([t[keep], c[n:n + 1]]) for t, c in ((fg, cfg), (mask, cmask), (depth, cdepth)))
    return hyps, scores


# --- occluded objects: contested cells --------------------------------------------------------------------------


def add_occluded(hyps: list[Hypothesis], scores: list[float], pool: list[Hypothesis], features: torch.Tensor,
                 clutter: torch.Tensor, meshes: NeuralMeshes, camera: Camera, config: ParserConfig,
                 chroma: torch.Tensor, foreground: torch.Tensor, pool_maps: CellMaps | None = None
                 ) -> tuple[list[Hypothesis], list[float]]:
    """Accept peaks the 3D-NMS shut out behind a nearer mesh's overshoot, when their colour says they are another
    object: each rejected peak (``pool``, best first) is scored with contested cells (:func:`claimed_cells`) and
    accepted by the 3D-NMS's rules (gain, front fraction, footprints apart) if its median chroma differs from that
    of every accepted proposal whose mask its own meets (:func:`_distinct_colours`). ``pool_maps``: the pool's
    :func:`cell_scores` when the caller has them (the accepted proposals' are taken from them if they are peaks)."""
    if config.contest_margin is None or not hyps or all(h in hyps for h in pool):
        return hyps, scores
    if pool_maps is None:
        pool_maps = cell_scores(pool, features, clutter, meshes, camera, config)
    fg, mask, depth = rows_of(pool_maps, pool, hyps) if all(h in pool for h in hyps) else \
        cell_scores(hyps, features, clutter, meshes, camera, config)
    rejected = [h for h in pool if h not in hyps]
    pool_fg, pool_mask, pool_depth = rows_of(pool_maps, pool, rejected)
    pool, hyps, scores = rejected, list(hyps), list(scores)
    total = float(front_scores(fg, mask, depth, config).sum())
    for m in sorted(range(len(pool)), key=lambda m: -pool[m].score):
        footprint = float(pool_mask[m].sum())
        if footprint == 0 or any(footprints_overlap(pool[m], h, config.occluded_footprint_shrink) for h in hyps):
            continue
        stack = tuple(torch.cat([t, c[m:m + 1]]) for t, c in ((fg, pool_fg), (mask, pool_mask), (depth, pool_depth)))
        front = front_cells(*stack, config)
        if float(front[-1].sum()) < config.min_new_fraction * footprint:
            continue
        new_scores = torch.where(front, stack[0], torch.zeros_like(stack[0])).flatten(1).sum(-1)
        if float(new_scores.sum()) - total < config.existence_threshold:
            continue
        colour = proposal_chroma(*stack, chroma, foreground, config)
        touching = [k for k in range(len(hyps)) if bool((mask[k] & pool_mask[m]).any())]
        if not all(_distinct_colours(colour[-1], colour[k], config) for k in touching):
            continue
        hyps.append(pool[m])
        fg, mask, depth = stack
        scores = [float(v) for v in new_scores]
        total = float(new_scores.sum())
    return hyps, scores


def _distinct_colours(a: torch.Tensor, b: torch.Tensor, config: ParserConfig) -> bool:
    """Two median chromas that tell two bodies apart: both measured and further apart than one body's spread."""
    return bool(torch.isfinite(a).all() and torch.isfinite(b).all()
                and torch.linalg.norm(a - b) > config.merge_colour_distance)


# --- camera and position: local search around the accepted proposals ----------------------------------------------


def _window_offsets(config: ParserConfig) -> torch.Tensor:
    """[M, 2] pixel offsets every ``local_step_px`` within ``local_radius_px`` (a square window)."""
    r = config.local_radius_px
    d = torch.arange(-r, r + 1e-6, config.local_step_px, dtype=torch.float64)
    dy, dx = torch.meshgrid(d, d, indexing="ij")
    return torch.stack([dx.reshape(-1), dy.reshape(-1)], -1)


def _local_pixels(hyps: list[Hypothesis], camera: Camera, config: ParserConfig) -> tuple[torch.Tensor, torch.Tensor]:
    """Image points around each proposal's projected base centre ([M, 2]) and the proposal of each ([M])."""
    offs = _window_offsets(config)
    centres = project_points(camera, torch.tensor([[h.x, h.y, 0.0] for h in hyps], dtype=torch.float64))[:, :2]
    pix = (centres[:, None] + offs[None]).reshape(-1, 2)
    owner = torch.arange(len(hyps)).repeat_interleave(len(offs))
    return pix, owner


def _peak_pixels(hyps: list[Hypothesis], camera: Camera, peaks: CentrePeaks, config: ParserConfig
                 ) -> tuple[torch.Tensor, torch.Tensor]:
    """Image points around each centre-head peak within ``centre_reach_px`` of a proposal's base centre ([M, 2]),
    each owned by the proposal nearest its peak when that peak is also the proposal's nearest ([M]): a proposal
    located off its object can move there, but not onto a neighbour's peak."""
    if len(peaks) == 0:
        return torch.zeros(0, 2, dtype=torch.float64), torch.zeros(0, dtype=torch.long)
    bases = project_points(camera, torch.tensor([[h.x, h.y, 0.0] for h in hyps], dtype=torch.float64))[:, :2]
    distance = torch.cdist(peaks.pixels.double(), bases)
    nearest = distance.min(1)
    mutual = distance.argmin(0)[nearest.indices] == torch.arange(len(peaks))
    reach = (nearest.values <= config.centre_reach_px) & mutual
    offs = _window_offsets(config)
    pix = (peaks.pixels[reach].double()[:, None] + offs[None]).reshape(-1, 2)
    return pix, nearest.indices[reach].repeat_interleave(len(offs))


def estimate_camera(hyps: list[Hypothesis], evidence: list[torch.Tensor], feature_size: tuple[int, int],
                    templates: Templates, prior: CameraPrior, config: ParserConfig) -> Camera:
    """The camera-prior candidate (a grid over the jitter box) under which the accepted objects fit best: the sum
    over proposals of their best local score with their category (object sizes against depth pin the camera)."""
    base = prior.base
    candidates = prior.candidates(config.camera_steps) if config.camera_steps > 1 else [base]
    if len(candidates) == 1 or not hyps:
        return base
    pix, owner = _local_pixels(hyps, base, config)
    cats = torch.tensor([h.category for h in hyps])[owner]
    totals = []
    for cam in candidates:
        grid, ok = grid_at_pixels(cam, pix, templates, config.ground_extent + 1.0)
        own, cat = owner[ok], cats[ok]
        best = torch.full((len(hyps),), -1e9)
        for c in cat.unique().tolist():
            sel = cat == c
            sc = category_scores(evidence[c], c, feature_size, subset(grid, sel), templates).flatten(1).max(-1).values
            best = best.scatter_reduce(0, own[sel], sc, "amax")
        totals.append(float(best.sum()))
    return candidates[int(np.argmax(totals))]


def relocate(hyps: list[Hypothesis], evidence: list[torch.Tensor], feature_size: tuple[int, int],
             templates: Templates, camera: Camera, found_with: Camera, config: ParserConfig,
             coarse: torch.Tensor, coarse_grid: Grid, heatmap: torch.Tensor | None = None,
             peaks: CentrePeaks | None = None, hidden: torch.Tensor | None = None
             ) -> tuple[list[Hypothesis], list[tuple[torch.Tensor, torch.Tensor, torch.Tensor]]]:
    """Under ``camera``: each proposal's best local hypothesis (finer positions than the coarse grid) and its
    tables (category [5], pose [5, A], size [2]): log-sum-exps over positions within ``table_radius`` of it. A
    proposal with no local position in the search extent keeps its pose and takes its tables from the coarse
    search's scores ``coarse`` over ``coarse_grid`` (:func:`_tables`). With the centre head's ``heatmap`` and its
    ``peaks`` (``ParserConfig.centre_reach_px``, ``centre_weight``) the peaks' points are searched too and the log
    heatmap is a position prior. ``hidden`` [B, h, w]: cells each proposal's search may not use
    (:func:`cells_of_nearer`)."""
    if not hyps:
        return [], []
    pix, owner = _local_pixels(hyps, found_with, config)
    at_peak = torch.zeros(len(owner), dtype=torch.bool)
    if peaks is not None and config.centre_reach_px > 0:
        peak_pix, peak_owner = _peak_pixels(hyps, found_with, peaks, config)
        pix, owner = torch.cat([pix, peak_pix]), torch.cat([owner, peak_owner])
        at_peak = torch.cat([at_peak, torch.ones(len(peak_owner), dtype=torch.bool)])
    grid, ok = grid_at_pixels(camera, pix, templates, config.ground_extent + 1.0)
    owner, at_peak = owner[ok], at_peak[ok]
    visible = None
    if hidden is not None:  # the rendered cells, brought to the feature map's size (cells beyond it: not hidden)
        rows, cols = feature_size
        hidden = hidden[:, :rows, :cols]
        hidden = F.pad(hidden, (0, cols - hidden.shape[2], 0, rows - hidden.shape[1]))
        visible = (~hidden).flatten(1)[owner]
    scores = coarse_scores(evidence, feature_size, grid, templates, visible)
    choice = scores
    if at_peak.any():  # a proposal moves to a peak with its own category (a larger mesh there takes neighbours' cells)
        own_category = torch.tensor([h.category for h in hyps])[owner[at_peak]]
        other = torch.arange(scores.shape[1])[None] != own_category[:, None]
        choice = scores.clone()
        rows = choice[at_peak]
        rows[other] = -float("inf")
        choice[at_peak] = rows
    prior = (config.centre_weight * log_centre_prior(heatmap, grid.pixel)
             if heatmap is not None and config.centre_weight > 0 else torch.zeros(len(owner)))
    out, tables = [], []
    for i, h in enumerate(hyps):
        idx = torch.nonzero(owner == i).reshape(-1)
        if idx.numel() == 0:
            out.append(h)
            tables.append(_tables(coarse, coarse_grid, h, config))
            continue
        local = choice[idx]
        best_of = local.flatten(1).max(1)
        p = int((best_of.values + prior[idx].to(local.dtype)).argmax())
        c, s_, a = np.unravel_index(int(best_of.indices[p]), local.shape[1:])
        q = int(idx[p])
        x, y = (float(v) for v in grid.ground[q, :2])
        rotation = yaw_of(camera, x, y, float(config.azimuths[a]))
        new = Hypothesis(q, int(c), int(s_), int(a), x, y, rotation, float(grid.depth[q]), float(best_of.values[p]))
        near = idx[torch.linalg.norm(grid.ground[idx, :2] - grid.ground[q, :2], dim=-1) <= config.table_radius]
        out.append(new)
        tables.append(_tables_of(scores[near].double()))
    return out, tables


# --- refinement: gradient descent on the render-and-compare loss ---------------------------------------------------


def refine(hyps: list[Hypothesis], features: torch.Tensor, clutter: torch.Tensor, meshes: NeuralMeshes,
           camera: Camera, config: ParserConfig) -> list[Hypothesis]:
    """A few Adam steps on every proposal's (x, y, yaw) at once, maximising its render-and-compare score: the sum
    over the cells its mesh covers (minus the cells nearer proposals own) of ``kappa f . m`` (vertex features
    interpolated by the rasteriser) against the clutter model. The hard z-buffer gives gradients through the
    interpolation only (not the silhouette), so each proposal keeps its best-scoring iterate, never a worse one."""
    from po3d_ppl.perception.category_meshes import category_mesh
    from po3d_ppl.perception.rasterizer import pad_meshes, rasterize_camera

    if not hyps or config.refine_steps <= 0:
        return hyps
    canon = pad_meshes([(torch.tensor(np.array(category_mesh(CATEGORIES[h.category]).vertices)),
                         torch.tensor(np.array(category_mesh(CATEGORIES[h.category]).faces))) for h in hyps])
    verts0, faces = canon
    scale = torch.tensor([float(ontology.SIZE_SCALE[SIZES[h.size]]) for h in hyps], dtype=torch.float32)
    tex = torch.zeros(len(hyps), verts0.shape[1], meshes.dim)
    for i, h in enumerate(hyps):
        tex[i, : meshes.textures[CATEGORIES[h.category]].shape[0]] = meshes.textures[CATEGORIES[h.category]]
    occluded = _occluded_cells(hyps, camera, features.shape[1:])
    f = features.permute(1, 2, 0).float()
    bg = clutter.view(f.shape[0], f.shape[1])
    x = torch.tensor([h.x for h in hyps], requires_grad=True)
    y = torch.tensor([h.y for h in hyps], requires_grad=True)
    yaw = torch.tensor([h.rotation for h in hyps], requires_grad=True)
    opt = torch.optim.Adam([{"params": [x, y], "lr": config.refine_lr_xy},
                            {"params": [yaw], "lr": config.refine_lr_yaw}])
    best = torch.full((len(hyps),), -float("inf"))
    best_pose = torch.stack([x, y, yaw], -1).detach().clone()
    for _ in range(config.refine_steps + 1):
        v = _pose_batch(verts0.float(), x, y, yaw, scale)
        frags = rasterize_camera(v, faces, camera, stride=STRIDE, cull_backfaces=True)
        rendered = F.normalize(frags.interpolate_sparse(tex), dim=-1)
        b = frags.batch_index
        cell = frags.pixel - b * frags.height * frags.width
        keep = ~occluded.view(len(hyps), -1)[b, cell]
        score_px = config.kappa * (rendered * f.reshape(-1, f.shape[-1])[cell]).sum(-1) - bg.reshape(-1)[cell]
        per = torch.zeros(len(hyps)).index_add(0, b[keep], score_px[keep])
        with torch.no_grad():
            better = per > best
            best = torch.where(better, per, best)
            best_pose = torch.where(better[:, None], torch.stack([x, y, yaw], -1), best_pose)
        opt.zero_grad()
        (-per.sum()).backward()
        opt.step()
    out = []
    for i, h in enumerate(hyps):
        bx, by, byaw = (float(t) for t in best_pose[i])
        pos = torch.tensor([bx, by, 0.0], dtype=torch.float64)
        depth = float(project_points(camera, pos)[2])
        azimuth = float(_view_azimuth(camera, np.array([bx, by])) - byaw) % 360.0
        a = round(azimuth / (360.0 / config.azimuth_bins)) % config.azimuth_bins
        out.append(Hypothesis(h.position, h.category, h.size, a, bx, by, byaw % 360.0, depth, h.score))
    return out


def keep_apart(moved: list[Hypothesis], accepted: list[Hypothesis], config: ParserConfig) -> list[Hypothesis]:
    """Undo the moves (re-search, refinement) that made footprints intersect: best accepted first, a proposal whose
    moved footprint meets one already kept goes back to its accepted pose (where 3D-NMS left them apart); then,
    while two footprints still meet, the worse of those that moved goes back too."""
    order = sorted(range(len(moved)), key=lambda i: -accepted[i].score)
    kept: dict[int, Hypothesis] = {}
    for i in order:
        h = moved[i]
        if any(footprints_overlap(h, k, config.footprint_shrink) for k in kept.values()):
            h = accepted[i]
        kept[i] = h
    out = [kept[i] for i in range(len(moved))]
    # a better proposal that moved onto a worse one's accepted pose goes back too (accepted poses stand apart)
    while clash := next(((i, j) for i in range(len(out)) for j in range(i)
                         if out[i] != accepted[i] or out[j] != accepted[j]
                         if footprints_overlap(out[i], out[j], config.footprint_shrink)), None):
        back = [k for k in clash if out[k] != accepted[k]]
        k = min(back, key=lambda k: accepted[k].score)
        out[k] = accepted[k]
    return out


def _pose_batch(verts: torch.Tensor, x: torch.Tensor, y: torch.Tensor, yaw: torch.Tensor, scale: torch.Tensor
                ) -> torch.Tensor:
    """[B, V, 3] padded canonical vertices posed per item (differentiable in x, y, yaw)."""
    th = torch.deg2rad(yaw)[:, None]
    c, s = torch.cos(th), torch.sin(th)
    vx, vy, vz = verts[..., 0], verts[..., 1], verts[..., 2]
    k = scale[:, None]
    return torch.stack([k * (c * vx - s * vy) + x[:, None], k * (s * vx + c * vy) + y[:, None], k * vz], -1)


def _occluded_cells(hyps: list[Hypothesis], camera: Camera, size: tuple[int, int]) -> torch.Tensor:
    """[B, h, w]: cells where another proposal's mesh is nearer than this one's (fixed during refinement)."""
    from po3d_ppl.perception.rasterizer import rasterize_camera

    verts, faces, _ = _posed_meshes(hyps)
    frags = rasterize_camera(verts, faces, camera, stride=STRIDE, cull_backfaces=True)
    depth = frags.depth_map.detach()[:, : size[0], : size[1]]
    nearest = depth.min(0, keepdim=True).values
    return frags.mask[:, : size[0], : size[1]] & (depth > nearest)


def cells_of_nearer(hyps: list[Hypothesis], claimed: torch.Tensor) -> torch.Tensor:
    """[B, h, w]: for each proposal, the cells that the proposals nearer the camera than it claim (``claimed``
    [B, h, w], :func:`claimed_cells`): what hides it wherever a local search moves it."""
    depth = torch.tensor([h.depth for h in hyps])
    nearer = (depth[None, :] < depth[:, None]).float()  # [i, j]: j is nearer than i
    return torch.einsum("ij,jhw->ihw", nearer, claimed.float()) > 0


# --- the record ----------------------------------------------------------------------------------------------------


def _tables_of(near: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """(category [5], pose [5, A], size [2]) log-sum-exps of scores [p, 5, 2, A] over the other parameters."""
    if near.shape[0] == 0:
        raise InputError("scores", "no position to build the tables from")
    pose = torch.logsumexp(torch.logsumexp(near, 0), 1)  # [5, A]
    category = torch.logsumexp(pose, -1)
    size = torch.logsumexp(torch.logsumexp(torch.logsumexp(near, 0), -1), 0)
    return category, pose, size


def _tables(scores: torch.Tensor, grid: Grid, hyp: Hypothesis, config: ParserConfig
            ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Tables of a hypothesis from the coarse grid's scores: over grid positions within ``table_radius`` of it."""
    d = torch.linalg.norm(grid.ground[:, :2] - torch.tensor([hyp.x, hyp.y]), dim=-1)
    return _tables_of(scores[d <= config.table_radius].double())


def _ownership(hyps: list[Hypothesis], camera: Camera, config: ParserConfig, size: tuple[int, int],
               fg: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """([H, W] index of the proposal owning each pixel, -1: none; [N] pixels of each proposal's silhouette;
    [N, h, w] each mesh's coverage at ``mask_stride``).

    Each proposal is rendered alone at ``mask_stride`` (one batched call). A pixel goes to the nearest proposal
    that claims it (:func:`claimed_cells` on its cell scores ``fg``, stride 8, bilinear), as after the 3D-NMS: a
    category mesh overshoots its subtype, so it hides what lies behind it only where its evidence says it is there.
    Other covered pixels go to the nearest mesh (all of them without ``fg``: a plain z-buffer)."""
    from po3d_ppl.perception.rasterizer import rasterize_camera

    width, height = size
    if not hyps:
        return (torch.full((height, width), -1, dtype=torch.long), torch.zeros(0, dtype=torch.long),
                torch.zeros(0, 1, 1, dtype=torch.bool))
    verts, faces, _ = _posed_meshes(hyps)
    frags = rasterize_camera(verts, faces, camera, stride=config.mask_stride, cull_backfaces=True)
    depth = torch.where(frags.mask, frags.depth_map.detach(), torch.full_like(frags.depth_map, float("inf")))
    nearest_mesh, mesh_owner = depth.min(0)
    small = torch.where(torch.isfinite(nearest_mesh), mesh_owner, -1)
    if fg is not None:
        up = F.interpolate(fg[:, None].float(), scale_factor=STRIDE / config.mask_stride, mode="bilinear",
                           align_corners=False)[:, 0, : depth.shape[1], : depth.shape[2]]
        up = F.pad(up, (0, depth.shape[2] - up.shape[2], 0, depth.shape[1] - up.shape[1]), value=-float("inf"))
        claimed = claimed_cells(up, frags.mask, config)
        solid = torch.where(claimed, depth, torch.full_like(depth, float("inf")))
        nearest_solid, solid_owner = solid.min(0)
        small = torch.where(torch.isfinite(nearest_solid), solid_owner, small)
    full = small.repeat_interleave(config.mask_stride, 0).repeat_interleave(config.mask_stride, 1)
    return full[:height, :width], frags.mask.flatten(1).sum(-1) * config.mask_stride**2, frags.mask


def _evidence_cut(ownership: torch.Tensor, fg: torch.Tensor, threshold: float = 0.0) -> torch.Tensor:
    """Pixels of an owner where its cell scores (bilinearly upsampled) fall below clutter go to the background:
    the category mesh
    encloses all its subtypes, so its silhouette overshoots the object (measured: aeroplane boxes too large)."""
    h, w = ownership.shape
    up = F.interpolate(fg[:, None], scale_factor=STRIDE, mode="bilinear", align_corners=False)[:, 0]
    cells = (up > threshold)[:, :h, :w]
    own = ownership.clamp_min(0)
    keep = torch.gather(cells, 0, own[None])[0]
    return torch.where((ownership >= 0) & keep, ownership, -1)


def _foreground_cut(ownership: torch.Tensor, foreground: np.ndarray, grow_px: int) -> torch.Tensor:
    """Owners keep their foreground pixels; foreground pixels no mesh covers go to the nearest owner within
    ``grow_px`` (a posed category mesh misses the edges of its object when the pose is a little off)."""
    import cv2

    own = ownership.numpy()
    out = np.where(foreground, own, -1)
    if grow_px > 0 and (own >= 0).any():
        uncovered = foreground & (own < 0)
        dist, labels = cv2.distanceTransformWithLabels((own < 0).astype(np.uint8), cv2.DIST_L2, 5,
                                                       labelType=cv2.DIST_LABEL_PIXEL)
        # labels index the zero pixels (owned ones) in scan order; map each label to its owner
        owned_rows, owned_cols = np.nonzero(own >= 0)
        lut = np.full(labels.max() + 1, -1, dtype=np.int64)
        lut[labels[owned_rows, owned_cols]] = own[owned_rows, owned_cols]
        near = uncovered & (dist <= grow_px)
        out[near] = lut[labels[near]]
    return torch.from_numpy(out)


def xywh_boxes(masks: torch.Tensor) -> torch.Tensor:
    """[N, 4] float64 (x, y, w, h) pixel boxes of bool masks [N, H, W] (zeros when empty)."""
    from po3d_ppl.perception.attributes import mask_boxes

    corners = mask_boxes(masks)[0].double()  # (x0, y0, x1, y1), x1 and y1 exclusive
    return torch.cat([corners[:, :2], corners[:, 2:] - corners[:, :2]], -1)


def ownership_masks(ownership: torch.Tensor, n: int) -> torch.Tensor:
    """[n, H, W] bool: each proposal's pixels of an ownership map [H, W] (proposal index, -1 none)."""
    return ownership[None] == torch.arange(n, device=ownership.device)[:, None, None]


def merge_proposals(proposals: ObjectProposals, into: list[int]) -> ObjectProposals:
    """``proposals`` with each proposal ``i`` whose ``into[i] != i`` folded into proposal ``into[i]`` (which must
    keep itself: ``into[into[i]] == into[i]``): its pixels go to that one, and its rows leave every table. The kept
    proposals keep their order and tables; masks and boxes are redrawn from the merged ownership."""
    n = len(proposals)
    if len(into) != n or any(not 0 <= t < n or into[t] != t for t in into):
        raise InputError("into", f"must map each of the {n} proposals to one that keeps itself, got {into}")
    kept = [i for i in range(n) if into[i] == i]
    new_index = torch.full((n + 1,), -1, dtype=torch.int64)  # old index + 1 (0: background) -> new index
    new_index[1:] = torch.tensor([kept.index(into[i]) for i in range(n)], dtype=torch.int64)
    ownership = new_index.to(proposals.ownership.device)[proposals.ownership + 1]
    rows = torch.tensor(kept, dtype=torch.int64)
    redrawn = ("masks", "boxes", "ownership")  # per-pixel or derived from it: rebuilt below
    tables = {f.name: value.index_select(0, rows.to(value.device)) for f in fields(ObjectProposals)
              if f.name not in redrawn and isinstance(value := getattr(proposals, f.name), torch.Tensor)}
    masks = ownership_masks(ownership, len(kept))
    return replace(proposals, **tables, masks=masks, boxes=xywh_boxes(masks), ownership=ownership,
                   poses=[proposals.poses[i] for i in kept] if proposals.poses else [])


def parse_objects(image, model: FeatureModel | None = None, config: ParserConfig | None = None,
                  calibration: TableCalibration | None = None, background: BackgroundModel | None = None,
                  centres: CentreNet | None = None) -> ObjectProposals:
    """Detect, classify and pose every object of ``image`` (anything :func:`load_image` reads) by coarse
    render-and-compare search and depth-ordered 3D-NMS. Reads pixels only (the camera is the prior's base).
    ``calibration`` rescales the tables (default: the shipped fit; ``TableCalibration()`` gives raw scores);
    ``model``, ``background`` and ``centres`` default to the shipped ones (the background only if
    ``config.use_background``, the centre head only if ``config.centre_threshold`` is set).
    The search (:func:`search_objects`) and the record (:func:`record_objects`) are separate so that the scene
    parser can add proposals in between (:func:`add_region_proposals`)."""
    return record_objects(search_objects(image, model, config, calibration, background, centres))


@dataclass(eq=False)
class ObjectSearch:
    """The object parser's state between search and record: the image's features and coarse scores, the peaks'
    hypotheses (``pool``) with their cell maps, and the located proposals with their scores and tables. Kept so a
    later stage can add proposals without searching the image again (:func:`add_region_proposals`)."""

    image: ImageInput
    config: ParserConfig
    calibration: TableCalibration
    features: torch.Tensor
    clutter: torch.Tensor
    meshes: NeuralMeshes
    evidence: list[torch.Tensor]
    feature_size: tuple[int, int]
    templates: Templates
    grid: Grid
    scores: torch.Tensor
    #: the camera the peaks were found with (the prior's base) and the one the proposals are located under
    found_with: Camera
    camera: Camera
    pool: list[Hypothesis]
    #: the pool's :func:`cell_scores` (None when there is no peak)
    pool_maps: CellMaps | None
    located: list[Hypothesis]
    proposal_scores: list[float]
    tables: list
    foreground: np.ndarray | None
    chroma: torch.Tensor
    #: the centre head's heatmap [h, w] (None without the head)
    heatmap: torch.Tensor | None = None
    #: its peaks over ``centre_threshold`` (None without the head)
    centre_peaks: CentrePeaks | None = None
    timings: dict[str, float] = field(default_factory=dict)
    #: the [H, W] regions of unexplained foreground the last ``len(regions)`` of ``located`` were proposed for
    #: (:func:`add_region_proposals`); each claims its region's pixels for its mask (:func:`_claim_regions`)
    regions: tuple[np.ndarray, ...] = ()

    @property
    def from_regions(self) -> int:
        """How many of ``located`` (the last ones) came from unexplained foreground."""
        return len(self.regions)


def search_objects(image, model: FeatureModel | None = None, config: ParserConfig | None = None,
                   calibration: TableCalibration | None = None, background: BackgroundModel | None = None,
                   centres: CentreNet | None = None) -> ObjectSearch:
    """Stages 1-4 of :func:`parse_objects`: features, coarse search, 3D-NMS (with centre proposals), local
    re-search and refinement."""
    config = config or ParserConfig()
    model = model or _default_model()
    calibration = calibration if calibration is not None else _default_calibration()
    if not config.use_background:
        background = None
    elif background is None:
        background = _default_background()
    if config.centre_threshold is None:
        centres = None
    elif centres is None:
        centres = _default_centres()
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    img = load_image(image)
    prior = CameraPrior.for_image(img)
    camera = prior.base
    meshes = model.meshes.normalised().to("cpu")
    features = extract_features(model.extractor, img.pixels).cpu()
    t1 = time.perf_counter()
    timings["features"] = t1 - t0
    templates = _cached_templates((img.size[0], img.size[1], img.intrinsics), config)
    size_hw = (int(features.shape[1]), int(features.shape[2]))
    grid = position_grid(camera, size_hw, templates, config)
    evidence, clutter = cell_evidence(features, meshes, config.kappa)
    scores = coarse_scores(evidence, size_hw, grid, templates)
    peaks = find_peaks(scores, grid, config)
    t2 = time.perf_counter()
    timings["coarse"] = t2 - t1
    hyps = _best_hypotheses(scores, peaks, grid, camera, config)
    peak_maps = cell_scores(hyps, features, clutter, meshes, camera, config) if hyps else None
    accepted, new_scores = accept_proposals(hyps, features, clutter, meshes, camera, config, peak_maps)
    foreground = _foreground(img, background)
    chroma, colour_fg = _chroma(img), (torch.from_numpy(foreground) if foreground is not None else
                                       torch.ones(img.size[::-1], dtype=torch.bool))
    accepted, new_scores = add_occluded(accepted, new_scores, hyps, features, clutter, meshes, camera, config,
                                        chroma, colour_fg, peak_maps)
    if config.merge_penalty is not None and len(accepted) >= 2:
        # every proposal is still one of the peaks: their cell maps are rendered already
        accepted, new_scores = merge_fragments(accepted, new_scores, features, clutter, meshes, evidence, size_hw,
                                               templates, camera, config, chroma, colour_fg,
                                               rows_of(peak_maps, hyps, accepted))
    heatmap = centres.heatmap(features).detach().cpu() if centres is not None else None
    heat_peaks = centre_peaks(heatmap, config.centre_threshold) if heatmap is not None else None
    if heat_peaks is not None:
        accepted, new_scores, _ = add_centre_proposals(accepted, new_scores, heat_peaks, scores, grid, camera,
                                                       config, calibration)
    t3 = time.perf_counter()
    timings["nms"] = t3 - t2
    found = camera
    camera = estimate_camera(accepted, evidence, size_hw, templates, prior, config)
    hidden = None
    if config.relocate_unoccluded and len(accepted) > 1:
        fg, mask, _ = cell_scores(accepted, features, clutter, meshes, found, config)
        hidden = cells_of_nearer(accepted, claimed_cells(fg, mask, config))
    located, tables = relocate(accepted, evidence, size_hw, templates, camera, found, config, scores, grid, heatmap,
                               heat_peaks, hidden)
    t4 = time.perf_counter()
    timings["camera+relocate"] = t4 - t3
    located = keep_apart(refine(located, features, clutter, meshes, camera, config), accepted, config)
    timings["refine"] = time.perf_counter() - t4
    return ObjectSearch(img, config, calibration, features, clutter, meshes, evidence, size_hw, templates, grid,
                        scores, found, camera, hyps, peak_maps, located, new_scores, tables, foreground, chroma,
                        heatmap, heat_peaks, timings)


def record_objects(search: ObjectSearch) -> ObjectProposals:
    """Stage 5 of :func:`parse_objects`: ownership, masks, boxes and calibrated tables of the located proposals
    (dropping slivers of a neighbour)."""
    t0 = time.perf_counter()
    config, img, camera = search.config, search.image, search.camera
    located, new_scores, tables = search.located, search.proposal_scores, search.tables
    fg = cell_scores(located, search.features, search.clutter, search.meshes, camera, config)[0] if located else None
    regions = [None] * (len(located) - search.from_regions) + list(search.regions)  # per proposal, None: none
    ownership, silhouette = _final_ownership(located, camera, config, img.size, fg, search.foreground, search.chroma,
                                             regions)
    keep = _not_fragments(ownership, silhouette, config.min_visible_fraction)
    if len(keep) < len(located):
        located, new_scores, tables, regions = ([items[i] for i in keep]
                                                for items in (located, new_scores, tables, regions))
        fg = fg[keep] if keep else None
        ownership, _ = _final_ownership(located, camera, config, img.size, fg, search.foreground, search.chroma,
                                        regions)
    from_region = torch.tensor([region is not None for region in regions], dtype=torch.bool)
    record = _record(located, new_scores, tables, camera, config, ownership, search.calibration, from_region)
    record.timings = {**search.timings, "record": time.perf_counter() - t0}
    return record


# --- centre proposals: where the centre head sees an object stand ----------------------------------------------------


def add_centre_proposals(accepted: list[Hypothesis], scores_of: list[float], peaks: CentrePeaks,
                         scores: torch.Tensor, grid: Grid, camera: Camera, config: ParserConfig,
                         calibration: TableCalibration) -> tuple[list[Hypothesis], list[float], int]:
    """The accepted proposals with one more for each peak of the centre head (most probable first) over
    ``centre_threshold`` whose hypothesis meets no accepted footprint (shrunk by ``footprint_shrink``), and how
    many were added. The 3D-NMS loses objects behind others because their evidence is their occluder's too; the
    centre head reads where objects stand from the features instead (:mod:`~po3d_ppl.perception.centres`). A peak
    takes the coarse grid position whose base centre is nearest (within ``centre_snap_px``) and that position's best
    hypothesis; its existence log-odds is ``centre_existence`` applied to the peak's logit, written as the score the
    calibration maps to it (:func:`_score_for_existence`). Proposals added here are re-searched and refined with
    the others."""
    if config.centre_threshold is None or len(peaks) == 0:
        return accepted, scores_of, 0
    kept, kept_scores = list(accepted), list(scores_of)
    scale, bias = config.centre_existence
    for pixel, probability in zip(peaks.pixels, peaks.probabilities.tolist()):
        if probability <= config.centre_threshold:
            break
        distance = torch.linalg.norm(grid.pixel.double() - pixel.double(), dim=-1)
        position = int(distance.argmin())
        if float(distance[position]) > config.centre_snap_px:
            continue
        hyp = _best_hypotheses(scores, [position], grid, camera, config)[0]
        if any(footprints_overlap(hyp, other, config.footprint_shrink) for other in kept):
            continue
        p = min(max(probability, 1e-6), 1 - 1e-6)
        kept.append(hyp)
        kept_scores.append(_score_for_existence(scale * math.log(p / (1 - p)) + bias, config, calibration))
    return kept, kept_scores, len(kept) - len(accepted)


def _score_for_existence(logodds: float, config: ParserConfig, calibration: TableCalibration) -> float:
    """The proposal score that :func:`_record`'s existence calibration maps to ``logodds``."""
    return config.existence_threshold + (logodds - calibration.existence_bias) / calibration.existence_scale


# --- a second search: foreground the first reading leaves unexplained ----------------------------------------------


def unexplained_regions(foreground: np.ndarray, explained: np.ndarray | None, config: ParserConfig
                        ) -> list[np.ndarray]:
    """[H, W] bool masks of the foreground no proposal explains (``explained`` [H, W]: the proposal seen per pixel,
    -1 none; None: no proposal), closed with a ``region_close_px`` square, opened with a ``region_open_px`` one
    (thin slivers along outlines go) and split into connected regions of at least ``region_min_pixels`` of
    unexplained foreground, largest first.

    Opening alone erased see-through objects: a bicycle's spokes and frame are lines a pixel or two wide, so a
    missed bicycle could leave no region at all (seed 712, image 10), and an occluder cut a hidden object's pixels
    into pieces each under ``region_min_pixels`` or each fitted on its own. Closing first joins such lines and
    pieces into one region; the region keeps only its own pixels, not the ground the closing filled, since the
    attribute network names it and its proposal claims it. An isolated sliver is a single strip that closing
    leaves thin, so the opening still removes it. All 120 images of 712 (chosen on, 7 against 11 px): precision
    0.970 -> 0.971, recall 0.948 -> 0.952; 716: 0.972 -> 0.971, 0.965 -> 0.968."""
    import cv2

    loose = np.asarray(foreground if explained is None else foreground & (explained < 0), dtype=bool)

    def morphology(mask: np.ndarray, operation: int, px: int) -> np.ndarray:
        return cv2.morphologyEx(mask, operation, np.ones((px, px), np.uint8)) if px > 1 else mask

    joined = morphology(loose.astype(np.uint8), cv2.MORPH_CLOSE, config.region_close_px)
    count, labels, stats, _ = cv2.connectedComponentsWithStats(morphology(joined, cv2.MORPH_OPEN,
                                                                          config.region_open_px), connectivity=8)
    # a region keeps only its unexplained foreground, not the gaps the closing filled (without closing the opened
    # components lie inside it already)
    large = [c for c in range(1, count) if stats[c, cv2.CC_STAT_AREA] >= config.region_min_pixels]
    regions = [(labels == c) & loose for c in large]
    areas = [int(region.sum()) for region in regions]
    return [region for area, region in sorted(zip(areas, regions), key=lambda pair: -pair[0])
            if area >= config.region_min_pixels]


def _region_cells(region: np.ndarray, feature_size: tuple[int, int], share: float) -> torch.Tensor:
    """[h, w] the stride-8 cells at least ``share`` of whose pixels lie in ``region``."""
    pixels = torch.from_numpy(region.astype(np.float32))[None, None]
    fraction = F.avg_pool2d(pixels, STRIDE, ceil_mode=True)[0, 0]
    cells = torch.zeros(feature_size, dtype=torch.bool)
    h, w = min(feature_size[0], fraction.shape[0]), min(feature_size[1], fraction.shape[1])
    cells[:h, :w] = fraction[:h, :w] >= share
    return cells


@dataclass
class RegionFit:
    """The best hypothesis of a named region (:func:`_named_region_hypothesis`): the IoU of its visible cells with
    the region's, its score over the region's cells, its tables, and its cell maps (rendered once)."""

    hypothesis: Hypothesis
    iou: float
    score: float
    tables: tuple[torch.Tensor, torch.Tensor, torch.Tensor]
    maps: CellMaps


def _named_region_hypothesis(search: ObjectSearch, region: np.ndarray, cells: torch.Tensor, category: int,
                             standing: list[Hypothesis], standing_maps: CellMaps | None,
                             explained_cells: torch.Tensor) -> RegionFit | None:
    """The hypothesis of ``category`` whose visible silhouette best fits a region: base centres every
    ``local_step_px`` over the region's box and as far again below it, the ``region_candidates`` best
    footprint-free (size, azimuth, position) by coarse score rendered, each hidden on the ``explained_cells``
    where a ``standing`` proposal (``standing_maps``: their cell maps) is nearer, and ranked by the IoU of its
    visible cells with the region's ``cells``. The category meshes in front overshoot into the region, so without
    the explained-cells rule they would hide every candidate there."""
    config, camera = search.config, search.camera
    ys, xs = np.nonzero(region)
    step = config.local_step_px
    height = float(ys.max() - ys.min() + 1)
    u = torch.arange(float(xs.min()), float(xs.max()) + 1, step, dtype=torch.float64)
    v = torch.arange(float(ys.min()), float(ys.max()) + height + 1, step, dtype=torch.float64)
    pix = torch.stack(torch.meshgrid(u, v, indexing="xy"), -1).reshape(-1, 2)
    grid, _ = grid_at_pixels(camera, pix, search.templates, config.ground_extent + 1.0)
    if grid.ground.shape[0] == 0:
        return None
    scores = coarse_scores(search.evidence, search.feature_size, grid, search.templates)  # [P, 5, 2, A]
    own = scores[:, category]
    flat = own.flatten()
    candidates: list[Hypothesis] = []
    for idx in torch.argsort(flat, descending=True).tolist():
        if len(candidates) >= config.region_candidates or not math.isfinite(float(flat[idx])):
            break
        p, s_, az = np.unravel_index(idx, own.shape)
        hyp = _hypothesis_at(grid, int(p), category, s_, az, float(flat[idx]), camera, config)
        if not any(footprints_overlap(hyp, other, config.footprint_shrink) for other in standing):
            candidates.append(hyp)
    if not candidates:
        return None
    fg, mask, depth = cell_scores(candidates, search.features, search.clutter, search.meshes, camera, config)
    size = (int(fg.shape[1]), int(fg.shape[2]))
    region_cells = cells[: size[0], : size[1]]
    visible = mask
    if standing:
        _, standing_mask, standing_depth = standing_maps
        nearest = torch.where(standing_mask, standing_depth, torch.full_like(standing_depth, float("inf"))).min(0)
        hidden = explained_cells[: size[0], : size[1]][None] & (nearest.values[: size[0], : size[1]][None] < depth)
        visible = mask & ~hidden
    inter = (visible & region_cells).flatten(1).sum(-1).float()
    union = (visible | region_cells).flatten(1).sum(-1).float().clamp_min(1.0)
    iou = inter / union
    best = int(iou.argmax())
    hyp = candidates[best]
    score = float(torch.where(visible[best] & region_cells, fg[best], torch.zeros_like(fg[best])).sum())
    near = torch.linalg.norm(grid.ground[:, :2] - torch.tensor([hyp.x, hyp.y]), dim=-1) <= config.table_radius
    return RegionFit(hyp, float(iou[best]), score, _tables_of(scores[near].double()),
                     (fg[best:best + 1], mask[best:best + 1], depth[best:best + 1]))


def add_region_proposals(search: ObjectSearch, explained: np.ndarray | None, name_regions=None
                         ) -> ObjectSearch | None:
    """A second search confined to the foreground the first reading leaves unexplained; None if it adds nothing.

    The 3D-NMS misses objects mostly behind others (recall 0.34 at >= 20% occlusion on seed 720), yet most of them
    still show as background-model foreground that no aligned subtype silhouette covers (40 of 57 missed objects on
    seed 712; ``benchmarks/unexplained_regions.py``). For each such region (:func:`unexplained_regions`) the peaks
    whose mesh covers at least ``region_min_cover`` of the region's cells compete on their score over those cells;
    the best is proposed when that score exceeds ``region_min_score`` and its footprint (shrunk by
    ``footprint_shrink``) meets no located proposal's. Regions are taken largest first, and one whose cells a picked
    peak's mesh already covers (``region_min_cover``) is skipped: one object can leave two regions. The footprint
    test matters: a found object's own pixels outside its silhouette (a misalignment, a wrong subtype) raise regions
    as often as missed objects do, and a peak there lies on that object. Taking instead the best peak whose
    footprint meets none added 4 objects and 5 false proposals on the first 60 images of seed 712, against 3 and 1.
    When the best peak is blocked, ``name_regions`` (the scene parser's attribute network: region masks [K, H, W]
    in, category probabilities [K, 5] out) names the region and :func:`_named_region_hypothesis` searches that
    category afresh (``region_named_iou``): hidden objects show mostly as such regions, and their peaks are
    their occluders'. A proposal is then re-searched locally like the others (its tables; the move is undone if
    its footprint then meets another's) but not refined; its existence score is its region score. Each proposal
    claims its region's pixels for its mask (``ObjectSearch.regions``, :func:`_claim_regions`). ``explained``:
    the scene parser's most likely scene (``ParsedScene.object_ids``; None when it has no proposal)."""
    config = search.config
    if config.region_min_score is None or search.foreground is None or not search.pool:
        return None
    if explained is not None and explained.shape != search.foreground.shape:
        raise InputError("explained", f"must be the image's [H, W] {search.foreground.shape}, got {explained.shape}")
    pool_fg, pool_mask, _ = search.pool_maps
    size = (int(pool_mask.shape[1]), int(pool_mask.shape[2]))
    picked: list[Hypothesis] = []
    picked_tables: list[tuple | None] = []  # tables to fall back on (None: the coarse grid's)
    region_scores: list[float] = []
    standing_maps: CellMaps | None = None  # cell maps of search.located + picked, rendered when first needed
    explained_cells = _region_cells(explained >= 0, size, 0.5) if explained is not None else \
        torch.zeros(size, dtype=torch.bool)
    covered = torch.zeros(size, dtype=torch.bool)  # the cells the picked peaks' meshes cover
    regions: list[np.ndarray] = []  # each pick's region
    for region in unexplained_regions(search.foreground, explained, config):
        cells = _region_cells(region, size, config.region_cell_share)
        if not bool(cells.any()) or float((cells & covered).sum()) >= config.region_min_cover * float(cells.sum()):
            continue  # nothing to read, or a larger region's proposal explains it already
        inside = pool_mask & cells
        cover = inside.flatten(1).sum(-1).float() / float(cells.sum())
        score = torch.where(inside, pool_fg, torch.zeros_like(pool_fg)).flatten(1).sum(-1)
        score = torch.where(cover >= config.region_min_cover, score, torch.full_like(score, -float("inf")))
        best = int(score.argmax())
        hyp, hyp_score, hyp_mask = search.pool[best], float(score[best]), pool_mask[best]
        fallback, hyp_maps = None, None
        if hyp_score <= config.region_min_score or \
                any(footprints_overlap(hyp, other, config.footprint_shrink) for other in search.located + picked):
            if config.region_named_iou is None or name_regions is None:
                continue
            probabilities = name_regions(torch.from_numpy(region)[None])[0]
            category = int(probabilities.argmax())
            if float(probabilities[category]) < config.region_named_probability:
                continue
            standing = search.located + picked
            if standing_maps is None:
                standing_maps = cell_scores(standing, search.features, search.clutter, search.meshes, search.camera,
                                            config)
            fit = _named_region_hypothesis(search, region, cells, category, standing, standing_maps,
                                           explained_cells)
            if fit is None or fit.iou < config.region_named_iou or fit.score <= config.region_named_min_score:
                continue
            hyp, hyp_score, fallback, hyp_maps = fit.hypothesis, fit.score, fit.tables, fit.maps
            hyp_mask = hyp_maps[1][0][: size[0], : size[1]]
        if standing_maps is not None:  # the pick stands in front of later regions' candidates too
            hyp_maps = hyp_maps or cell_scores([hyp], search.features, search.clutter, search.meshes, search.camera,
                                               config)
            standing_maps = tuple(torch.cat([t, n]) for t, n in zip(standing_maps, hyp_maps))
        regions.append(region)
        picked.append(hyp)
        picked_tables.append(fallback)
        covered |= hyp_mask
        region_scores.append(hyp_score)
    if not picked:
        return None
    moved, tables = relocate(picked, search.evidence, search.feature_size, search.templates, search.camera,
                             search.found_with, config, search.scores, search.grid, search.heatmap,
                             search.centre_peaks)
    kept = list(search.located)
    for i, hyp in enumerate(moved):
        if any(footprints_overlap(hyp, other, config.footprint_shrink) for other in kept):  # undo the move
            moved[i] = picked[i]
            tables[i] = picked_tables[i] or _tables(search.scores, search.grid, picked[i], config)
        kept.append(moved[i])
    return replace(search, located=kept, proposal_scores=search.proposal_scores + region_scores,
                   tables=search.tables + tables, regions=search.regions + tuple(regions))


def _record(accepted: list[Hypothesis], new_scores: list[float], tables: list, camera: Camera,
            config: ParserConfig, ownership: torch.Tensor, calibration: TableCalibration,
            from_region: torch.Tensor) -> ObjectProposals:
    n, k = len(accepted), config.azimuth_bins
    cat = torch.stack([t[0] for t in tables]) if n else torch.zeros(0, len(CATEGORIES), dtype=torch.float64)
    pose = torch.stack([t[1] for t in tables]) if n else torch.zeros(0, len(CATEGORIES), k, dtype=torch.float64)
    # the pose table is conditional on the category (normalised over azimuths): the category evidence is the
    # category table alone, so a consumer that multiplies both (the scene model) does not count it twice
    pose = torch.log_softmax(pose / calibration.pose_temperature, -1)
    cat = cat / calibration.category_temperature
    existence = calibration.existence_scale * (torch.tensor(new_scores, dtype=torch.float64)
                                               - config.existence_threshold) + calibration.existence_bias
    size = torch.stack([t[2] for t in tables]) / calibration.size_temperature if n else \
        torch.zeros(0, 2, dtype=torch.float64)
    masks = ownership_masks(ownership, n)
    support = torch.tensor(config.azimuths, dtype=torch.float64).expand(n, k).clone()
    return ObjectProposals(
        existence_logodds=existence.reshape(n),
        category_loglik=cat, pose_support=support, pose_loglik=pose, size_loglik=size,
        positions=torch.tensor([[h.x, h.y, 0.0] for h in accepted], dtype=torch.float64).reshape(n, 3),
        depths=torch.tensor([h.depth for h in accepted], dtype=torch.float64),
        rotations=torch.tensor([h.rotation for h in accepted], dtype=torch.float64),
        boxes=xywh_boxes(masks), masks=masks, ownership=ownership, camera=camera, from_region=from_region,
        poses=list(accepted),
        notes=NOTES + ((RAW_NOTE,) if calibration == TableCalibration() else ()))


def _foreground(img: ImageInput, background: BackgroundModel | None) -> np.ndarray | None:
    """The background model's foreground of ``img`` (None without a model, or one of another image size)."""
    if background is None or tuple(img.size[::-1]) != background.ground.shape[:2]:
        return None
    return background.foreground(_rgb8(img))


def _rgb8(img: ImageInput) -> np.ndarray:
    """[H, W, 3] uint8 RGB of ``img`` (what the background model and OpenCV read)."""
    return (img.pixels.permute(1, 2, 0).numpy() * 255.0).round().astype(np.uint8)


def _chroma(img: ImageInput) -> torch.Tensor:
    """[H, W, 2] CIELAB a, b of ``img`` (OpenCV's 8-bit scale): an object's body colour, little changed by shading."""
    import cv2

    return torch.from_numpy(cv2.cvtColor(_rgb8(img), cv2.COLOR_RGB2LAB)[..., 1:].astype(np.float32))


def _final_ownership(accepted: list[Hypothesis], camera: Camera, config: ParserConfig, size: tuple[int, int],
                     fg: torch.Tensor | None, foreground: np.ndarray | None, chroma: torch.Tensor | None = None,
                     regions: list[np.ndarray | None] | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """The record's ownership map (the z-buffer cut to the foreground, or to the evidence) and each proposal's
    silhouette pixels (:func:`_ownership`). ``regions``: per proposal the [H, W] region it was proposed for (None:
    not a region proposal), whose pixels under its mesh it owns (:func:`_claim_regions`)."""
    ownership, silhouette, coverage = _ownership(accepted, camera, config, size, fg)
    if foreground is not None:
        ownership = _foreground_cut(ownership, foreground, config.grow_px)
        if chroma is not None and config.colour_margin is not None and len(accepted) >= 2:
            ownership = _recolour(ownership, coverage, chroma, config)
    elif fg is not None and config.mask_by_evidence:
        ownership = _evidence_cut(ownership, fg, config.mask_threshold)
    if regions and any(r is not None for r in regions):
        ownership = _claim_regions(ownership, coverage, regions, config)
    return ownership, silhouette


def _pixel_coverage(coverage: torch.Tensor, config: ParserConfig, size: tuple[int, int]) -> torch.Tensor:
    """[N, H, W] each mesh's coverage (rendered at ``mask_stride``) at full resolution ``size`` = (H, W)."""
    height, width = size
    covered = coverage.repeat_interleave(config.mask_stride, 1).repeat_interleave(config.mask_stride, 2)
    covered = F.pad(covered, (0, max(0, width - covered.shape[2]), 0, max(0, height - covered.shape[1])))
    return covered[:, :height, :width]


def _claim_regions(ownership: torch.Tensor, coverage: torch.Tensor, regions: list[np.ndarray | None],
                   config: ParserConfig) -> torch.Tensor:
    """Pixels of a region proposal's region that its mesh covers go to it. The region is foreground the first
    reading's aligned subtype silhouettes leave unexplained, so a nearer proposal owns it there only through its
    category mesh's overshoot, which its cell evidence often claims, since the features of the object behind look
    like a vehicle's too. Without this, most proposals named behind an occluder kept under
    ``min_visible_fraction`` of their silhouette and were dropped as slivers (seed 712: the first three of three)."""
    covered = _pixel_coverage(coverage, config, tuple(ownership.shape))
    owned = ownership.clone()
    for k, region in enumerate(regions):  # the regions are disjoint (connected components)
        if region is not None:
            owned[torch.from_numpy(region).to(owned.device) & covered[k]] = k
    return owned


def _recolour(ownership: torch.Tensor, coverage: torch.Tensor, chroma: torch.Tensor, config: ParserConfig
              ) -> torch.Tensor:
    """Foreground pixels two posed meshes cover go to the one whose body colour they show: a pixel moves from its
    owner to another proposal whose mesh covers it when its chroma is within ``colour_close`` of that proposal's
    median and nearer to it than to the owner's by ``colour_margin`` (the depth order of enclosing category meshes
    misplaces the boundary between touching objects; the world paints each object one colour)."""
    n = coverage.shape[0]
    covered = _pixel_coverage(coverage, config, tuple(ownership.shape))
    medians = torch.full((n, 2), float("nan"))
    for k in range(n):
        own = ownership == k
        if bool(own.any()):
            medians[k] = chroma[own].median(0).values
    owned = ownership >= 0
    distance = torch.linalg.norm(chroma[None] - medians[:, None, None, :], dim=-1)  # [N, H, W] (NaN: no median)
    candidate = torch.where(covered & torch.isfinite(distance), distance, torch.full_like(distance, float("inf")))
    best_distance, best = candidate.min(0)
    current = torch.gather(distance, 0, ownership.clamp_min(0)[None])[0]
    move = owned & (best != ownership) & (best_distance <= config.colour_close) & \
        (torch.nan_to_num(current, nan=float("inf")) - best_distance > config.colour_margin)
    return torch.where(move, best, ownership)


def _not_fragments(ownership: torch.Tensor, silhouette: torch.Tensor, min_fraction: float) -> list[int]:
    """Indices of the proposals owning at least ``min_fraction`` of their own silhouette's pixels; the others are
    slivers of a neighbour that the 3D-NMS let through."""
    owned = torch.bincount(ownership[ownership >= 0].reshape(-1), minlength=len(silhouette))
    return [i for i in range(len(silhouette)) if float(owned[i]) >= min_fraction * float(silhouette[i])]


@lru_cache(maxsize=1)
def _default_model() -> FeatureModel:
    return load_feature_model()


@lru_cache(maxsize=1)
def _default_calibration() -> TableCalibration:
    return load_calibration()


@lru_cache(maxsize=1)
def _default_centres() -> CentreNet:
    return load_centre_net()


@lru_cache(maxsize=1)
def _default_background() -> BackgroundModel | None:
    return load_background()

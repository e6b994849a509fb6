"""The object parser against ground truth (issue "Perception I", Done means): detection, category, azimuth,
position, depth order and category calibration, overall and for occluded objects.

Ground truth is read here only, for scoring; the parser sees the pixels.

- **Matching**: greedy by 2D IoU (proposal box vs the object's visible-mask bbox) >= ``min_iou``, one to one.
  Recall counts objects with >= ``min_pixels`` visible pixels; precision counts every proposal, except one matched
  to a smaller object (it found a real object, just a tiny one).
- **Azimuth** error is in the ``pose_degree`` frame (clockwise from the viewing ray), read from the pose table of
  the true category (the argmax of what the parser reports, not a separate guess).
- **Position** error is on the ground plane in the *camera's ground frame*: the position minus the camera's
  ground point (x, y of its location). The world jitters the camera by a translation only, on a uniform ground, so
  a camera moved in x-y gives exactly the image of every object moved the other way: absolute x-y is not
  identifiable from pixels by any method, while positions relative to the camera (hence CLEVR's six directions and
  depths) are. The parser reports positions for its estimated camera; the truth uses the image's true camera.
- **Depth order**: over pairs of matched objects in one image whose true view depths differ by >= 0.05, whether
  the proposals' depths order them the same way.
- **Failures**: :func:`detection_failures` sorts every missed object and false proposal by what went wrong
  (merged into a neighbour's proposal, a proposal of the wrong extent, nothing there), which says which stage to
  work on: the 3D-NMS and second search (merged, unseen) or the masks (wrong extent).
- **Calibration**: ECE (15 bins, :func:`~po3d_ppl.evaluation.calibration.binned_calibration_error`) of the top
  category's softmax probability on matched objects (the tables come calibrated: :func:`fit_calibration` fits the
  temperatures on a validation seed, ``po3d train calibration``).
"""

from __future__ import annotations

import json
import statistics
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import torch

from po3d_ppl import ontology
from po3d_ppl.errors import InputError
from po3d_ppl.evaluation.calibration import binned_calibration_error
from po3d_ppl.perception.calibration import fit_temperature, top_label_ece

CATEGORIES = tuple(ontology.CATEGORIES)
SIZES = tuple(ontology.SIZES)


def box_iou(a: Sequence[float], b: Sequence[float]) -> float:
    """IoU of two (x, y, w, h) boxes."""
    ax0, ay0, aw, ah = a
    bx0, by0, bw, bh = b
    ix = max(0.0, min(ax0 + aw, bx0 + bw) - max(ax0, bx0))
    iy = max(0.0, min(ay0 + ah, by0 + bh) - max(ay0, by0))
    inter = ix * iy
    union = aw * ah + bw * bh - inter
    return inter / union if union > 0 else 0.0


def match_boxes(pred: np.ndarray, truth: np.ndarray, min_iou: float = 0.5) -> list[tuple[int, int]]:
    """Greedy one-to-one (prediction, truth) pairs by IoU, best first, above ``min_iou``."""
    pairs = sorted(((box_iou(p, g), i, j) for i, p in enumerate(pred) for j, g in enumerate(truth)), reverse=True)
    used_p, used_g, out = set(), set(), []
    for value, i, j in pairs:
        if value < min_iou:
            break
        if i in used_p or j in used_g:
            continue
        used_p.add(i)
        used_g.add(j)
        out.append((i, j))
    return out


@dataclass
class ObjectOutcome:
    """One ground-truth object and what the parser made of it (``proposal`` -1: missed)."""

    image: str
    index: int
    category: str
    visible_pixels: int
    occlusion_ratio: float
    true_depth: float
    proposal: int = -1
    category_loglik: list[float] = field(default_factory=list)
    azimuth_error: float | None = None
    position_error: float | None = None
    depth: float | None = None
    #: The pose table of the true category and the index of its bin nearest the true azimuth (for calibration).
    pose_loglik: list[float] = field(default_factory=list)
    true_bin: int | None = None
    #: The size table (large, small) and the true size's index.
    size_loglik: list[float] = field(default_factory=list)
    true_size: int | None = None
    #: The object's visible-mask box (x, y, w, h), what proposals are matched against.
    box: list[float] = field(default_factory=list)


@dataclass
class ImageOutcome:
    image: str
    objects: list[ObjectOutcome]
    proposals: int
    #: Proposals matched to an object below the pixel floor (not false positives).
    matched_small: int
    existence_logodds: list[float]
    #: Per proposal: whether it matched any object.
    proposal_matched: list[bool]
    seconds: float
    timings: dict[str, float]
    #: Per proposal its box (x, y, w, h).
    proposal_boxes: list[list[float]] = field(default_factory=list)


def score_image(proposals, scene, image_name: str, seconds: float, min_pixels: int = 200, min_iou: float = 0.5
                ) -> ImageOutcome:
    """Match one image's :class:`~po3d_ppl.perception.object_parser.ObjectProposals` to its scene's objects."""
    from po3d_ppl.perception.image_input import project_points

    objs = scene.objects
    truth_boxes = np.array([o.annotation.bbox for o in objs], dtype=np.float64).reshape(-1, 4)
    pairs = {j: i for i, j in match_boxes(proposals.boxes.numpy(), truth_boxes, min_iou)}
    true_ground = scene.camera.location[:2]
    est_ground = proposals.camera.location[:2]
    outcomes = []
    for j, o in enumerate(objs):
        depth = float(project_points(scene.camera, np.asarray(o.position, dtype=np.float64))[2])
        out = ObjectOutcome(image_name, j, o.category, int(o.annotation.visible_pixels),
                            float(o.annotation.occlusion_ratio), depth, box=[float(v) for v in truth_boxes[j]])
        p = pairs.get(j)
        if p is not None:
            out.proposal = p
            out.category_loglik = [float(v) for v in proposals.category_loglik[p]]
            table = proposals.pose_loglik[p, CATEGORIES.index(o.category)]
            guess = float(proposals.pose_support[p, int(table.argmax())])
            out.pose_loglik = [float(v) for v in table]
            gaps = (proposals.pose_support[p] - o.pose_degree + 180.0) % 360.0 - 180.0
            out.true_bin = int(gaps.abs().argmin())
            out.azimuth_error = abs((guess - o.pose_degree + 180.0) % 360.0 - 180.0)
            rel_est = proposals.positions[p, :2].numpy() - est_ground
            rel_true = np.asarray(o.position[:2]) - true_ground
            out.position_error = float(np.linalg.norm(rel_est - rel_true))
            out.depth = float(proposals.depths[p])
            out.size_loglik = [float(v) for v in proposals.size_loglik[p]]
            out.true_size = SIZES.index(o.size)
        outcomes.append(out)
    matched_to = {p: j for j, p in pairs.items()}
    small = sum(1 for j in pairs if objs[j].annotation.visible_pixels < min_pixels)
    return ImageOutcome(image_name, outcomes, len(proposals), small,
                        [float(v) for v in proposals.existence_logodds],
                        [i in matched_to for i in range(len(proposals))], seconds, dict(proposals.timings),
                        [[float(v) for v in box] for box in proposals.boxes.tolist()])


def parse_dataset(data: Path, split: str | None, limit: int | None, parse: Callable, min_pixels: int = 200,
                  progress: Callable[[int, int], None] | None = None) -> list[ImageOutcome]:
    """Parse every image of ``split`` (``None`` or ``"all"``: every image) of a dataset directory and score it."""
    import time

    from po3d_ppl.perception.image_input import load_image
    from po3d_ppl.questions.dataset import load_dataset

    dataset = load_dataset(data)
    indices = dataset.split_indices(split or "all")
    indices = indices[:limit] if limit is not None else indices
    out = []
    for n, i in enumerate(indices):
        scene = dataset.scene(i)
        image = load_image(dataset.image_path(i))
        start = time.perf_counter()
        proposals = parse(image)
        out.append(score_image(proposals, scene, scene.image_filename, time.perf_counter() - start, min_pixels))
        if progress is not None:
            progress(n + 1, len(indices))
    return out


def save_outcomes(outcomes: Iterable[ImageOutcome], path: Path) -> None:
    Path(path).write_text("\n".join(json.dumps(asdict(o)) for o in outcomes) + "\n")


def load_outcomes(path: Path) -> list[ImageOutcome]:
    out = []
    for line in Path(path).read_text().splitlines():
        if line.strip():
            raw = json.loads(line)
            raw["objects"] = [ObjectOutcome(**o) for o in raw["objects"]]
            out.append(ImageOutcome(**raw))
    return out


def category_logits(outcomes: Sequence[ImageOutcome], min_pixels: int = 200) -> tuple[torch.Tensor, torch.Tensor]:
    """[M, 5] category log-likelihoods of matched objects (>= ``min_pixels``) and their true category index."""
    rows = [(o.category_loglik, CATEGORIES.index(o.category)) for img in outcomes for o in img.objects
            if o.proposal >= 0 and o.visible_pixels >= min_pixels]
    if not rows:
        return torch.zeros(0, len(CATEGORIES), dtype=torch.float64), torch.zeros(0, dtype=torch.long)
    return torch.tensor([r[0] for r in rows], dtype=torch.float64), torch.tensor([r[1] for r in rows])


def _subset_figures(objs: list[ObjectOutcome]) -> dict[str, float | int | None]:
    matched = [o for o in objs if o.proposal >= 0]
    cats = [CATEGORIES[int(np.argmax(o.category_loglik))] == o.category for o in matched]
    az = [o.azimuth_error <= 30.0 for o in matched]
    pos = [o.position_error for o in matched]
    return {"objects": len(objs), "recall": len(matched) / len(objs) if objs else None,
            "category_accuracy": float(np.mean(cats)) if cats else None,
            "azimuth_within_30": float(np.mean(az)) if az else None,
            "median_position_error": statistics.median(pos) if pos else None}


def summarise(outcomes: Sequence[ImageOutcome], min_pixels: int = 200, occluded_ratio: float = 0.2) -> dict:
    """Every Done-means figure of the object parser over ``outcomes``."""
    objs = [o for img in outcomes for o in img.objects if o.visible_pixels >= min_pixels]
    predictions = sum(img.proposals - img.matched_small for img in outcomes)
    true_positives = sum(1 for o in objs if o.proposal >= 0)
    pairs = correct = 0
    for img in outcomes:
        m = [o for o in img.objects if o.proposal >= 0]
        for a in range(len(m)):
            for b in range(a + 1, len(m)):
                if abs(m[a].true_depth - m[b].true_depth) < 0.05:
                    continue
                pairs += 1
                correct += (m[a].true_depth < m[b].true_depth) == (m[a].depth < m[b].depth)
    logits, target = category_logits(outcomes, min_pixels)
    probs = torch.softmax(logits, -1)
    conf, guess = probs.max(-1) if len(target) else (torch.zeros(0), torch.zeros(0))
    occluded = [o for o in objs if o.occlusion_ratio >= occluded_ratio]
    figures = {
        "images": len(outcomes), "objects": len(objs), "proposals": predictions,
        "precision": true_positives / predictions if predictions else None,
        **_subset_figures(objs),
        "depth_order_pairs": pairs, "depth_order_correct": correct / pairs if pairs else None,
        "category_ece": binned_calibration_error(conf.tolist(), (guess == target).tolist()) if len(target) else None,
        "seconds_per_image_median": statistics.median(img.seconds for img in outcomes) if outcomes else None,
        f"occluded_{int(occluded_ratio * 100)}pct": _subset_figures(occluded),
        "per_category": {c: _subset_figures([o for o in objs if o.category == c]) for c in CATEGORIES},
        "detection_failures": detection_failures(outcomes, min_pixels),
        "believed": believed_detection(outcomes, min_pixels),
        "stage_seconds_median": {k: statistics.median(img.timings[k] for img in outcomes)
                                 for k in (outcomes[0].timings if outcomes else {})},
    }
    return figures


def _has_boxes(img: ImageOutcome) -> bool:
    """Whether the outcome holds every proposal's and object's box (outcomes saved before they were kept do not)."""
    return len(img.proposal_boxes) == img.proposals and all(o.box for o in img.objects)


def believed_detection(outcomes: Sequence[ImageOutcome], min_pixels: int = 200, min_iou: float = 0.5) -> dict:
    """Detection counting only the proposals the evidence believes (existence log-odds > 0), matched afresh among
    themselves, and the existence table's calibration (its sigmoid against whether the proposal matches an
    object). The headline precision and recall count every proposal, whatever its existence: reasoning weighs a
    proposal by its existence, so one at log-odds -10 is all but absent from the answers. Outcomes saved before
    boxes were recorded are skipped."""
    true_positives = predictions = objects = 0
    confidences: list[float] = []
    matched: list[bool] = []
    for img in outcomes:
        if not _has_boxes(img):
            continue
        believed = [k for k, value in enumerate(img.existence_logodds) if value > 0]
        boxes = np.array([img.proposal_boxes[k] for k in believed], dtype=np.float64).reshape(-1, 4)
        truth = np.array([o.box for o in img.objects], dtype=np.float64).reshape(-1, 4)
        found = {j for _, j in match_boxes(boxes, truth, min_iou)}
        true_positives += sum(1 for j in found if img.objects[j].visible_pixels >= min_pixels)
        predictions += len(believed) - sum(1 for j in found if img.objects[j].visible_pixels < min_pixels)
        objects += sum(1 for o in img.objects if o.visible_pixels >= min_pixels)
        confidences += torch.sigmoid(torch.tensor(img.existence_logodds, dtype=torch.float64)).tolist()
        matched += list(img.proposal_matched)
    return {"proposals": predictions, "precision": true_positives / predictions if predictions else None,
            "recall": true_positives / objects if objects else None,
            "existence_ece": binned_calibration_error(confidences, matched) if confidences else None}


@dataclass(frozen=True)
class ImageFailures:
    """One image's detection failures by kind: missed object index -> kind, false proposal index -> kind."""

    missed: dict[int, str]
    false_proposals: dict[int, str]


MISSED_KINDS = ("merged", "misboxed", "unseen")
FALSE_KINDS = ("duplicate", "misboxed", "phantom")


def image_failures(img: ImageOutcome, min_pixels: int = 200, near_iou: float = 0.1) -> ImageFailures | None:
    """What went wrong with each missed object (>= ``min_pixels``) and each false proposal of one image, by the box
    that overlaps it most (IoU >= ``near_iou`` counts as overlapping):

    - a missed object is ``merged`` when that proposal was matched to another object (one proposal took two
      objects, or an occluder's mask took a hidden object's pixels), ``misboxed`` when that proposal is unmatched
      (it found the object with the wrong extent: a fragment, or a mask that spilled onto a neighbour), and
      ``unseen`` when no proposal overlaps it;
    - a false proposal (unmatched; one matched to a smaller object is not false, as in the precision) is a
      ``duplicate`` when the object it overlaps most was matched by another proposal, ``misboxed`` when that object
      went unmatched, and a ``phantom`` when it overlaps none.

    None for an outcome saved before boxes were recorded."""
    if not _has_boxes(img):
        return None

    def most_overlapping(box: Sequence[float], others: Sequence[Sequence[float]]) -> int:
        """Index of the box of ``others`` overlapping ``box`` most, -1 when none reaches ``near_iou``."""
        overlaps = [box_iou(box, other) for other in others]
        best = int(np.argmax(overlaps)) if overlaps else -1
        return best if best >= 0 and overlaps[best] >= near_iou else -1

    matched_proposals = {o.proposal for o in img.objects if o.proposal >= 0}
    missed = {}
    for j, o in enumerate(img.objects):
        if o.proposal < 0 and o.visible_pixels >= min_pixels:
            best = most_overlapping(o.box, img.proposal_boxes)
            missed[j] = "unseen" if best < 0 else "merged" if best in matched_proposals else "misboxed"
    object_boxes = [o.box for o in img.objects]
    false = {}
    for k, box in enumerate(img.proposal_boxes):
        if k not in matched_proposals:
            best = most_overlapping(box, object_boxes)
            false[k] = "phantom" if best < 0 else "duplicate" if img.objects[best].proposal >= 0 else "misboxed"
    return ImageFailures(missed, false)


def detection_failures(outcomes: Sequence[ImageOutcome], min_pixels: int = 200, near_iou: float = 0.1
                       ) -> dict[str, dict[str, int]]:
    """:func:`image_failures` counted by kind over ``outcomes`` (outcomes without boxes are skipped)."""
    missed = dict.fromkeys(MISSED_KINDS, 0)
    false = dict.fromkeys(FALSE_KINDS, 0)
    for img in outcomes:
        failures = image_failures(img, min_pixels, near_iou)
        if failures is None:
            continue
        for kind in failures.missed.values():
            missed[kind] += 1
        for kind in failures.false_proposals.values():
            false[kind] += 1
    return {"missed": missed, "false_proposals": false}


def require_both_outcomes(labels: torch.Tensor, what: str) -> None:
    """A calibration fit needs true and false labels: say so, naming ``what``, when one is missing."""
    if labels.numel() == 0 or labels.all() or not labels.any():
        raise InputError(what, "Platt scaling needs both outcomes (true and false) in the validation set")


def fit_platt(scores: torch.Tensor, labels: torch.Tensor, unit: float = 100.0, what: str = "existence",
              ) -> tuple[float, float]:
    """(a, b) of ``sigmoid(a * score + b)`` minimising the NLL of ``labels`` (LBFGS; a kept > 0). ``unit`` is the
    scores' typical size (raw render-and-compare scores: 100; log-odds: 1), so the optimiser starts near a = 1 /
    unit."""
    require_both_outcomes(labels, what)
    x, y = scores.double(), labels.double()
    log_a = torch.zeros((), dtype=torch.float64, requires_grad=True)
    b = torch.zeros((), dtype=torch.float64, requires_grad=True)
    opt = torch.optim.LBFGS([log_a, b], lr=0.5, max_iter=200, line_search_fn="strong_wolfe")

    def closure():
        opt.zero_grad()
        loss = torch.nn.functional.binary_cross_entropy_with_logits(torch.exp(log_a) * x / unit + b, y)
        loss.backward()
        return loss

    opt.step(closure)
    return float(torch.exp(log_a.detach())) / unit, float(b.detach())


def fit_calibration(outcomes: Sequence[ImageOutcome], min_pixels: int = 200):
    """The :class:`~po3d_ppl.perception.calibration.TableCalibration` of outcomes parsed with raw scores, and the
    validation figures before and after it."""
    from po3d_ppl.perception.calibration import TableCalibration

    logits, target = category_logits(outcomes, min_pixels)
    t_category = fit_temperature(logits, target)
    rows = [(o.pose_loglik, o.true_bin) for img in outcomes for o in img.objects
            if o.proposal >= 0 and o.visible_pixels >= min_pixels and o.pose_loglik]
    pose_logits = torch.tensor([r[0] for r in rows], dtype=torch.float64)
    t_pose = fit_temperature(pose_logits, torch.tensor([r[1] for r in rows]))
    size_rows = [(o.size_loglik, o.true_size) for img in outcomes for o in img.objects
                 if o.proposal >= 0 and o.visible_pixels >= min_pixels and o.size_loglik]
    size_logits = torch.tensor([r[0] for r in size_rows], dtype=torch.float64).reshape(-1, len(SIZES))
    size_target = torch.tensor([r[1] for r in size_rows], dtype=torch.long)
    t_size = fit_temperature(size_logits, size_target, high=1e4)
    scores = torch.tensor([s for img in outcomes for s in img.existence_logodds], dtype=torch.float64)
    labels = torch.tensor([m for img in outcomes for m in img.proposal_matched])
    a, b = fit_platt(scores, labels)
    calibration = TableCalibration(t_category, t_pose, a, b, t_size)

    def figures(tc: float, tp: float, ea: float, eb: float, ts: float) -> dict[str, float]:
        size = torch.log_softmax(size_logits / ts, -1)
        cat = torch.softmax(logits / tc, -1)
        pose = torch.softmax(pose_logits / tp, -1)
        exist = torch.sigmoid(ea * scores + eb)
        pose_conf, pose_guess = pose.max(-1)
        cat_conf, cat_guess = cat.max(-1)
        return {
            "category_nll": float(torch.nn.functional.nll_loss(torch.log(cat), target)),
            "category_ece": binned_calibration_error(cat_conf.tolist(), (cat_guess == target).tolist()),
            "pose_nll": float(torch.nn.functional.nll_loss(torch.log(pose.clamp_min(1e-300)),
                                                           torch.tensor([r[1] for r in rows]))),
            "pose_ece": binned_calibration_error(pose_conf.tolist(),
                                                 (pose_guess == torch.tensor([r[1] for r in rows])).tolist()),
            "existence_ece": binned_calibration_error(exist.tolist(), labels.tolist()),
            "size_nll": float(torch.nn.functional.nll_loss(size, size_target)) if len(size_target) else None,
            "size_ece": top_label_ece(size, size_target),
        }

    report = {"objects": len(target), "proposals": len(labels),
              "size_accuracy": float((size_logits.argmax(-1) == size_target).double().mean()) if len(size_target)
              else None,
              "raw": figures(1.0, 1.0, 1.0, 0.0, 1.0), "fitted": figures(t_category, t_pose, a, b, t_size)}
    return calibration, report


@dataclass(frozen=True, eq=False)
class EvidenceAsProposals:
    """A :class:`~po3d_ppl.evidence.SceneEvidence` with the fields :func:`score_image` reads, so the object figures
    can be computed from the scene parser's evidence (its estimated camera and positions, the subtype table's
    category marginal) without parsing again: ``EvidenceAsProposals.of(evidence)``."""

    boxes: torch.Tensor
    category_loglik: torch.Tensor
    pose_loglik: torch.Tensor
    pose_support: torch.Tensor
    positions: torch.Tensor
    depths: torch.Tensor
    existence_logodds: torch.Tensor
    size_loglik: torch.Tensor
    camera: object
    timings: dict = field(default_factory=dict)

    @classmethod
    def of(cls, evidence, timings: dict | None = None) -> EvidenceAsProposals:
        from po3d_ppl.perception.scene_parser import category_marginal

        return cls(evidence.boxes, category_marginal(evidence.subtype_loglik), evidence.pose_loglik,
                   evidence.pose_support, evidence.positions, evidence.depths, evidence.exist_logodds,
                   evidence.size_loglik, evidence.camera, dict(timings or {}))

    def __len__(self) -> int:
        return int(self.existence_logodds.shape[0])

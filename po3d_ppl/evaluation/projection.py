"""Fitting and measuring the projected tables' calibration (:mod:`po3d_ppl.perception.projection_calibration`)
against ground truth, which is read here only.

Entries are those :mod:`po3d_ppl.evaluation.evidence_scores` scores: proposals matched to objects (box IoU >= 0.5),
the true subtype's part slots, ordered pairs of matched objects. Each table gets ``sigmoid(a * logodds + b)``,
shifted at the projection's floor and ceiling (:func:`fit_edge_platt`; the module docstring of
:mod:`~po3d_ppl.perception.projection_calibration` says why), and its ECE (15 bins, the event's probability against
its frequency) before and after. The part-look table gets one scale on its log-likelihoods
(:func:`fit_style_scale`), over the visible parts of the true subtype's slots, and each object table one scale
(:func:`fit_object_scale`), over the matched proposals' rows.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np
import torch

from po3d_ppl import ontology
from po3d_ppl.evidence import NUM_STYLES
from po3d_ppl.evaluation.calibration import binned_calibration_error
from po3d_ppl.evaluation.objects import fit_platt, match_boxes, require_both_outcomes
from po3d_ppl.perception.projection_calibration import (
    OBJECT_TABLES,
    STYLE_TABLE,
    TABLES,
    ProjectionCalibration,
    edge_states,
)


def matched_proposals(evidence, scene, min_iou: float = 0.5):
    """(proposal, object, subtype index) of every proposal matched to an object (box IoU >= ``min_iou``), and the
    proposal of each matched object."""
    if evidence.boxes is None:
        raise ValueError("the evidence carries no boxes to match objects by")
    objs = scene.objects
    boxes = np.array([o.annotation.bbox for o in objs], dtype=np.float64).reshape(-1, 4)
    pairs = match_boxes(evidence.boxes.numpy(), boxes, min_iou)
    proposal_of = {j: i for i, j in pairs}
    return [(i, objs[j], j, ontology.SUBTYPES.index(objs[j].subtype)) for i, j in pairs], proposal_of


def table_entries(evidence, scene, min_iou: float = 0.5) -> dict[str, tuple[list[float], list[bool]]]:
    """Per table: the log-odds of the matched entries and whether each event is true in the scene."""
    from po3d_ppl.perception.simulated import part_visible

    out: dict[str, tuple[list[float], list[bool]]] = {name: ([], []) for name in TABLES}

    def add(name: str, value, truth: bool) -> None:
        out[name][0].append(float(value))
        out[name][1].append(bool(truth))

    matched, proposal_of = matched_proposals(evidence, scene, min_iou)
    for i, o, j, s in matched:
        add("occluded_logodds", evidence.occluded_logodds[i], o.occluded)
        others = [(k, proposal_of[k]) for k in proposal_of if k != j]
        for k, other in others:
            add("occludes_logodds", evidence.occludes_logodds[i, other], k in o.occluded_by)
        for p, raw in enumerate(ontology.PARTS[o.subtype]):
            add("part_visible_logodds", evidence.part_visible_logodds[i, s, p], part_visible(o, raw))
            add("part_occluded_logodds", evidence.part_occluded_logodds[i, s, p], o.part_occluded(raw))
            by = o.part_occluded_by(raw)
            for k, other in others:
                add("part_occludes_logodds", evidence.part_occludes_logodds[i, s, p, other], k in by)
    return out


def style_entries(evidence, scene, min_iou: float = 0.5) -> tuple[list[list[float]], list[int]]:
    """The part-look log-likelihoods [17] of every visible part of the matched objects (their true subtype's slot)
    and the index of its true look (0 plain)."""
    from po3d_ppl.evidence import style_index
    from po3d_ppl.perception.simulated import part_visible

    tables, truths = [], []
    for i, o, _, s in matched_proposals(evidence, scene, min_iou)[0]:
        for p, raw in enumerate(ontology.PARTS[o.subtype]):
            if part_visible(o, raw):
                style = o.parts.get(raw)
                tables.append(evidence.part_style_loglik[i, s, p].double().tolist())
                truths.append(0 if style is None else style_index(style.color, style.material))
    return tables, truths


def object_entries(evidence, scene, min_iou: float = 0.5) -> dict[str, tuple[list[list[float]], list[int]]]:
    """Per object table (``OBJECT_TABLES``): the matched proposals' rows and the index of the object's true value."""
    from po3d_ppl.perception.attributes import OBJECT_HEADS

    out: dict[str, tuple[list[list[float]], list[int]]] = {name: ([], []) for name in OBJECT_TABLES}
    for i, o, _, _ in matched_proposals(evidence, scene, min_iou)[0]:
        for name, attribute in OBJECT_TABLES.items():
            out[name][0].append(getattr(evidence, name)[i].double().tolist())
            out[name][1].append(OBJECT_HEADS[attribute].index(getattr(o, attribute)))
    return out


def collect(pairs: Iterable[tuple[object, object]]) -> dict[str, tuple[torch.Tensor, torch.Tensor]]:
    """Every binary table's (log-odds, truth) over ``(evidence, scene)`` pairs; under ``STYLE_TABLE`` the part
    looks' (log-likelihoods ``[M, 17]``, true look ``[M]``) and under each of ``OBJECT_TABLES`` the matched
    proposals' (log-likelihoods ``[M, K]``, true value ``[M]``)."""
    values: dict[str, tuple[list[float], list[bool]]] = {name: ([], []) for name in TABLES}
    categorical: dict[str, tuple[list[list[float]], list[int]]] = {name: ([], []) for name in (STYLE_TABLE,
                                                                                                *OBJECT_TABLES)}
    for evidence, scene in pairs:
        for name, (x, y) in table_entries(evidence, scene).items():
            values[name][0].extend(x)
            values[name][1].extend(y)
        for name, (tables, truths) in {STYLE_TABLE: style_entries(evidence, scene),
                                       **object_entries(evidence, scene)}.items():
            categorical[name][0].extend(tables)
            categorical[name][1].extend(truths)
    out = as_tensors(values)
    for name, (tables, truths) in categorical.items():
        if truths:
            out[name] = (torch.tensor(tables, dtype=torch.float64), torch.tensor(truths, dtype=torch.long))
    return out


def as_tensors(values: dict[str, tuple[list[float], list[bool]]]) -> dict[str, tuple[torch.Tensor, torch.Tensor]]:
    """Entries gathered as lists (``collect``, ``EvidenceCounts.entries``) as (float64, bool) tensors."""
    return {name: (torch.tensor(x, dtype=torch.float64), torch.tensor(y, dtype=torch.bool))
            for name, (x, y) in values.items()}


def table_figures(logodds: torch.Tensor, truth: torch.Tensor) -> dict[str, float | int]:
    """ECE, NLL and accuracy (at 0.5) of one table's entries."""
    p = torch.sigmoid(logodds)
    nll = torch.nn.functional.binary_cross_entropy(p.clamp(1e-6, 1 - 1e-6), truth.double())
    return {"entries": int(truth.numel()), "positive_rate": round(float(truth.double().mean()), 4),
            "ece": round(binned_calibration_error(p.tolist(), truth.tolist()), 4), "nll": round(float(nll), 4),
            "accuracy": round(float(((p > 0.5) == truth).double().mean()), 4)}


def style_log_prior(recoloured: float, styles: int = NUM_STYLES) -> torch.Tensor:
    """The scene model's prior over a visible part's looks: plain ``1 - recoloured``, each recoloured look
    ``recoloured / (styles - 1)``."""
    prior = torch.full((styles,), math.log(recoloured / (styles - 1)), dtype=torch.float64)
    prior[0] = math.log(1.0 - recoloured)
    return prior


def style_log_posterior(tables: torch.Tensor, recoloured: float, scale: float = 1.0) -> torch.Tensor:
    """``log P(look | table)`` ``[M, 17]`` for part-look log-likelihoods times ``scale`` under
    :func:`style_log_prior`."""
    return torch.log_softmax(tables.double() * scale + style_log_prior(recoloured, tables.shape[-1]), dim=-1)


def style_figures(tables: torch.Tensor, truth: torch.Tensor, recoloured: float, scale: float = 1.0) -> dict:
    """NLL of the true look and accuracy of the posterior's arg-max (all parts, plain ones, recoloured ones)."""
    log_post = style_log_posterior(tables, recoloured, scale)
    hit = log_post.argmax(-1) == truth
    plain = truth == 0
    return {"parts": int(truth.numel()), "recoloured_rate": round(float((~plain).double().mean()), 4),
            "nll": round(float(-log_post.gather(1, truth[:, None]).mean()), 4),
            "accuracy": round(float(hit.double().mean()), 4),
            "accuracy_plain": round(float(hit[plain].double().mean()), 4) if plain.any() else None,
            "accuracy_recoloured": round(float(hit[~plain].double().mean()), 4) if (~plain).any() else None}


def object_figures(tables: torch.Tensor, truth: torch.Tensor, scale: float = 1.0) -> dict:
    """ECE of the top value (15 bins), NLL of the true value and accuracy of an object table's rows times
    ``scale`` under the scene model's uniform prior (None each when there are no rows)."""
    from po3d_ppl.perception.calibration import top_label_ece

    if truth.numel() == 0:
        return {"rows": 0, "ece": None, "nll": None, "accuracy": None}
    log_post = torch.log_softmax(tables.double() * scale, dim=-1)
    return {"rows": int(truth.numel()), "ece": round(top_label_ece(log_post, truth), 4),
            "nll": round(float(-log_post.gather(1, truth[:, None]).mean()), 4),
            "accuracy": round(float((log_post.argmax(-1) == truth).double().mean()), 4)}


def fit_object_scale(tables: torch.Tensor, truth: torch.Tensor, low: float = 0.05, high: float = 4.0) -> float:
    """The scale in [low, high] minimising the NLL of the true values of an object table's rows: one over the
    temperature :func:`~po3d_ppl.perception.calibration.fit_temperature` finds (the priors are uniform)."""
    from po3d_ppl.perception.calibration import fit_temperature

    return 1.0 / fit_temperature(tables, truth, low=1.0 / high, high=1.0 / low)


def fit_style_scale(tables: torch.Tensor, truth: torch.Tensor, low: float = 0.25, high: float = 8.0) -> float:
    """The scale in [low, high] minimising the NLL of the true looks under the parts' own rate of recoloured parts
    (the prior the scene model will multiply in): one over the temperature that
    :func:`~po3d_ppl.perception.calibration.fit_temperature` finds with that prior as its offset."""
    from po3d_ppl.perception.calibration import fit_temperature

    prior = style_log_prior(float((truth > 0).double().mean()), tables.shape[-1])
    return 1.0 / fit_temperature(tables, truth, low=1.0 / high, high=1.0 / low, offset=prior)


#: Spread (nats) of the zero-mean normal prior on each edge shift: it keeps a shift finite when every entry at an
#: edge has one outcome (seed 712's floor of "object i occludes j": no event in 1,329 entries), where the
#: likelihood alone would push it to infinity.
EDGE_SHIFT_PRIOR = 5.0


def fit_edge_platt(x: torch.Tensor, y: torch.Tensor, edge: float | None) -> tuple[float, float, float, float]:
    """``(a, b, floor_shift, ceiling_shift)`` of ``sigmoid(a x + b + floor_shift [x <= -edge] + ceiling_shift
    [x >= edge])`` at the maximum of the likelihood of ``y`` times a normal prior on the shifts
    (:data:`EDGE_SHIFT_PRIOR`); ``a > 0``, ``floor_shift <= 0 <= ceiling_shift`` (monotone). ``edge`` None: plain
    Platt scaling (:func:`~po3d_ppl.evaluation.objects.fit_platt`). Both outcomes must occur."""
    if edge is None:
        return (*fit_platt(x, y, unit=1.0, what="projection calibration"), 0.0, 0.0)
    require_both_outcomes(y, "projection calibration")
    # start at a = 1, b = 0, shifts -+0.69 rather than at the plain fit: both reach the optimum, but LBFGS stops at
    # slightly different points along flat directions (seed 712's occluder ceiling shift: 0.011 against 0.035), and
    # this start reproduces the shipped file byte for byte
    x, y = x.double(), y.double()
    at_floor, at_ceiling = edge_states(x, edge)
    log_a, bias, floor_raw, ceiling_raw = (torch.tensor(v, dtype=torch.float64, requires_grad=True)
                                           for v in (0.0, 0.0, 0.0, 0.0))
    opt = torch.optim.LBFGS([log_a, bias, floor_raw, ceiling_raw], lr=0.5, max_iter=500, tolerance_grad=1e-10,
                            tolerance_change=1e-14, line_search_fn="strong_wolfe")

    def shifts() -> tuple[torch.Tensor, torch.Tensor]:
        return -torch.nn.functional.softplus(floor_raw), torch.nn.functional.softplus(ceiling_raw)

    def closure():
        opt.zero_grad()
        low, high = shifts()
        logits = torch.exp(log_a) * x + bias + low * at_floor + high * at_ceiling
        nll = torch.nn.functional.binary_cross_entropy_with_logits(logits, y, reduction="sum")
        loss = (nll + (low ** 2 + high ** 2) / (2 * EDGE_SHIFT_PRIOR ** 2)) / x.numel()
        loss.backward()
        return loss

    opt.step(closure)
    with torch.no_grad():
        low, high = shifts()
        return float(torch.exp(log_a)), float(bias), float(low), float(high)


def fit_projection_calibration(entries: dict[str, tuple[torch.Tensor, torch.Tensor]], edge: float | None = None
                               ) -> tuple[ProjectionCalibration, dict]:
    """The Platt scaling (with edge states at ``edge``, the projection floor's log-odds; None: plain) of every
    binary table with both outcomes present, the part-look scale (when ``STYLE_TABLE`` entries hold recoloured and
    plain parts), the scale of each object table with entries, and each table's figures before and after."""
    platt, base_rate, report = {}, {}, {}
    entries = dict(entries)
    object_scales = {}
    for name in OBJECT_TABLES:
        rows = entries.pop(name, None)
        if rows is not None and rows[1].numel():
            object_scales[name] = fit_object_scale(*rows)
            report[name] = {"before": object_figures(*rows), "scale": round(object_scales[name], 4),
                            "after": object_figures(*rows, object_scales[name])}
    style_scale = None
    looks = entries.pop(STYLE_TABLE, None)
    if looks is not None and 0 < int((looks[1] > 0).sum()) < looks[1].numel():
        tables, truth = looks
        recoloured = float((truth > 0).double().mean())
        style_scale = fit_style_scale(tables, truth)
        report[STYLE_TABLE] = {"before": style_figures(tables, truth, recoloured), "scale": round(style_scale, 4),
                               "after": style_figures(tables, truth, recoloured, style_scale)}
    for name, (x, y) in entries.items():
        if y.numel() == 0 or y.all() or not y.any():
            report[name] = {"before": table_figures(x, y) if y.numel() else {"entries": 0}, "fitted": None}
            continue
        platt[name] = fit_edge_platt(x, y, edge)
        base_rate[name] = float(y.double().mean())
    calibration = ProjectionCalibration(platt, base_rate, style_scale, edge, object_scales)
    for name, values in platt.items():
        x, y = entries[name]
        report[name] = {"before": table_figures(x, y),
                        **dict(zip(("scale", "bias", "floor_shift", "ceiling_shift"), (round(v, 4) for v in values))),
                        "after": table_figures(calibration.posterior_logodds(name, x.double()), y)}
    return calibration, report


def measure(calibration: ProjectionCalibration | None, entries: dict[str, tuple[torch.Tensor, torch.Tensor]]
            ) -> dict[str, dict]:
    """Each table's figures as they are and (with ``calibration``) after it, on entries of another split."""
    out = {}
    for name, (x, y) in entries.items():
        if y.numel() == 0 or name not in TABLES:
            continue
        row = {"raw": table_figures(x, y)}
        if calibration is not None and name in calibration.platt:
            # the posterior at the fitted base rate
            row["calibrated"] = table_figures(calibration.posterior_logodds(name, x), y)
        out[name] = row
    return out

"""Perception's evidence against ground truth (issue "Perception II", Done means): attributes, parts, occlusion.

Ground truth is read here only. Proposals are matched to objects by box IoU >= 0.5 (as in
:mod:`po3d_ppl.evaluation.objects`); every figure below is over matched objects, read at the argmax (or at
log-odds 0) of each table's posterior on its own: the table (a likelihood) plus the scene model's prior
(``priors``; the shipped, world-fitted ones in ``po3d eval evidence``):

- object subtype, colour, material and size accuracy;
- part attribute accuracy over the visible parts of the true subtype (the world's rule: recoloured, or >= 20
  visible pixels): plain vs recoloured, and when recoloured its colour and material, all three right; read at the
  scene model's part-state posterior given that the part is visible (with the recolouring rule when the priors
  hold it: :mod:`po3d_ppl.reasoning.part_counts`);
- object occlusion relations: F1 of "object i is occluded by object j" over ordered pairs of matched objects;
- part occlusion: F1 of "part p of object i is occluded" over the parts of the true subtype.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

import torch

from po3d_ppl import ontology
from po3d_ppl.evidence import ScenePriors
from po3d_ppl.perception.projection_calibration import OBJECT_TABLES, TABLE_PRIOR


def table_prior_logodds(priors: ScenePriors, table: str) -> float:
    """logit of the scene model's prior of a projected table's latent."""
    p = getattr(priors, TABLE_PRIOR[table])
    return math.log(p / (1.0 - p))


def part_state_log_posterior(evidence, priors: ScenePriors) -> torch.Tensor:
    """``[N, 21, P, 18]`` log posterior of each part's state (hidden, plain, 16 looks) in the scene model: its
    part-state factor (with the recolouring rule when ``priors`` hold it) times its prior."""
    from po3d_ppl.reasoning.part_counts import part_state_loglik

    joint = part_state_loglik(evidence, priors) + torch.log(priors.part_state_probs()).to(evidence.part_style_loglik)
    return torch.log_softmax(joint, -1)


@dataclass
class EvidenceCounts:
    """Counts summed over images (:meth:`figures` turns them into accuracies and F1s), and every projected
    table's (log-odds, truth) entries (:func:`po3d_ppl.evaluation.projection.table_entries`), which the occlusion
    F1s and the part visibility recall are read from (at log-odds 0) and the tables' calibration is measured on."""

    counts: Counter = field(default_factory=Counter)
    entries: dict[str, tuple[list[float], list[bool]]] = field(default_factory=dict)
    priors: ScenePriors = field(default_factory=ScenePriors)
    #: Per object table (``OBJECT_TABLES``): the matched proposals' rows and their true values
    #: (:func:`po3d_ppl.evaluation.projection.object_entries`), which :meth:`object_tables` scores.
    object_rows: dict[str, tuple[list[list[float]], list[int]]] = field(
        default_factory=lambda: {name: ([], []) for name in OBJECT_TABLES})

    def add(self, evidence, scene, min_iou: float = 0.5) -> None:
        from po3d_ppl.evaluation.projection import matched_proposals, object_entries, table_entries
        from po3d_ppl.evidence import STATE_COLOR, STATE_MATERIAL, style_index
        from po3d_ppl.perception.simulated import part_visible

        c = self.counts
        part_states = part_state_log_posterior(evidence, self.priors) if evidence.num_objects else None
        matched = matched_proposals(evidence, scene, min_iou)[0]
        c["objects"] += len(scene.objects)
        c["matched"] += len(matched)
        c["proposals"] += evidence.num_objects
        for i, o, _, s in matched:
            c["subtype_ok"] += int(evidence.subtype_loglik[i].argmax()) == s
            c["color_ok"] += int(evidence.color_loglik[i].argmax()) == ontology.COLORS.index(o.color)
            c["material_ok"] += int(evidence.material_loglik[i].argmax()) == ontology.MATERIALS.index(o.material)
            c["size_ok"] += int(evidence.size_loglik[i].argmax()) == ontology.SIZES.index(o.size)
            for p, raw in enumerate(ontology.PARTS[o.subtype]):
                if not part_visible(o, raw):
                    continue
                c["visible_parts"] += 1
                style = o.parts.get(raw)
                truth = style_index(style.color, style.material) if style else 0
                said = int(part_states[i, s, p, 1:].argmax())  # the look given that the part is visible
                c["part_style_ok"] += said == truth
                c["part_look_ok"] += (said > 0) == (truth > 0)
                if truth > 0:
                    c["recoloured_parts"] += 1
                    state = said + 1  # the part-state axis puts "hidden" first
                    c["part_color_ok"] += int(STATE_COLOR[state]) == ontology.COLORS.index(style.color)
                    c["part_material_ok"] += int(STATE_MATERIAL[state]) == ontology.MATERIALS.index(style.material)
        for name, (rows, truths) in object_entries(evidence, scene, min_iou).items():
            self.object_rows[name][0].extend(rows)
            self.object_rows[name][1].extend(truths)
        for name, (values, truths) in table_entries(evidence, scene, min_iou).items():
            prior = table_prior_logodds(self.priors, name)
            values = [v + prior for v in values]  # the entry's posterior log-odds
            kept = self.entries.setdefault(name, ([], []))
            kept[0].extend(values)
            kept[1].extend(truths)
            prefix = {"occludes_logodds": "occ", "part_occluded_logodds": "part_occ"}.get(name)
            for value, truth in zip(values, truths):
                said = value > 0
                if prefix is not None:
                    c[f"{prefix}_tp"] += truth and said
                    c[f"{prefix}_fp"] += said and not truth
                    c[f"{prefix}_fn"] += truth and not said
                elif name == "part_visible_logodds" and truth:
                    c["part_visible_ok"] += said

    def object_tables(self) -> dict[str, dict]:
        """Accuracy, ECE and NLL of each object table over the rows added (None each for a table without rows)."""
        from po3d_ppl.evaluation.projection import object_figures

        return {name: object_figures(torch.tensor(rows, dtype=torch.float64), torch.tensor(truths, dtype=torch.long))
                for name, (rows, truths) in self.object_rows.items()}

    def figures(self) -> dict[str, float | int | None]:
        c = self.counts

        def ratio(a: str, b: str) -> float | None:
            return c[a] / c[b] if c[b] else None

        def f1(prefix: str) -> float | None:
            tp, fp, fn = c[f"{prefix}_tp"], c[f"{prefix}_fp"], c[f"{prefix}_fn"]
            return 2 * tp / (2 * tp + fp + fn) if tp + fp + fn else None

        return {
            "objects": c["objects"], "matched": c["matched"], "proposals": c["proposals"],
            "subtype_accuracy": ratio("subtype_ok", "matched"), "color_accuracy": ratio("color_ok", "matched"),
            "material_accuracy": ratio("material_ok", "matched"), "size_accuracy": ratio("size_ok", "matched"),
            "visible_parts": c["visible_parts"],
            "part_attribute_accuracy": ratio("part_style_ok", "visible_parts"),
            "part_look_accuracy": ratio("part_look_ok", "visible_parts"),
            "part_color_accuracy_recoloured": ratio("part_color_ok", "recoloured_parts"),
            "part_material_accuracy_recoloured": ratio("part_material_ok", "recoloured_parts"),
            "part_visible_recall": ratio("part_visible_ok", "visible_parts"),
            "object_occlusion_f1": f1("occ"), "part_occlusion_f1": f1("part_occ"),
            "object_occlusion_counts": {k: c[f"occ_{k}"] for k in ("tp", "fp", "fn")},
            "part_occlusion_counts": {k: c[f"part_occ_{k}"] for k in ("tp", "fp", "fn")},
        }

"""What the object parser read, for a person to look at (an overlay PNG) and for scripts (a JSON record).

The overlay tints each proposal's visible mask (the pixels its posed category mesh owns in the parser's z-buffer)
with its category's colour, outlines its box and labels it with the category probability, the best azimuth and
the existence log-odds; proposals the parser does not believe (log-odds <= 0) are drawn thin and grey.
"""

from __future__ import annotations

import cv2
import numpy as np
import torch

from po3d_ppl import ontology

#: RGB colours per category, in ``ontology.CATEGORIES`` order.
CATEGORY_RGB = ((230, 60, 60), (60, 120, 230), (240, 170, 30), (60, 190, 90), (170, 80, 210))


def proposals_record(proposals) -> dict:
    """A JSON-ready summary: per proposal its category distribution, best pose, position, box and existence."""
    category = torch.softmax(proposals.category_loglik, -1)
    out = []
    for i in range(len(proposals)):
        c = int(category[i].argmax())
        azimuth = float(proposals.pose_support[i, int(proposals.pose_loglik[i, c].argmax())])
        out.append({
            "existence_logodds": float(proposals.existence_logodds[i]),
            "category": {name: float(p) for name, p in zip(ontology.CATEGORIES, category[i].tolist())},
            "azimuth_degree": azimuth,
            "pose_label": ontology.pose_label(azimuth),
            "size": {name: float(p) for name, p in zip(ontology.SIZES, torch.softmax(proposals.size_loglik[i], -1)
                                                       .tolist())},
            "position": [float(v) for v in proposals.positions[i]],
            "box_xywh": [int(v) for v in proposals.boxes[i]],
            "visible_pixels": int(proposals.masks[i].sum()),
            "from_region": bool(proposals.from_region[i]),
        })
    return {"proposals": out, "timings_s": dict(proposals.timings), "notes": list(proposals.notes)}


def draw_overlay(image_rgb: np.ndarray, proposals, record: dict | None = None, alpha: float = 0.45) -> np.ndarray:
    """``image_rgb`` (HxWx3 uint8, the parser's working size) with the proposals drawn on it (uint8 RGB);
    ``record`` is :func:`proposals_record` of them, when the caller has it already."""
    entries = (record or proposals_record(proposals))["proposals"]
    canvas = image_rgb.astype(np.float32).copy()
    looks = []
    for i, entry in enumerate(entries):
        name = max(entry["category"], key=entry["category"].get)
        believed = entry["existence_logodds"] > 0
        colour = CATEGORY_RGB[ontology.CATEGORIES.index(name)] if believed else (150, 150, 150)
        looks.append((name, believed, colour))
        mask = proposals.masks[i].numpy()
        canvas[mask] = (1 - alpha) * canvas[mask] + alpha * np.array(colour, dtype=np.float32)
    out = np.clip(canvas, 0, 255).astype(np.uint8)
    for i, (entry, (name, believed, colour)) in enumerate(zip(entries, looks)):
        x, y, w, h = entry["box_xywh"]
        cv2.rectangle(out, (x, y), (x + w - 1, y + h - 1), colour, 2 if believed else 1)
        label = (f"{i} {name} {entry['category'][name]:.2f} az{entry['azimuth_degree']:.0f} "
                 f"e{entry['existence_logodds']:+.0f}")
        cv2.putText(out, label, (x, max(y - 4, 10)), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 3, cv2.LINE_AA)
        cv2.putText(out, label, (x, max(y - 4, 10)), cv2.FONT_HERSHEY_SIMPLEX, 0.4, colour, 1, cv2.LINE_AA)
    return out


def _probs(logits: torch.Tensor, names) -> dict[str, float]:
    return {name: float(p) for name, p in zip(names, torch.softmax(logits, -1).tolist())}


def evidence_record(parsed) -> dict:
    """A JSON-ready reading of a :class:`~po3d_ppl.perception.scene_parser.ParsedScene`: per object the existence
    probability, the top subtypes, colour, material, size and pose, P(occluded) and the likely occluders, and its
    most likely subtype's visible, occluded and recoloured parts (probability > 0.5)."""
    from po3d_ppl.evidence import STATE_COLOR, STATE_MATERIAL

    ev = parsed.evidence
    out = []
    for i in range(ev.num_objects):
        subtypes = _probs(ev.subtype_loglik[i], ontology.SUBTYPES)
        best = max(subtypes, key=subtypes.get)
        s = ontology.SUBTYPES.index(best)
        c = ontology.CATEGORIES.index(ontology.CATEGORY_OF[best])
        pose = torch.softmax(ev.pose_loglik[i, c], -1)
        azimuth = float(ev.pose_support[i, int(pose.argmax())])
        parts = []
        for p, raw in enumerate(ontology.PARTS[best]):
            visible = float(torch.sigmoid(ev.part_visible_logodds[i, s, p]))
            if visible <= 0.5:
                continue
            style = torch.softmax(ev.part_style_loglik[i, s, p], -1)
            k = int(style.argmax())
            entry = {"part": raw, "visible": visible,
                     "occluded": float(torch.sigmoid(ev.part_occluded_logodds[i, s, p]))}
            if k > 0:
                entry["recoloured"] = {"color": ontology.COLORS[int(STATE_COLOR[k + 1])],
                                       "material": ontology.MATERIALS[int(STATE_MATERIAL[k + 1])],
                                       "probability": float(style[k])}
            parts.append(entry)
        occluders = torch.sigmoid(ev.occludes_logodds[i])
        out.append({
            "exists": float(torch.sigmoid(ev.exist_logodds[i])),
            "subtype": dict(sorted(subtypes.items(), key=lambda kv: -kv[1])[:3]),
            "color": _probs(ev.color_loglik[i], ontology.COLORS),
            "material": _probs(ev.material_loglik[i], ontology.MATERIALS),
            "size": _probs(ev.size_loglik[i], ontology.SIZES),
            "azimuth_degree": azimuth, "pose_label": ontology.pose_label(azimuth),
            "position": [float(v) for v in ev.positions[i]], "depth": float(ev.depths[i]),
            "occluded": float(torch.sigmoid(ev.occluded_logodds[i])),
            "occluded_by": {int(j): float(occluders[j]) for j in range(ev.num_objects) if j != i and occluders[j] > 0.5},
            "parts": parts,
        })
    return {"objects": out, "timings_s": dict(parsed.timings), "notes": list(parsed.notes)}


def draw_scene_overlay(image_rgb: np.ndarray, parsed, record: dict | None = None) -> np.ndarray:
    """The most likely scene drawn on ``image_rgb``: each object's projected mesh outlined in its category's colour
    and labelled (subtype, colour, material), its visible parts outlined (white; red where P(occluded) > 0.5) and
    an arrow from each likely occluder to the object it hides."""
    entries = (record or evidence_record(parsed))["objects"]
    out = np.ascontiguousarray((0.75 * image_rgb.astype(np.float32)).astype(np.uint8))
    if parsed.object_ids is None:
        return out
    ids, part_ids = parsed.object_ids, parsed.part_ids
    centres = {}
    for i, entry in enumerate(entries):
        subtype = next(iter(entry["subtype"]))
        colour = CATEGORY_RGB[ontology.CATEGORIES.index(ontology.CATEGORY_OF[subtype])]
        own = (ids == i).astype(np.uint8)
        if not own.any():
            continue
        occluded = {ontology.part_id(subtype, p["part"]) for p in entry["parts"] if p["occluded"] > 0.5}
        for p in np.unique(part_ids[ids == i]):
            if p < 0:
                continue
            mask = ((ids == i) & (part_ids == p)).astype(np.uint8)
            contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
            cv2.drawContours(out, contours, -1, (230, 40, 40) if p in occluded else (235, 235, 235), 1)
        contours, _ = cv2.findContours(own, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        cv2.drawContours(out, contours, -1, colour, 2)
        ys, xs = np.nonzero(own)
        centres[i] = (int(xs.mean()), int(ys.mean()))
        colour_name = max(entry["color"], key=entry["color"].get)
        material = max(entry["material"], key=entry["material"].get)
        label = f"{i} {ontology.readable_name(subtype)} {colour_name} {material}"
        at = (int(xs.min()), max(int(ys.min()) - 4, 10))
        cv2.putText(out, label, at, cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 3, cv2.LINE_AA)
        cv2.putText(out, label, at, cv2.FONT_HERSHEY_SIMPLEX, 0.4, colour, 1, cv2.LINE_AA)
    for i, entry in enumerate(entries):
        for j in entry["occluded_by"]:
            if i in centres and int(j) in centres:
                cv2.arrowedLine(out, centres[int(j)], centres[i], (230, 40, 40), 2, cv2.LINE_AA, tipLength=0.08)
    return out

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

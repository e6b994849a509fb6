"""Pictures of detection failures, for looking rather than counting: the images with the most failures, each
missed object and false proposal boxed and labelled with its kind (:func:`~po3d_ppl.evaluation.objects.image_failures`),
drawn from the cached evidence's boxes (nothing is parsed again).

On each picture: found objects' true boxes thin green, matched proposals thin blue, missed objects red and false
proposals orange, each with its kind. ``index.md`` lists the pictures with their failures.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from po3d_ppl.errors import InputError
from po3d_ppl.evaluation.objects import ImageFailures, ImageOutcome, image_failures
from po3d_ppl.world.contact_sheet import write_png

#: BGR colours (OpenCV draws in BGR).
FOUND, PROPOSAL, MISSED, FALSE = (0, 170, 0), (230, 120, 0), (0, 0, 230), (0, 140, 255)
LEGEND = (("found object", FOUND), ("matched proposal", PROPOSAL), ("missed object", MISSED),
          ("false proposal", FALSE))


def _box(canvas: np.ndarray, box: Sequence[float], colour: tuple[int, int, int], thickness: int,
         label: str | None = None) -> None:
    import cv2

    x, y, w, h = (int(round(v)) for v in box)
    cv2.rectangle(canvas, (x, y), (x + w, y + h), colour, thickness)
    if label:
        (tw, th), _ = cv2.getTextSize(label, cv2.FONT_HERSHEY_SIMPLEX, 0.4, 1)
        top = max(y - th - 4, 0)
        cv2.rectangle(canvas, (x, top), (x + tw + 4, top + th + 4), colour, -1)
        cv2.putText(canvas, label, (x + 2, top + th + 1), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 255), 1,
                    cv2.LINE_AA)


def draw_failures(image: np.ndarray, img: ImageOutcome, failures: ImageFailures) -> np.ndarray:
    """``image`` [H, W, 3] BGR uint8 with ``img``'s boxes drawn by outcome, and a legend band below."""
    import cv2

    canvas = np.ascontiguousarray(image.copy())
    for o in img.objects:
        if o.proposal >= 0:
            _box(canvas, o.box, FOUND, 1)
    for k, box in enumerate(img.proposal_boxes):
        if k not in failures.false_proposals and img.proposal_matched[k]:
            _box(canvas, box, PROPOSAL, 1)
    for j, kind in failures.missed.items():
        _box(canvas, img.objects[j].box, MISSED, 2, f"missed {img.objects[j].category}: {kind}")
    for k, kind in failures.false_proposals.items():
        _box(canvas, img.proposal_boxes[k], FALSE, 2, f"false: {kind}")
    band = np.full((22, canvas.shape[1], 3), 255, dtype=np.uint8)
    x = 6
    for name, colour in LEGEND:
        cv2.rectangle(band, (x, 6), (x + 12, 16), colour, -1)
        cv2.putText(band, name, (x + 16, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 1, cv2.LINE_AA)
        x += 22 + cv2.getTextSize(name, cv2.FONT_HERSHEY_SIMPLEX, 0.4, 1)[0][0]
    return np.concatenate([canvas, band], 0)


def write_gallery(outcomes: Sequence[ImageOutcome], image_paths: Sequence[Path], out: Path, images: int = 12,
                  min_pixels: int = 200) -> Path:
    """Draw the ``images`` images of ``outcomes`` with the most failures into ``out`` (one PNG each) and write
    ``out/index.md``; returns the index's path. ``image_paths[i]`` is the picture ``outcomes[i]`` was read from."""
    import cv2

    if len(image_paths) != len(outcomes):
        raise InputError("image_paths", f"one path per outcome: got {len(image_paths)} for {len(outcomes)}")
    found = [(i, failures) for i, img in enumerate(outcomes)
             if (failures := image_failures(img, min_pixels)) is not None]
    worst = sorted(found, key=lambda item: -(len(item[1].missed) + len(item[1].false_proposals)))[:images]
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for i, failures in worst:
        if not failures.missed and not failures.false_proposals:
            break
        picture = cv2.imread(str(image_paths[i]), cv2.IMREAD_COLOR)
        if picture is None:
            raise InputError("image", f"cannot read {image_paths[i]} (moved or not an image?)")
        name = f"{Path(outcomes[i].image).stem}_failures.png"
        write_png(out / name, draw_failures(picture, outcomes[i], failures))
        rows.append(f"| {outcomes[i].image} | {_counted(failures.missed.values())} | "
                    f"{_counted(failures.false_proposals.values())} | ![{name}]({name}) |")
    lines = ["# Detection failures", "",
             f"The {len(rows)} images with the most failures of {len(outcomes)} (objects >= {min_pixels} visible "
             "pixels; kinds as in `evaluation.objects.image_failures`).", "",
             "| image | missed | false proposals | picture |", "|---|---|---|---|", *rows, ""]
    index = out / "index.md"
    index.write_text("\n".join(lines))
    return index


def _counted(kinds) -> str:
    counts = Counter(kinds)
    return ", ".join(f"{n} {kind}" for kind, n in sorted(counts.items())) or "-"

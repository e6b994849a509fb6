"""The object parser's second search, side by side: detection after the first reading and after the second.

Each image of ``--data`` is read once by the shipped models: the object parser's search (centre proposals
included), its record (the first reading, what ``ParserConfig(region_min_score=None)`` ships), the scene parser's
most likely scene, and then :func:`~po3d_ppl.perception.object_parser.add_region_proposals` on the foreground that
scene leaves unexplained.
Both sets of proposals are scored against the scene file (for scoring only) by :mod:`po3d_ppl.evaluation.objects`:
precision, recall, recall of objects >= 20% occluded, and what the second search added (matched to an object the
first reading missed, to one it had, or to none).

    python benchmarks/second_search.py --data /work/data/val_s716 --limit 60
"""

from __future__ import annotations

from dataclasses import replace

from dataset_args import add_overrides_option, dataset_parser, parser_overrides
from detection_table import print_detection_table


def main() -> None:
    parser = dataset_parser(__doc__)
    add_overrides_option(parser, "ParserConfig", "region_min_score=50")
    args = parser.parse_args()

    import numpy as np
    import torch
    from rich.progress import track

    from po3d_ppl.evaluation.objects import match_boxes, score_image, summarise
    from po3d_ppl.perception.object_parser import (
        ParserConfig,
        add_region_proposals,
        record_objects,
        search_objects,
    )
    from po3d_ppl.perception.scene_parser import ImageParser, read_scene
    from po3d_ppl.questions.dataset import load_dataset

    torch.set_num_threads(args.threads)
    dataset = load_dataset(args.data)
    reader = replace(ImageParser.load(), parser_config=ParserConfig(**parser_overrides(args.set)))
    first, second = [], []
    added = {"a missed object": 0, "an object found already": 0, "no object": 0}
    for index in track(dataset.split_indices(args.split)[: args.limit], description="parsing"):
        scene = dataset.scene(index)
        search = search_objects(dataset.image_path(index), reader.object_model, reader.parser_config,
                                reader.object_calibration, reader.background)
        before = record_objects(search)
        parsed = read_scene(search.image, before, reader.attributes, reader.viewpoint,
                            reader.projection_calibration, reader.config)
        grown = add_region_proposals(search, parsed.object_ids)
        after = record_objects(grown) if grown is not None else before
        first.append(score_image(before, scene, str(index), 0.0))
        second.append(score_image(after, scene, str(index), 0.0))
        if grown is not None:
            truth = np.array([o.annotation.bbox for o in scene.objects], dtype=np.float64).reshape(-1, 4)
            had = {j for _, j in match_boxes(before.boxes.numpy(), truth)}
            pairs = dict(match_boxes(after.boxes.numpy(), truth))
            new = grown.located[len(search.located):]
            for i, pose in enumerate(after.poses):
                if any(pose is h for h in new):
                    j = pairs.get(i)
                    added["no object" if j is None else "an object found already" if j in had
                          else "a missed object"] += 1
    print(f"{len(first)} images of {args.data}")
    print_detection_table(summarise(first), summarise(second), "first reading", "with second")
    print("second-search proposals matched to " + ", ".join(f"{k}: {v}" for k, v in added.items()))


if __name__ == "__main__":
    main()

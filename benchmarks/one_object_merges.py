"""The scene parser's merge of proposals read as one object, side by side: detection before and after it.

Each image of ``--data`` is read once by the shipped models with the merge off (``SceneParserConfig(
merge_max_distance=None)``), then :func:`~po3d_ppl.perception.scene_parser.one_object_merges` picks the pairs under
the shipped settings (or ``--set FIELD=VALUE`` overrides of them) and the scene is read again without the folded
proposals, as :func:`~po3d_ppl.perception.scene_parser.parse_scene` does. Both are scored against the scene file
(for scoring only) by :mod:`po3d_ppl.evaluation.objects`: precision, recall, recall of objects >= 20% occluded,
and the detection failures by kind.

    python benchmarks/one_object_merges.py --data /work/data/val_s716 --limit 60
"""

from __future__ import annotations

import time
from dataclasses import replace

from dataset_args import add_overrides_option, config_overrides, dataset_parser
from detection_table import print_detection_table


def main() -> None:
    parser = dataset_parser(__doc__)
    add_overrides_option(parser, "SceneParserConfig merge_*", "merge_min_colour=0.3")
    args = parser.parse_args()

    import torch
    from rich.progress import track

    from po3d_ppl.evaluation.objects import EvidenceAsProposals, score_image, summarise
    from po3d_ppl.perception.image_input import load_image
    from po3d_ppl.perception.object_parser import merge_proposals
    from po3d_ppl.perception.scene_parser import (
        ImageParser,
        SceneParserConfig,
        one_object_merges,
        read_scene,
        seen_as_read,
    )
    from po3d_ppl.questions.dataset import load_dataset

    merging = replace(SceneParserConfig(), **config_overrides(args.set, SceneParserConfig, prefix="merge_"))
    torch.set_num_threads(args.threads)
    dataset = load_dataset(args.data)
    reader = ImageParser.load(config=SceneParserConfig(merge_max_distance=None))
    before, after, merged, seconds = [], [], 0, []
    for index in track(dataset.split_indices(args.split)[: args.limit], description="parsing"):
        scene = dataset.scene(index)
        parsed = reader.parse(dataset.image_path(index))
        before.append(score_image(EvidenceAsProposals.of(parsed.evidence), scene, str(index), 0.0))
        start = time.perf_counter()
        into = one_object_merges(parsed.evidence, merging)
        if into is not None:
            merged += len(into) - len(set(into))
            parsed = seen_as_read(read_scene(load_image(dataset.image_path(index)),
                                             merge_proposals(parsed.proposals, into), reader.attributes,
                                             reader.viewpoint, reader.projection_calibration, merging))
            seconds.append(time.perf_counter() - start)
        after.append(score_image(EvidenceAsProposals.of(parsed.evidence), scene, str(index), 0.0))
    print(f"{len(before)} images of {args.data}; {merged} proposal(s) merged on {len(seconds)} image(s)"
          + (f", {sum(seconds) / len(seconds):.2f} s a merge (read again)" if seconds else ""))
    print_detection_table(summarise(before), summarise(after), "merge off", "merge on", failures=True)


if __name__ == "__main__":
    main()

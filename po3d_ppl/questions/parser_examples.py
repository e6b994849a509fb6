"""A built dataset's questions as (question, program) examples for the question parser.

Lives with the questions stage so that the language stage never imports it: the parser learns from examples
(:class:`~po3d_ppl.language.seq2seq.data.Example`), and this is where a dataset folder becomes examples.
"""

from __future__ import annotations

from pathlib import Path

from po3d_ppl.errors import InputError
from po3d_ppl.language.seq2seq.data import Example, examples_from_records
from po3d_ppl.questions.dataset import Dataset, load_dataset


def open_dataset(data_dir: Path) -> Dataset:
    """A dataset directory built by ``po3d dataset build``, read once (its splits, questions and manifest)."""
    data_dir = Path(data_dir)
    if not data_dir.is_dir():
        raise InputError("--data", f"{data_dir} is not a directory; build one with `po3d dataset build --out DIR`")
    return load_dataset(data_dir)


def split_examples(dataset: Dataset, split: str) -> list[Example]:
    """Every question of ``split`` in ``dataset``, grouped by question file."""
    if split not in dataset.splits:
        raise InputError("--split", f"unknown split {split!r} (known: {', '.join(dataset.splits)})")
    members = set(dataset.splits[split])
    examples: list[Example] = []
    for source, records in dataset.questions.items():
        examples.extend(examples_from_records((r for r in records if r.get("image_index") in members), source))
    if not examples:
        raise InputError("--split", f"no questions for split {split!r} in {dataset.root}")
    return examples


def load_examples(data_dir: Path, split: str) -> list[Example]:
    """Every question of ``split`` in a dataset built by ``po3d dataset build``, grouped by question file."""
    return split_examples(open_dataset(data_dir), split)

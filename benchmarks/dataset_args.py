"""The command line the dataset benchmarks share: ``--data DIR [--split S] [--limit N] [--threads T]``."""

from __future__ import annotations

import argparse
from pathlib import Path


def dataset_parser(doc: str) -> argparse.ArgumentParser:
    """An argument parser described by ``doc``'s first line, with the dataset options every benchmark reads."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--data", type=Path, required=True, help="dataset directory from `po3d dataset build`")
    parser.add_argument("--split", default="all")
    parser.add_argument("--limit", type=int, default=None, help="only the first N images")
    parser.add_argument("--threads", type=int, default=1)
    return parser

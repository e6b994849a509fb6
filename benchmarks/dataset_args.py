"""The command line the dataset benchmarks share: ``--data DIR [--split S] [--limit N] [--threads T]``, and the
object parser's ``--set FIELD=VALUE`` overrides."""

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


def add_overrides_option(parser: argparse.ArgumentParser, what: str, example: str) -> None:
    """The repeatable ``--set FIELD=VALUE`` option, overriding fields of ``what`` (e.g. ``ParserConfig``)."""
    parser.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                        help=f"override a {what} field (repeatable), e.g. --set {example}")


def config_overrides(settings: list[str], config_class: type, prefix: str = "") -> dict:
    """Fields of the dataclass ``config_class`` (those starting with ``prefix``) from ``FIELD=VALUE`` items:
    ``none`` gives None, a bool field reads true/false (or 1/0, yes/no), a field whose default is None a float, any
    other its default's type."""
    default = config_class()
    overrides = {}
    for item in settings:
        name, _, text = item.partition("=")
        if name not in config_class.__dataclass_fields__ or not name.startswith(prefix):
            raise SystemExit(f"unknown {config_class.__name__} field {name!r}"
                             + (f" (only {prefix}* fields here)" if prefix else ""))
        current = getattr(default, name)
        if text.lower() == "none":
            overrides[name] = None
        elif isinstance(current, bool):
            overrides[name] = text.lower() in ("1", "true", "yes")
        else:
            overrides[name] = float(text) if current is None else type(current)(text)
    return overrides


def parser_overrides(settings: list[str]) -> dict:
    """``ParserConfig`` fields from ``FIELD=VALUE`` items (:func:`config_overrides`)."""
    from po3d_ppl.perception.object_parser import ParserConfig

    return config_overrides(settings, ParserConfig)

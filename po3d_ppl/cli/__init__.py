"""The ``po3d`` command line.

Each stage owns one module here that exposes ``register(app)``; this file only assembles them and turns
:class:`~po3d_ppl.errors.Po3dError` into a one-line message (exit code 2) instead of a traceback. Modules import
their heavy dependencies inside the commands so that ``po3d --help`` stays fast.
"""

from __future__ import annotations

import importlib
import sys

import typer
from rich.console import Console
from rich.text import Text

from po3d_ppl.errors import Po3dError

app = typer.Typer(
    name="po3d",
    help="po3d_ppl: probabilistic 3D-aware visual question answering.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)
#: Groups shared by several stages (``po3d train parser``, ``po3d eval parser`` ...).
train_app = typer.Typer(help="Train a model and write its weights to models/.", no_args_is_help=True)
eval_app = typer.Typer(help="Evaluate a model on a dataset split.", no_args_is_help=True)
app.add_typer(train_app, name="train")
app.add_typer(eval_app, name="eval")

#: Command modules, in help order. Each defines ``register(app, train_app, eval_app)``.
_MODULES = ("demo", "world", "dataset", "execute", "language", "answer", "perceive", "perception", "attributes",
            "viewpoint", "centres", "objects", "priors", "evaluate", "results", "train_all")

for _name in _MODULES:
    importlib.import_module(f"po3d_ppl.cli.{_name}").register(app, train_app, eval_app)


def print_error(exc: Po3dError, console: Console | None = None) -> None:
    """Print ``exc`` as ``error: <message>``, literally: messages quote paths and programs holding ``[...]``,
    which must neither be read as markup nor be wrapped at the console width (the error stays one line)."""
    console = console or Console(stderr=True)
    console.print(Text.assemble(("error:", "bold red"), " ", str(exc)), highlight=False, soft_wrap=True)


def main() -> None:
    try:
        app()
    except Po3dError as exc:
        print_error(exc)
        sys.exit(2)

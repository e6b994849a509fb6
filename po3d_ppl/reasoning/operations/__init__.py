"""Latent-world implementations of the built-in operations, one module per family; importing this package
attaches them to the declarations in :mod:`po3d_ppl.catalogue.builtin`."""

from po3d_ppl.reasoning.operations import core, occlusion, parts, pose  # noqa: F401

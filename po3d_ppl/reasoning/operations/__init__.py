"""Built-in program operations, one module per family. Importing this package registers them all."""

from po3d_ppl.reasoning.operations import core, occlusion, parts, pose  # noqa: F401

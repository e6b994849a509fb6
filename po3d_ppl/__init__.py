"""po3d_ppl: a probabilistic-programming engine for 3D-aware visual question answering."""

__version__ = "0.1.0"

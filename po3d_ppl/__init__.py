"""po3d_ppl: a probabilistic-programming engine for 3D-aware visual question answering.

``po3d_ppl.answer(image, question)`` gives an answer distribution from pixels with the shipped models;
``po3d_ppl.load_pipeline()`` loads them once for many images (:mod:`po3d_ppl.pipeline`). Both are imported on
first use, so ``import po3d_ppl`` stays light.
"""

__version__ = "0.1.0"

_LAZY = {"answer": "po3d_ppl.pipeline", "load_pipeline": "po3d_ppl.pipeline", "Pipeline": "po3d_ppl.pipeline"}
__all__ = ["Pipeline", "__version__", "answer", "load_pipeline"]


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'po3d_ppl' has no attribute {name!r}")

"""Perception: pixels (or, for the simulated sensor, a ground-truth scene) in, :class:`SceneEvidence` out.

A back-end is anything with ``evidence(observation) -> SceneEvidence`` (:class:`EvidenceSource`). Today there is
one, the simulated sensor (:mod:`po3d_ppl.perception.simulated`); the render-and-compare parser (issue
"Perception I/II") will be the second, behind the same interface. Perception imports the world and the contract
(:mod:`po3d_ppl.evidence`), never reasoning.

Foundations of the render-and-compare parser, in place: image input with the world's camera prior
(:mod:`~po3d_ppl.perception.image_input`), category-level meshes that enclose each category's subtypes
(:mod:`~po3d_ppl.perception.category_meshes`), a torch rasteriser (:mod:`~po3d_ppl.perception.rasterizer`), and
the stride-8 feature extractor with the neural textures and clutter bank trained by the contrastive objective
(:mod:`~po3d_ppl.perception.features`, :mod:`~po3d_ppl.perception.neural_mesh`,
:mod:`~po3d_ppl.perception.train_features`; shipped in ``models/perception_features.safetensors``), and a first
multi-object parser (:func:`~po3d_ppl.perception.object_parser.parse_objects`: coarse search, 3D-NMS, refinement,
``ObjectProposals``), not yet turned into ``SceneEvidence``.
They are imported lazily (the simulated sensor needs none of them).
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

from po3d_ppl.evidence import SceneEvidence
from po3d_ppl.perception.simulated import SimulatedSensor, simulated_evidence


@runtime_checkable
class EvidenceSource(Protocol):
    """A perception back-end."""

    name: str

    def evidence(self, observation: Any) -> SceneEvidence:
        """The evidence for one observation (an image for a real parser, a scene for the simulated sensor)."""
        ...


_LAZY = {
    "load_image": "image_input", "ImageInput": "image_input", "CameraPrior": "image_input",
    "project_points": "image_input", "backproject_to_plane": "image_input", "pixel_directions": "image_input",
    "CategoryMesh": "category_meshes", "category_mesh": "category_meshes", "all_category_meshes": "category_meshes",
    "pose_category_mesh": "category_meshes", "pose_vertices_torch": "category_meshes",
    "write_category_sheet": "category_meshes",
    "rasterize": "rasterizer", "rasterize_camera": "rasterizer", "Fragments": "rasterizer",
    "CameraTensors": "rasterizer", "camera_tensors": "rasterizer", "project_vertices": "rasterizer",
    "pad_meshes": "rasterizer", "scaled_intrinsics": "rasterizer",
    "FeatureExtractor": "features", "FeatureConfig": "features", "extract_features": "features",
    "NeuralMeshes": "neural_mesh", "FeatureModel": "neural_mesh", "load_feature_model": "neural_mesh",
    "save_feature_model": "neural_mesh",
    "parse_objects": "object_parser", "ObjectProposals": "object_parser", "ParserConfig": "object_parser",
}

__all__ = ["EvidenceSource", "SceneEvidence", "SimulatedSensor", "simulated_evidence", *_LAZY]


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f"po3d_ppl.perception.{_LAZY[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

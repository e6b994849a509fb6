"""Perception: pixels (or, for the simulated sensor, a ground-truth scene) in, :class:`SceneEvidence` out.

A back-end is anything with ``evidence(observation) -> SceneEvidence`` (:class:`EvidenceSource`). Two ship:

- the render-and-compare parser, :class:`~po3d_ppl.perception.scene_parser.ImageParser` (``ImageParser.load()``
  with the shipped models; :func:`~po3d_ppl.perception.scene_parser.parse_scene`): the stride-8 features and
  neural meshes (:mod:`~po3d_ppl.perception.features`, :mod:`~po3d_ppl.perception.neural_mesh`), the multi-object
  parser (:func:`~po3d_ppl.perception.object_parser.parse_objects`), the background model, calibrated tables, the
  attribute network, the viewpoint network (whole-object azimuth), and parts and occlusion by projecting the
  world's part-labelled meshes;
- the simulated sensor (:mod:`po3d_ppl.perception.simulated`), for reasoning on its own.

Perception imports the world and the contract (:mod:`po3d_ppl.evidence`), never reasoning. The image modules are
imported lazily (the simulated sensor needs none of them). ``docs/perception.md`` has the stages and figures.
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
    "parse_scene": "scene_parser", "ImageParser": "scene_parser", "ParsedScene": "scene_parser",
    "SceneParserConfig": "scene_parser", "BackgroundModel": "background", "load_background": "background",
    "TableCalibration": "calibration", "load_calibration": "calibration",
    "AttributeNet": "attributes", "AttributeEnsemble": "attributes", "AttributeReader": "attributes",
    "load_attribute_net": "attributes",
    "ViewpointNet": "viewpoint", "load_viewpoint_net": "viewpoint", "combine_pose": "viewpoint",
}

__all__ = ["EvidenceSource", "SceneEvidence", "SimulatedSensor", "simulated_evidence", *_LAZY]


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f"po3d_ppl.perception.{_LAZY[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

"""The world: scene records, generation (sample -> ray-cast render -> exact annotations) and public scene files.

Names are resolved lazily (PEP 562) so that importing ``po3d_ppl.ontology`` or ``.scene`` does not pull in
the renderer's dependencies (trimesh, embree, OpenCV).
"""

from importlib import import_module

_EXPORTS = {
    "RenderedScene": "generate", "generate_scene": "generate", "render_layout": "generate",
    "ObjectSpec": "sampler", "SceneConfig": "sampler",
    "Camera": "scene", "EntityAnnotation": "scene", "Occlusion": "scene", "PartStyle": "scene", "Scene": "scene",
    "SceneObject": "scene",
    "load_scene": "scene_io", "load_scenes": "scene_io", "save_scene": "scene_io", "save_scenes": "scene_io",
    "scene_from_public": "scene_io", "scene_to_public": "scene_io",
}
__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        return getattr(import_module(f"po3d_ppl.world.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module 'po3d_ppl.world' has no attribute {name!r}")

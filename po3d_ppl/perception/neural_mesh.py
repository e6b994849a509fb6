"""Neural meshes: per category, a learned unit feature per vertex of its category mesh (the neural texture), and a
clutter (background) feature bank; saved with the feature extractor as one shipped model (paper §4.2).

Render-and-compare scores a pixel's feature against the texture of the mesh it is rendered from and against the
clutter model, so textures and extractor are trained together (:mod:`~po3d_ppl.perception.train_features`) and
must be used together: they are one file, ``models/perception_features.safetensors``, with tensors
``extractor.<param>``, ``texture.<category>`` ``[V, dim]`` and ``clutter`` ``[K, dim]``, and a JSON header
(format, extractor config, each category's vertex count and a digest of its mesh vertices). A texture belongs to
one mesh: if :func:`~po3d_ppl.perception.category_meshes.category_mesh` changes, loading fails with the fix
(retrain) instead of scoring features against the wrong vertices. Checksums are the model store's
(:func:`po3d_ppl.model_store.model_files`): a missing or altered file is a :class:`~po3d_ppl.errors.ModelFileError`
naming it.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F

from po3d_ppl import ontology
from po3d_ppl.errors import InputError, ModelFileError
from po3d_ppl.perception.features import FeatureConfig, FeatureExtractor

MODEL_NAME = "perception_features"
WEIGHTS = f"{MODEL_NAME}.safetensors"
FORMAT = 1
RETRAIN = ("restore it with `git checkout models/` or retrain: "
           "`po3d train perception --data DIR --out models/ --seed 0`")


def mesh_digest(vertices: np.ndarray) -> str:
    """A short digest of a mesh's vertex array (float32, rounded to 1e-5): ties a texture to its mesh."""
    rounded = np.round(np.asarray(vertices, dtype=np.float64), 5).astype(np.float32)
    return hashlib.sha256(np.ascontiguousarray(rounded).tobytes()).hexdigest()[:16]


@dataclass(eq=False)
class NeuralMeshes:
    """Neural textures of the five categories (unit rows) and the clutter bank (unit rows), one feature space."""

    textures: dict[str, torch.Tensor]
    clutter: torch.Tensor

    def __post_init__(self) -> None:
        missing = [c for c in ontology.CATEGORIES if c not in self.textures]
        if missing:
            raise InputError("textures", f"needs one texture per category; missing {missing}")
        dims = {t.shape[-1] for t in self.textures.values()} | {self.clutter.shape[-1]}
        if len(dims) != 1 or self.clutter.dim() != 2 or any(t.dim() != 2 for t in self.textures.values()):
            raise InputError("textures", f"textures [V, D] and clutter [K, D] must share D; got dims {sorted(dims)}")

    @property
    def dim(self) -> int:
        return int(self.clutter.shape[-1])

    @property
    def categories(self) -> tuple[str, ...]:
        return tuple(c for c in ontology.CATEGORIES)

    def offsets(self) -> dict[str, int]:
        """First row of each category in :meth:`all_vertices` (categories in ``ontology.CATEGORIES`` order)."""
        out, start = {}, 0
        for c in self.categories:
            out[c] = start
            start += int(self.textures[c].shape[0])
        return out

    def all_vertices(self) -> torch.Tensor:
        """[sum V, D]: every category's texture stacked in ``ontology.CATEGORIES`` order."""
        return torch.cat([self.textures[c] for c in self.categories])

    def clutter_vector(self) -> torch.Tensor:
        """[D]: the clutter bank's mean, renormalised (the single background model of NeMo's inference)."""
        return F.normalize(self.clutter.mean(0), dim=0)

    def to(self, device: torch.device | str) -> NeuralMeshes:
        return NeuralMeshes({c: t.to(device) for c, t in self.textures.items()}, self.clutter.to(device))

    def normalised(self) -> NeuralMeshes:
        return NeuralMeshes({c: F.normalize(t.float(), dim=-1) for c, t in self.textures.items()},
                            F.normalize(self.clutter.float(), dim=-1))


@dataclass(eq=False)
class FeatureModel:
    """A trained extractor with the neural meshes it was trained with."""

    extractor: FeatureExtractor
    meshes: NeuralMeshes

    def to(self, device: torch.device | str) -> FeatureModel:
        return FeatureModel(self.extractor.to(device), self.meshes.to(device))


def _mesh_header() -> dict[str, Any]:
    from po3d_ppl.perception.category_meshes import category_mesh

    return {c: {"vertices": category_mesh(c).num_vertices, "digest": mesh_digest(category_mesh(c).vertices)}
            for c in ontology.CATEGORIES}


def save_feature_model(model: FeatureModel, directory: Path | str, **manifest: Any) -> Path:
    """Write ``model`` to ``directory/perception_features.safetensors`` and record it in the directory's
    manifest with ``manifest`` (command, data seed, metrics ...); other models' entries are kept."""
    from safetensors.torch import save_file

    from po3d_ppl.model_store import write_entry

    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    header = _mesh_header()
    for c, t in model.meshes.textures.items():
        if t.shape[0] != header[c]["vertices"]:
            raise InputError(f"textures[{c!r}]", f"has {t.shape[0]} rows, the {c} mesh has "
                                                 f"{header[c]['vertices']} vertices")
    tensors = {f"extractor.{k}": v.detach().cpu().contiguous() for k, v in model.extractor.state_dict().items()}
    tensors |= {f"texture.{c}": t.detach().cpu().float().contiguous() for c, t in model.meshes.textures.items()}
    tensors["clutter"] = model.meshes.clutter.detach().cpu().float().contiguous()
    path = directory / WEIGHTS
    meta = {"format": str(FORMAT), "config": json.dumps(model.extractor.config.to_dict()),
            "meshes": json.dumps(header)}
    save_file(tensors, str(path), metadata=meta)
    path.chmod(0o644)
    write_entry(MODEL_NAME, [path], directory, **manifest)
    return path


def load_feature_model(directory: Path | str | None = None, device: torch.device | str = "cpu") -> FeatureModel:
    """The shipped feature model (or the one in ``directory``), checked against the manifest (sha256) and against
    today's category meshes; the extractor is in eval mode."""
    from po3d_ppl.model_store import load_tensors

    path, meta, tensors = load_tensors(MODEL_NAME, directory, RETRAIN, str(FORMAT))
    try:
        config = FeatureConfig.from_dict(json.loads(meta["config"]))
        saved_meshes = json.loads(meta["meshes"])
        extractor = FeatureExtractor(config)
        extractor.load_state_dict({k.removeprefix("extractor."): v for k, v in tensors.items()
                                   if k.startswith("extractor.")})
        meshes = NeuralMeshes({c: tensors[f"texture.{c}"] for c in ontology.CATEGORIES}, tensors["clutter"])
    except ModelFileError:
        raise
    except (OSError, ValueError, KeyError, TypeError, RuntimeError) as exc:
        raise ModelFileError(f"cannot load the perception features from {path} ({exc}); {RETRAIN}") from None
    _check_meshes(saved_meshes, path)
    return FeatureModel(extractor.to(device).eval(), meshes.to(device))


def _check_meshes(saved: Mapping[str, Any], path: Path) -> None:
    now = _mesh_header()
    changed = [c for c in ontology.CATEGORIES if saved.get(c) != now[c]]
    if changed:
        raise ModelFileError(f"{path}: the neural textures of {changed} were trained on other category meshes "
                             f"(vertex count or digest differs from perception.category_meshes today); {RETRAIN}")

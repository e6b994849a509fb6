"""On-disk evidence cache: a re-run of an evaluation costs only reasoning.

Key: sha256 of the image file + sha256 of the back-end's identity (name, settings, model sha). Values are
safetensors files (tensors only, no pickle: a cache directory is safe to share), with the camera and the key's
inputs as JSON metadata. Files are written to a temporary name and moved into place, so a killed run never
leaves a half-written entry.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import torch
from safetensors import SafetensorError
from safetensors.torch import load_file, save_file

from po3d_ppl.errors import InputError
from po3d_ppl.evidence import SceneEvidence
from po3d_ppl.world.scene import Camera

FORMAT = "po3d-evidence-1"
_DIRECTION = "directions."


def file_sha256(path: Path) -> str:
    """sha256 of a file's bytes (the image hash of the cache key)."""
    digest = hashlib.sha256()
    try:
        with open(path, "rb") as handle:
            for block in iter(lambda: handle.read(1 << 20), b""):
                digest.update(block)
    except FileNotFoundError:
        raise InputError("image", f"{path} is missing; is the dataset directory complete?") from None
    return digest.hexdigest()


def identity_sha256(identity: dict[str, Any]) -> str:
    return hashlib.sha256(json.dumps(identity, sort_keys=True).encode()).hexdigest()


def evidence_to_tensors(evidence: SceneEvidence) -> tuple[dict[str, torch.Tensor], dict[str, str]]:
    """(tensors, metadata) for safetensors: every tensor field, directions flattened, the camera as JSON."""
    tensors: dict[str, torch.Tensor] = {}
    for f in dataclasses.fields(evidence):
        value = getattr(evidence, f.name)
        if isinstance(value, torch.Tensor):
            tensors[f.name] = value.detach().cpu().contiguous()
    for name, value in evidence.directions.items():
        tensors[_DIRECTION + name] = value.detach().cpu().contiguous()
    camera = None if evidence.camera is None else dataclasses.asdict(evidence.camera)
    return tensors, {"format": FORMAT, "camera": json.dumps(camera)}


def evidence_from_tensors(tensors: dict[str, torch.Tensor], metadata: dict[str, str]) -> SceneEvidence:
    directions = {k[len(_DIRECTION):]: v for k, v in tensors.items() if k.startswith(_DIRECTION)}
    fields = {k: v for k, v in tensors.items() if not k.startswith(_DIRECTION)}
    camera = json.loads(metadata.get("camera", "null"))
    if camera is not None:
        camera = Camera(width=camera["width"], height=camera["height"],
                        intrinsics=tuple(tuple(r) for r in camera["intrinsics"]),
                        camera_to_world=tuple(tuple(r) for r in camera["camera_to_world"]))
    return SceneEvidence(**fields, directions=directions, camera=camera)


class EvidenceCache:
    """``cache.get(image_path, identity, compute)``: the cached evidence, or ``compute()`` stored for next time.

    ``hits`` and ``misses`` count lookups (the tests check that a re-run never calls the back-end)."""

    def __init__(self, root: Path | str | None):
        self.root = None if root is None else Path(root)
        self.hits = self.misses = 0
        if self.root is not None:
            try:
                self.root.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise InputError("--cache", f"cannot create the cache directory {self.root}: {exc}") from None

    def path(self, image_path: Path, identity: dict[str, Any]) -> Path:
        assert self.root is not None
        return self.root / f"{file_sha256(image_path)}-{identity_sha256(identity)[:16]}.safetensors"

    def get(self, image_path: Path, identity: dict[str, Any], compute: Callable[[], SceneEvidence],
            device: torch.device | str = "cpu") -> SceneEvidence:
        if self.root is None:
            self.misses += 1
            return compute().to(device)
        path = self.path(image_path, identity)
        if path.exists():
            try:
                loaded = self._load(path)
            except (SafetensorError, OSError, ValueError, KeyError):  # damaged entry: recompute and replace it
                loaded = None
            if loaded is not None:
                self.hits += 1
                return loaded.to(device)
        self.misses += 1
        evidence = compute()
        self._store(path, evidence, identity)
        return evidence.to(device)

    @staticmethod
    def _load(path: Path) -> SceneEvidence | None:
        from safetensors import safe_open

        with safe_open(str(path), framework="pt") as handle:
            metadata = handle.metadata() or {}
        if metadata.get("format") != FORMAT:
            return None
        return evidence_from_tensors(load_file(str(path)), metadata)

    @staticmethod
    def _store(path: Path, evidence: SceneEvidence, identity: dict[str, Any]) -> None:
        tensors, metadata = evidence_to_tensors(evidence)
        metadata["identity"] = json.dumps(identity, sort_keys=True)
        temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        save_file(tensors, str(temporary), metadata=metadata)
        os.replace(temporary, path)

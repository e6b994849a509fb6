"""Shipped model files and their manifest: checksums on load, provenance on save.

``models/manifest.json`` maps a model name to its files (sha256 and byte size of each), the data seed, the exact
command that produced it and its metrics. Loading verifies every file against the manifest, so a truncated
download or a stale file fails with a :class:`~po3d_ppl.errors.ModelFileError` that names the file and the fix,
instead of loading wrong weights silently. Weights are safetensors only (never pickle).
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

from po3d_ppl.errors import ModelFileError

MANIFEST = "manifest.json"


def models_dir() -> Path:
    """The shipped ``models/`` directory."""
    from po3d_ppl.resources import resource_dir

    return resource_dir("models")


def sha256_file(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def read_manifest(directory: Path | None = None) -> dict[str, Any]:
    """The manifest of ``directory`` (default: the shipped models); empty if there is none yet."""
    path = Path(directory or models_dir()) / MANIFEST
    if not path.exists():
        return {}
    try:
        data = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise ModelFileError(f"{path}: unreadable model manifest ({exc}); restore it with `git checkout {path}`") \
            from None
    if not isinstance(data, dict):
        raise ModelFileError(f"{path}: the model manifest must be a JSON object")
    return data


def model_files(name: str, directory: Path | None = None, retrain_hint: str = "") -> dict[str, Path]:
    """Paths of model ``name``'s files after checking each one's size and sha256 against the manifest."""
    directory = Path(directory or models_dir())
    fix = retrain_hint or "restore the file from the repository (`git checkout models/`) or retrain the model"
    entry = read_manifest(directory).get(name)
    if not isinstance(entry, Mapping) or not isinstance(entry.get("files"), Mapping):
        raise ModelFileError(f"model {name!r} has no entry in {directory / MANIFEST}; {fix}")
    paths: dict[str, Path] = {}
    for filename, expected in entry["files"].items():
        path = directory / filename
        if not path.is_file():
            raise ModelFileError(f"model file {path} is missing; {fix}")
        size = path.stat().st_size
        if size != expected.get("bytes"):
            raise ModelFileError(f"model file {path} has {size} bytes, the manifest says {expected.get('bytes')}; "
                                 f"{fix}")
        if sha256_file(path) != expected.get("sha256"):
            raise ModelFileError(f"model file {path} does not match its sha256 in {directory / MANIFEST}; {fix}")
        paths[filename] = path
    return paths


def write_entry(name: str, files: Iterable[Path], directory: Path | None = None, **metadata: Any) -> dict[str, Any]:
    """Record ``files`` (already written into ``directory``) as model ``name``, with ``metadata`` (data seed,
    command, metrics ...). Other models' entries are kept; the manifest is replaced atomically."""
    directory = Path(directory or models_dir())
    entry = {"files": {Path(f).name: {"sha256": sha256_file(directory / Path(f).name),
                                      "bytes": (directory / Path(f).name).stat().st_size} for f in files},
             **metadata}
    with _manifest_lock(directory):
        manifest = read_manifest(directory)
        manifest[name] = entry
        _write_manifest(manifest, directory)
    return entry


def record_metrics(name: str, key: str, metrics: Mapping[str, Any], directory: Path | None = None) -> None:
    """Store ``metrics`` under ``metrics[key]`` of model ``name``'s entry (e.g. an evaluation on held-out data),
    keeping everything else."""
    directory = Path(directory or models_dir())
    with _manifest_lock(directory):
        manifest = read_manifest(directory)
        if name not in manifest:
            raise ModelFileError(f"model {name!r} has no entry in {directory / MANIFEST}")
        manifest[name].setdefault("metrics", {})[key] = dict(metrics)
        _write_manifest(manifest, directory)


@contextlib.contextmanager
def _manifest_lock(directory: Path) -> Iterator[None]:
    """Hold an exclusive lock on ``directory`` while its manifest is read, changed and replaced: models trained
    in parallel (``po3d train all``'s parser members) write their entries into one manifest, and an unlocked
    read-modify-write would drop an entry written in between. The lock is on the directory itself (``flock`` on
    its descriptor), so no lock file is left among the models."""
    descriptor = os.open(directory, os.O_RDONLY)
    try:
        fcntl.flock(descriptor, fcntl.LOCK_EX)
        yield
    finally:
        fcntl.flock(descriptor, fcntl.LOCK_UN)
        os.close(descriptor)


def _write_manifest(manifest: Mapping[str, Any], directory: Path) -> None:
    fd, tmp = tempfile.mkstemp(dir=directory, prefix=".manifest-", suffix=".json")
    with os.fdopen(fd, "w") as f:
        json.dump(manifest, f, indent=2, sort_keys=True)
        f.write("\n")
    os.chmod(tmp, 0o644)
    os.replace(tmp, directory / MANIFEST)


def load_tensors(name: str, directory: Path | None = None, retrain_hint: str = "",
                 expected_format: str | None = None) -> tuple[Path, dict[str, str], dict[str, Any]]:
    """(path, metadata, tensors) of model ``name``'s one safetensors file, after the manifest's size and sha256
    checks; a file that will not open, or whose ``format`` metadata is not ``expected_format``, is a
    :class:`ModelFileError` naming it and the fix."""
    from safetensors import safe_open

    fix = retrain_hint or "restore the file from the repository (`git checkout models/`) or retrain the model"
    files = [p for p in model_files(name, directory, retrain_hint).values() if p.suffix == ".safetensors"]
    if len(files) != 1:
        raise ModelFileError(f"model {name!r} should have one safetensors file, the manifest lists {len(files)}; "
                             f"{fix}")
    path = files[0]
    try:
        with safe_open(str(path), framework="pt") as f:
            metadata = dict(f.metadata() or {})
            tensors = {k: f.get_tensor(k) for k in f.keys()}  # noqa: SIM118 (safe_open is no dict)
    except (OSError, ValueError, RuntimeError) as exc:
        raise ModelFileError(f"cannot read {path} ({exc}); {fix}") from None
    if expected_format is not None and metadata.get("format") != expected_format:
        raise ModelFileError(f"{path}: format {metadata.get('format')!r}, expected {expected_format}; {fix}")
    return path, metadata, tensors

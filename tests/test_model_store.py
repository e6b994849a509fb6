"""models/manifest.json bookkeeping: entries written by processes at once are all kept (``po3d train all --jobs``
trains the parser ensemble's members in parallel into one directory), and checksums catch changed files."""

from __future__ import annotations

import multiprocessing
from pathlib import Path

import pytest

from po3d_ppl.errors import ModelFileError
from po3d_ppl.model_store import model_files, read_manifest, record_metrics, write_entry


def _write_many(directory: str, worker: int, count: int) -> None:
    for i in range(count):
        name = f"model_{worker}_{i}"
        (Path(directory) / f"{name}.bin").write_bytes(bytes([worker, i]))
        write_entry(name, [Path(f"{name}.bin")], Path(directory), command=f"worker {worker}")
        record_metrics(name, "check", {"i": i}, Path(directory))


def test_entries_written_by_processes_at_once_are_all_kept(tmp_path):
    context = multiprocessing.get_context("spawn")
    workers = [context.Process(target=_write_many, args=(str(tmp_path), w, 15)) for w in range(3)]
    for process in workers:
        process.start()
    for process in workers:
        process.join(60)
        assert process.exitcode == 0
    manifest = read_manifest(tmp_path)
    assert len(manifest) == 45
    assert all(entry["metrics"]["check"]["i"] == int(name.rsplit("_", 1)[1]) for name, entry in manifest.items())
    assert model_files("model_2_14", tmp_path)


def test_a_changed_file_fails_its_checksum_naming_it(tmp_path):
    (tmp_path / "weights.bin").write_bytes(b"abcd")
    write_entry("weights", [Path("weights.bin")], tmp_path)
    (tmp_path / "weights.bin").write_bytes(b"abce")
    with pytest.raises(ModelFileError, match="weights.bin"):
        model_files("weights", tmp_path)

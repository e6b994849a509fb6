"""Dataset folders that were damaged or abandoned: integrity checks on resume, typed errors naming the file, and
workers that end with the build.

Regression tests of issue 10 ("Reliability"): a truncated ``work/scene_*.json.gz`` was counted as done and the
build died with click's bare "Aborted!" (gzip's EOFError) on every re-run; a garbage ``build_config.json`` was a
JSONDecodeError; killing a ``--workers 2`` build by its parent PID left the workers and the resource tracker
running. One tiny clean build (160x120) is shared; each test damages a copy of it.
"""

from __future__ import annotations

import filecmp
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from po3d_ppl.errors import DamagedFileError, Po3dError
from po3d_ppl.questions import dataset as ds
from po3d_ppl.questions.dataset import BuildConfig, build_dataset

CONFIG = BuildConfig(scenes=3, seed=5, width=160, height=120)


@pytest.fixture(scope="module")
def clean(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("integrity") / "clean"
    build_dataset(root, CONFIG, workers=1)
    return root


@pytest.fixture
def copy(clean, tmp_path) -> Path:
    root = tmp_path / "copy"
    shutil.copytree(clean, root)
    return root


def _files(root: Path) -> list[Path]:
    return sorted(p.relative_to(root) for p in root.rglob("*") if p.is_file())


def assert_same_files(a: Path, b: Path) -> None:
    assert _files(a) == _files(b)
    for rel in _files(a):
        assert filecmp.cmp(a / rel, b / rel, shallow=False), rel


def truncate(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def flip_a_byte(path: Path) -> None:
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0xFF
    path.write_bytes(bytes(data))


def test_every_finished_scene_has_checksums(clean):
    for index in range(CONFIG.scenes):
        stored = json.loads(ds.checksum_path(clean, index).read_text())
        assert set(stored) == {f"images/{ds.IMAGE_PATTERN.format(index)}", f"work/scene_{index:06d}.json.gz"}
        assert ds._damage(clean, index) is None


@pytest.mark.parametrize("damage", [truncate, flip_a_byte, Path.unlink], ids=["truncated", "changed", "missing"])
@pytest.mark.parametrize("which", ["work", "image"])
def test_damaged_scene_files_are_rebuilt_and_reported(clean, copy, damage, which):
    path = ds.work_path(copy, 1) if which == "work" else ds.image_path(copy, 1)
    damage(path)
    notes = []
    report = build_dataset(copy, CONFIG, workers=1, notify=notes.append)
    assert (report.built, report.skipped) == (1, 2)
    name = path.relative_to(copy).as_posix()
    assert len(report.repaired) == 1 and report.repaired[0].startswith(f"scene 1: {name} ")
    assert notes == [f"{report.repaired[0]}; rebuilding it"]
    assert_same_files(clean, copy)
    again = build_dataset(copy, CONFIG, workers=1)
    assert (again.built, again.skipped, again.repaired) == (0, 3, [])


def test_scenes_without_checksums_are_decoded_in_full(clean, copy):
    """Scenes finished before checksums were stored (or killed just before writing them): sound ones are adopted,
    a truncated work file is rebuilt."""
    for index in range(CONFIG.scenes):
        ds.checksum_path(copy, index).unlink()
    truncate(ds.work_path(copy, 2))
    report = build_dataset(copy, CONFIG, workers=1)
    assert (report.built, report.skipped) == (1, 2)
    assert report.repaired == ["scene 2: work/scene_000002.json.gz does not decode (truncated or changed)"]
    assert_same_files(clean, copy)


def test_unfinished_scene_is_built_without_a_repair_note(clean, copy):
    ds.work_path(copy, 2).unlink()  # killed after writing the image, before the work file
    ds.checksum_path(copy, 2).unlink()
    report = build_dataset(copy, CONFIG, workers=1)
    assert (report.built, report.skipped, report.repaired) == (1, 2, [])
    assert_same_files(clean, copy)


def test_damaged_work_file_read_at_assembly_names_the_file(copy):
    truncate(ds.work_path(copy, 1))
    with pytest.raises(DamagedFileError, match=r"scene_000001\.json\.gz is damaged .*run the same build command"):
        ds._read_work(copy, 1)


def test_build_cli_names_the_damaged_file(copy, monkeypatch, capsys):
    """Even where the checks are bypassed, the build's last line says which file failed (it was "Aborted!")."""
    from po3d_ppl.cli import main

    truncate(ds.work_path(copy, 0))
    monkeypatch.setattr(ds, "_survey", lambda root, scenes: ([], []))
    monkeypatch.setattr(sys, "argv", ["po3d", "dataset", "build", "--out", str(copy), "--scenes", "3", "--seed", "5",
                                      "--width", "160", "--height", "120"])
    with pytest.raises(SystemExit) as stopped:
        main()
    err = capsys.readouterr().err
    assert stopped.value.code == 2 and "Traceback" not in err and "Aborted" not in err
    assert err.startswith(f"error: {ds.work_path(copy, 0)} is damaged") and err.count("\n") == 1, err


def test_failing_scene_is_named(tmp_path, monkeypatch):
    def broken(root, config, index):
        raise RuntimeError("renderer exploded")

    monkeypatch.setattr(ds, "build_scene", broken)
    with pytest.raises(RuntimeError, match="renderer exploded") as failed:
        build_dataset(tmp_path / "d", CONFIG, workers=1)
    assert f"while building scene 0 in {tmp_path / 'd'}" in failed.value.__notes__


@pytest.mark.parametrize("content", [b"garbage", b"[1, 2]", b"\xff\xfe", b'{"scenes": 3'])
def test_garbage_build_config_is_a_typed_error_naming_the_file(tmp_path, monkeypatch, capsys, content):
    from po3d_ppl.cli import main

    root = tmp_path / "d"
    root.mkdir()
    (root / "build_config.json").write_bytes(content)
    with pytest.raises(DamagedFileError) as failed:
        build_dataset(root, CONFIG, workers=1)
    message = str(failed.value)
    assert str(root / "build_config.json") in message and "delete it" in message and f"delete {root}" in message
    monkeypatch.setattr(sys, "argv", ["po3d", "dataset", "build", "--out", str(root), "--scenes", "3"])
    with pytest.raises(SystemExit) as stopped:
        main()
    err = capsys.readouterr().err
    assert stopped.value.code == 2 and err.startswith("error: ") and err.count("\n") == 1, err


# ---- orphans ------------------------------------------------------------------------------------------------------
def _children(pid: int) -> list[int]:
    """Processes whose parent is ``pid`` (Linux /proc)."""
    kids = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rpartition(")")[2].split()
            except OSError:
                continue
            if int(fields[1]) == pid:
                kids.append(int(entry.name))
    return kids


def _alive(pid: int) -> bool:
    try:
        return (Path("/proc") / str(pid) / "stat").read_text().rpartition(")")[2].split()[0] != "Z"
    except OSError:
        return False


def _is_stray_worker(pid: int) -> bool:
    try:
        return _alive(pid) and b"multiprocessing" in (Path("/proc") / str(pid) / "cmdline").read_bytes()
    except OSError:
        return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM], ids=["SIGKILL", "SIGTERM"])
def test_workers_end_when_the_build_process_is_killed(tmp_path, sig):
    out = tmp_path / "d"
    proc = subprocess.Popen([sys.executable, "-m", "po3d_ppl", "dataset", "build", "--out", str(out), "--scenes", "40",
                             "--width", "160", "--height", "120", "--workers", "2"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    kids: list[int] = []
    try:
        deadline = time.monotonic() + 60
        while not ds.checksum_path(out, 0).exists() and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.05)
        assert proc.poll() is None, "the build ended before it could be killed"
        kids = _children(proc.pid)
        assert len(kids) >= 3, kids  # two workers and the resource tracker
        proc.send_signal(sig)
        proc.wait(timeout=10)
        deadline = time.monotonic() + 10
        while any(map(_alive, kids)) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not [k for k in kids if _alive(k)], "workers or the resource tracker outlived the build"
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        for kid in filter(_is_stray_worker, kids):  # never leave strays behind, even when the test fails
            os.kill(kid, signal.SIGKILL)


def test_po3d_errors_stay_catchable_as_one_base_class():
    assert issubclass(DamagedFileError, Po3dError) and issubclass(DamagedFileError, ValueError)

"""Dataset builder and loader: rendered scenes, public scene and question files, splits and a manifest.

Layout of a build directory::

    images/superCLEVR_new_%06d.png      rendered images
    scenes.json                         {"info", "scenes"} in the public layout (scene_to_public)
    questions/<set>.json                {"info", "questions"}: parts, pose, occlusion, obj_occlusion, core
                                        (+ height_depth with --height-depth)
    splits.json                         {"train": [...], "val": [...], "test": [...]} image indices
    manifest.json                       version, seed, config, counts
    work/scene_%06d.json.gz             per-scene intermediate: public scene + candidate questions (JSON lines)
    work/scene_%06d.sha256              sha256 of the scene's work file and image (JSON), the completion marker

Design:
- Scene i is generated from ``SeedSequence([seed, i])``, independently of every other scene, by any worker.
  Its checksum file is the completion marker, written last and atomically, so a killed build resumes where it
  stopped and never reads a half-written file. A resumed build checks every finished scene against its
  checksums (files truncated or changed by a full disk, a crash or a copy) and rebuilds the damaged ones.
- Workers end with the build process, however it ends (``PR_SET_PDEATHSIG`` on Linux, a watchdog thread).
- Answers are balanced across the whole build (:mod:`po3d_ppl.questions.balance`), which needs scenes in order:
  workers only produce candidates; the final files are assembled sequentially from the work files (cheap), so
  the output is byte-identical whatever the number of workers or interruptions.
- Every file is written to a temporary name and moved into place with ``os.replace``.
"""

from __future__ import annotations

import ctypes
import dataclasses
import gzip
import hashlib
import json
import math
import os
import signal
import sys
import threading
import time
import zlib
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from multiprocessing import get_context
from pathlib import Path

import numpy as np

import po3d_ppl
from po3d_ppl.catalogue.semantics import DEFAULT_SEMANTICS, PUBLIC, check_semantics
from po3d_ppl.errors import DamagedFileError, InputError, Po3dError
from po3d_ppl.questions.generator import Candidate
from po3d_ppl.questions.question_sets import public_family_index, question_sets
from po3d_ppl.questions.scene_questions import (
    balancer_for,
    families_of,
    public_question,
    scene_candidates,
    select_for_scene,
)

FORMAT_VERSION = 1
SPLITS = ("train", "val", "test")
#: The real dataset's 20k / 5k / 5k proportions.
DEFAULT_SPLIT_FRACTIONS = (4 / 6, 1 / 6, 1 / 6)
IMAGE_PATTERN = "superCLEVR_new_{:06d}.png"
_LICENSE = "Creative Commons Attribution (CC-BY 4.0)"


@dataclass(frozen=True)
class BuildConfig:
    """Everything that determines a build's content (the worker count does not)."""

    scenes: int
    seed: int = 0
    width: int = 640
    height: int = 480
    height_depth: bool = False
    split_fractions: tuple[float, float, float] = DEFAULT_SPLIT_FRACTIONS
    redundancy: float = 1.0
    min_objects: int = 3
    max_objects: int = 10
    #: "intended" or "public" (docs/semantics.md): the answers, and the generator's rules, of that semantics
    semantics: str = "intended"

    def __post_init__(self) -> None:
        def need(ok: bool, name: str, msg: str) -> None:
            if not ok:
                raise InputError(name, f"{msg}, got {getattr(self, name)!r}")

        for name in ("scenes", "seed", "width", "height", "min_objects", "max_objects"):
            value = getattr(self, name)
            need(isinstance(value, int) and not isinstance(value, bool), name, "must be an integer")
        need(self.scenes >= 1, "scenes", "must be at least 1")
        need(self.seed >= 0, "seed", "must be a non-negative integer")
        need(self.width >= 16 and self.height >= 16, "width", "image sides must be at least 16 pixels")
        need(len(self.split_fractions) == 3 and all(f >= 0 for f in self.split_fractions)
             and math.isclose(sum(self.split_fractions), 1.0, abs_tol=1e-6), "split_fractions",
             "must be three non-negative fractions (train, val, test) summing to 1")
        need(-1.0 <= self.redundancy <= 1.0, "redundancy", "must be in [-1, 1]")
        check_semantics(self.semantics)
        need(not (self.semantics == PUBLIC and self.height_depth), "height_depth",
             "the height/depth families have no public semantics (public scene files hold no above/below "
             "relations); build them under semantics 'intended'")
        need(not (self.semantics == PUBLIC and self.redundancy < 0), "redundancy",
             "must be >= 0 under public semantics (the public generator crashes on part keys with r < 0)")

    def scene_config(self):
        from po3d_ppl.world.sampler import SceneConfig

        return SceneConfig(min_objects=self.min_objects, max_objects=self.max_objects, width=self.width,
                           height=self.height, elevated_aeroplanes=self.height_depth)

    def to_json(self) -> dict:
        out = {**dataclasses.asdict(self), "split_fractions": list(self.split_fractions)}
        if self.semantics == DEFAULT_SEMANTICS:  # builds from before the setting read the same
            del out["semantics"]
        return out


def split_sizes(n: int, fractions: Sequence[float]) -> tuple[int, int, int]:
    train = round(n * fractions[0])
    val = min(n - train, round(n * fractions[1]))
    return train, val, n - train - val


def split_of(index: int, n: int, fractions: Sequence[float]) -> str:
    """Contiguous splits: the first ~2/3 of the indices train, then val, then test."""
    train, val, _ = split_sizes(n, fractions)
    return "train" if index < train else "val" if index < train + val else "test"


def scene_seeds(seed: int, index: int) -> tuple[int, int]:
    """(render seed, question seed) of scene ``index``, from ``SeedSequence([seed, index])``."""
    state = np.random.SeedSequence([seed, index]).generate_state(2)
    return int(state[0]), int(state[1])


# ---- atomic files ---------------------------------------------------------------------------------------------
def _temp_path(path: Path) -> Path:
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` so that readers see the old file or the whole new one, never a part."""
    tmp = _temp_path(path)
    try:
        with open(tmp, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def _dumps(data: object) -> str:
    return json.dumps(data, allow_nan=False)


class _JsonListFile:
    """Streams ``{"info": ..., "<key>": [items...]}`` to a temporary file; :meth:`commit` moves it into place."""

    def __init__(self, path: Path, info: dict, key: str):
        self.path, self.tmp = path, _temp_path(path)
        self.f = open(self.tmp, "w", encoding="utf-8")
        self.f.write('{"info": ' + _dumps(info) + ', "' + key + '": [')
        self.count = 0

    def add(self, item: object) -> None:
        self.add_json(_dumps(item))

    def add_json(self, text: str) -> None:
        """Append an item already encoded as JSON text."""
        self.f.write(("\n" if self.count == 0 else ",\n") + text)
        self.count += 1

    def commit(self) -> None:
        self.f.write("\n]}\n")
        self.f.close()
        os.replace(self.tmp, self.path)

    def abort(self) -> None:
        """Drop the temporary file (a no-op after a successful commit)."""
        self.f.close()
        self.tmp.unlink(missing_ok=True)


# ---- per-scene work ---------------------------------------------------------------------------------------------
def work_path(root: Path, index: int) -> Path:
    return root / "work" / f"scene_{index:06d}.json.gz"


def image_path(root: Path, index: int) -> Path:
    return root / "images" / IMAGE_PATTERN.format(index)


def checksum_path(root: Path, index: int) -> Path:
    return root / "work" / f"scene_{index:06d}.sha256"


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _relative(root: Path, path: Path) -> str:
    return path.relative_to(root).as_posix()


def _scene_files(root: Path, index: int) -> tuple[Path, Path]:
    """The files a finished scene consists of (its checksum file excluded)."""
    return image_path(root, index), work_path(root, index)


def _write_checksums(root: Path, index: int, contents: dict[Path, bytes]) -> None:
    digests = {_relative(root, path): _sha256(data) for path, data in sorted(contents.items())}
    atomic_write_bytes(checksum_path(root, index), (json.dumps(digests, indent=1) + "\n").encode())


def _damage(root: Path, index: int) -> str | None:
    """Why the finished scene ``index`` cannot be used (a file missing, or not matching its stored sha256), or
    None when it is intact. Raises FileNotFoundError when the scene was never finished (no checksum file)."""
    try:
        stored = json.loads(checksum_path(root, index).read_text(encoding="utf-8"))
        if not isinstance(stored, dict):
            raise ValueError("not a JSON object")
    except (UnicodeDecodeError, ValueError) as exc:
        return f"{_relative(root, checksum_path(root, index))} is unreadable ({exc})"
    for path in _scene_files(root, index):
        name = _relative(root, path)
        if not path.is_file():
            return f"{name} is missing"
        if stored.get(name) != _sha256(path.read_bytes()):
            return f"{name} does not match its sha256 (truncated or changed)"
    return None


def _unchecked_damage(root: Path, index: int) -> str | None:
    """For a scene whose work file exists without a checksum file (killed just before writing it, or built
    before checksums were stored): why it cannot be used, or None after decoding its work file and image in
    full and storing their checksums."""
    import cv2

    image, work = _scene_files(root, index)
    if not image.is_file():
        return f"{_relative(root, image)} is missing"
    try:
        _read_work(root, index)
    except DamagedFileError:
        return f"{_relative(root, work)} does not decode (truncated or changed)"
    data = {image: image.read_bytes(), work: work.read_bytes()}
    if cv2.imdecode(np.frombuffer(data[image], np.uint8), cv2.IMREAD_UNCHANGED) is None:
        return f"{_relative(root, image)} does not decode (truncated or changed)"
    _write_checksums(root, index, data)
    return None


def _survey(root: Path, scenes: int) -> tuple[list[int], list[str]]:
    """(scenes still to build, why each damaged one among them is rebuilt). The files of a damaged scene are
    removed, so that a build killed while rebuilding it cannot take them for finished ones."""
    pending, repairs = [], []
    for index in range(scenes):
        try:
            reason = _damage(root, index)
        except FileNotFoundError:  # no checksum file: never finished, or finished before checksums
            reason = _unchecked_damage(root, index) if work_path(root, index).is_file() else ""
        if reason is None:
            continue
        if reason:
            for path in (checksum_path(root, index), *_scene_files(root, index)):
                path.unlink(missing_ok=True)
            repairs.append(f"scene {index}: {reason}")
        pending.append(index)
    return pending, repairs


@dataclass
class SceneTiming:
    render_s: float
    questions_s: float
    questions: int


def build_scene(root: Path, config: BuildConfig, index: int) -> SceneTiming:
    """Render scene ``index``, generate its candidate questions and write its image and work file."""
    import cv2

    from po3d_ppl.world.generate import generate_scene
    from po3d_ppl.world.scene_io import scene_to_public

    render_seed, question_seed = scene_seeds(config.seed, index)
    start = time.perf_counter()
    rendered = generate_scene(render_seed, config.scene_config(), image_index=index)
    scene = dataclasses.replace(rendered.scene, image_index=index, image_filename=IMAGE_PATTERN.format(index),
                                split=split_of(index, config.scenes, config.split_fractions))
    ok, png = cv2.imencode(".png", cv2.cvtColor(rendered.image, cv2.COLOR_RGB2BGR))
    if not ok:
        raise RuntimeError(f"scene {index}: PNG encoding failed")
    image = png.tobytes()
    atomic_write_bytes(image_path(root, index), image)
    rendered_at = time.perf_counter()
    sets = question_sets(config.height_depth).values()
    found = scene_candidates(scene, question_seed, families_of(sets), redundancy=config.redundancy,
                             semantics=config.semantics)
    # two JSON lines: the public scene (copied verbatim into scenes.json) and the candidates
    record = _dumps(scene_to_public(scene)) + "\n" + _dumps(
        [[f, i, [c.to_record() for c in cands]] for (f, i), cands in found.items()]) + "\n"
    done = time.perf_counter()
    work = gzip.compress(record.encode(), mtime=0)
    atomic_write_bytes(work_path(root, index), work)
    _write_checksums(root, index, {image_path(root, index): image, work_path(root, index): work})
    return SceneTiming(rendered_at - start, done - rendered_at, sum(len(c) for c in found.values()))


class SceneBuildError(Po3dError):
    """A scene of a build could not be made; the message names the scene (picklable across processes)."""


def _build_scene_task(root: Path, config: BuildConfig, index: int) -> SceneTiming:
    try:
        return build_scene(root, config, index)
    except Po3dError as exc:  # re-raised as a plain message: typed errors with extra fields do not unpickle
        raise SceneBuildError(f"scene {index}: {exc}") from None
    except Exception as exc:  # a bug or the system (disk full): keep the traceback, and say which scene failed
        exc.add_note(f"while building scene {index} in {root}")
        raise


def _read_work(root: Path, index: int) -> tuple[str, list]:
    """(public scene as JSON text, candidate records) of a finished scene. A work file that does not decode in
    full (gzip checks its CRC and length) is a :class:`DamagedFileError` naming it."""
    path = work_path(root, index)
    try:
        scene_text, _, candidates = gzip.decompress(path.read_bytes()).decode().partition("\n")
        if not candidates.strip():  # the first work format, one object: {"scene", "candidates"} (old builds)
            record = json.loads(scene_text)
            return _dumps(record["scene"]), record["candidates"]
        json.loads(scene_text)
        return scene_text, json.loads(candidates)
    except (OSError, EOFError, zlib.error, UnicodeDecodeError, ValueError, KeyError, TypeError) as exc:
        raise DamagedFileError(f"{path} is damaged ({type(exc).__name__}: {exc}); run the same build command "
                               "again to rebuild that scene") from None


# ---- assembly -----------------------------------------------------------------------------------------------------
def _assemble(root: Path, config: BuildConfig) -> dict:
    """Write scenes.json, questions/*.json, splits.json and manifest.json from the work files, in scene order."""
    sets = question_sets(config.height_depth)
    balancer = balancer_for(config.semantics)
    rng = np.random.default_rng(np.random.SeedSequence([config.seed], spawn_key=(7,)))
    (root / "questions").mkdir(exist_ok=True)
    scenes_file = _JsonListFile(root / "scenes.json", {"date": "", "version": "1.0", "split": "all",
                                                       "license": _LICENSE}, "scenes")
    question_files = {name: _JsonListFile(root / "questions" / f"{name}.json",
                                          {"date": "", "version": "1.0", "split": "all", "license": _LICENSE,
                                           "question_set": name}, "questions") for name in sets}
    family_counts = {name: Counter() for name in sets}
    outputs = (scenes_file, *question_files.values())
    try:
        for index in range(config.scenes):
            scene_text, records = _read_work(root, index)
            scenes_file.add_json(scene_text)
            candidates = {(f, i): [Candidate.from_record(r) for r in recs] for f, i, recs in records}
            split = split_of(index, config.scenes, config.split_fractions)
            for name, chosen in select_for_scene(candidates, sets.values(), balancer, rng).items():
                out = question_files[name]
                for cand in chosen:
                    if config.semantics == PUBLIC:
                        cand = dataclasses.replace(cand, question_family_index=public_family_index(
                            name, cand.template_filename, cand.question_family_index))
                    out.add(public_question(cand, index, IMAGE_PATTERN.format(index), split, out.count))
                    family_counts[name][f"{cand.template_filename}:{cand.question_family_index}"] += 1
        for f in outputs:
            f.commit()
    finally:
        for f in outputs:
            f.abort()
    sizes = split_sizes(config.scenes, config.split_fractions)
    bounds = np.cumsum((0,) + sizes)
    splits = {name: list(range(int(bounds[k]), int(bounds[k + 1]))) for k, name in enumerate(SPLITS)}
    atomic_write_bytes(root / "splits.json", (_dumps(splits) + "\n").encode())
    manifest = {
        "name": "po3d_ppl Super-CLEVR-3D-style dataset", "format": FORMAT_VERSION,
        "po3d_ppl_version": po3d_ppl.__version__, "seed": config.seed, "config": config.to_json(),
        "counts": {"scenes": config.scenes, "splits": {k: len(v) for k, v in splits.items()},
                   "questions": {name: f.count for name, f in question_files.items()},
                   "families": {name: dict(sorted(c.items())) for name, c in family_counts.items()}},
        "question_sets": {name: {"families": [f"{f}:{i}" for f, i in s.families], "per_scene": s.per_scene}
                          for name, s in sets.items()},
    }
    atomic_write_bytes(root / "manifest.json", (json.dumps(manifest, indent=1) + "\n").encode())
    return manifest


# ---- build --------------------------------------------------------------------------------------------------------
@dataclass
class BuildReport:
    manifest: dict
    built: int
    skipped: int
    timings: list[SceneTiming] = field(default_factory=list)
    #: why each damaged scene found on resume was rebuilt ("scene 3: work/scene_000003.json.gz is missing")
    repaired: list[str] = field(default_factory=list)
    assemble_s: float = 0.0
    wall_s: float = 0.0


def _check_config(root: Path, config: BuildConfig) -> None:
    path, wanted = root / "build_config.json", config.to_json()
    if path.is_file():
        existing = _read_build_config(path)
        if existing != wanted:
            diff = sorted(k for k in wanted if existing.get(k) != wanted[k])
            raise InputError("out", f"{root} holds a build with different settings ({', '.join(diff)}); use another "
                                    "directory or the same settings to resume it")
    else:
        atomic_write_bytes(path, (json.dumps(wanted, indent=1) + "\n").encode())


def _read_build_config(path: Path) -> dict:
    """The settings a build directory was started with; a damaged file is a typed error saying how to go on."""
    try:
        existing = json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        reason = f"not valid JSON ({exc.msg} at line {exc.lineno})" if isinstance(exc, json.JSONDecodeError) \
            else "not UTF-8 text"
    else:
        if isinstance(existing, dict):
            return existing
        reason = f"a JSON {type(existing).__name__}, not an object"
    raise DamagedFileError(f"{path} is damaged: {reason}; delete it to resume the build with the settings given "
                           f"now, or delete {path.parent} to start over")


def _clean_temporaries(root: Path) -> None:
    for folder in (root, root / "work", root / "images", root / "questions"):
        if folder.is_dir():
            for tmp in folder.glob(".*.tmp"):
                tmp.unlink(missing_ok=True)


def build_dataset(out: str | os.PathLike, config: BuildConfig, *, workers: int = 1,
                  progress: Callable[[int, int], None] | bool = False,
                  notify: Callable[[str], None] | None = None) -> BuildReport:
    """Build (or resume) a dataset in ``out``. ``progress`` is True for a rich progress bar, or a callback
    ``(done, total)``. ``notify`` is told of every damaged scene found on resume before it is rebuilt (the
    report lists them too)."""
    if not isinstance(workers, int) or workers < 1:
        raise InputError("workers", f"must be a positive integer, got {workers!r}")
    config.scene_config()  # invalid scene settings fail here, before any directory is made
    root = Path(out)
    if root.exists() and not root.is_dir():
        raise InputError("out", f"{root} exists and is not a directory")
    for sub in ("images", "work", "questions"):
        (root / sub).mkdir(parents=True, exist_ok=True)
    _check_config(root, config)
    _clean_temporaries(root)
    start = time.perf_counter()
    pending, repaired = _survey(root, config.scenes)
    for note in repaired if notify is not None else ():
        notify(f"{note}; rebuilding it")
    report = BuildReport({}, built=len(pending), skipped=config.scenes - len(pending), repaired=repaired)
    for timing in _run(root, config, pending, workers, progress):
        report.timings.append(timing)
    assembled = time.perf_counter()
    report.manifest = _assemble(root, config)
    report.assemble_s = time.perf_counter() - assembled
    report.wall_s = time.perf_counter() - start
    return report


def _run(root: Path, config: BuildConfig, pending: list[int], workers: int,
         progress: Callable[[int, int], None] | bool) -> Iterator[SceneTiming]:
    total = len(pending)
    bar = None
    if progress is True:
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeRemainingColumn

        bar = Progress("[progress.description]{task.description}", BarColumn(), MofNCompleteColumn(),
                       TimeRemainingColumn())
        task = bar.add_task("scenes", total=total)
        bar.start()

    def tick(done: int) -> None:
        if bar is not None:
            bar.update(task, completed=done)
        elif callable(progress):
            progress(done, total)

    try:
        if workers == 1 or total <= 1:
            for k, index in enumerate(pending):
                yield _build_scene_task(root, config, index)
                tick(k + 1)
            return
        with ProcessPoolExecutor(max_workers=min(workers, total), mp_context=get_context("spawn"),
                                 initializer=_end_with_parent, initargs=(os.getpid(),)) as pool:
            futures = [pool.submit(_build_scene_task, root, config, i) for i in pending]
            try:
                for k, future in enumerate(as_completed(futures)):
                    yield future.result()
                    tick(k + 1)
            except BaseException:  # a failed scene, Ctrl-C or an abandoned generator: do not render the rest
                pool.shutdown(wait=False, cancel_futures=True)
                raise
    finally:
        if bar is not None:
            bar.stop()


# ---- workers end with the build --------------------------------------------------------------------------------
_PR_SET_PDEATHSIG = 1
_PARENT_POLL_S = 0.5


def _end_with_parent(parent: int) -> None:
    """Pool initializer: end this worker when the build process ends, even by SIGKILL. Otherwise a killed build
    leaves its workers rendering for nobody, and the multiprocessing resource tracker they hold open."""
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, ctypes.c_ulong(signal.SIGKILL), ctypes.c_ulong(0), ctypes.c_ulong(0),
                       ctypes.c_ulong(0))
        except (OSError, AttributeError):
            pass
    if os.getppid() != parent:  # the build ended before the signal was armed
        os._exit(1)
    # the portable fallback, and a second line of defence where prctl is tied to the spawning thread
    threading.Thread(target=_poll_parent, args=(parent,), name="po3d-parent-watch", daemon=True).start()


def _poll_parent(parent: int) -> None:
    while os.getppid() == parent:
        time.sleep(_PARENT_POLL_S)
    os._exit(1)


# ---- loading ------------------------------------------------------------------------------------------------------
@dataclass
class DatasetSplit:
    name: str
    #: scenes of the split, in image-index order
    scenes: list
    #: question set name -> questions of the split's images
    questions: dict[str, list[dict]]


@dataclass
class Dataset:
    """A built dataset: manifest, splits, public scene dicts and questions (parsed into Scenes on demand)."""

    root: Path
    manifest: dict
    splits: dict[str, list[int]]
    public_scenes: list[dict]
    questions: dict[str, list[dict]]

    def image_path(self, index: int) -> Path:
        return image_path(self.root, index)

    def scene(self, index: int):
        from po3d_ppl.world.scene_io import scene_from_public

        return scene_from_public(self.public_scenes[index], f"{self.root / 'scenes.json'}: scenes[{index}]")

    def split_indices(self, name: str) -> list[int]:
        """The image indices of split ``name``; ``"all"``: every image (a dataset held out as a whole, e.g. a seed
        built only for testing)."""
        if name != "all" and name not in self.splits:
            raise InputError("split", f"unknown split {name!r} (known: {', '.join(self.splits)}, or all)")
        return sorted(i for part in self.splits.values() for i in part) if name == "all" else list(self.splits[name])

    def split(self, name: str) -> DatasetSplit:
        """The images and questions of split ``name`` (:meth:`split_indices`)."""
        indices = self.split_indices(name)
        members = set(indices)
        return DatasetSplit(name, [self.scene(i) for i in indices],
                            {k: [q for q in qs if q["image_index"] in members] for k, qs in self.questions.items()})


def _read_json_file(path: Path, what: str) -> object:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(what, f"{path} is missing; is this a finished `po3d dataset build` directory?") from None
    except json.JSONDecodeError as exc:
        raise InputError(what, f"{path} is not valid JSON ({exc.msg} at line {exc.lineno})") from None


def load_dataset(root: str | os.PathLike) -> Dataset:
    """Load a built dataset directory."""
    root = Path(root)
    if not root.is_dir():
        raise InputError("dataset", f"{root} is not a directory")
    manifest = _read_json_file(root / "manifest.json", "manifest")
    splits = _read_json_file(root / "splits.json", "splits")
    scenes = _read_json_file(root / "scenes.json", "scenes")["scenes"]
    questions = {p.stem: _read_json_file(p, f"questions/{p.name}")["questions"]
                 for p in sorted((root / "questions").glob("*.json"))}
    return Dataset(root, manifest, splits, scenes, questions)

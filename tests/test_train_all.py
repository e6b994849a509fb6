"""``po3d train all``: the whole training chain at ``--scale tiny`` into a temporary directory (every model in the
manifest with its sha256, the per-stage timing report), prerequisites as typed errors naming the stage to run first,
and ``--scale full`` against the commands recorded in models/manifest.json."""

from __future__ import annotations

import itertools
import json
import os
import shlex
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from po3d_ppl.cli import app, main
from po3d_ppl.cli.train_all import FULL, REPORT, SCALES, STAGES, TEST_SEED, TIMELINE, TINY, link, plan
from po3d_ppl.model_store import models_dir, read_manifest, sha256_file

#: every model the chain writes (manifest name -> files)
MODELS = {
    "question_parser": ("question_parser.safetensors", "question_parser.vocab.json"),
    "question_parser_cr_seed0": ("question_parser_cr_seed0.safetensors", "question_parser_cr_seed0.vocab.json"),
    "question_parser_ensemble": ("question_parser_ensemble.json",),
    "perception_features": ("perception_features.safetensors",),
    "background": ("background.safetensors",),
    "object_calibration": ("object_calibration.safetensors",),
    "attributes": ("attributes.safetensors",),
    "viewpoint": ("viewpoint.safetensors",),
    "centres": ("centres.safetensors",),
    "projection_calibration": ("projection_calibration.safetensors",),
    "priors": ("priors.json",),
    "answer_calibration": ("answer_calibration.json",),
    "answer_calibration_soft": ("answer_calibration_soft.json",),
    "answer_calibration_thresholded": ("answer_calibration_thresholded.json",),
}


@pytest.fixture(scope="module")
def tiny_chain(tmp_path_factory, torch_one_thread):
    root = tmp_path_factory.mktemp("train_all")
    data, out = root / "data", root / "models"
    result = CliRunner().invoke(app, ["train", "all", "--data", str(data), "--out", str(out), "--scale", "tiny",
                                      "--seed", "0", "--threads", "1", "--jobs", "1"])
    assert result.exit_code == 0, (result.output, result.exception)
    return data, out, result.output


@pytest.mark.slow
def test_tiny_chain_writes_every_model_with_its_sha256(tiny_chain):
    data, out, _ = tiny_chain
    manifest = read_manifest(out)
    assert set(MODELS) <= set(manifest)
    for name, files in MODELS.items():
        entry = manifest[name]
        assert set(entry["files"]) == set(files), name
        for filename in files:
            assert entry["files"][filename]["sha256"] == sha256_file(out / filename), filename
        assert entry["command"].startswith("po3d train "), name
    priors = manifest["priors"]
    assert "--split train" in priors["command"] and priors["metrics"]["scenes"] > 0
    caches = ("attribute_crops", "centre_features")
    assert sorted(p.name for p in data.iterdir() if p.name not in caches) == sorted(d.name for d in TINY.datasets)
    assert all(json.loads((data / d.name / "manifest.json").read_text())["seed"] == d.seed for d in TINY.datasets)


@pytest.mark.slow
def test_tiny_chain_reports_every_stage_with_seconds(tiny_chain):
    _, out, output = tiny_chain
    report = json.loads((out / REPORT).read_text())
    assert list(report["stages"]) == list(STAGES)
    for stage, row in report["stages"].items():
        assert isinstance(row["seconds"], float | int) and row["seconds"] >= 0, stage
        assert row["cpu_seconds"] >= 0 and row["steps"], stage
        assert all(step["command"].startswith("po3d ") for step in row["steps"]), stage
    assert report["total_seconds"] == pytest.approx(sum(r["seconds"] for r in report["stages"].values()), abs=0.2)
    assert report["scale"] == "tiny" and report["threads"] == 1 and report["jobs"] == 1
    # --jobs 1: one command after another in this process, in the stages' order, timed from the run's start
    steps = [step for row in report["stages"].values() for step in row["steps"]]
    assert all(0 <= step["start"] <= step["end"] for step in steps)
    assert [step["step"] for step in report["stages"]["parser"]["steps"]][-1] == "parser ensemble"
    by_start = sorted(steps, key=lambda step: step["start"])
    assert all(a["end"] <= b["start"] + 0.2 for a, b in itertools.pairwise(by_start))
    assert report["wall_seconds"] >= sum(step["seconds"] for step in steps) - 1.0
    for stage in STAGES:  # the printed table
        assert stage in output
    assert "total" in output and REPORT in output


@pytest.mark.slow
def test_a_stage_alone_reads_the_earlier_ones_from_out_and_keeps_their_timings(tiny_chain, monkeypatch, capsys):
    data, out, _ = tiny_chain
    before = json.loads((out / REPORT).read_text())["stages"]["perception"]
    code, stdout, err = run_main(monkeypatch, capsys, "train", "all", "--data", str(data), "--out", str(out),
                                 "--scale", "tiny", "--stages", "calibration,priors", "--jobs", "2")
    assert code == 0, err
    report = json.loads((out / REPORT).read_text())
    assert list(report["stages"]) == list(STAGES)  # earlier stages' timings are kept
    assert report["stages"]["perception"] == before
    assert report["stages"]["calibration"]["outputs"] == ["object_calibration.safetensors"]
    assert "(earlier run)" in stdout and "$ po3d train calibration" in stdout
    # --jobs 2: each command a `po3d` process of its own, its output in a log, its CPU seconds measured
    ran = [step for stage in ("datasets", "calibration", "priors") for step in report["stages"][stage]["steps"]]
    assert all(Path(step["log"]).is_file() and step["cpu_seconds"] > 0 for step in ran)
    assert report["stages"]["calibration"]["start"] >= max(step["end"] for step in report["stages"]["datasets"]
                                                          ["steps"] if "val_s712" in step["step"])
    assert (out / TIMELINE).stat().st_size > 0


def run_main(monkeypatch, capsys, *args: str) -> tuple[int, str, str]:
    """(exit code, stdout, stderr) of ``po3d ARGS`` run by the real entry point, in this process."""
    monkeypatch.setattr(sys, "argv", ["po3d", *args])
    with pytest.raises(SystemExit) as stopped:
        main()
    out = capsys.readouterr()
    return stopped.value.code or 0, out.out, out.err


def test_calibration_on_an_empty_out_names_the_features_stage(monkeypatch, capsys, tmp_path):
    data = tmp_path / "data"
    code, _, err = run_main(monkeypatch, capsys, "train", "all", "--data", str(data), "--out",
                            str(tmp_path / "out"), "--scale", "tiny", "--stages", "calibration")
    assert code == 2 and "Traceback" not in err and err.startswith("error: --stages") and err.count("\n") == 1, err
    assert "'calibration' needs the perception features of stage 'perception'" in err
    assert "--stages perception" in err
    assert not data.exists()  # checked before anything is built


@pytest.mark.parametrize("args, fragment", [
    (["--stages", "parser,features"], "unknown stage 'features'"),
    (["--scale", "huge"], "unknown scale 'huge'"),
    (["--seed", "-1"], "--seed"),
])
def test_bad_options_are_one_line_errors(monkeypatch, capsys, tmp_path, args, fragment):
    code, _, err = run_main(monkeypatch, capsys, "train", "all", "--data", str(tmp_path / "d"), "--out",
                            str(tmp_path / "o"), *args)
    assert code == 2 and err.startswith("error: ") and err.count("\n") == 1 and fragment in err, err


def test_tiny_never_writes_into_the_shipped_models(monkeypatch, capsys, tmp_path):
    for out in ([], ["--out", str(models_dir())]):
        code, _, err = run_main(monkeypatch, capsys, "train", "all", "--data", str(tmp_path), "--scale", "tiny",
                                *out)
        assert code == 2 and "--out" in err, err


def test_no_scale_uses_the_held_out_test_seed():
    for scale in SCALES.values():
        assert TEST_SEED not in {d.seed for d in scale.datasets}


def _options(words: list[str]) -> dict[str, str]:
    """Option -> value of a command line (paths and directories left out, and --threads: the chain's is the run's
    choice, each model's manifest records the one it was trained with)."""
    skip = {"--data", "--out", "--eval-data", "--model-dir", "--cache", "--threads"}
    options, i = {}, 0
    while i < len(words):
        if words[i].startswith("--") and i + 1 < len(words) and not words[i + 1].startswith("--"):
            if words[i] not in skip:
                options[words[i]] = words[i + 1]
            i += 2
        else:
            i += 1
    return options


def test_full_scale_repeats_the_shipped_commands(tmp_path):
    """Every option of each shipped model's recorded command has the same value in the chain's full plan."""
    shipped = read_manifest()
    steps = plan(FULL, tmp_path / "data", tmp_path / "out", seed=0, threads=1)
    ours = {step.label: step.words for stage in steps.values() for step in stage}
    recorded = {"parser": shipped["question_parser"]["command"],
                "parser calibration": shipped["question_parser"]["calibration_command"],
                **{f"parser{suffix} {name}": shipped[name][key] for name in ("question_parser_cr_seed0",
                                                                             "question_parser_w2_seed2")
                   for suffix, key in (("", "command"), (" calibration", "calibration_command"))},
                "parser ensemble": shipped["question_parser_ensemble"]["command"],
                "perception": shipped["perception_features"]["command"],
                "background": shipped["background"]["command"],
                "calibration": shipped["object_calibration"]["command"],
                "attributes": shipped["attributes"]["command"],
                "viewpoint": shipped["viewpoint"]["command"],
                "centres": shipped["centres"]["command"],
                "projection": shipped["projection_calibration"]["command"]}
    for label, command in recorded.items():
        words = shlex.split(command)
        assert words[:3] == ours[label][:3], label
        expected, got = _options(words), _options(ours[label])
        assert {k: got.get(k) for k in expected} == expected, label
        # as many training datasets
        datasets = [w for k, w in itertools.pairwise(words) if k == "--data"]
        assert len(datasets) == len([w for k, w in itertools.pairwise(ours[label]) if k == "--data"]), label
    # the answer calibration reads as many validation seeds as the shipped fit (its --cache is not an option)
    answer_words = shlex.split(shipped["answer_calibration"]["command"])
    assert sum(w == "--data" for w in answer_words) == sum(w == "--data" for w in ours["answer calibration"])
    for method in ("soft", "thresholded"):  # the baselines' calibrations, fitted the same way
        words = shlex.split(shipped[f"answer_calibration_{method}"]["command"])
        assert _options(words)["--method"] == _options(ours[f"answer calibration ({method})"])["--method"] == method
        assert [w for k, w in itertools.pairwise(words) if k == "--data"] == \
            [w for k, w in itertools.pairwise(answer_words) if k == "--data"]
    built = {(d.seed, d.scenes) for d in FULL.datasets}
    recorded_builds = set()
    for entry in shipped.values():
        for command in entry.get("data_commands", []):
            words = _options(shlex.split(command))
            recorded_builds.add((int(words["--seed"]), int(words["--scenes"])))
    assert built <= recorded_builds


def test_a_failed_command_stops_the_others(tmp_path):
    """When one command fails, the processes still running are terminated, not left training."""
    import time

    from rich.console import Console

    from po3d_ppl.cli.train_all import Step
    from po3d_ppl.cli.train_schedule import run_commands
    from po3d_ppl.errors import Po3dError

    pid_file = tmp_path / "slow.pid"
    scripts = {"slow": f"import os, time; open({str(pid_file)!r}, 'w').write(str(os.getpid())); time.sleep(60)",
               "fails": "import time, sys; time.sleep(1); sys.exit(3)"}
    steps = [Step(label=name, fn=print, kwargs={}, words=["po3d", name]) for name in scripts]
    start = time.perf_counter()
    with pytest.raises(Po3dError, match="fails failed"):
        run_commands(steps, 2, tmp_path, Console(quiet=True), lambda step: [sys.executable, "-c", scripts[step.label]],
                     lambda step, finished: None)
    assert time.perf_counter() - start < 30
    pid = int(pid_file.read_text())
    with pytest.raises(ProcessLookupError):  # terminated and reaped
        for _ in range(50):
            os.kill(pid, 0)
            time.sleep(0.1)


def test_commands_wait_for_what_they_read_and_share_the_cores(tmp_path):
    """A command starts only after the ones it waits for have ended; independent ones run side by side; the one
    more commands wait on starts first."""
    from rich.console import Console

    from po3d_ppl.cli.train_all import Step
    from po3d_ppl.cli.train_schedule import run_commands

    def script(name: str) -> str:
        return (f"import time; open({str(tmp_path / name)!r}, 'w').write(str(time.time())); time.sleep(0.6); "
                f"open({str(tmp_path / name)!r}, 'a').write(' ' + str(time.time()))")

    steps = [Step("alone", print, {}, ["po3d", "alone"]), Step("first", print, {}, ["po3d", "first"]),
             Step("second", print, {}, ["po3d", "second"], after=("first",)),
             Step("third", print, {}, ["po3d", "third"], after=("second", "alone"))]
    finished = []
    run_commands(steps, 2, tmp_path / "logs", Console(quiet=True),
                 lambda step: [sys.executable, "-c", script(step.label)], lambda step, record: finished.append(record))
    times = {name: [float(t) for t in (tmp_path / name).read_text().split()] for name in ("alone", "first", "second",
                                                                                          "third")}
    assert times["second"][0] >= times["first"][1]
    assert times["third"][0] >= max(times["second"][1], times["alone"][1])
    assert times["alone"][0] < times["first"][1] and times["first"][0] < times["alone"][1]  # side by side
    assert [record.step for record in finished][-1] == "third"
    assert all(record.cpu_seconds >= 0 and Path(record.log).is_file() for record in finished)
    with pytest.raises(ValueError, match="cycle"):
        run_commands([Step("a", print, {}, ["po3d", "a"], after=("b",)), Step("b", print, {}, ["po3d", "b"],
                                                                               after=("a",))],
                     2, tmp_path / "logs", Console(quiet=True), lambda step: [sys.executable, "-c", "pass"],
                     lambda step, record: None)


def test_full_chain_waits_for_what_each_stage_reads(tmp_path):
    """The shipped chain's graph: the object calibration after the features and the background, the ensemble after
    its members, the perception after the builds of its datasets, the parser's members after nothing; the feature
    training, which most commands wait on, is the first to start after the datasets."""
    from po3d_ppl.cli.train_schedule import dependents

    steps = plan(FULL, tmp_path / "data", tmp_path / "out", 0, 1)
    ordered = link(steps, list(STAGES), FULL)
    after = {step.label: set(step.after) for step in ordered}
    assert after["calibration"] == {"perception", "background", "dataset val_s712"}
    assert after["parser"] == set() and after["parser calibration"] == {"parser"}
    assert {"parser calibration", "parser calibration question_parser_w2_seed2"} <= after["parser ensemble"]
    assert after["perception"] == {"dataset train_s711", "dataset val_s712"}
    assert "viewpoint" in after["projection"] and "centres" in after["projection"]
    assert steps["centres"][0].kwargs["threads"] == 2  # two threads whatever --threads says, as shipped
    weight = dependents(ordered)
    trainings = ("perception", "background", "attributes", "viewpoint", "parser", "priors")
    assert max(trainings, key=weight.get) == "perception" and weight["parser"] < weight["viewpoint"]

"""Run a graph of commands as processes, at most ``jobs`` at a time, each as soon as the ones it waits for are done.

Why processes rather than threads: every training command runs on its own torch thread(s) and holds the GIL
in its Python loops, so two commands only share the two cores when each has a process of its own. Why a graph
rather than stages in turn: most stages read only the datasets (perception, background, attributes, viewpoint,
the parser's members), so a core that one stage leaves idle can train another.

A command that waits for nothing starts first when it has the most commands waiting on it (directly or not), so
the long chain perception -> centres -> projection -> answer calibration is not held up by commands nothing
waits for (the parser's members fill the cores last). Each command's output goes to a log of its own; the
console shows one line per command (waiting, running, done). The first failure, Ctrl-C or SIGTERM terminates
every command still running: none is left training or writing into the output directory.
"""

from __future__ import annotations

import os
import re
import shlex
import signal
import subprocess
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol


class Command(Protocol):
    """What the scheduler needs of a step: its name, the names it waits for and its command line."""

    label: str
    after: tuple[str, ...]
    words: list[str]


@dataclass
class Finished:
    """One command's record: wall and CPU seconds, and when it started and ended (seconds after ``origin``)."""

    step: str
    command: str
    seconds: float
    cpu_seconds: float
    start: float
    end: float
    log: str | None = None  # None: run in the calling process (``po3d train all --jobs 1``)


#: how often the running commands are checked (seconds)
POLL_SECONDS = 0.2


def dependents(steps: Sequence[Command]) -> dict[str, int]:
    """For each step, how many steps wait on it, directly or through others."""
    after = {step.label: set(step.after) for step in steps}
    ancestors: dict[str, set[str]] = {}

    def of(label: str) -> set[str]:
        if label not in ancestors:
            ancestors[label] = found = set()  # in place before the parents: a cycle ends here (run_commands names it)
            for parent in after.get(label, ()):
                found |= {parent} | of(parent)
        return ancestors[label]

    counts = dict.fromkeys(after, 0)
    for label in after:
        for parent in of(label):
            if parent in counts:
                counts[parent] += 1
    return counts


def log_name(label: str) -> str:
    """A file name for a step's log (its label, spaces and punctuation as underscores)."""
    return re.sub(r"[^A-Za-z0-9.-]+", "_", label).strip("_") + ".log"


def run_commands(steps: Sequence[Command], jobs: int, logs: Path, console, command: Callable[[Command], list[str]],
                 on_finish: Callable[[Command, Finished], None], origin: float | None = None) -> None:
    """Run every step's ``command(step)`` as a process, at most ``jobs`` at once, each after the steps named in
    its ``after``; call ``on_finish`` as each one ends. A failed command raises
    :class:`~po3d_ppl.errors.Po3dError` with its log's last lines once the others are terminated."""
    from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    from po3d_ppl.errors import Po3dError

    labels = [step.label for step in steps]
    unknown = {name for step in steps for name in step.after} - set(labels)
    if unknown or len(set(labels)) != len(labels):
        raise ValueError(f"steps wait for unknown or repeated labels: {sorted(unknown) or labels}")
    origin = time.perf_counter() if origin is None else origin
    weight = dependents(steps)
    order = {label: index for index, label in enumerate(labels)}
    logs.mkdir(parents=True, exist_ok=True)
    pending = list(steps)
    done: set[str] = set()
    running: dict[subprocess.Popen, tuple[Command, float, object, Path]] = {}

    def exit_on_sigterm(signum, frame):
        raise SystemExit(128 + signum)

    try:
        previous = signal.signal(signal.SIGTERM, exit_on_sigterm)
    except ValueError:  # not the main thread: SIGTERM keeps its handler
        previous = None
    try:
        with Progress(SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(),
                      console=console) as progress:
            tasks = {step.label: progress.add_task(f"{step.label}: waiting", total=1, start=False)
                     for step in steps}
            while pending or running:
                ready = [step for step in pending if done.issuperset(step.after)]
                ready.sort(key=lambda step: (-weight[step.label], order[step.label]))
                for step in ready[:max(jobs - len(running), 0)]:
                    pending.remove(step)
                    log = logs / log_name(step.label)
                    handle = open(log, "w")
                    progress.console.print("$ " + shlex.join(step.words), markup=False, highlight=False,
                                           style="dim", soft_wrap=True)
                    running[subprocess.Popen(command(step), stdout=handle, stderr=subprocess.STDOUT)] = (
                        step, time.perf_counter(), handle, log)
                    progress.start_task(tasks[step.label])
                    progress.update(tasks[step.label], description=f"{step.label}: running")
                if not running:
                    raise ValueError(f"steps wait for each other in a cycle: {[s.label for s in pending]}")
                time.sleep(POLL_SECONDS)
                for process in list(running):
                    pid, status, usage = os.wait4(process.pid, os.WNOHANG)
                    if pid == 0:
                        continue
                    process.returncode = os.waitstatus_to_exitcode(status)
                    step, start, handle, log = running.pop(process)
                    handle.close()
                    if process.returncode != 0:
                        tail = log.read_text(errors="replace").strip().splitlines()[-8:]
                        raise Po3dError(f"{step.label} failed (exit {process.returncode}): "
                                        f"{shlex.join(step.words)}\n" + "\n".join(tail) + f"\n(full output: {log})")
                    end = time.perf_counter()
                    done.add(step.label)
                    progress.stop_task(tasks[step.label])
                    progress.update(tasks[step.label], description=f"{step.label}: done", completed=1)
                    on_finish(step, Finished(step.label, shlex.join(step.words), round(end - start, 1),
                                             round(usage.ru_utime + usage.ru_stime, 1), round(start - origin, 1),
                                             round(end - origin, 1), str(log)))
    finally:  # a failure, Ctrl-C or SIGTERM: leave no command running
        for process in running:
            process.terminate()
        for process, (_, _, handle, _) in running.items():
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
            handle.close()
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)

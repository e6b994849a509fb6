"""PNG figures: reliability diagrams, the noise sweep and the difficulty curves (matplotlib, Agg backend)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from po3d_ppl.evaluation.calibration import CalibrationReport, SweepPoint
from po3d_ppl.evaluation.difficulty import DifficultyRow


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90, bbox_inches="tight")
    _pyplot().close(fig)
    return path


def reliability_diagrams(reports: Sequence[CalibrationReport], path: Path, title: str = "") -> Path:
    """One panel per method: accuracy per confidence bin (bars) against the diagonal, bin counts as shading."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, len(reports), figsize=(2.8 * len(reports), 3.0), squeeze=False, sharey=True)
    for ax, report in zip(axes[0], reports, strict=True):
        total = max(sum(b.count for b in report.bins), 1)
        for b in report.bins:
            if not b.count:
                continue
            width = b.upper - b.lower
            alpha = 0.35 + 0.65 * min(1.0, 8 * b.count / total)
            ax.bar(b.lower, b.accuracy, width=width, align="edge", color="tab:blue", alpha=alpha, edgecolor="k",
                   linewidth=0.4)
            ax.plot([b.lower + width / 2], [b.confidence], "r.", markersize=4)
        ax.plot([0, 1], [0, 1], "k--", linewidth=0.8)
        ax.set_xlim(0, 1)
        ax.set_ylim(0, 1)
        ax.set_title(f"{report.method}\nECE {report.ece:.3f}  acc {report.accuracy:.2f}", fontsize=9)
        ax.set_xlabel("confidence", fontsize=8)
        ax.tick_params(labelsize=7)
    axes[0][0].set_ylabel("accuracy (bars); red: mean confidence", fontsize=8)
    if title:
        fig.suptitle(title, fontsize=9, y=1.04)
    return _save(fig, path)


def noise_sweep_plot(points: Sequence[SweepPoint], path: Path, title: str = "") -> Path:
    """Accuracy and ECE against sensor noise, one line per method (two panels of one figure)."""
    plt = _pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(8.0, 3.2))
    for method in dict.fromkeys(p.method for p in points):
        mine = sorted((p for p in points if p.method == method), key=lambda p: p.noise)
        xs = [p.noise for p in mine]
        left.plot(xs, [p.accuracy for p in mine], marker="o", markersize=3, label=method)
        right.plot(xs, [p.ece for p in mine], marker="o", markersize=3, label=method)
    left.set_ylabel("accuracy")
    right.set_ylabel("ECE (15 bins, top answer)")
    for ax in (left, right):
        ax.set_xlabel("simulated sensor noise")
        ax.grid(alpha=0.3)
    left.legend(fontsize=7)
    if title:
        fig.suptitle(title, fontsize=9)
    return _save(fig, path)


def difficulty_plot(panels: Sequence[tuple[str, str, Sequence[DifficultyRow], dict]], path: Path) -> Path:
    """One panel per (title, x label, rows, paper curves): accuracy per bin for each method, the paper's
    curves dashed."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, len(panels), figsize=(4.0 * len(panels), 3.2), squeeze=False)
    for ax, (title, xlabel, rows, paper) in zip(axes[0], panels, strict=True):
        bins = list(dict.fromkeys(r.bin for r in rows))
        xs = range(len(bins))
        for method in dict.fromkeys(r.method for r in rows):
            accs = [next((r.accuracy for r in rows if r.method == method and r.bin == b), None) for b in bins]
            ax.plot([x for x, a in zip(xs, accs) if a is not None], [a for a in accs if a is not None],
                    marker="o", markersize=3, label=method)
        for name, values in paper.items():
            ax.plot(list(xs)[:len(values)], [v / 100 for v in values], linestyle="--", linewidth=0.9,
                    label=f"paper: {name}")
        counts = [next((r.n for r in rows if r.bin == b), 0) for b in bins]
        ax.set_xticks(list(xs), [f"{b}\n(n={n})" for b, n in zip(bins, counts, strict=True)], fontsize=7)
        ax.set_title(title, fontsize=9)
        ax.set_xlabel(xlabel, fontsize=8)
        ax.set_ylabel("accuracy", fontsize=8)
        ax.set_ylim(0, 1.02)
        ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=6, loc="lower left")
    return _save(fig, path)


def ceiling_plot(report, path: Path, title: str = "") -> Path:
    """Points of accuracy each oracle adds over perception, one group of bars per question file
    (:class:`~po3d_ppl.evaluation.ceilings.CeilingReport`)."""
    import numpy as np

    plt = _pyplot()
    base, others = report.rows[0], report.rows[1:]
    files = sorted(report.questions)
    fig, ax = plt.subplots(figsize=(1.6 + 1.4 * len(files), 3.4))
    width = 0.8 / max(len(others), 1)
    x = np.arange(len(files))
    cmap = plt.get_cmap("tab20")
    for k, row in enumerate(others):
        gains = [100 * (row.files[f] - base.files[f]) for f in files]
        ax.bar(x + (k - (len(others) - 1) / 2) * width, gains, width, label=row.variant, color=cmap(k % 20))
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xticks(x, [f"{f}\n({100 * base.files[f]:.1f}%)" for f in files])
    ax.set_ylabel("accuracy gained (points)")
    ax.set_title(title or "answers with one table replaced by the truth")
    ax.legend(fontsize=7, ncol=2, frameon=False, bbox_to_anchor=(1.0, 1.0), loc="upper left")
    return _save(fig, path)

"""``ScenePriors`` fitted to the world's statistics: the rates of the scene model's binary latents in real scenes.

The scene model's priors were hand-set and are off by factors of 2-10 in our world (docs/reasoning.md); a prior
that does not match the world makes the posteriors over- or under-confident wherever the evidence is weak. Each
rate is counted exactly as the simulated sensor reads the latent (:mod:`po3d_ppl.perception.simulated`), over
ground-truth scenes of a training split, with add-one smoothing so that every prior stays in (0, 1).

``exists`` is not a property of scenes but of a parser's proposals (how many it makes that are not objects): it
keeps its hand-set value (0.5: the object calibration's existence log-odds are a posterior at that prior).

The fitted priors ship as ``models/priors.json`` (a manifest entry with its sha256, like every model); the pipeline
and the evaluation read them with :func:`load_priors`. Perception's tables are likelihoods (the attribute network
divides its training rates out, the projection calibration its base rates), so these priors are the one place the
world's rates enter.
"""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Iterable
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path

from po3d_ppl import ontology
from po3d_ppl.errors import InputError, ModelFileError
from po3d_ppl.evidence import RATE_FIELDS, ScenePriors
from po3d_ppl.perception.simulated import part_visible
from po3d_ppl.world.scene import Scene


@dataclass
class Rate:
    """A counted rate: ``hits`` of ``total`` (smoothed: (hits + 1) / (total + 2))."""

    hits: int = 0
    total: int = 0

    def add(self, hit: bool) -> None:
        self.hits += int(hit)
        self.total += 1

    @property
    def smoothed(self) -> float:
        return (self.hits + 1) / (self.total + 2)


@dataclass
class WorldRates:
    """The rates of every binary latent of the scene model, by ``ScenePriors`` field, and what the scenes say of
    the recolouring rule (:mod:`po3d_ppl.reasoning.part_counts`)."""

    rates: dict[str, Rate] = field(default_factory=lambda: {name: Rate() for name in FITTED})
    scenes: int = 0
    #: Objects by (recoloured parts, visible parts).
    recoloured_counts: Counter = field(default_factory=Counter)
    #: Recoloured parts whose colour differs from their object's.
    unlike_body: Rate = field(default_factory=Rate)

    @property
    def max_recoloured(self) -> int:
        return max((k for k, _ in self.recoloured_counts), default=0)

    @property
    def count_rule_objects(self) -> Rate:
        """Objects with exactly ``min(max_recoloured, visible parts)`` recoloured parts."""
        cap = self.max_recoloured
        return Rate(sum(n for (k, m), n in self.recoloured_counts.items() if k == min(cap, m)),
                    sum(self.recoloured_counts.values()))

    def priors(self, base: ScenePriors = ScenePriors()) -> ScenePriors:
        """``base`` with every fitted field replaced by its smoothed rate, and the recolouring rule where every
        counted object keeps it (a rule with exceptions is not the world's; the independent prior stays)."""
        rule = self.count_rule_objects
        holds = self.max_recoloured >= 1 and rule.hits == rule.total
        unlike = holds and self.unlike_body.total > 0 and self.unlike_body.hits == self.unlike_body.total
        return replace(base, **{name: rate.smoothed for name, rate in self.rates.items()},
                       max_recoloured_parts=self.max_recoloured if holds else None, recoloured_unlike_body=unlike)


#: The ``ScenePriors`` fields a scene tells (``exists`` is about proposals, not scenes).
FITTED = ("occluded", "occludes", "part_visible", "part_recoloured", "part_occluded", "part_occludes")


def count_rates(scenes: Iterable[Scene]) -> WorldRates:
    """Count the binary latents over ground-truth scenes (objects, ordered object pairs, part slots)."""
    out = WorldRates()
    r = out.rates
    for scene in scenes:
        out.scenes += 1
        objects = scene.objects
        for i, obj in enumerate(objects):
            r["occluded"].add(obj.occluded)
            for j in range(len(objects)):
                if j != i:
                    r["occludes"].add(j in obj.occluded_by)
            shown = 0
            for raw in ontology.PARTS[obj.subtype]:
                visible = part_visible(obj, raw)
                shown += visible
                r["part_visible"].add(visible)
                if visible:
                    r["part_recoloured"].add(raw in obj.parts)
                r["part_occluded"].add(obj.part_occluded(raw))
                by = obj.part_occluded_by(raw)
                for j in range(len(objects)):
                    if j != i:
                        r["part_occludes"].add(j in by)
            out.recoloured_counts[(len(obj.parts), shown)] += 1
            for style in obj.parts.values():
                out.unlike_body.add(style.color != obj.color)
    if out.scenes == 0:
        raise InputError("scenes", "no scenes to count rates over; give a split with at least one scene")
    return out


def fit_priors(scenes: Iterable[Scene], base: ScenePriors = ScenePriors()) -> tuple[ScenePriors, WorldRates]:
    """(``base`` with the world's rates, the counts behind them)."""
    rates = count_rates(scenes)
    return rates.priors(base), rates


MODEL_NAME = "priors"
PRIORS_FILE = "priors.json"
RETRAIN = "refit them with `po3d train priors --data /work/data/perc_train_s711` or `git checkout models/`"


def save_priors(priors: ScenePriors, directory: Path) -> Path:
    """Write ``priors`` as ``directory/priors.json`` (the caller records it in the manifest)."""
    path = Path(directory) / PRIORS_FILE
    path.write_text(json.dumps(asdict(priors), indent=1) + "\n")
    return path


def load_priors(directory: Path | str | None = None) -> ScenePriors:
    """The fitted priors of ``directory`` (default: the shipped models), checked against the manifest's sha256;
    the hand-set ``ScenePriors()`` when none are listed."""
    from po3d_ppl.model_store import model_files, read_manifest

    directory = Path(directory) if directory is not None else None
    if MODEL_NAME not in read_manifest(directory):
        return ScenePriors()
    path = model_files(MODEL_NAME, directory, RETRAIN)[PRIORS_FILE]
    try:
        values = json.loads(path.read_text())
        known = {f.name for f in fields(ScenePriors)}
        unknown = set(values) - known
        if unknown:
            raise ValueError(f"unknown fields {sorted(unknown)}")
        return ScenePriors(**{k: (float(v) if k in RATE_FIELDS else v) for k, v in values.items()})
    except (ValueError, TypeError, AttributeError, InputError) as exc:
        raise ModelFileError(f"cannot read the priors from {path} ({exc}); {RETRAIN}") from None

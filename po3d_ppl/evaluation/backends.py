"""Evidence back-ends as the evaluation sees them: one observation in, ``SceneEvidence`` out, plus an identity.

The identity (name, settings, later the model's sha256) is half of the evidence cache key, so changing the noise,
the seed or the model never reads stale evidence. The render-and-compare parser plugs in as another
:class:`EvidenceBackend` (it reads ``observation.image_path``; the simulated sensor reads ``observation.scene``).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from po3d_ppl.errors import InputError
from po3d_ppl.evidence import SceneEvidence, ScenePriors
from po3d_ppl.perception import SimulatedSensor
from po3d_ppl.world.scene import Scene


@dataclass(frozen=True)
class Observation:
    """One image of a dataset split: its index, file and ground-truth scene (the last for the simulated sensor
    and for scoring only; a real back-end must not read it)."""

    index: int
    image_path: Path
    scene: Scene


@runtime_checkable
class EvidenceBackend(Protocol):
    """What the evaluation needs of a perception back-end."""

    name: str

    def identity(self) -> dict[str, Any]:
        """Everything that determines the evidence besides the image (JSON-serialisable)."""
        ...

    def evidence(self, observation: Observation) -> SceneEvidence:
        """What is cached: the evidence before any post-hoc calibration (refitting one never re-parses images)."""
        ...

    def calibrate(self, evidence: SceneEvidence) -> SceneEvidence:
        """The cached evidence with the back-end's post-hoc calibration applied (the identity when it has none)."""
        ...

    def provenance(self) -> dict[str, Any]:
        """The identity plus the calibration applied after the cache: what a report records."""
        ...

    def scene_priors(self, priors: ScenePriors) -> ScenePriors:
        """The scene model's priors for this back-end's proposals (``priors`` where it knows no better)."""
        ...


def image_seed(seed: int, index: int) -> int:
    """The sensor seed of image ``index``: independent noise per image, reproducible from (seed, index)."""
    return int(np.random.SeedSequence([int(seed), int(index)]).generate_state(1)[0])


@dataclass(frozen=True)
class SimulatedBackend:
    """The simulated sensor (:class:`po3d_ppl.perception.SimulatedSensor`) on each image's ground-truth scene, with
    a per-image seed derived from ``seed`` (so two images never share a noise draw)."""

    noise: float = 0.05
    seed: int = 0
    pose_bins: int | None = None
    name: str = "simulated"

    def __post_init__(self) -> None:
        self._sensor(0)  # validates noise and seed with the sensor's own typed errors

    def _sensor(self, index: int) -> SimulatedSensor:
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise InputError("--seed", f"must be a non-negative integer, got {self.seed!r}")
        extra = {} if self.pose_bins is None else {"pose_bins": self.pose_bins}
        return SimulatedSensor(noise=self.noise, seed=image_seed(self.seed, index), **extra)

    def identity(self) -> dict[str, Any]:
        sensor = self._sensor(0)
        return {"name": self.name, "noise": float(self.noise), "seed": int(self.seed),
                "pose_bins": int(sensor.pose_bins), "seed_rule": "SeedSequence([seed, image_index])"}

    def evidence(self, observation: Observation) -> SceneEvidence:
        return self._sensor(observation.index).evidence(observation.scene)

    def calibrate(self, evidence: SceneEvidence) -> SceneEvidence:
        return evidence

    def provenance(self) -> dict[str, Any]:
        return self.identity()

    def scene_priors(self, priors: ScenePriors) -> ScenePriors:
        return priors  # the sensor reads every object of the scene: the world's rates


#: Bumped whenever the code that turns the models' outputs into evidence changes (cached evidence of an older
#: version is then never read). 2: part style tables as likelihoods (the log 16 of ``AttributeNet.style_loglik``).
#: 3: the object parser merges fragments of one object (``ParserConfig.merge_penalty``). 4: contested cells and
#: occluded objects added (``ParserConfig.contest_margin``). 5: masks split between touching proposals by colour
#: (``ParserConfig.colour_margin``). 6: a second search on the foreground the first reading leaves unexplained
#: (``ParserConfig.region_min_score``). 7: part looks read under the most likely pose only
#: (``SceneParserConfig.style_pose_hypotheses``). 8: centre proposals (``ParserConfig.centre_threshold``). 9: the
#: centre heatmap as a position prior in the local re-search (``ParserConfig.centre_weight``). 10: the second
#: search names a region whose peak is blocked and fits that category's visible cells (``region_named_iou``).
#: 11: a region proposal owns the pixels of its region that its mesh covers (``object_parser._claim_regions``).
#: 12: masks and boxes redrawn by the most likely scene's subtype silhouettes (``scene_parser.seen_ownership``).
#: 13: touching proposals read as one object of one colour are merged (``scene_parser.one_object_merges``).
#: 14: the camera height compares each candidate's silhouettes at their best shift
#: (``SceneParserConfig.height_shift_px``). 15: the post-filter lowers existence by at most 1 nat
#: (``SceneParserConfig.post_filter_max_nats``). The settings key the cache too, so a changed default alone needs
#: no new version (``SceneParserConfig.min_subtype_weight`` 0.002 -> 0 kept 15; the new setting
#: ``ParserConfig.relocate_unoccluded``, the re-search on the cells nearer proposals leave, kept it too).
EVIDENCE_VERSION = 15


@dataclass(frozen=True)
class ImageBackend:
    """The render-and-compare parser (:func:`po3d_ppl.perception.scene_parser.parse_scene`) on each image's
    pixels; it never reads ``observation.scene``. Its identity holds the perception models' sha256 and every
    setting, so retraining or retuning never reads stale cached evidence. Visible masks are dropped from the
    evidence it returns (reasoning never reads them, and they would dominate the cache: 0.3 MB per object).

    The cache holds the evidence with its projected tables raw; :meth:`calibrate` applies the shipped projection
    calibration after the cache (it is a per-table affine map), so refitting that calibration costs no parse.
    ``calibrated_projection=False`` leaves the tables raw (what their calibration is fitted on); ``models_dir``
    reads another model directory than the shipped one (``po3d train all --out``)."""

    name: str = "image"
    calibrated_projection: bool = True
    models_dir: Path | None = None

    def _settings(self) -> dict[str, Any]:
        from dataclasses import asdict

        from po3d_ppl.perception.object_parser import ParserConfig
        from po3d_ppl.perception.scene_parser import SceneParserConfig

        return {"object_parser": asdict(ParserConfig()), "scene_parser": asdict(SceneParserConfig()),
                "evidence_version": EVIDENCE_VERSION}

    def identity(self) -> dict[str, Any]:
        return self._loaded[0]

    def evidence(self, observation: Observation) -> SceneEvidence:
        import dataclasses

        evidence = self.parser.evidence(observation.image_path)
        return dataclasses.replace(evidence, masks=None)

    def calibrate(self, evidence: SceneEvidence) -> SceneEvidence:
        calibration = self._loaded[2]
        return evidence if calibration is None else calibration.apply(evidence)

    def provenance(self) -> dict[str, Any]:
        return {**self.identity(), "post_hoc": self._loaded[3]}

    def scene_priors(self, priors: ScenePriors) -> ScenePriors:
        calibration = self._loaded[2]
        return priors if calibration is None else calibration.proposal_priors(priors)

    @property
    def parser(self):
        """The perception models (projection uncalibrated: see :meth:`calibrate`), loaded once per back-end."""
        return self._loaded[1]

    @cached_property
    def _loaded(self) -> tuple[dict[str, Any], Any, Any, dict[str, Any]]:
        """(cache identity, parser, projection calibration or None, the calibration's sha256), read together once:
        models swapped in models/ during a run change none of them, so a long evaluation never files one model's
        evidence under another's key."""
        import dataclasses

        from po3d_ppl.model_store import read_manifest
        from po3d_ppl.perception.projection_calibration import MODEL_NAME
        from po3d_ppl.perception.scene_parser import ImageParser

        manifest = read_manifest(self.models_dir)

        def shas(names: tuple[str, ...]) -> dict[str, dict[str, str]]:
            return {name: {f: meta["sha256"] for f, meta in entry.get("files", {}).items()}
                    for name, entry in manifest.items() if name in names}

        used = ("perception_features", "object_calibration", "background", "attributes", "viewpoint", "centres")
        parser = ImageParser.load(self.models_dir, calibrated_projection=self.calibrated_projection)
        calibration = parser.projection_calibration
        parser = dataclasses.replace(parser, projection_calibration=None)
        post_hoc = shas((MODEL_NAME,)) if calibration is not None else {}
        return {"name": self.name, "models": shas(used), "settings": self._settings()}, parser, calibration, post_hoc

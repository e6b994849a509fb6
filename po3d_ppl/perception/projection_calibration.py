"""Calibration of the scene parser's evidence: one Platt scaling with edge states (``a * logodds + b``, shifted at
the projection's floor and ceiling) per binary table the projection fills, one scale on the part-look table's
log-likelihoods, and one scale on each object table (subtype, colour, material, size).

The projection (:mod:`po3d_ppl.perception.scene_parser`) reads "part p is visible", "object i is occluded by j"
and so on off renderings of its hypotheses and squashes their weighted frequency into log-odds with a fixed floor
(0.05 on each side). Most entries sit at that floor, so the floor *is* the confidence, and one wrong pose or mask
makes many of them wrong together. How often an entry at the floor is right is an empirical question: it is
answered per table on a validation seed (ground truth is read there only, by
:func:`po3d_ppl.evaluation.projection.fit_projection_calibration`), and the scene parser applies the fitted
scaling to every image (``ImageParser.load`` reads ``models/projection_calibration.safetensors`` when shipped).

**Edge states.** An entry at the floor means "no rendering, under any hypothesis or shift, shows the event", and
one at the ceiling "every rendering shows it": point masses, not points on the scale the entries between them
lie on. One line through all of them is pulled flat by the thousands of floor entries (on seed 712's part
occlusion: entries at raw log-odds 0 to 0.5 happen 48% of the time and plain Platt said 21%; at -2 to -1, 28%
against 4%). The scaling therefore adds a shift for each edge (``floor_shift`` <= 0, ``ceiling_shift`` >= 0, so
the map stays monotone): ``a * x + b + floor_shift [x <= -edge] + ceiling_shift [x >= edge]``, ``edge`` the
projection floor's log-odds. Without an ``edge`` it is plain Platt scaling.

**Likelihoods, not posteriors.** Platt scaling fits ``P(event | log-odds)`` on the validation entries, a posterior
that already holds those entries' base rate. The scene model adds its own prior (``ScenePriors``) to every table,
so the evidence must be a likelihood ratio: the fitted base rate's log-odds are subtracted
(``a * logodds + b - logit(base_rate)``), and the scene model's prior of that latent is the same base rate
(:meth:`ProjectionCalibration.proposal_priors`, applied wherever image evidence is reasoned over), so the posterior
of an entry is the fitted one instead of counting a base rate twice (with the hand-set part-occluder prior 0.05
that double count pushed every part-occlusion posterior down by 3 nats).

**The part-look table** (``part_style_loglik``: plain, or one of 16 colour-material looks) is read by the
attribute network through projected part masks, so its confidence depends on where the parts land. One scale on
its log-likelihoods is fitted by the negative log-likelihood of the true look under the validation parts' own
rate of recoloured parts (the scene model multiplies the table by that prior): on seed 712 it is 1.22, the table
was under-confident, and "recoloured" lost to the prior even for well-placed parts (docs/perception.md).

**The object tables** are sums of readings calibrated one by one: the subtype table adds the object parser's
category, the attribute network's subtype and the silhouette's subtype term; the size table the object parser's
size and the attribute network's. Each reading was calibrated alone (the attribute network on true masks, where its
size head never errs and its temperature went to the grid's floor), so the sums count shared evidence twice and are
over-confident through the parser's masks. One scale per table (one over a temperature) is fitted by the NLL of the
matched objects' true values; the scene model's priors over them are uniform, so no prior enters the fit.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import torch

from po3d_ppl.errors import InputError, ModelFileError
from po3d_ppl.evidence import SceneEvidence, ScenePriors

MODEL_NAME = "projection_calibration"
WEIGHTS = "projection_calibration.safetensors"
#: 3: ``[scale, bias, floor_shift, ceiling_shift, base_rate]`` per table and the ``edge``, and optionally the
#: part-look scale and one scale per object table (files without them load as before; 2 had no edge states; 1 no
#: base rate: posteriors, which the scene model's prior counted twice).
FORMAT = "3"
#: Entries within this of an edge's log-odds sit on it (the tables are stored in float32).
EDGE_TOLERANCE = 1e-4
RETRAIN = "refit it with `po3d train projection --data VAL` (a validation dataset) or `git checkout models/`"
#: The binary tables of the contract that the projection fills.
TABLES = ("occluded_logodds", "occludes_logodds", "part_visible_logodds", "part_occluded_logodds",
          "part_occludes_logodds")
#: The categorical table scaled as a whole (one scale on its log-likelihoods).
STYLE_TABLE = "part_style_loglik"
#: The object tables scaled as wholes (one scale each), with the scene attribute each one reads.
OBJECT_TABLES = {"subtype_loglik": "subtype", "color_loglik": "color", "material_loglik": "material",
                 "size_loglik": "size"}
#: The file's entry holding the edge log-odds.
EDGE = "edge"
#: The ``ScenePriors`` field of each table.
TABLE_PRIOR = {"occluded_logodds": "occluded", "occludes_logodds": "occludes", "part_visible_logodds":
               "part_visible", "part_occluded_logodds": "part_occluded", "part_occludes_logodds": "part_occludes"}


def edge_logodds(floor: float) -> float:
    """The log-odds of a projected table's ceiling (minus: its floor) for a probability floor ``floor``."""
    return math.log((1.0 - floor) / floor)


def edge_states(table: torch.Tensor, edge: float) -> tuple[torch.Tensor, torch.Tensor]:
    """Float masks of the entries at the floor and at the ceiling of a table floored at ``edge`` log-odds."""
    return ((table <= -edge + EDGE_TOLERANCE).to(table.dtype), (table >= edge - EDGE_TOLERANCE).to(table.dtype))


@dataclass(frozen=True)
class ProjectionCalibration:
    """``(scale, bias, floor_shift, ceiling_shift)`` per table of ``TABLES`` (a pair ``(scale, bias)`` means no
    shifts), the projection edge they were fitted at (None: no edge states), and the base rate of the entries it
    was fitted on (divided out: see the module docstring); a table not listed is left as it is."""

    platt: dict[str, tuple[float, ...]] = field(default_factory=dict)
    base_rate: dict[str, float] = field(default_factory=dict)
    #: Multiplies ``part_style_loglik`` (None: left as it is).
    style_scale: float | None = None
    #: The projection's floor log-odds (:func:`edge_logodds`) the shifts apply at; None: plain Platt scaling.
    edge: float | None = None
    #: Multiplies each listed table of ``OBJECT_TABLES`` (one over its fitted temperature).
    object_scales: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.style_scale is not None and not (math.isfinite(self.style_scale) and self.style_scale > 0):
            raise InputError("ProjectionCalibration", f"the part-look scale must be finite and > 0, got "
                                                      f"{self.style_scale}")
        for name, scale in self.object_scales.items():
            if name not in OBJECT_TABLES or not (math.isfinite(scale) and scale > 0):
                raise InputError("ProjectionCalibration", f"object table {name!r}: expected one of "
                                                          f"{', '.join(OBJECT_TABLES)} with a finite scale > 0, "
                                                          f"got {scale}")
        if self.edge is not None and not (math.isfinite(self.edge) and self.edge > 0):
            raise InputError("ProjectionCalibration", f"the edge log-odds must be finite and > 0, got {self.edge}")
        padded = {}
        for name, values in self.platt.items():
            if name not in TABLES:
                raise InputError("ProjectionCalibration", f"unknown table {name!r} (known: {', '.join(TABLES)})")
            if len(values) not in (2, 4):
                raise InputError("ProjectionCalibration", f"{name}: expected (scale, bias) or (scale, bias, "
                                                          f"floor_shift, ceiling_shift), got {values}")
            scale, bias, floor_shift, ceiling_shift = (*map(float, values), 0.0, 0.0)[:4]
            if not (all(map(math.isfinite, (scale, bias, floor_shift, ceiling_shift))) and scale > 0):
                raise InputError("ProjectionCalibration", f"{name}: scale must be > 0 and all finite, got {values}")
            if floor_shift > 0 or ceiling_shift < 0:
                raise InputError("ProjectionCalibration", f"{name}: the floor shift must be <= 0 and the ceiling "
                                                          f"shift >= 0 (a monotone map), got {values}")
            if (floor_shift or ceiling_shift) and self.edge is None:
                raise InputError("ProjectionCalibration", f"{name}: edge shifts need the edge they apply at")
            padded[name] = (scale, bias, floor_shift, ceiling_shift)
        object.__setattr__(self, "platt", padded)
        for name, rate in self.base_rate.items():
            if name not in self.platt or not 0.0 < rate < 1.0:
                raise InputError("ProjectionCalibration", f"{name}: a base rate needs a fitted table and a value "
                                                          f"in (0, 1), got {rate}")

    def posterior_logodds(self, name: str, table: torch.Tensor) -> torch.Tensor:
        """The fitted ``P(event | entry)`` of table ``name``'s raw entries, as log-odds."""
        scale, bias, floor_shift, ceiling_shift = self.platt[name]
        out = table * scale + bias
        if self.edge is not None:
            at_floor, at_ceiling = edge_states(table, self.edge)
            out = out + floor_shift * at_floor + ceiling_shift * at_ceiling
        return out

    def prior_logodds(self, name: str) -> float:
        """The log-odds of the base rate divided out of table ``name`` (0 when none was recorded: a rate of 0.5)."""
        rate = self.base_rate.get(name)
        return 0.0 if rate is None else math.log(rate / (1.0 - rate))

    def proposal_priors(self, base: ScenePriors) -> ScenePriors:
        """``base`` with each calibrated table's prior set to its fitted base rate: the rate among a parser's
        proposals, which is not the world's (a missed object is more often an occluded one: seed 712, 0.17 of the
        matched proposals are occluded against 0.22 of all objects). With it the scene model's posterior of an
        entry is exactly the fitted one."""
        return replace(base, **{TABLE_PRIOR[name]: rate for name, rate in self.base_rate.items()})

    def apply(self, evidence: SceneEvidence) -> SceneEvidence:
        """The evidence with every calibrated table rescaled to a likelihood ratio (``occludes`` keeps its ignored
        diagonal at 0)."""
        changes = {}
        for name in self.platt:
            table = getattr(evidence, name)
            scaled = self.posterior_logodds(name, table) - self.prior_logodds(name)
            if name == "occludes_logodds" and table.numel():
                scaled = scaled * (1 - torch.eye(table.shape[0], dtype=table.dtype, device=table.device))
            changes[name] = scaled
        if self.style_scale is not None:
            changes[STYLE_TABLE] = evidence.part_style_loglik * self.style_scale
        for name, scale in self.object_scales.items():
            changes[name] = getattr(evidence, name) * scale
        return dataclasses.replace(evidence, **changes)

    def save(self, directory: Path) -> Path:
        from safetensors.torch import save_file

        path = Path(directory) / WEIGHTS
        tensors = {name: torch.tensor([*values, self.base_rate.get(name, 0.5)], dtype=torch.float64)
                   for name, values in self.platt.items()}
        if self.style_scale is not None:
            tensors[STYLE_TABLE] = torch.tensor([self.style_scale], dtype=torch.float64)
        if self.edge is not None:
            tensors[EDGE] = torch.tensor([self.edge], dtype=torch.float64)
        for name, scale in self.object_scales.items():
            tensors[name] = torch.tensor([scale], dtype=torch.float64)
        save_file(tensors, str(path), metadata={"format": FORMAT})
        path.chmod(0o644)
        return path

    def to_dict(self) -> dict[str, list[float]]:
        """``{table: [scale, bias, floor_shift, ceiling_shift, base_rate]}``, and ``{"part_style_loglik": [scale]}``,
        ``{"edge": [log-odds]}`` and ``{object table: [scale]}`` when fitted."""
        out = {name: [*values, self.base_rate.get(name)] for name, values in self.platt.items()}
        if self.style_scale is not None:
            out[STYLE_TABLE] = [self.style_scale]
        if self.edge is not None:
            out[EDGE] = [self.edge]
        out.update({name: [scale] for name, scale in self.object_scales.items()})
        return out


def load_projection_calibration(directory: Path | str | None = None) -> ProjectionCalibration | None:
    """The shipped calibration (checked against the manifest), or None when none is listed."""
    from po3d_ppl.model_store import load_tensors, models_dir, read_manifest

    directory = Path(directory) if directory is not None else models_dir()
    if MODEL_NAME not in read_manifest(directory):
        return None
    path, _, tensors = load_tensors(MODEL_NAME, directory, RETRAIN, FORMAT)
    try:
        binary = {name: v for name, v in tensors.items() if name in TABLES}
        style, edge = tensors.get(STYLE_TABLE), tensors.get(EDGE)
        unknown = set(tensors) - set(TABLES) - set(OBJECT_TABLES) - {STYLE_TABLE, EDGE}
        if unknown:
            raise ValueError(f"unknown entries {sorted(unknown)}")
        return ProjectionCalibration({name: tuple(float(x) for x in v[:4]) for name, v in binary.items()},
                                     {name: float(v[4]) for name, v in binary.items()},
                                     None if style is None else float(style[0]),
                                     None if edge is None else float(edge[0]),
                                     {name: float(tensors[name][0]) for name in OBJECT_TABLES if name in tensors})
    except (ValueError, IndexError, TypeError, InputError) as exc:
        raise ModelFileError(f"cannot load the projection calibration from {path} ({exc}); {RETRAIN}") from None

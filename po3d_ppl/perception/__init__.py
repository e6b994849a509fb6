"""Perception: pixels (or, for the simulated sensor, a ground-truth scene) in, :class:`SceneEvidence` out.

A back-end is anything with ``evidence(observation) -> SceneEvidence`` (:class:`EvidenceSource`). Today there is
one, the simulated sensor (:mod:`po3d_ppl.perception.simulated`); the render-and-compare parser (issue
"Perception I/II") will be the second, behind the same interface. Perception imports the world and the contract
(:mod:`po3d_ppl.evidence`), never reasoning.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

from po3d_ppl.evidence import SceneEvidence
from po3d_ppl.perception.simulated import SimulatedSensor, simulated_evidence


@runtime_checkable
class EvidenceSource(Protocol):
    """A perception back-end."""

    name: str

    def evidence(self, observation: Any) -> SceneEvidence:
        """The evidence for one observation (an image for a real parser, a scene for the simulated sensor)."""
        ...


__all__ = ["EvidenceSource", "SceneEvidence", "SimulatedSensor", "simulated_evidence"]

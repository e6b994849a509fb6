"""Collecting labelled pieces into one part-labelled vehicle mesh in the canonical frame.

Builders add closed pieces with a part label (a raw part name of the subtype) or none (body, frame, glass: id -1)
and a *finish* (paint, glass, rubber, chrome, lamp) that only says what the surface is made of, so previews and
renderers can shade unlabelled geometry sensibly. :meth:`Assembly.finish` checks the labels against the ontology
and normalises the result to the canonical frame and the public ``info_box`` size.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import trimesh

from po3d_ppl import ontology

#: Surface kinds. Index = value stored in ``VehicleMesh.face_finish``.
FINISHES: tuple[str, ...] = ("paint", "glass", "rubber", "chrome", "lamp")

#: Body/frame faces carry this part id.
UNLABELLED = -1


def canonical_extents(subtype: str) -> np.ndarray:
    """Target bounding-box size (x = length, y = width, z = height) from the public ``info_box``.

    The public boxes list (width, length, height) for every category except bicycles, whose models were stored
    with their length first (the same reason their pose offset differs by 90 degrees, spec §1.7).
    """
    box = ontology.INFO_BOX[subtype]
    if ontology.CATEGORY_OF[subtype] == "bicycle":
        return np.array([box[0], box[1], box[2]], dtype=np.float64)
    return np.array([box[1], box[0], box[2]], dtype=np.float64)


def design_extents(subtype: str, length: float) -> np.ndarray:
    """The canonical extents scaled to a design length (builders work in metres-like units)."""
    ext = canonical_extents(subtype)
    return ext * (length / ext[0])


@dataclass(frozen=True)
class VehicleMesh:
    """One subtype's mesh in the canonical frame (front +x, up +z, left +y, resting on z = 0, centred in x and y),
    sized to the public ``info_box``, with one part id per triangle."""

    subtype: str
    mesh: trimesh.Trimesh
    #: int16 [F]: index into ``ontology.PARTS[subtype]``, or -1 for body/frame/glass.
    face_parts: np.ndarray
    #: int8 [F]: index into :data:`FINISHES`.
    face_finish: np.ndarray
    #: Per-axis scale that mapped the builder's design onto ``info_box``, relative to their mean (distortion check).
    axis_scale: tuple[float, float, float] = field(default=(1.0, 1.0, 1.0))

    @property
    def category(self) -> str:
        return ontology.CATEGORY_OF[self.subtype]

    @property
    def part_names(self) -> tuple[str, ...]:
        return ontology.PARTS[self.subtype]

    @property
    def extents(self) -> np.ndarray:
        return self.mesh.extents.copy()

    def part_faces(self, part: str | int) -> np.ndarray:
        """Indices of the faces of one part (raw name or id)."""
        pid = ontology.part_id(self.subtype, part) if isinstance(part, str) else int(part)
        return np.flatnonzero(self.face_parts == pid)

    def part_mesh(self, part: str | int) -> trimesh.Trimesh:
        """The sub-mesh of one part."""
        return self.mesh.submesh([self.part_faces(part)], append=True)

    @cached_property
    def part_centroids(self) -> np.ndarray:
        """[P, 3] area-weighted centroid of each part's surface."""
        area = self.mesh.area_faces
        centers = self.mesh.triangles_center
        out = np.zeros((len(self.part_names), 3))
        for pid in range(len(self.part_names)):
            sel = self.face_parts == pid
            out[pid] = (centers[sel] * area[sel, None]).sum(0) / area[sel].sum()
        return out


class Assembly:
    """Pieces of a vehicle under construction, each with a part label (or none) and a finish."""

    def __init__(self, subtype: str):
        if subtype not in ontology.SUBTYPES:
            raise ValueError(f"unknown subtype {subtype!r}")
        self.subtype = subtype
        self._pieces: list[tuple[trimesh.Trimesh, int, int]] = []

    def add(self, label: str | None, *meshes: trimesh.Trimesh, finish: str = "paint") -> None:
        """Add pieces; ``label`` is a raw part name of the subtype, or None for body/frame geometry."""
        if label is None:
            pid = UNLABELLED
        elif label in ontology.PARTS[self.subtype]:
            pid = ontology.PARTS[self.subtype].index(label)
        else:
            raise ValueError(f"{label!r} is not a part of {self.subtype}: {ontology.PARTS[self.subtype]}")
        fid = FINISHES.index(finish)
        for mesh in meshes:
            # renderers shade with face normals: every piece must be closed and wound outward
            if not mesh.is_watertight or mesh.volume <= 0:
                raise ValueError(f"{self.subtype}: a piece labelled {label!r} is not a closed, outward-wound solid")
            self._pieces.append((mesh, pid, fid))

    def body(self, *meshes: trimesh.Trimesh, finish: str = "paint") -> None:
        self.add(None, *meshes, finish=finish)

    @property
    def labels(self) -> set[str]:
        names = ontology.PARTS[self.subtype]
        return {names[pid] for _, pid, _ in self._pieces if pid >= 0}

    def finish(self) -> VehicleMesh:
        """Concatenate, check that every listed part is present, and normalise to the canonical frame/size."""
        missing = set(ontology.PARTS[self.subtype]) - self.labels
        if missing:
            raise ValueError(f"{self.subtype} builder did not build parts {sorted(missing)}")
        meshes = [m for m, _, _ in self._pieces]
        mesh = trimesh.util.concatenate(meshes)
        counts = [len(m.faces) for m in meshes]
        face_parts = np.repeat([pid for _, pid, _ in self._pieces], counts).astype(np.int16)
        face_finish = np.repeat([fid for _, _, fid in self._pieces], counts).astype(np.int8)

        lo, hi = mesh.bounds
        design = hi - lo
        target = canonical_extents(self.subtype)
        scale = target / design
        vertices = (mesh.vertices - np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]])) * scale
        out = trimesh.Trimesh(vertices, mesh.faces, process=False)
        rel = scale / scale.mean()
        return VehicleMesh(self.subtype, out, face_parts, face_finish, tuple(float(r) for r in rel))

"""Procedural, part-labelled meshes of the 21 Super-CLEVR-3D vehicle subtypes.

The public CAD models cannot be redistributed, so every subtype is built here from primitives, one labelled piece
per part (``ontology.PARTS[subtype]``), in the canonical frame: front along +x, up +z, left side on +y, resting on
z = 0 with its bounding box centred at x = y = 0 and sized to the public ``info_box`` (scale by
``ontology.SIZE_SCALE`` to place it in a scene). See docs/world_meshes.md.

    >>> vm = vehicle_mesh("sedan")
    >>> vm.part_names[vm.face_parts[0]]   # part of the first triangle (or -1 for body)
"""

from __future__ import annotations

from functools import cache

from po3d_ppl import ontology
from po3d_ppl.errors import UnknownNameError
from po3d_ppl.world.meshes import aeroplanes, bicycles, buses, cars, motorbikes  # noqa: F401  (register builders)
from po3d_ppl.world.meshes.assembly import FINISHES, UNLABELLED, VehicleMesh, canonical_extents
from po3d_ppl.world.meshes.export import export_glb
from po3d_ppl.world.meshes.registry import BUILDERS

__all__ = [
    "FINISHES", "UNLABELLED", "VehicleMesh", "all_vehicle_meshes", "canonical_extents", "export_glb", "vehicle_mesh",
]


@cache
def vehicle_mesh(subtype: str) -> VehicleMesh:
    """The part-labelled mesh of ``subtype`` (built once, then cached; treat it as read-only and ``copy()`` the
    trimesh before transforming it)."""
    if subtype not in ontology.SUBTYPES:
        raise UnknownNameError("subtype", subtype, ontology.SUBTYPES)
    vm = BUILDERS[subtype]().finish()
    vm.face_parts.setflags(write=False)
    vm.face_finish.setflags(write=False)
    return vm


def all_vehicle_meshes() -> dict[str, VehicleMesh]:
    """Every subtype's mesh, in ``ontology.SUBTYPES`` order."""
    return {s: vehicle_mesh(s) for s in ontology.SUBTYPES}

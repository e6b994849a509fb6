"""Builder registry: one function per subtype, registered with :func:`builder`, looked up by ``vehicle_mesh``.

Keeping builders in a table (instead of a chain of ifs) lets each category module register its own subtypes and
lets tests enumerate exactly the subtypes that can be built.
"""

from __future__ import annotations

from collections.abc import Callable

from po3d_ppl.world.meshes.assembly import Assembly

Builder = Callable[[], Assembly]

#: subtype -> function returning the assembled (not yet normalised) vehicle in design units.
BUILDERS: dict[str, Builder] = {}


def builder(subtype: str) -> Callable[[Builder], Builder]:
    """Register the decorated function as the builder of ``subtype``."""

    def register(fn: Builder) -> Builder:
        if subtype in BUILDERS:
            raise ValueError(f"a builder for {subtype!r} is already registered")
        BUILDERS[subtype] = fn
        return fn

    return register

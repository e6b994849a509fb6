"""Cars: suv, wagon, minivan, sedan (lofted bodies with panels) and truck (a pickup: cab plus open bed).

Every car is described by a :class:`CarShape`: key body stations measured from the front bumper line (``s``, in
metres) and the ranges of its panels. :func:`build_car` turns that into labelled geometry: doors, hood, roof and
trunk are panels lying on the body skin (see :mod:`.bodies`), lights/bumpers/plates/mirrors are separate solids,
wheels sit in dark wheel-arch flares.
"""

from __future__ import annotations

from dataclasses import dataclass

from po3d_ppl import ontology
from po3d_ppl.world.meshes import primitives as P
from po3d_ppl.world.meshes.assembly import Assembly, design_extents
from po3d_ppl.world.meshes.bodies import (
    LEFT_GLASS,
    LEFT_SIDE,
    RIGHT_GLASS,
    RIGHT_SIDE,
    TOP,
    Section,
    SectionedBody,
)
from po3d_ppl.world.meshes.registry import builder

#: How far the mirrors stick out of the body side (the public width includes them).
MIRROR_OUT = 0.13


@dataclass(frozen=True)
class Station:
    """A body cross-section ``s`` metres behind the front: top and belt heights, half widths as ratios of the full
    body half width (``top_ratio`` at the roof line, ``side_ratio`` at the belt) and a raised bottom."""

    s: float
    top: float
    belt: float
    top_ratio: float = 0.8
    side_ratio: float = 1.0
    bottom_raise: float = 0.0


@dataclass(frozen=True)
class CarShape:
    length: float
    stations: tuple[Station, ...]
    clearance: float
    wheel_radius: float
    wheel_width: float
    axles: tuple[float, float]
    hood: tuple[float, float]
    windshield: tuple[float, float]
    roof: tuple[float, float]
    side_windows: tuple[tuple[float, float], ...]
    #: s range of a trunk lid on top of the body (sedans), else None
    deck: tuple[float, float] | None = None
    #: s range of a rear window lying on the top surface (sedans), else None (the window is on the tailgate)
    rear_window: tuple[float, float] | None = None
    #: z range of the trunk panel on the rear face (tailgate / lower trunk face)
    tailgate: tuple[float, float] = (0.6, 1.0)
    #: z range of the rear window on the tailgate (hatchbacks), else None
    tailgate_glass: tuple[float, float] | None = None
    back_doors: bool = True
    #: height of the head and tail lights' centres
    light_z: tuple[float, float] = (0.75, 0.9)


class CarBuilder:
    """Places the standard car parts around a :class:`SectionedBody` built from a :class:`CarShape`."""

    def __init__(self, subtype: str, shape: CarShape):
        self.subtype, self.shape = subtype, shape
        L, W, H = design_extents(subtype, shape.length)
        self.L, self.W, self.H = L, W, H
        self.hw = W / 2 - MIRROR_OUT
        self.asm = Assembly(subtype)
        self.body = SectionedBody([self._section(st) for st in shape.stations])

    def x(self, s: float) -> float:
        return self.L / 2 - s

    def _section(self, st: Station) -> Section:
        hw = self.hw * st.side_ratio
        return Section(
            x=self.x(st.s),
            half_width=hw,
            bottom=self.shape.clearance + st.bottom_raise,
            belt=st.belt,
            top=st.top,
            top_half_width=self.hw * st.top_ratio,
            chamfer=0.06,
            round=0.07,
        )

    def has(self, part: str) -> bool:
        return part in ontology.PARTS[self.subtype]

    def build(self) -> Assembly:
        self.asm.body(self.body.mesh())
        self.wheels()
        self.panels()
        self.glass()
        self.lights()
        self.bumpers_and_plates()
        self.mirrors()
        return self.asm

    # -- pieces -------------------------------------------------------------------------------------------------
    def wheels(self) -> None:
        sh = self.shape
        R, w = sh.wheel_radius, sh.wheel_width
        y = self.hw - w / 2 + 0.04
        for s, end in zip(sh.axles, ("front", "back")):
            for sign, side in ((1, "left"), (-1, "right")):
                c = (self.x(s), sign * y, R)
                self.asm.add(f"{end}_{side}_wheel", P.tyre(c, R, w, sections=20))
                self.asm.add(f"{end}_{side}_wheel", P.disc((c[0], sign * (y + w * 0.36), R), R * 0.55, 0.03),
                             finish="chrome")
                arch = P.fender((self.x(s), sign * (self.hw - 0.01), R), R + 0.03, 8, 172, 0.07, 0.05, n=10)
                self.asm.body(arch, finish="rubber")

    def door_ranges(self) -> list[tuple[str, float, float]]:
        sh = self.shape
        gap = 0.03
        start = sh.axles[0] + sh.wheel_radius + 0.1
        if not sh.back_doors:
            return [("front", start, sh.roof[1] - 0.05)]
        end = sh.axles[1] - sh.wheel_radius - 0.08
        split = start + (end - start) * 0.52
        return [("front", start, split - gap / 2), ("back", split + gap / 2, end)]

    def panels(self) -> None:
        sh, b = self.shape, self.body
        for which, s0, s1 in self.door_ranges():
            self.asm.add(f"{which}_left_door", b.panel(self.x(s0), self.x(s1), LEFT_SIDE, 0.12, 0.97))
            # RIGHT_SIDE runs from the belt down to the sill, so its parameter range is mirrored
            self.asm.add(f"{which}_right_door", b.panel(self.x(s0), self.x(s1), RIGHT_SIDE, 0.03, 0.88))
        self.asm.add("hood", b.panel(self.x(sh.hood[0]), self.x(sh.hood[1]), TOP))
        self.asm.add("roof", b.panel(self.x(sh.roof[0]), self.x(sh.roof[1]), TOP, 0.02, 0.98))
        self.rear_panels()

    def rear_panels(self) -> None:
        """The trunk: a lid on the deck (sedans) and a panel on the rear face."""
        sh, b = self.shape, self.body
        if sh.deck is not None:
            self.asm.add("trunk", b.panel(self.x(sh.deck[0]), self.x(sh.deck[1]), TOP))
        z0, z1 = sh.tailgate
        self.asm.add("trunk", b.end_panel("back", z0, z1, 0.06, thickness=0.015))

    def glass(self) -> None:
        sh, b = self.shape, self.body
        self.asm.body(b.panel(self.x(sh.windshield[0]), self.x(sh.windshield[1]), TOP, 0.04, 0.96), finish="glass")
        if sh.rear_window is not None:
            self.asm.body(b.panel(self.x(sh.rear_window[0]), self.x(sh.rear_window[1]), TOP, 0.05, 0.95),
                          finish="glass")
        for s0, s1 in sh.side_windows:
            self.asm.body(b.panel(self.x(s0), self.x(s1), LEFT_GLASS, 0.08, 0.8), finish="glass")
            self.asm.body(b.panel(self.x(s0), self.x(s1), RIGHT_GLASS, 0.2, 0.92), finish="glass")
        if sh.tailgate_glass is not None:
            g0, g1 = sh.tailgate_glass
            self.asm.body(b.end_panel("back", g0, g1, (0.12, 0.0), thickness=0.03), finish="glass")

    def lights(self) -> None:
        hz, tz = self.shape.light_z
        front, back = self.body.front, self.body.back
        front_hw = self.body.profile_at(front)[:, 0].max()
        back_hw = self.body.profile_at(back)[:, 0].max()
        for sign, side in ((1, "left"), (-1, "right")):
            head = P.rounded_box((front - 0.02, sign * (front_hw - 0.21), hz), (0.1, 0.4, 0.15), 0.03)
            self.asm.add(f"{side}_head_light", head, finish="lamp")
            size = (0.08, 0.34, 0.15) if self.shape.deck is not None else (0.08, 0.2, 0.34)
            tail = P.rounded_box((back + 0.01, sign * (back_hw - size[1] / 2 + 0.02), tz), size, 0.025)
            self.asm.add(f"{side}_tail_light", tail, finish="lamp")

    def bumpers_and_plates(self) -> None:
        z0 = self.shape.clearance + 0.02
        zc = z0 + 0.14
        front, back = self.body.front, self.body.back
        front_hw = self.body.profile_at(front)[:, 0].max()
        grille = self.body.end_panel("front", z0 + 0.26, self.shape.light_z[0] + 0.07, (0.0, 0.0), 0.02,
                                     y_max=front_hw - 0.43)
        self.asm.body(grille, finish="rubber")
        self.asm.add("front_bumper", P.rounded_box((front - 0.02, 0, zc), (0.2, 2 * self.hw * 0.97, 0.26), 0.06))
        self.asm.add("back_bumper", P.rounded_box((back + 0.02, 0, zc), (0.2, 2 * self.hw * 0.97, 0.26), 0.06))
        if self.has("front_license_plate"):
            self.asm.add("front_license_plate", P.box((front + 0.085, 0, zc), (0.02, 0.5, 0.13)))
        if self.has("back_license_plate"):
            self.asm.add("back_license_plate", P.box((back - 0.085, 0, zc), (0.02, 0.5, 0.13)))

    def mirrors(self) -> None:
        sh = self.shape
        s = sh.windshield[0] + 0.15
        belt = self.body.profile_at(self.x(s))[2, 1]
        z = belt + 0.09
        for sign, side in ((1, "left"), (-1, "right")):
            y_in, y_out = sign * (self.hw - 0.02), sign * (self.hw + MIRROR_OUT)
            self.asm.body(P.tube((self.x(s), y_in, z - 0.02), (self.x(s) - 0.02, sign * (self.hw + 0.05), z), 0.015, 6),
                          finish="rubber")
            housing = P.rounded_box((self.x(s) - 0.03, (y_in + y_out) / 2 + sign * 0.025, z),
                                    (0.12, abs(y_out - y_in) - 0.05, 0.19), 0.035)
            self.asm.add(f"{side}_mirror", housing)


def _hatch_stations(nose: float, hood_front: float, hood: float, roof: float, tail: float, belt: float,
                    ws: float, rf: float, rb: float, L: float, tumble: float = 0.8) -> tuple[Station, ...]:
    """Stations of a two-box body (hood, cabin running to a near-vertical rear)."""
    return (
        Station(0.0, nose, nose - 0.06, 0.86, 0.9, 0.1),
        Station(0.05, (nose + hood_front) / 2 + 0.02, (nose + hood_front) / 2 - 0.04, 0.92, 0.97, 0.03),
        Station(0.16, hood_front, hood_front - 0.05, 0.95, 1.0, 0.0),
        Station(ws, hood, hood - 0.04, 0.96, 1.0),
        Station(rf, roof, belt, tumble),
        Station(rb, roof - 0.02, belt, tumble),
        Station(L - 0.12, tail, belt, tumble * 0.98, 1.0),
        Station(L - 0.04, tail - 0.02, belt - 0.02, tumble * 0.96, 0.98, 0.03),
        Station(L, tail - 0.06, belt - 0.05, tumble * 0.92, 0.94, 0.08),
    )


@builder("suv")
def suv() -> Assembly:
    L = 4.7
    _, _, H = design_extents("suv", L)
    shape = CarShape(
        length=L,
        stations=_hatch_stations(0.92, 1.05, 1.17, H, H - 0.1, 1.17, 1.25, 1.95, 4.45, L, 0.84),
        clearance=0.36, wheel_radius=0.39, wheel_width=0.27, axles=(0.95, 3.8),
        hood=(0.18, 1.2), windshield=(1.28, 1.92), roof=(2.0, 4.45),
        side_windows=((1.4, 2.45), (2.55, 3.45), (3.55, 4.4)),
        tailgate=(0.62, H - 0.12), tailgate_glass=(1.22, H - 0.2), light_z=(0.88, 1.05),
    )
    return CarBuilder("suv", shape).build()


@builder("wagon")
def wagon() -> Assembly:
    L = 4.85
    _, _, H = design_extents("wagon", L)
    shape = CarShape(
        length=L,
        stations=_hatch_stations(0.68, 0.82, 0.96, H, H - 0.07, 0.97, 1.5, 2.3, 4.6, L, 0.8),
        clearance=0.2, wheel_radius=0.33, wheel_width=0.23, axles=(0.95, 3.85),
        hood=(0.18, 1.45), windshield=(1.55, 2.25), roof=(2.35, 4.62),
        side_windows=((1.7, 2.6), (2.75, 3.6), (3.7, 4.62)),
        tailgate=(0.5, H - 0.18), tailgate_glass=(1.0, H - 0.24), light_z=(0.66, 0.85),
    )
    return CarBuilder("wagon", shape).build()


@builder("minivan")
def minivan() -> Assembly:
    L = 5.0
    _, _, H = design_extents("minivan", L)
    shape = CarShape(
        length=L,
        stations=_hatch_stations(0.82, 0.95, 1.1, H, H - 0.08, 1.1, 0.75, 1.95, 4.8, L, 0.86),
        clearance=0.24, wheel_radius=0.36, wheel_width=0.24, axles=(0.9, 3.95),
        hood=(0.18, 0.72), windshield=(0.8, 1.9), roof=(2.0, 4.8),
        side_windows=((1.4, 2.35), (2.5, 3.5), (3.6, 4.85)),
        tailgate=(0.55, H - 0.12), tailgate_glass=(1.15, H - 0.2), light_z=(0.8, 1.2),
    )
    return CarBuilder("minivan", shape).build()


@builder("sedan")
def sedan() -> Assembly:
    L = 4.8
    _, _, H = design_extents("sedan", L)
    stations = (
        Station(0.0, 0.7, 0.64, 0.86, 0.9, 0.1),
        Station(0.05, 0.79, 0.73, 0.92, 0.97, 0.03),
        Station(0.16, 0.84, 0.79, 0.95, 1.0),
        Station(1.5, 0.98, 0.94, 0.96, 1.0),
        Station(2.25, H, 0.98, 0.78),
        Station(3.25, H - 0.03, 0.98, 0.78),
        Station(4.0, 1.03, 0.98, 0.93),
        Station(4.68, 1.01, 0.96, 0.95, 1.0),
        Station(4.76, 0.99, 0.94, 0.92, 0.98, 0.03),
        Station(4.8, 0.94, 0.9, 0.88, 0.94, 0.08),
    )
    shape = CarShape(
        length=L, stations=stations, clearance=0.2, wheel_radius=0.33, wheel_width=0.23, axles=(0.95, 3.85),
        hood=(0.18, 1.45), windshield=(1.55, 2.2), roof=(2.3, 3.22), rear_window=(3.3, 3.95), deck=(4.05, 4.68),
        side_windows=((1.7, 2.6), (2.75, 3.55)), tailgate=(0.5, 0.9), light_z=(0.66, 0.85),
    )
    return CarBuilder("sedan", shape).build()


class PickupBuilder(CarBuilder):
    """A pickup: the lofted body ends behind the cab; an open bed (floor + walls + tailgate) follows."""

    def __init__(self, shape: CarShape, bed_length: float):
        self.bed_length = bed_length
        super().__init__("truck", shape)

    def build(self) -> Assembly:
        super().build()
        self.bed()
        return self.asm

    def bed(self) -> None:
        sh = self.shape
        cab_back = self.body.back
        x0, x1 = cab_back - 0.04, cab_back - self.bed_length
        floor_z, wall_top = 0.82, 1.22
        hw = self.hw
        mid = (x0 + x1) / 2
        length = x0 - x1
        # lower body under the bed (frame/skirts), walls, floor, tailgate
        self.asm.body(P.rounded_box((mid, 0, (sh.clearance + floor_z) / 2), (length, 2 * hw, floor_z - sh.clearance), 0.05))
        for sign in (1, -1):
            self.asm.body(P.rounded_box((mid, sign * (hw - 0.04), (floor_z + wall_top) / 2), (length, 0.08, wall_top - floor_z), 0.02))
        self.asm.add("trunk", P.box((mid, 0, floor_z + 0.01), (length - 0.1, 2 * hw - 0.16, 0.02)))
        self.asm.add("trunk", P.rounded_box((x1 + 0.04, 0, (floor_z + wall_top) / 2 - 0.02), (0.08, 2 * hw - 0.02, wall_top - floor_z + 0.04), 0.02))

    # the bed's rear replaces the body's rear face for lights, bumper and trunk
    def rear_panels(self) -> None:
        """The cab's rear window (the trunk is the bed, see :meth:`bed`)."""
        self.asm.body(self.body.end_panel("back", 1.25, 1.6, 0.25, thickness=0.02), finish="glass")

    def lights(self) -> None:
        hz, tz = self.shape.light_z
        front = self.body.front
        front_hw = self.body.profile_at(front)[:, 0].max()
        back = self.body.back - 0.04 - self.bed_length
        for sign, side in ((1, "left"), (-1, "right")):
            head = P.rounded_box((front - 0.02, sign * (front_hw - 0.2), hz), (0.1, 0.36, 0.14), 0.03)
            self.asm.add(f"{side}_head_light", head, finish="lamp")
            tail = P.rounded_box((back + 0.02, sign * (self.hw - 0.04), tz), (0.08, 0.1, 0.3), 0.02)
            self.asm.add(f"{side}_tail_light", tail, finish="lamp")

    def bumpers_and_plates(self) -> None:
        z0 = self.shape.clearance + 0.02
        zc = z0 + 0.15
        front = self.body.front
        back = self.body.back - 0.04 - self.bed_length
        self.asm.add("front_bumper", P.rounded_box((front - 0.02, 0, zc), (0.22, 2 * self.hw * 0.97, 0.28), 0.06))
        self.asm.add("back_bumper", P.rounded_box((back - 0.02, 0, zc), (0.2, 2 * self.hw * 0.97, 0.24), 0.06))
        self.asm.add("front_license_plate", P.box((front + 0.1, 0, zc), (0.02, 0.5, 0.13)))


@builder("truck")
def truck() -> Assembly:
    L = 5.4
    bed = 2.2
    _, _, H = design_extents("truck", L)
    cab_len = L - bed - 0.04
    stations = (
        Station(0.0, 1.02, 0.96, 0.88, 0.93, 0.12),
        Station(0.05, 1.1, 1.04, 0.93, 0.98, 0.04),
        Station(0.16, 1.14, 1.09, 0.96, 1.0),
        Station(1.6, 1.24, 1.2, 0.97, 1.0),
        Station(2.25, H, 1.24, 0.84),
        Station(cab_len - 0.1, H - 0.02, 1.24, 0.84),
        Station(cab_len, H - 0.06, 1.22, 0.82),
    )
    shape = CarShape(
        length=L, stations=stations, clearance=0.42, wheel_radius=0.41, wheel_width=0.28, axles=(1.0, 4.3),
        hood=(0.18, 1.55), windshield=(1.65, 2.2), roof=(2.3, cab_len - 0.08),
        side_windows=((1.8, cab_len - 0.1),), back_doors=False, light_z=(0.95, 1.0),
    )
    return PickupBuilder(shape, bed).build()

"""Buses: regular (a plain box), double (two storeys), articulated (two bodies and a bellows joint) and school (a
bonnet nose).

Bus bodies are lofted with a high belt line so that the whole vertical side is one flat polyline: window bands,
doors and the rear engine hatch ("trunk") are panels placed on it by height.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from po3d_ppl import ontology
from po3d_ppl.world.meshes import primitives as P
from po3d_ppl.world.meshes.assembly import Assembly, design_extents
from po3d_ppl.world.meshes.bodies import LEFT_SIDE, RIGHT_SIDE, TOP, Section, SectionedBody
from po3d_ppl.world.meshes.registry import builder

BODY_HALF_WIDTH = 1.25
CLEARANCE = 0.3
WHEEL_RADIUS = 0.5
WHEEL_WIDTH = 0.32


@dataclass(frozen=True)
class BusShape:
    length: float
    #: s (from the front) ranges of the bodies (one, or two for articulated buses)
    bodies: tuple[tuple[float, float], ...]
    #: axles: (s, part prefix or None for unlabelled)
    axles: tuple[tuple[float, str | None], ...]
    #: doors: (part name, side, s0, s1)
    doors: tuple[tuple[str, str, float, float], ...]
    #: window bands (z0, z1)
    window_rows: tuple[tuple[float, float], ...] = ((1.25, 2.55),)
    #: bonnet: (s where the passenger box starts, bonnet height) for school buses
    bonnet: tuple[float, float] | None = None
    body_half_width: float = BODY_HALF_WIDTH


class BusBuilder:
    def __init__(self, subtype: str, shape: BusShape):
        self.subtype, self.shape = subtype, shape
        self.L, self.W, self.H = design_extents(subtype, shape.length)
        self.hw = shape.body_half_width
        #: small parts (lights, mirrors) grow on long buses so they stay visible once scaled to the public size
        self.detail = max(1.0, shape.length / 12.0)
        self.asm = Assembly(subtype)
        self.bodies = [self._body(s0, s1, k == 0, k == len(shape.bodies) - 1) for k, (s0, s1) in enumerate(shape.bodies)]

    def x(self, s: float) -> float:
        return self.L / 2 - s

    def has(self, part: str) -> bool:
        return part in ontology.PARTS[self.subtype]

    def _section(self, s: float, top: float, side: float = 1.0, raise_: float = 0.0) -> Section:
        return Section(self.x(s), self.hw * side, CLEARANCE + raise_, top - 0.28, top, self.hw * side * 0.95,
                       chamfer=0.08, round=0.2)

    def _body(self, s0: float, s1: float, is_front: bool, is_back: bool) -> SectionedBody:
        H = self.H
        secs = []
        if is_front and self.shape.bonnet is not None:
            box_start, bonnet_h = self.shape.bonnet
            secs += [self._section(s0, bonnet_h - 0.1, 0.92, 0.1), self._section(s0 + 0.12, bonnet_h, 0.97),
                     self._section(box_start - 0.35, bonnet_h + 0.2, 1.0),
                     self._section(box_start, H - 0.05), self._section(box_start + 0.2, H)]
        elif is_front:
            secs += [self._section(s0, H - 0.12, 0.96, 0.04), self._section(s0 + 0.18, H)]
        else:
            secs += [self._section(s0, H - 0.04, 0.97), self._section(s0 + 0.1, H)]
        if is_back:
            secs += [self._section(s1 - 0.15, H), self._section(s1, H - 0.08, 0.96, 0.04)]
        else:
            secs += [self._section(s1 - 0.1, H), self._section(s1, H - 0.04, 0.97)]
        return SectionedBody(secs)

    def body_at(self, s: float) -> SectionedBody:
        x = self.x(s)
        for b in self.bodies:
            if b.back <= x <= b.front:
                return b
        raise ValueError(f"no bus body at s={s}")

    def side_panel(self, side: str, s0: float, s1: float, z0: float, z1: float, thickness: float = 0.02):
        """A panel on the flat left (+y) or right (-y) side between heights z0 and z1."""
        body = self.body_at((s0 + s1) / 2)
        prof = body.profile_at(self.x((s0 + s1) / 2))
        lo, hi = prof[1, 1], prof[2, 1]  # sill and belt heights of the side polyline
        t0, t1 = (np.clip((z - lo) / (hi - lo), 0, 1) for z in (z0, z1))
        if side == "left":
            return body.panel(self.x(s0), self.x(s1), LEFT_SIDE, t0, t1, thickness)
        return body.panel(self.x(s0), self.x(s1), RIGHT_SIDE, 1 - t1, 1 - t0, thickness)

    def build(self) -> Assembly:
        for b in self.bodies:
            self.asm.body(b.mesh())
        self.wheels()
        self.doors_and_windows()
        self.front_and_back()
        self.mirrors()
        self.roof()
        return self.asm

    def wheels(self) -> None:
        R, w = WHEEL_RADIUS, WHEEL_WIDTH
        y = self.hw - w / 2 + 0.03
        for s, prefix in self.shape.axles:
            for sign, side in ((1, "left"), (-1, "right")):
                c = (self.x(s), sign * y, R)
                label = f"{prefix}_{side}" if prefix else None
                self.asm.add(label, P.tyre(c, R, w, sections=20), finish="rubber")
                self.asm.add(label, P.disc((c[0], sign * (y + w * 0.4), R), R * 0.6, 0.03), finish="chrome")
                self.asm.body(P.fender((c[0], sign * (self.hw - 0.02), R), R + 0.06, 5, 175, 0.06, 0.06, n=10),
                              finish="rubber")

    def doors_and_windows(self) -> None:
        for name, side, s0, s1 in self.shape.doors:
            top = self.shape.window_rows[0][1]
            self.asm.add(name, self.side_panel(side, s0, s1, CLEARANCE + 0.12, top, 0.035))
            mid = (s0 + s1) / 2
            for a, b in ((s0 + 0.08, mid - 0.03), (mid + 0.03, s1 - 0.08)):  # glazed door leaves
                self.asm.body(self.side_panel(side, a, b, CLEARANCE + 0.9, top - 0.1, 0.045), finish="glass")
        for side in ("left", "right"):
            doors = sorted((s0, s1) for _, sd, s0, s1 in self.shape.doors if sd == side)
            for z0, z1 in self.shape.window_rows:
                for a, b in self._free_spans(doors, z0):
                    # split long spans into individual windows with pillars
                    n = max(1, int(round((b - a) / 1.4)))
                    edges = np.linspace(a, b, n + 1)
                    for e0, e1 in zip(edges[:-1], edges[1:]):
                        self.asm.body(self.side_panel(side, e0 + 0.05, e1 - 0.05, z0, z1), finish="glass")

    def _free_spans(self, doors: list[tuple[float, float]], z0: float) -> list[tuple[float, float]]:
        """Stretches of the side free for windows (not doors, not joints, not the bonnet)."""
        spans = []
        for body_s0, body_s1 in self.shape.bodies:
            start = body_s0 + 0.35
            if self.shape.bonnet is not None and body_s0 == self.shape.bodies[0][0]:
                start = self.shape.bonnet[0] + 0.3
            end = body_s1 - 0.35
            cuts = [d for d in doors if d[1] > start and d[0] < end and z0 < self.shape.window_rows[0][1]]
            cur = start
            for d0, d1 in cuts:
                if d0 - 0.1 > cur + 0.3:
                    spans.append((cur, d0 - 0.1))
                cur = max(cur, d1 + 0.1)
            if end > cur + 0.3:
                spans.append((cur, end))
        return spans

    def front_and_back(self) -> None:
        H = self.H
        front, back = self.bodies[0], self.bodies[-1]
        xf, xb = front.front, back.back
        fw = front.profile_at(xf)[:, 0].max()
        bw = back.profile_at(xb)[:, 0].max()
        if self.shape.bonnet is None and len(self.shape.window_rows) > 1:  # a windscreen per deck
            for z0, z1 in self.shape.window_rows:
                self.asm.body(front.end_panel("front", z0, z1, (0.08, 0.0), 0.02), finish="glass")
        elif self.shape.bonnet is None:  # windscreen and destination display
            self.asm.body(front.end_panel("front", 1.15, H - 0.55, (0.08, 0.0), 0.02), finish="glass")
            self.asm.body(front.end_panel("front", H - 0.48, H - 0.22, (0.35, 0.0), 0.025), finish="glass")
        else:  # windscreen on the raked face of the passenger box, above the bonnet
            s_box = self.shape.bonnet[0]
            self.asm.body(front.panel(self.x(s_box - 0.33), self.x(s_box - 0.02), TOP, 0.03, 0.97, 0.03), finish="glass")
            self.asm.body(front.end_panel("front", CLEARANCE + 0.45, self.shape.bonnet[1] - 0.2, (0.3, 0.0), 0.03),
                          finish="rubber")
        self.asm.body(back.end_panel("back", H - 1.1, H - 0.35, (0.15, 0.0), 0.02), finish="glass")
        if self.has("trunk"):
            self.asm.add("trunk", back.end_panel("back", 0.75, 1.75, (0.35, 0.0), 0.03))
        zc = CLEARANCE + 0.2
        light_z = (CLEARANCE + 0.62) if self.shape.bonnet is None else self.shape.bonnet[1] - 0.35
        d = self.detail
        for sign, side in ((1, "left"), (-1, "right")):
            self.asm.add(f"head_light_{side}", P.rounded_box((xf - 0.01, sign * (fw - 0.34 * d), light_z),
                                                            (0.12, 0.56 * d, 0.3 * d), 0.04), finish="lamp")
            self.asm.add(f"tail_light_{side}", P.rounded_box((xb + 0.02, sign * (bw - 0.15 * d), 1.35),
                                                            (0.1, 0.24 * d, 0.7 * d), 0.04), finish="lamp")
        bumper_w = 2 * self.hw * 0.98
        if self.has("bumper_front"):
            self.asm.add("bumper_front", P.rounded_box((xf + 0.03, 0, zc), (0.2, bumper_w, 0.36), 0.06))
        else:
            self.asm.body(P.rounded_box((xf + 0.03, 0, zc), (0.2, bumper_w, 0.36), 0.06), finish="rubber")
        self.asm.add("bumper_back", P.rounded_box((xb - 0.03, 0, zc), (0.2, bumper_w, 0.36), 0.06))
        plate = (0.03, 0.62 * self.detail, 0.2 * self.detail)
        self.asm.add("license_plate_front", P.box((xf + 0.14, 0, zc), plate))
        self.asm.add("license_plate_back", P.box((xb - 0.14, 0, zc), plate))

    def mirrors(self) -> None:
        front = self.bodies[0]
        x_face = front.front if self.shape.bonnet is None else self.x(self.shape.bonnet[0])
        out = self.W / 2
        z_top = self.H - 0.35 if self.shape.bonnet is None else self.shape.bonnet[1] + 0.6
        for sign, side in ((1, "left"), (-1, "right")):
            p0 = (x_face - 0.15, sign * (self.hw - 0.05), z_top)
            p1 = (x_face + 0.3, sign * (out - 0.08), z_top)
            p2 = (x_face + 0.3, sign * (out - 0.08), z_top - 0.35)
            self.asm.body(P.polyline_tube(np.array([p0, p1, p2]), 0.03, 6, up=(1, 0, 0)),
                          finish="chrome")
            d = self.detail
            self.asm.add(f"mirror_{side}", P.rounded_box((x_face + 0.3, sign * (out - 0.1 * d), z_top - 0.55 * d),
                                                         (0.1, 0.2 * d, 0.45 * d), 0.03))

    def roof(self) -> None:
        for b in self.bodies:
            s0 = self.L / 2 - b.front + (0.5 if b is self.bodies[0] and self.shape.bonnet is None else 0.25)
            if b is self.bodies[0] and self.shape.bonnet is not None:
                s0 = self.shape.bonnet[0] + 0.3
            s1 = self.L / 2 - b.back - 0.3
            self.asm.add("roof", b.panel(self.x(s0), self.x(s1), TOP, 0.04, 0.96, 0.03))


@builder("regular")
def regular() -> Assembly:
    L = 12.0
    shape = BusShape(
        length=L, bodies=((0.0, L),), axles=((2.7, "wheel_front"), (L - 3.3, "wheel_back")),
        doors=(("door_front_right", "right", 0.35, 1.6), ("door_mid_right", "right", 4.9, 6.1),
               ("door_back_right", "right", L - 2.6, L - 1.45)),
    )
    return BusBuilder("regular", shape).build()


@builder("double")
def double() -> Assembly:
    L = 11.0
    _, W, H = design_extents("double", L)
    shape = BusShape(
        length=L, bodies=((0.0, L),), axles=((2.5, "wheel_front"), (L - 3.0, "wheel_back")),
        doors=(("door_front_right", "right", 0.3, 1.45), ("door_mid_right", "right", 4.4, 5.55),
               ("door_front_left", "left", 0.3, 1.45), ("door_mid_left", "left", 4.4, 5.55)),
        window_rows=((1.15, 1.85), (2.35, H - 0.42)),
        body_half_width=W / 2 - 0.06,
    )
    return BusBuilder("double", shape).build()


class ArticulatedBuilder(BusBuilder):
    """Two bodies joined by an accordion bellows over a turntable."""

    def build(self) -> Assembly:
        super().build()
        (_, s_end), (s_start, _) = self.shape.bodies
        x0, x1 = self.x(s_end), self.x(s_start)
        n = 9
        prof = self.bodies[0].profile_at(self.bodies[0].back)
        c = np.array([0.0, prof[:, 1].mean()])
        for k, x in enumerate(np.linspace(x0, x1, n)):
            shrink = 0.06 if k % 2 else 0.0
            scaled = c + (prof - c) * (1 - shrink)
            ring = np.column_stack([np.full(len(prof), x), scaled])
            self.asm.body(P.loft([ring + [0.045, 0, 0], ring - [0.045, 0, 0]]), finish="rubber")
        return self.asm


@builder("articulated")
def articulated() -> Assembly:
    L = 18.0
    H = design_extents("articulated", L)[2]
    shape = BusShape(
        length=L, bodies=((0.0, 10.6), (11.4, L)),
        axles=((2.6, "wheel_front"), (8.9, None), (L - 2.3, "wheel_back")),
        doors=(("door_front_right", "right", 0.3, 1.55), ("door_mid_right", "right", 5.0, 6.25),
               ("door_back_right", "right", 12.3, 13.55)),
        window_rows=((1.15, H - 0.45),),
    )
    return ArticulatedBuilder("articulated", shape).build()


@builder("school")
def school() -> Assembly:
    L = 11.0
    _, W, H = design_extents("school", L)
    shape = BusShape(
        length=L, bodies=((0.0, L),), axles=((0.95, "wheel_front"), (L - 3.1, "wheel_back")),
        doors=(("door_front_right", "right", 2.05, 2.95), ("door_mid_left", "left", 5.6, 6.5)),
        window_rows=((1.35, H - 0.5),), bonnet=(1.9, 1.45), body_half_width=W / 2 - 0.1,
    )
    return BusBuilder("school", shape).build()

"""Bicycles: road (drop bars, thin tyres), utility (upright bars, fenders, rear carrier, side stand), mountain
(thick tyres, suspension fork, flat bars, disc brakes) and tandem (long frame, two saddles, two sets of bars).

A :class:`Geometry` record holds the frame's key points (in the xz plane, left = +y); :class:`BikeBuilder` turns it
into tubes and labelled parts. Parts missing from a subtype's list (e.g. the tandem's pedals) are still built, as
unlabelled geometry.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from po3d_ppl import ontology
from po3d_ppl.world.meshes import primitives as P
from po3d_ppl.world.meshes.assembly import Assembly
from po3d_ppl.world.meshes.registry import builder

SIDES = ((1.0, "left"), (-1.0, "right"))


def _p(xz: tuple[float, float], y: float = 0.0) -> tuple[float, float, float]:
    return (xz[0], y, xz[1])


@dataclass(frozen=True)
class Geometry:
    front_axle: float
    rear_axle: float
    wheel_radius: float
    tyre: float
    bb: tuple[float, float]
    seat_top: tuple[float, float]
    head_top: tuple[float, float]
    head_bottom: tuple[float, float]
    saddle: tuple[float, float]
    tube: float = 0.018
    crank: float = 0.17
    crank_angle: float = -35.0
    step_through: bool = False


class BikeBuilder:
    def __init__(self, subtype: str, g: Geometry):
        self.subtype, self.g = subtype, g
        self.asm = Assembly(subtype)

    def label(self, name: str) -> str | None:
        """The part label if the subtype lists it, else None (built unlabelled)."""
        return name if name in ontology.PARTS[self.subtype] else None

    def add(self, name: str, *meshes, finish: str = "paint") -> None:
        self.asm.add(self.label(name), *meshes, finish=finish)

    def wheel(self, name: str, x: float) -> None:
        g = self.g
        R, t = g.wheel_radius, g.tyre
        c = (x, 0.0, R)
        self.add(name, P.torus(c, (0, 1, 0), R - t, t, 28, 6), finish="rubber")
        self.add(name, P.torus(c, (0, 1, 0), R - 2 * t - 0.008, 0.008, 28, 4), finish="chrome")
        self.add(name, P.tube((x, -0.05, R), (x, 0.05, R), 0.02, 8), finish="chrome")
        rim = R - 2 * t - 0.01
        for k in range(16):
            a = 2 * np.pi * k / 16
            side = 0.035 if k % 2 else -0.035
            self.add(name, P.tube((x, side, R), (x + rim * np.cos(a), 0.0, R + rim * np.sin(a)), 0.004, 3),
                     finish="chrome")

    def single_rider(self, suspension: bool = False) -> None:
        """What every one-seat bike shares: both wheels, the frame, the fork, the saddle and the drivetrain."""
        g = self.g
        self.wheel("wheel_front", g.front_axle)
        self.wheel("wheel_back", g.rear_axle)
        self.frame()
        self.fork(suspension)
        self.saddle(g.saddle)
        self.drivetrain(g.bb, g.crank_angle)

    def frame(self) -> None:
        g = self.g
        f = g.tube
        bb, st, ht, hb = _p(g.bb), _p(g.seat_top), _p(g.head_top), _p(g.head_bottom)
        ra = (g.rear_axle, 0.0, g.wheel_radius)
        tubes = [(ht, hb, f * 1.4), (hb, bb, f * 1.15), (bb, st, f)]
        if g.step_through:
            mid = ((hb[0] + bb[0]) / 2 - 0.05, 0.0, bb[2] + 0.08)
            tubes = [(ht, hb, f * 1.4), (hb, mid, f * 1.2), (mid, bb, f * 1.2), (bb, st, f),
                     ((hb[0] - 0.03, 0, hb[2] - 0.05), (mid[0] - 0.1, 0, mid[2] + 0.08), f)]
        else:
            tubes.append(((st[0] + 0.02, 0, st[2] - 0.04), (ht[0] - 0.01, 0, ht[2] - 0.04), f))
        for sign, _ in SIDES:
            tubes.append((bb, (ra[0], sign * 0.055, ra[2]), f * 0.7))
            tubes.append(((st[0], sign * 0.02, st[2] - 0.03), (ra[0], sign * 0.055, ra[2]), f * 0.6))
        for a, b, r in tubes:
            self.asm.body(P.tube(a, b, r, 8))
        # seat post
        sd = _p(g.saddle)
        self.asm.body(P.tube(st, (sd[0] + 0.01, 0, sd[2] - 0.03), f * 0.8, 8), finish="chrome")

    def saddle(self, at: tuple[float, float], name: str = "saddle") -> None:
        x, z = at
        self.add(name, P.hull_of(P.ellipsoid((x + 0.1, 0, z), (0.06, 0.03, 0.025), 1),
                                 P.ellipsoid((x - 0.05, 0, z), (0.07, 0.085, 0.035), 1)), finish="rubber")

    def fork(self, suspension: bool = False) -> None:
        g = self.g
        hb = np.array(_p(g.head_bottom))
        axle = np.array([g.front_axle, 0.0, g.wheel_radius])
        crown = hb + (axle - hb) * 0.08
        self.add("fork", P.tube(_p(g.head_top), hb, 0.014, 8), finish="chrome")  # steerer
        self.add("fork", P.box(crown, (0.05, 0.13, 0.03)))
        for sign, _ in SIDES:
            top = crown + [0, sign * 0.055, 0]
            end = axle + [0, sign * 0.055, 0]
            if suspension:
                mid = top + (end - top) * 0.45
                self.add("fork", P.tube(top, mid, 0.02, 10), finish="chrome")
                self.add("fork", P.tube(mid - (end - top) * 0.08, end, 0.026, 10))
            else:
                bend = top + (end - top) * 0.7 + [0.02, 0, 0]
                self.add("fork", P.polyline_tube(np.array([top, bend, end]), 0.011, 8))

    def drivetrain(self, bb: tuple[float, float], crank_angle: float, with_chain: bool = True) -> None:
        """Crank arms with pedals on both sides and (optionally) the chainring and chain on the right (-y)."""
        g = self.g
        b = np.array(_p(bb))
        a = np.radians(crank_angle)
        d = np.array([np.cos(a), 0.0, np.sin(a)])
        for sign, side in SIDES:
            dd = d * sign  # the left crank points opposite the right one
            y_arm = sign * 0.075
            p0 = b + [0, y_arm, 0]
            p1 = p0 + dd * g.crank
            arm = P.hull_of(P.disc(p0, 0.022, 0.014, (0, 1, 0), 10), P.disc(p1, 0.015, 0.014, (0, 1, 0), 10))
            self.add(f"crank_arm_{side}", arm, finish="chrome")
            pedal = P.rounded_box(p1 + [0, sign * 0.055, 0], (0.09, 0.085, 0.022), 0.008)
            self.add(f"pedal_{side}", pedal, finish="rubber")
            self.asm.body(P.tube(p1, p1 + [0, sign * 0.02, 0], 0.007, 6), finish="chrome")
        self.asm.body(P.tube(b + [0, 0.075, 0], b - [0, 0.075, 0], 0.02, 10), finish="chrome")
        if with_chain:
            y = -0.055
            rear = (g.rear_axle, g.wheel_radius)
            self.add("drive_chain", P.chain_loop((b[0], y, b[2]), 0.1, (rear[0], y, rear[1]), 0.045, 0.012, 0.008),
                     finish="chrome")
            self.add("drive_chain", P.disc((b[0], y, b[2]), 0.095, 0.006, (0, 1, 0), 24), finish="chrome")
            self.add("drive_chain", P.disc((rear[0], y, rear[1]), 0.042, 0.02, (0, 1, 0), 12), finish="chrome")

    def drop_bars(self, stem_end: np.ndarray, half: float) -> None:
        for sign, side in SIDES:
            pts = np.array([[0, 0.02, 0], [0, half, 0], [0.05, half, -0.005], [0.1, half, -0.04],
                            [0.1, half, -0.1], [0.05, half, -0.14], [-0.02, half, -0.14]]) * [1, sign, 1] + stem_end
            self.add(f"handle_{side}", P.polyline_tube(pts, 0.013, 8))
            # brake lever hoods on the bars' front bends
            self.add("brake_system", P.rounded_box(stem_end + [0.1, sign * half, -0.03], (0.05, 0.03, 0.06), 0.01),
                     finish="rubber")

    def flat_bars(self, stem_end: np.ndarray, half: float, sweep: float = 0.0, rise: float = 0.0) -> None:
        for sign, side in SIDES:
            pts = np.array([[0, 0.02, 0], [-sweep * 0.3, half * 0.6, rise], [-sweep, half, rise]]) * [1, sign, 1]
            pts = pts + stem_end
            self.add(f"handle_{side}", P.polyline_tube(pts, 0.012, 8),
                     P.tube(pts[-1] - (pts[-1] - pts[-2]) * 0.35, pts[-1] + (pts[-1] - pts[-2]) * 0.03, 0.018, 10))
            lever_at = pts[-1] - (pts[-1] - pts[-2]) * 0.45
            self.add("brake_system", P.tube(lever_at, lever_at + [0.09, sign * 0.02, -0.02], 0.008, 6),
                     P.rounded_box(lever_at, (0.035, 0.03, 0.03), 0.008))

    def stem(self, rise: float, reach: float) -> np.ndarray:
        ht = np.array(_p(self.g.head_top))
        end = ht + [reach, 0, rise]
        self.asm.body(P.polyline_tube(np.array([ht - [0, 0, 0.02], ht + [0, 0, rise * 0.6], end]), 0.014, 8),
                      finish="chrome")
        return end

    def rim_brakes(self) -> None:
        g = self.g
        hb = np.array(_p(g.head_bottom))
        self.add("brake_system", P.rounded_box(hb + [0.035, 0, -0.03], (0.04, 0.07, 0.05), 0.01), finish="chrome")
        st = np.array(_p(g.seat_top))
        ra = np.array([g.rear_axle, 0.0, g.wheel_radius])
        bridge = st + (ra - st) * 0.35
        self.add("brake_system", P.rounded_box(bridge + [-0.03, 0, 0], (0.05, 0.08, 0.05), 0.01), finish="chrome")

    def disc_brakes(self) -> None:
        g = self.g
        for x in (g.front_axle, g.rear_axle):
            c = (x, 0.075, g.wheel_radius)
            self.add("brake_system", P.disc(c, 0.08, 0.006, (0, 1, 0), 20), finish="chrome")
            self.add("brake_system", P.rounded_box((x - 0.06, 0.08, g.wheel_radius + 0.06), (0.06, 0.035, 0.05), 0.01))

    def fenders(self, width: float = 0.06) -> None:
        g = self.g
        R = g.wheel_radius
        self.add("fender_front", P.fender((g.front_axle, 0, R), R + 0.015, -20, 130, width, 0.008, n=14))
        self.add("fender_back", P.fender((g.rear_axle, 0, R), R + 0.015, 40, 200, width, 0.008, n=14))


@builder("road")
def road() -> Assembly:
    g = Geometry(front_axle=0.5, rear_axle=-0.5, wheel_radius=0.34, tyre=0.013, bb=(-0.09, 0.27),
                 seat_top=(-0.25, 0.8), head_top=(0.34, 0.82), head_bottom=(0.38, 0.68), saddle=(-0.3, 0.92))
    b = BikeBuilder("road", g)
    b.single_rider()
    b.drop_bars(b.stem(0.03, 0.1), 0.2)
    b.rim_brakes()
    return b.asm


@builder("utility")
def utility() -> Assembly:
    g = Geometry(front_axle=0.55, rear_axle=-0.52, wheel_radius=0.35, tyre=0.02, bb=(-0.08, 0.28),
                 seat_top=(-0.27, 0.82), head_top=(0.36, 0.9), head_bottom=(0.42, 0.7), saddle=(-0.32, 0.98), step_through=True)
    b = BikeBuilder("utility", g)
    b.single_rider()
    b.flat_bars(b.stem(0.2, 0.02), 0.33, sweep=0.2, rise=0.04)
    b.rim_brakes()
    b.fenders(0.07)
    # rear carrier: a flat rack over the rear wheel on struts down to the axle
    top = 0.78
    rack = []
    for sign, _ in SIDES:
        rack.append(P.tube((-0.2, sign * 0.06, top), (-0.82, sign * 0.06, top), 0.008, 6))
        rack.append(P.tube((-0.75, sign * 0.065, top), (g.rear_axle, sign * 0.06, g.wheel_radius), 0.007, 6))
        rack.append(P.tube((-0.35, sign * 0.065, top), (g.rear_axle + 0.05, sign * 0.06, g.wheel_radius), 0.007, 6))
    rack.append(P.rounded_box((-0.52, 0, top + 0.005), (0.58, 0.13, 0.012), 0.004))
    rack.append(P.tube((-0.2, 0, top), (g.seat_top[0] + 0.01, 0, g.seat_top[1] - 0.06), 0.007, 6))
    b.add("carrier", *rack, finish="chrome")
    # kickstand on the left, folded down to the ground
    b.add("side_stand", P.tube((-0.22, 0.06, 0.3), (-0.32, 0.2, 0.0), 0.012, 8), finish="chrome")
    return b.asm


@builder("mountain")
def mountain() -> Assembly:
    g = Geometry(front_axle=0.56, rear_axle=-0.5, wheel_radius=0.34, tyre=0.03, bb=(-0.06, 0.31),
                 seat_top=(-0.22, 0.78), head_top=(0.38, 0.86), head_bottom=(0.44, 0.72), saddle=(-0.27, 0.95))
    b = BikeBuilder("mountain", g)
    b.single_rider(suspension=True)
    b.flat_bars(b.stem(0.04, 0.07), 0.36, sweep=0.03, rise=0.02)
    b.disc_brakes()
    return b.asm


@builder("tandem")
def tandem() -> Assembly:
    g = Geometry(front_axle=0.95, rear_axle=-0.95, wheel_radius=0.34, tyre=0.017, bb=(0.35, 0.28),
                 seat_top=(0.22, 0.8), head_top=(0.8, 0.88), head_bottom=(0.84, 0.72), saddle=(0.18, 1.0))
    b = BikeBuilder("tandem", g)
    b.wheel("wheel_front", g.front_axle)
    b.wheel("wheel_back", g.rear_axle)
    rear_bb, rear_seat = np.array([-0.52, 0, 0.28]), np.array([-0.65, 0, 0.8])
    f = g.tube
    bb, st, ht, hb = (np.array(_p(p)) for p in (g.bb, g.seat_top, g.head_top, g.head_bottom))
    ra = np.array([g.rear_axle, 0, g.wheel_radius])
    for a, c in ((ht, hb), (hb, bb), (bb, st), (st, ht - [0, 0, 0.04]), (bb, rear_bb), (rear_bb, rear_seat),
                 (st - [0, 0, 0.04], rear_seat - [0, 0, 0.04]), (hb, rear_bb)):
        b.asm.body(P.tube(a, c, f, 8))
    for sign, _ in SIDES:
        b.asm.body(P.tube(rear_bb, ra + [0, sign * 0.055, 0], f * 0.7, 8))
        b.asm.body(P.tube(rear_seat - [0, 0, 0.03], ra + [0, sign * 0.055, 0], f * 0.6, 8))
    for seat_top, saddle in ((st, g.saddle), (rear_seat, (-0.7, 1.0))):
        b.asm.body(P.tube(seat_top, (saddle[0] + 0.01, 0, saddle[1] - 0.03), f * 0.8, 8), finish="chrome")
        b.saddle(saddle)
    b.fork()
    # captain's bars on the stem, stoker's bars clamped to the captain's seat post
    b.flat_bars(b.stem(0.08, 0.06), 0.21, sweep=0.12)
    stoker = np.array([g.saddle[0] - 0.02, 0, g.saddle[1] - 0.05])
    for sign, _ in SIDES:
        b.asm.body(P.polyline_tube(np.array([stoker, stoker + [-0.12, sign * 0.05, 0.02],
                                             stoker + [-0.17, sign * 0.2, 0.02]]), 0.011, 8))
    b.drivetrain(g.bb, g.crank_angle, with_chain=False)
    b.drivetrain((-0.52, 0.28), g.crank_angle)
    b.asm.body(P.chain_loop((0.35, 0.07, 0.28), 0.09, (-0.52, 0.07, 0.28), 0.09, 0.012, 0.008), finish="chrome")
    b.fenders(0.06)
    # rear light on the back of the rear fender
    a = np.radians(150)
    r = g.wheel_radius + 0.035
    b.add("rearlight", P.rounded_box((g.rear_axle + r * np.cos(a), 0, g.wheel_radius + r * np.sin(a)),
                                     (0.04, 0.08, 0.07), 0.01), finish="lamp")
    return b.asm

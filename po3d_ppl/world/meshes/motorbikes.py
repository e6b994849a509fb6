"""Motorbikes: chopper (long raked fork, high bars), dirtbike (tall, high fenders), scooter (step-through, small
wheels, front cover) and cruiser (fairing and windscreen).

Each builder places its parts explicitly around a shared toolkit (:class:`Moto`): wheels in the xz plane, a fork
from the front axle to the steering head, handlebar halves, and mirrored left/right pieces (left = +y).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import trimesh

from po3d_ppl.world.meshes import primitives as P
from po3d_ppl.world.meshes.assembly import Assembly
from po3d_ppl.world.meshes.registry import builder

SIDES = ((1.0, "left"), (-1.0, "right"))


class Moto:
    """Helpers shared by the motorbike builders; ``asm`` collects the pieces."""

    def __init__(self, subtype: str):
        self.asm = Assembly(subtype)

    def both(self, label: str | None, make: Callable[[float], trimesh.Trimesh], finish: str = "paint") -> None:
        """Add a left/right pair; ``label`` may contain ``{side}``; ``make(sign)`` builds one side (+1 = left)."""
        for sign, side in SIDES:
            self.asm.add(label.format(side=side) if label else None, make(sign), finish=finish)

    def wheel(self, label: str, x: float, radius: float, width: float, spokes: int = 0, disc_brake: bool = True) -> None:
        c = (x, 0.0, radius)
        self.asm.add(label, P.tyre(c, radius, width, sections=22, rim=0.78), finish="rubber")
        self.asm.add(label, P.disc(c, radius * 0.2, width * 1.3), finish="chrome")
        rim_r = radius * 0.74
        if spokes:
            for k in range(spokes):
                a = 2 * np.pi * k / spokes
                end = (x + rim_r * np.cos(a), 0.0, radius + rim_r * np.sin(a))
                self.asm.add(label, P.tube(c, end, 0.012, 4), finish="chrome")
        else:
            self.asm.add(label, P.disc(c, rim_r, width * 0.35), finish="chrome")
        if disc_brake:
            self.asm.body(P.disc((x, width * 0.5 + 0.015, radius), radius * 0.45, 0.01), finish="chrome")

    def fork(self, axle: tuple[float, float], head: tuple[float, float], spread: float, radius: float,
             label: str = "fork") -> None:
        for sign, _ in SIDES:
            self.asm.add(label, P.tube((axle[0], sign * spread, axle[1]), (head[0], sign * spread, head[1]), radius, 10),
                         finish="chrome")
        self.asm.add(label, P.box((head[0], 0, head[1]), (0.08, 2 * spread + 0.06, 0.05)), finish="chrome")

    def bar(self, points: list[tuple[float, float, float]], radius: float = 0.014, grip: float = 0.13) -> Callable:
        """Handlebar half along ``points`` (given for the left side) ending in a rubber grip."""

        def make(sign: float) -> trimesh.Trimesh:
            pts = np.array(points, dtype=np.float64) * [1, sign, 1]
            end, before = pts[-1], pts[-2]
            d = (end - before) / np.linalg.norm(end - before)
            tube = P.polyline_tube(pts, radius, 8)
            grip_mesh = P.tube(end - d * grip, end + d * 0.01, radius * 1.8, 10)
            return trimesh.util.concatenate([tube, grip_mesh])

        return make

    def mirror(self, base: tuple[float, float, float], head: tuple[float, float, float], size: float) -> Callable:
        def make(sign: float) -> trimesh.Trimesh:
            b = np.array(base) * [1, sign, 1]
            h = np.array(head) * [1, sign, 1]
            stalk = P.tube(b, h, 0.008, 6)
            glass = P.ellipsoid(h, (0.02, size, size * 0.65), 1)
            return trimesh.util.concatenate([stalk, glass])

        return make

    def peg(self, x: float, z: float, y0: float, y1: float, radius: float = 0.018) -> Callable:
        return lambda sign: P.tube((x, sign * y0, z), (x, sign * y1, z), radius, 8)

    def exhaust(self, points: list[tuple[float, float, float]], radius: float, muffler: float, length: float) -> Callable:
        """A header pipe along ``points`` (left side) ending in a muffler of radius ``muffler`` going backwards."""

        def make(sign: float) -> trimesh.Trimesh:
            pts = np.array(points, dtype=np.float64) * [1, sign, 1]
            pipe = P.polyline_tube(pts, radius, 8)
            end = pts[-1]
            d = (pts[-1] - pts[-2]) / np.linalg.norm(pts[-1] - pts[-2])
            can = P.revolve(end - d * 0.02, d, [(0, muffler * 0.7), (0.05, muffler), (length - 0.05, muffler),
                                                 (length, muffler * 0.6)], sections=14)
            return trimesh.util.concatenate([pipe, can])

        return make

    def chain(self, label: str, front: tuple[float, float], r_front: float, back: tuple[float, float],
              r_back: float, y: float) -> None:
        self.asm.add(label, P.chain_loop((front[0], y, front[1]), r_front, (back[0], y, back[1]), r_back, 0.025, 0.018),
                     finish="chrome")
        self.asm.body(P.disc((back[0], y, back[1]), r_back * 0.95, 0.01), finish="chrome")

    def frame(self, segments: list[tuple[tuple[float, float, float], tuple[float, float, float]]], radius: float) -> None:
        for a, b in segments:
            self.asm.body(P.tube(a, b, radius, 8))


def _lamp(center: tuple[float, float, float], radius: float, depth: float, axis=(1, 0, 0)) -> trimesh.Trimesh:
    c = np.asarray(center, dtype=np.float64)
    a = np.asarray(axis, dtype=np.float64)
    return P.revolve(c - a * depth, a, [(0, radius * 0.6), (depth * 0.6, radius), (depth, radius * 0.95)], sections=14)


@builder("chopper")
def chopper() -> Assembly:
    m = Moto("chopper")
    fx, rx = 0.98, -0.82
    fR, rR = 0.34, 0.33
    head = (0.34, 1.0)
    m.wheel("wheel_front", fx, fR, 0.09, spokes=12)
    m.wheel("wheel_back", rx, rR, 0.2, spokes=12)
    m.fork((fx, fR), head, 0.09, 0.026)
    # frame: backbone, down tubes, rear stays
    m.frame([((head[0], 0, head[1]), (-0.45, 0, 0.7)), ((head[0], 0, head[1] - 0.05), (0.15, 0, 0.25)),
             ((0.15, 0, 0.25), (-0.5, 0, 0.25)), ((-0.45, 0, 0.7), (rx, 0.1, rR)), ((-0.45, 0, 0.7), (rx, -0.1, rR)),
             ((-0.5, 0, 0.25), (rx, 0.1, rR)), ((-0.5, 0, 0.25), (rx, -0.1, rR))], 0.025)
    m.asm.add("gas_tank", P.hull_of(P.ellipsoid((0.12, 0, 0.9), (0.26, 0.13, 0.1), 1),
                                    P.ellipsoid((-0.12, 0, 0.85), (0.1, 0.1, 0.07), 1)))
    m.asm.add("seat", P.hull_of(P.ellipsoid((-0.25, 0, 0.74), (0.14, 0.15, 0.05), 1),
                                P.ellipsoid((-0.52, 0, 0.78), (0.1, 0.1, 0.05), 1)))
    m.asm.add("panel", P.rounded_box((-0.38, 0, 0.55), (0.28, 0.24, 0.22), 0.05))
    # V-twin engine: crankcase and two cylinders
    m.asm.add("engine", P.rounded_box((-0.08, 0, 0.33), (0.36, 0.22, 0.2), 0.05), finish="chrome")
    m.asm.add("engine", P.hull_of(P.disc((0.0, 0, 0.5), 0.08, 0.16, (0.5, 0, 1)),
                                  P.disc((0.09, 0, 0.68), 0.08, 0.16, (0.5, 0, 1))),
              finish="chrome")
    m.asm.add("engine", P.hull_of(P.disc((-0.16, 0, 0.5), 0.08, 0.16, (-0.5, 0, 1)),
                                  P.disc((-0.25, 0, 0.66), 0.08, 0.16, (-0.5, 0, 1))),
              finish="chrome")
    m.chain("drive_chain", (-0.12, 0.3), 0.07, (rx, rR), 0.13, 0.15)
    m.asm.add("exhaust_right_s", m.exhaust([(0.05, 0.1, 0.62), (0.12, 0.2, 0.45), (-0.1, 0.22, 0.3),
                                            (-0.5, 0.22, 0.3)], 0.025, 0.045, 0.55)(-1.0), finish="chrome")
    m.both(None, lambda s: P.tube((0.17, 0, 0.33), (0.4, s * 0.13, 0.36), 0.015, 6), finish="chrome")  # mounts
    m.both("footrest_{side}_s", m.peg(0.4, 0.36, 0.12, 0.3, 0.022), finish="rubber")
    # ape-hanger bars: risers up from the clamp, then out and back
    m.both("handle_{side}", m.bar([(head[0] + 0.02, 0.06, head[1] + 0.02), (head[0] + 0.02, 0.12, 1.22),
                                   (head[0] - 0.04, 0.2, 1.25), (head[0] - 0.14, 0.36, 1.2)]))
    m.both("mirror_{side}", m.mirror((0.26, 0.26, 1.23), (0.3, 0.3, 1.35), 0.06))
    m.asm.add("headlight_center", _lamp((head[0] + 0.2, 0, 0.9), 0.09, 0.12), finish="lamp")
    m.asm.add("windscreen", P.hull(np.array([[0.52, 0.17, 0.98], [0.52, -0.17, 0.98], [0.44, 0.2, 1.22],
                                             [0.44, -0.2, 1.22], [0.51, 0.17, 0.98], [0.43, 0.2, 1.22],
                                             [0.51, -0.17, 0.98], [0.43, -0.2, 1.22]])), finish="glass")
    m.asm.add("fender_front", P.fender((fx, 0, fR), fR + 0.03, 20, 110, 0.11, 0.012, n=10))
    m.asm.add("fender_back", P.fender((rx, 0, rR), rR + 0.04, 40, 175, 0.24, 0.015, n=12))
    m.asm.add("taillight_center", P.rounded_box((rx - 0.36, 0, 0.5), (0.06, 0.1, 0.06), 0.015), finish="lamp")
    return m.asm


@builder("dirtbike")
def dirtbike() -> Assembly:
    m = Moto("dirtbike")
    fx, rx = 0.78, -0.7
    fR, rR = 0.36, 0.34
    head = (0.42, 1.08)
    m.wheel("wheel_front", fx, fR, 0.1, spokes=14, disc_brake=True)
    m.wheel("wheel_back", rx, rR, 0.14, spokes=14)
    m.fork((fx, fR), head, 0.085, 0.03)
    m.frame([((head[0], 0, head[1]), (-0.2, 0, 0.88)), ((head[0], 0, head[1] - 0.05), (0.22, 0, 0.3)),
             ((0.22, 0, 0.3), (-0.15, 0, 0.3)), ((-0.15, 0, 0.3), (-0.2, 0, 0.88)),
             ((-0.2, 0, 0.88), (-0.75, 0, 0.95))], 0.022)
    for sign, _ in SIDES:  # swingarm
        m.asm.body(P.tube((-0.12, sign * 0.08, 0.38), (rx, sign * 0.09, rR), 0.025, 8))
    m.asm.body(P.tube((-0.3, 0, 0.85), (-0.16, 0, 0.4), 0.04, 10), finish="chrome")  # shock
    m.asm.add("engine", P.rounded_box((0.05, 0, 0.4), (0.34, 0.2, 0.24), 0.05), finish="chrome")
    m.asm.add("engine", P.hull_of(P.disc((0.08, 0, 0.55), 0.09, 0.17, (0.3, 0, 1)),
                                  P.disc((0.13, 0, 0.72), 0.08, 0.15, (0.3, 0, 1))),
              finish="chrome")
    m.asm.add("gas_tank", P.hull_of(P.ellipsoid((0.2, 0, 0.98), (0.16, 0.14, 0.1), 1),
                                    P.ellipsoid((0.0, 0, 0.98), (0.1, 0.12, 0.07), 1)))
    m.asm.add("seat", P.rounded_box((-0.32, 0, 1.0), (0.8, 0.2, 0.08), 0.035), finish="rubber")
    # radiator shrouds either side of the tank
    m.asm.add("cover_front", *(P.hull(np.array([[0.38, s * 0.12, 1.02], [0.32, s * 0.2, 0.78], [0.12, s * 0.16, 0.72],
                                               [0.05, s * 0.13, 0.98], [0.38, s * 0.1, 1.02], [0.32, s * 0.17, 0.78],
                                               [0.12, s * 0.13, 0.72], [0.05, s * 0.1, 0.98]])) for s, _ in SIDES))
    m.asm.add("panel", *(P.hull(np.array([[-0.02, s * 0.14, 0.93], [-0.3, s * 0.14, 0.92], [-0.18, s * 0.13, 0.62],
                                         [-0.02, s * 0.1, 0.93], [-0.3, s * 0.1, 0.92], [-0.18, s * 0.09, 0.62]]))
                         for s, _ in SIDES))
    m.asm.add("fender_front", P.fender((fx + 0.02, 0, fR + 0.25), 0.22, 15, 150, 0.12, 0.015, n=10))
    # the rear plastic (tail fender with side plates) is the dirtbike's back cover
    m.asm.add("cover_back", *(P.hull(np.array([[-0.32, s * 0.13, 0.93], [-0.66, s * 0.1, 0.94], [-0.4, s * 0.12, 0.74],
                                              [-0.32, s * 0.09, 0.93], [-0.66, s * 0.07, 0.94], [-0.4, s * 0.08, 0.74]]))
                              for s, _ in SIDES))
    m.asm.add("cover_back", P.hull(np.array([[-0.6, 0.09, 0.95], [-0.6, -0.09, 0.95], [-1.1, 0.06, 1.02],
                                              [-1.1, -0.06, 1.02], [-0.6, 0.09, 0.92], [-0.6, -0.09, 0.92],
                                              [-1.1, 0.06, 1.0], [-1.1, -0.06, 1.0]])))
    m.chain("drive_chain", (-0.05, 0.32), 0.05, (rx, rR), 0.11, 0.1)
    m.asm.add("exhaust_right_s", m.exhaust([(0.18, 0.05, 0.62), (0.28, 0.12, 0.45), (0.05, 0.16, 0.4),
                                            (-0.3, 0.16, 0.72), (-0.45, 0.16, 0.82)], 0.022, 0.05, 0.4)(-1.0),
              finish="chrome")
    m.both("footrest_{side}_s", m.peg(-0.08, 0.36, 0.08, 0.22, 0.02), finish="chrome")
    m.both("handle_{side}", m.bar([(head[0] - 0.02, 0.03, head[1] + 0.06), (head[0] - 0.04, 0.2, head[1] + 0.08),
                                   (head[0] - 0.08, 0.38, head[1] + 0.1)]))
    return m.asm


@builder("scooter")
def scooter() -> Assembly:
    m = Moto("scooter")
    fx, rx = 0.6, -0.6
    R = 0.22
    head = (0.5, 1.02)
    m.wheel("wheel_front", fx, R, 0.11, disc_brake=False)
    m.wheel("wheel_back", rx, R, 0.12, disc_brake=False)
    m.fork((fx, R), (0.52, 0.62), 0.07, 0.024)
    m.asm.body(P.tube((0.52, 0, 0.6), (head[0], 0, head[1]), 0.035, 10))  # steering column behind the shield
    # leg shield / front cover: curved shell in front of the rider's legs down to the front wheel
    shield = P.hull(np.array([[0.56, 0.2, 0.42], [0.56, -0.2, 0.42], [0.5, 0.23, 0.98], [0.5, -0.23, 0.98],
                              [0.44, 0.2, 0.42], [0.44, -0.2, 0.42], [0.42, 0.23, 0.98], [0.42, -0.23, 0.98],
                              [0.62, 0.0, 0.7], [0.54, 0.0, 1.02]]))
    m.asm.add("cover_front", shield)
    m.asm.body(P.fender((fx, 0, R), R + 0.03, 10, 150, 0.14, 0.02, n=10))
    m.asm.add("panel", P.rounded_box((0.12, 0, 0.3), (0.62, 0.34, 0.06), 0.02), finish="rubber")
    m.asm.body(P.rounded_box((0.1, 0, 0.24), (0.66, 0.3, 0.1), 0.03))
    cowl = P.hull_of(P.ellipsoid((-0.5, 0, 0.58), (0.33, 0.2, 0.16), 2),
                     P.ellipsoid((-0.18, 0, 0.45), (0.1, 0.16, 0.16), 1),
                     P.ellipsoid((-0.75, 0, 0.62), (0.1, 0.12, 0.1), 1))
    m.asm.add("cover_back", cowl)
    m.asm.add("seat", P.hull_of(P.ellipsoid((-0.22, 0, 0.76), (0.12, 0.16, 0.06), 1),
                                P.ellipsoid((-0.6, 0, 0.78), (0.14, 0.14, 0.06), 1)),
              finish="rubber")
    m.asm.add("engine", P.rounded_box((-0.38, 0.06, 0.3), (0.34, 0.16, 0.18), 0.05), finish="chrome")
    m.asm.add("fender_back", P.fender((rx, 0, R), R + 0.03, 15, 170, 0.14, 0.015, n=12))
    m.chain("drive_chain", (-0.3, 0.3), 0.05, (rx, R), 0.07, -0.1)
    m.asm.add("exhaust_left_s", m.exhaust([(-0.3, 0.1, 0.26), (-0.45, 0.16, 0.24)], 0.02, 0.05, 0.32)(1.0),
              finish="chrome")
    # handlebar cowl with the headlight, bars, mirrors
    m.asm.body(P.rounded_box((head[0], 0, head[1] + 0.02), (0.18, 0.3, 0.1), 0.04))
    m.asm.add("headlight_center", _lamp((head[0] + 0.1, 0, head[1] + 0.02), 0.055, 0.06), finish="lamp")
    m.both("handle_{side}", m.bar([(head[0] - 0.02, 0.12, head[1] + 0.03), (head[0] - 0.07, 0.41, head[1] + 0.04)]))
    m.both("mirror_{side}", m.mirror((head[0] - 0.02, 0.15, head[1] + 0.06), (head[0] - 0.02, 0.3, head[1] + 0.13),
                                     0.045))
    m.asm.add("taillight_center", P.rounded_box((-0.85, 0, 0.6), (0.05, 0.12, 0.06), 0.015), finish="lamp")
    return m.asm


@builder("cruiser")
def cruiser() -> Assembly:
    m = Moto("cruiser")
    fx, rx = 0.86, -0.8
    R = 0.33
    head = (0.42, 0.98)
    m.wheel("wheel_front", fx, R, 0.13, spokes=0)
    m.wheel("wheel_back", rx, R, 0.16, spokes=0)
    m.fork((fx, R), head, 0.1, 0.03)
    m.frame([((head[0], 0, head[1]), (-0.45, 0, 0.7)), ((head[0], 0, head[1] - 0.05), (0.2, 0, 0.28)),
             ((0.2, 0, 0.28), (-0.45, 0, 0.28)), ((-0.45, 0, 0.7), (rx, 0.1, R)), ((-0.45, 0, 0.7), (rx, -0.1, R))],
            0.025)
    # engine (not a listed part of the cruiser, so unlabelled)
    m.asm.body(P.rounded_box((-0.08, 0, 0.36), (0.4, 0.24, 0.22), 0.05), finish="chrome")
    m.asm.body(P.hull_of(P.disc((0.02, 0, 0.5), 0.085, 0.17, (0.5, 0, 1)),
                         P.disc((0.1, 0, 0.66), 0.085, 0.17, (0.5, 0, 1))), finish="chrome")
    m.asm.body(P.hull_of(P.disc((-0.16, 0, 0.5), 0.085, 0.17, (-0.5, 0, 1)),
                         P.disc((-0.24, 0, 0.66), 0.085, 0.17, (-0.5, 0, 1))), finish="chrome")
    m.asm.add("gas_tank", P.hull_of(P.ellipsoid((0.15, 0, 0.86), (0.24, 0.16, 0.1), 1),
                                    P.ellipsoid((-0.1, 0, 0.82), (0.08, 0.12, 0.08), 1)))
    m.asm.add("seat", P.hull_of(P.ellipsoid((-0.28, 0, 0.76), (0.16, 0.18, 0.06), 1),
                                P.ellipsoid((-0.6, 0, 0.84), (0.14, 0.15, 0.06), 1)),
              finish="rubber")
    m.asm.add("panel", P.rounded_box((-0.38, 0, 0.56), (0.26, 0.3, 0.2), 0.05))
    m.asm.add("cover_back", P.hull(np.array([[-0.72, 0.16, 0.8], [-0.72, -0.16, 0.8], [-1.05, 0.12, 0.78],
                                             [-1.05, -0.12, 0.78], [-0.72, 0.17, 0.62], [-0.72, -0.17, 0.62],
                                             [-1.08, 0.13, 0.62], [-1.08, -0.13, 0.62]])))
    # batwing fairing around the headlight, windscreen on top
    fairing = P.hull_of(P.ellipsoid((0.55, 0, 0.98), (0.12, 0.38, 0.14), 2),
                        P.ellipsoid((0.45, 0, 1.0), (0.06, 0.3, 0.1), 1))
    m.asm.add("cover_front", fairing)
    m.asm.add("windscreen", P.hull(np.array([[0.6, 0.28, 1.06], [0.6, -0.28, 1.06], [0.5, 0.22, 1.32],
                                             [0.5, -0.22, 1.32], [0.58, 0.28, 1.06], [0.58, -0.28, 1.06],
                                             [0.48, 0.22, 1.32], [0.48, -0.22, 1.32]])), finish="glass")
    m.asm.add("headlight_center", _lamp((0.68, 0, 0.98), 0.08, 0.06), finish="lamp")
    for sign, side in SIDES:
        m.asm.add(f"headlight_{side}", _lamp((0.72, sign * 0.2, 0.66), 0.055, 0.08), finish="lamp")
        m.asm.body(P.tube((0.62, sign * 0.2, 0.66), (0.5, sign * 0.12, 0.8), 0.015, 6), finish="chrome")
        m.asm.add(f"taillight_{side}", P.rounded_box((-1.09, sign * 0.1, 0.72), (0.05, 0.08, 0.07), 0.015),
                  finish="lamp")
    m.asm.add("license_plate", P.box((-1.08, 0, 0.52), (0.02, 0.26, 0.15)))
    m.asm.add("fender_front", P.fender((fx, 0, R), R + 0.03, 10, 160, 0.16, 0.02, n=12))
    m.asm.add("fender_back", P.fender((rx, 0, R), R + 0.04, 20, 185, 0.2, 0.02, n=12))
    m.chain("drive_chain", (-0.15, 0.3), 0.07, (rx, R), 0.13, 0.13)
    for sign, side in SIDES:
        m.asm.add(f"exhaust_{side}_s", m.exhaust([(0.08, 0.1, 0.55), (0.12, 0.22, 0.35), (-0.2, 0.24, 0.25),
                                                  (-0.55, 0.24, 0.3)], 0.025, 0.05, 0.5)(sign), finish="chrome")
    m.both("footrest_{side}_s", lambda s: P.rounded_box((0.22, s * 0.28, 0.3), (0.26, 0.12, 0.025), 0.01),
           finish="rubber")
    m.both(None, lambda s: P.tube((0.2, s * 0.02, 0.28), (0.22, s * 0.24, 0.3), 0.015, 6), finish="chrome")
    # touring saddlebags either side of the rear wheel (not a listed part)
    m.both(None, lambda s: P.rounded_box((-0.8, s * 0.25, 0.56), (0.42, 0.15, 0.3), 0.05))
    m.both("handle_{side}", m.bar([(head[0] - 0.02, 0.06, head[1] + 0.05), (head[0] - 0.1, 0.25, head[1] + 0.08),
                                   (head[0] - 0.16, 0.37, head[1] + 0.06)]))
    m.both("mirror_{side}", m.mirror((0.5, 0.3, 1.08), (0.5, 0.38, 1.18), 0.05))
    return m.asm

"""Aeroplanes: jet (business jet with tail engines and a T-tail), fighter (delta wings, twin engines at the back),
biplane (two stacked wings, nose propeller) and airliner (long fuselage, underwing engines, doors on both sides).

All stand on their landing gear (z = 0 at the tyres); the fuselage is a :class:`RevolvedBody`, so doors and windows
are shells lying on its skin. Some public part lists are odd (a jet or an airliner with a propeller): the part is
built as listed, as a small nose propeller.
"""

from __future__ import annotations

import numpy as np
import trimesh

from po3d_ppl.world.meshes import primitives as P
from po3d_ppl.world.meshes.assembly import Assembly
from po3d_ppl.world.meshes.bodies import RevolvedBody
from po3d_ppl.world.meshes.registry import builder

SIDES = ((1.0, "left"), (-1.0, "right"))


def _mirror_y(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    out = mesh.copy()
    out.apply_transform(np.diag([1.0, -1.0, 1.0, 1.0]))
    return out


def wing_pair(asm: Assembly, label: str | None, root_le, root_chord, tip_le, tip_chord, thickness,
              finish: str = "paint") -> None:
    """A left wing (given, y > 0) and its mirror image on the right; ``label`` may contain ``{side}``."""
    left = P.wing(root_le, root_chord, tip_le, tip_chord, thickness)
    for mesh, side in ((left, "left"), (_mirror_y(left), "right")):
        asm.add(label.format(side=side) if label else None, mesh, finish=finish)


def gear_wheel(asm: Assembly, label: str | None, x: float, y: float, radius: float, width: float,
               strut_top: float) -> None:
    """A landing-gear wheel touching the ground with its (unlabelled) strut up to ``strut_top``."""
    asm.add(label, P.tyre((x, y, radius), radius, width, sections=16, rim=0.6), finish="rubber")
    asm.add(label, P.disc((x, y, radius), radius * 0.55, width * 1.05), finish="chrome")
    asm.body(P.tube((x, y, radius), (x, y, strut_top), radius * 0.18, 8), finish="chrome")


def propeller(asm: Assembly, nose: tuple[float, float, float], radius: float, blades: int, spinner: float) -> None:
    """Spinner plus twisted flat blades in the yz plane, just ahead of ``nose``."""
    x, y, z = nose
    asm.add("propeller", P.revolve((x - spinner * 0.3, y, z), (1, 0, 0),
                                   [(0, spinner), (spinner * 0.8, spinner * 0.75), (spinner * 1.6, 0.0)], 12))
    for k in range(blades):
        a = 2 * np.pi * (k + 0.25) / blades
        d = np.array([0.0, np.cos(a), np.sin(a)])
        side = np.cross([1.0, 0, 0], d)
        root = np.array([x + spinner * 0.2, y, z]) + d * spinner * 0.6
        tip = np.array([x + spinner * 0.2, y, z]) + d * radius
        w0, w1 = radius * 0.09, radius * 0.06
        pts = [root + side * w0 + [0.03 * radius, 0, 0], root - side * w0 - [0.03 * radius, 0, 0],
               tip + side * w1 + [0.02 * radius, 0, 0], tip - side * w1 - [0.02 * radius, 0, 0]]
        pts = np.array(pts)
        asm.add("propeller", P.hull(np.concatenate([pts, pts + [radius * 0.03, 0, 0]])))


def nacelle(center_front: tuple[float, float, float], length: float, radius: float) -> trimesh.Trimesh:
    """A jet engine pod from its intake lip backwards."""
    x, y, z = center_front
    return P.revolve((x, y, z), (-1, 0, 0), [(0, radius * 0.92), (length * 0.08, radius), (length * 0.6, radius * 0.95),
                                             (length, radius * 0.55)], 16)


@builder("jet")
def jet() -> Assembly:
    asm = Assembly("jet")
    zc, r = 2.0, 0.95
    fus = RevolvedBody([(7.5, 0.05), (7.0, 0.45), (6.0, 0.8), (5.0, r), (-3.0, r), (-5.5, 0.7), (-7.5, 0.25)], zc, 1.05)
    asm.body(fus.mesh())
    asm.body(fus.panel(6.6, 5.6, 35, 145, 0.03), finish="glass")  # cockpit glazing
    for x in np.arange(3.8, -2.0, -0.9):  # cabin windows
        for a0 in (10, 170):
            asm.body(fus.panel(x, x - 0.45, a0, a0 + 15, 0.02, 3), finish="glass")
    asm.add("door_left_s", fus.panel(4.8, 4.0, -35, 25, 0.04))
    wing_pair(asm, "wing_{side}", (1.6, 0.8, 1.4), 3.4, (-1.5, 9.4, 1.85), 1.2, 0.12)
    # T-tail: swept fin with the tailplanes on its top
    asm.add("fin", _fin((-4.6, 2.6), 3.0, (-6.6, 5.5), 1.6, 0.1))
    wing_pair(asm, "tailplane_{side}", (-6.4, 0.1, 5.45), 1.8, (-7.3, 3.1, 5.55), 0.9, 0.1)
    for sign, side in SIDES:
        asm.add(f"engine_{side}", nacelle((-3.2, sign * 1.75, 2.45), 3.2, 0.6))
        asm.body(P.rounded_box((-4.6, sign * 1.0, 2.35), (1.2, 0.9, 0.18), 0.05))  # pylon
    propeller(asm, (7.45, 0.0, zc), 0.9, 3, 0.22)
    gear_wheel(asm, "wheel_front", 5.6, 0.0, 0.4, 0.26, zc - 0.6)
    for sign, side in SIDES:
        gear_wheel(asm, f"wheel_back_{side}", -0.3, sign * 1.8, 0.48, 0.32, 1.45)
    return asm


def _fin(root_le: tuple[float, float], root_chord: float, tip_le: tuple[float, float], tip_chord: float,
         thickness: float) -> trimesh.Trimesh:
    """A vertical stabiliser in the symmetry plane (x, z given for the root and tip leading edges)."""
    return P.wing((root_le[0], 0.0, root_le[1]), root_chord, (tip_le[0], 0.0, tip_le[1]), tip_chord, thickness,
                  vertical=True)


@builder("fighter")
def fighter() -> Assembly:
    asm = Assembly("fighter")
    zc = 1.3
    fus = RevolvedBody([(7.5, 0.03), (6.0, 0.45), (4.0, 0.8), (1.0, 1.0), (-4.0, 1.05), (-6.0, 0.95)], zc, 0.8)
    asm.body(fus.mesh())
    asm.body(P.ellipsoid((3.7, 0, zc + 0.62), (1.6, 0.45, 0.4), 2), finish="glass")  # canopy
    for sign, _ in SIDES:  # intakes under the wing roots
        asm.body(P.rounded_box((1.0, sign * 1.0, zc - 0.2), (3.0, 0.55, 0.6), 0.12))
    wing_pair(asm, "wing_{side}", (3.2, 0.9, zc - 0.05), 7.0, (-3.6, 6.3, zc), 1.3, 0.05)
    wing_pair(asm, "tailplane_{side}", (-4.9, 1.0, zc - 0.1), 2.4, (-6.4, 3.2, zc - 0.1), 1.0, 0.05)
    asm.add("fin", _fin((-3.2, zc + 0.6), 3.4, (-6.0, zc + 1.85), 1.3, 0.06))
    for sign, side in SIDES:
        # twin engines side by side at the back: a long casing ending in a flared nozzle
        asm.add(f"engine_{side}", P.revolve((-2.0, sign * 0.6, zc - 0.05), (-1, 0, 0),
                                            [(0, 0.5), (4.0, 0.58), (5.2, 0.6), (5.9, 0.5), (6.0, 0.42)], 16))
    gear_wheel(asm, None, 4.6, 0.0, 0.25, 0.16, zc - 0.4)
    for sign, _ in SIDES:
        gear_wheel(asm, None, -1.5, sign * 1.45, 0.32, 0.22, zc - 0.3)
    return asm


@builder("biplane")
def biplane() -> Assembly:
    asm = Assembly("biplane")
    zc = 1.45
    fus = RevolvedBody([(3.2, 0.5), (2.6, 0.6), (0.5, 0.62), (-2.0, 0.38), (-3.5, 0.12)], zc, 1.1, sections=16)
    asm.body(fus.mesh())
    asm.body(fus.panel(0.4, -0.6, 70, 110, 0.04, 4), finish="rubber")  # open cockpit
    asm.body(P.ellipsoid((0.6, 0, zc + 0.72), (0.08, 0.3, 0.14), 1), finish="glass")  # little windscreen
    lower_z, upper_z = 0.95, 3.0
    wing_pair(asm, "wing_{side}", (1.6, 0.2, lower_z), 1.5, (1.5, 4.3, lower_z + 0.25), 1.4, 0.12)
    wing_pair(asm, "wing_{side}", (1.9, 0.0, upper_z), 1.5, (1.8, 4.3, upper_z + 0.05), 1.4, 0.12)
    for sign, _ in SIDES:  # interplane and cabane struts
        for x in (1.5, 0.5):
            asm.body(P.tube((x, sign * 3.2, lower_z + 0.2), (x + 0.2, sign * 3.2, upper_z), 0.04, 6))
            asm.body(P.tube((x + 0.1, sign * 0.45, zc + 0.4), (x + 0.3, sign * 0.5, upper_z), 0.035, 6))
    wing_pair(asm, "tailplane_{side}", (-2.75, 0.05, zc + 0.05), 0.85, (-3.2, 1.5, zc + 0.05), 0.55, 0.1)
    asm.add("fin", _fin((-2.6, zc + 0.2), 1.0, (-3.3, zc + 1.35), 0.6, 0.1))
    propeller(asm, (3.25, 0.0, zc), 1.25, 2, 0.22)
    # main gear: two wheels on a common axle (the "front wheel" of a tail-dragger) and a tail skid
    for sign, _ in SIDES:
        asm.add("wheel_front", P.tyre((1.9, sign * 0.85, 0.4), 0.4, 0.16, sections=16, rim=0.55), finish="rubber")
        asm.body(P.tube((1.9, sign * 0.85, 0.4), (1.4, sign * 0.3, zc - 0.45), 0.04, 6))
        asm.body(P.tube((1.9, sign * 0.85, 0.4), (2.4, sign * 0.3, zc - 0.45), 0.04, 6))
    asm.add("wheel_front", P.tube((1.9, -0.85, 0.4), (1.9, 0.85, 0.4), 0.05, 8), finish="chrome")
    asm.body(P.tube((-3.0, 0, zc - 0.2), (-3.25, 0, 0.05), 0.04, 6))  # tail skid
    return asm


@builder("airliner")
def airliner() -> Assembly:
    asm = Assembly("airliner")
    zc, r = 3.9, 2.0
    fus = RevolvedBody([(18.5, 0.1), (17.8, 1.0), (16.3, 1.75), (14.5, r), (-9.0, r), (-14.0, 1.3),
                        (-18.5, 0.4)], zc, 1.0, sections=24)
    asm.body(fus.mesh())
    asm.body(fus.panel(17.4, 16.4, 40, 140, 0.05, 5), finish="glass")
    for a0 in (12, 163):  # window bands
        asm.body(fus.panel(13.0, -10.5, a0, a0 + 5, 0.03, 2), finish="glass")
    for label, a0 in (("door_left_s", -25), ("door_right_s", 175)):
        for x in (14.6, -11.2):
            asm.add(label, fus.panel(x, x - 1.1, a0, a0 + 30, 0.06, 5))
    wing_pair(asm, "wing_{side}", (5.0, 1.5, 2.4), 7.5, (-5.5, 16.4, 3.6), 1.6, 0.11)
    wing_pair(asm, "tailplane_{side}", (-13.0, 0.5, 4.6), 4.0, (-16.6, 6.2, 5.0), 1.5, 0.1)
    asm.add("fin", _fin((-11.5, 5.6), 5.5, (-16.8, 12.2), 2.0, 0.1))
    for sign, side in SIDES:
        asm.add(f"engine_{side}", nacelle((5.5, sign * 5.8, 1.95), 4.6, 1.05))
        asm.body(P.rounded_box((2.6, sign * 5.8, 2.7), (3.4, 0.3, 0.9), 0.1))  # pylon
    propeller(asm, (18.45, 0.0, zc), 1.8, 3, 0.5)
    # twin-wheel gear legs (wheels drawn a little large so they stay visible at the public scale)
    for dy in (-0.45, 0.45):
        gear_wheel(asm, "wheel_front", 14.2, dy, 0.6, 0.4, zc - 1.6)
    for sign, side in SIDES:
        for dy in (-0.6, 0.6):
            gear_wheel(asm, f"wheel_back_{side}", -1.0, sign * 3.4 + dy, 0.8, 0.55, zc - 1.5)
    return asm

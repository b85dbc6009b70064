"""Bridges and scenarios that tests in several folders share (one home, not copies)."""

from __future__ import annotations

import math

import numpy as np

from svbi.examples import paper_section
from svbi.runtime.run.results3d import Histories3D

L, MU, E, AREA, Iy = paper_section()
"""The paper's span and deck section (examples/paper-2020.toml)."""

H, MU_P, E_P, A_P, I_P = 12.0, 30.0e3, 32.0e9, 9.0, 6.0
"""A concrete pier: height (m), mass per length (kg/m), E (Pa), area (m^2), second moment (m^4)."""


def bridge_dict(**girders) -> dict:
    return dict(
        mass_per_length=MU,
        youngs_modulus=E,
        area=AREA,
        second_moment=Iy,
        damping_ratio=0.0,
        elements_per_span=16,
        **girders,
    )


# a small viaduct: a simple span, then a continuous two-span girder, on piers
VIADUCT = {
    "bridge": bridge_dict(
        girders=[dict(spans=[24.0]), dict(spans=[30.0, 40.0], fixed_support=1)],
        piers=[
            dict(
                support=1, height=10.0, mass_per_length=MU_P, youngs_modulus=E_P, area=A_P, second_moment=I_P
            ),
            dict(
                support=2, height=12.0, mass_per_length=MU_P, youngs_modulus=E_P, area=A_P, second_moment=I_P
            ),
        ],
    )
    | {"elements_per_span": 8, "damping_ratio": 0.02, "rail_height": 1.5},
    "train": dict(vehicle="pioneer-2d", cars=2, speed_kmh=250.0),
    "track": dict(irregularity="none"),
    "earthquake": dict(vertical="synthetic", longitudinal="synthetic", arrival=0.0),
    "solver": dict(backend="numpy", time_step=5e-4, duration=1.5),
}

# A sprung mass (the sprung-mass benchmark values) on a coned wheelset: the 3D counterpart of
# sprung-mass, a symmetric lateral layout (3D step tests).
SPRUNG_WHEELSET_3D = """
name = "sprung-wheelset-3d"
kind = "rigid-body"
dimensions = 3
description = "A sprung mass on a coned wheelset: the 3D counterpart of sprung-mass (test vehicle)."
source = "tests: the sprung-mass benchmark values, a symmetric lateral layout"
[parameters.m_s]
value = 5750.0
unit = "kg"
description = "sprung mass"
[parameters.m_w]
value = 500.0
unit = "kg"
description = "wheelset mass"
[parameters.k]
value = 1.595e6
unit = "N/m"
description = "vertical stiffness, whole"
[parameters.kl]
value = 2.0e6
unit = "N/m"
description = "lateral and longitudinal stiffness per side"
[parameters.car_length]
value = 25.0
unit = "m"
description = "spacing"
[parameters.r0]
value = 0.46
unit = "m"
description = "wheel radius"
[[bodies]]
name = "body"
dofs = ["y", "z", "phi"]
mass = "m_s"
roll_inertia = "3000"
position = "0"
height = "1.5"
[[bodies]]
name = "ws"
dofs = ["y", "z", "phi", "psi"]
mass = "m_w"
roll_inertia = "100"
yaw_inertia = "100"
position = "0"
height = "r0"
[[suspensions]]
name = "spring"
body_a = "body"
body_b = "ws"
lateral = "1.0"
height = "0.8"
sides = 2
stiffness = ["kl", "kl", "k / 2"]
[[wheels]]
name = "left"
body = "ws"
lateral = "0.75"
radius = "r0"
[[wheels]]
name = "right"
body = "ws"
lateral = "-0.75"
radius = "r0"
"""

SHORT_SPAN_3D = """\
title = "the sprung wheelset on one short span under three ground components"
[bridge]
spans = 1
span_length = 10.0
mass_per_length = 2303.0
youngs_modulus = 2.87e9
area = 1.0
second_moment = 2.9
lateral_second_moment = 10.0
torsion_constant = 5.0
damping_ratio = 0.02
elements_per_span = 4
[train]
vehicle = "sw3d.toml"
speed_kmh = 100.0
start_position = 2.0
[contact]
creep = false
[solver]
backend = "numpy"
time_step = 1e-3
duration = 0.01
[earthquake]
vertical = "synthetic"
longitudinal = "synthetic"
lateral = "synthetic"
arrival = 0.0
"""
"""A 3D scenario that runs in a moment (ten steps of one car on one 10 m span of four elements, the
ground moving from t = 0): the vehicle file ``sw3d.toml`` beside it is :data:`SPRUNG_WHEELSET_3D`
(:func:`write_short_span_3d`)."""


def write_short_span_3d(folder, name: str = "base.toml", earthquake: bool = True):
    """Write :data:`SHORT_SPAN_3D` (without its ``[earthquake]`` when ``earthquake`` is false) and its
    vehicle file into ``folder``; returns the scenario's path."""
    (folder / "sw3d.toml").write_text(SPRUNG_WHEELSET_3D, encoding="utf-8")
    path = folder / name
    path.write_text(SHORT_SPAN_3D if earthquake else SHORT_SPAN_3D.split("[earthquake]")[0], encoding="utf-8")
    return path


def histories3d(
    normal: float = 50e3,
    angle: float = 0.05,
    steps: int = 400,
    cars: int = 2,
    axles: int = 4,
    dt: float = 1e-3,
    speed: float = 50.0,
    **arrays: np.ndarray,
) -> Histories3D:
    """Histories of a 3D run (run/results3d.py): every wheel at the normal force ``normal`` and the
    contact angle ``angle``, nothing lateral, the train at ``speed``; ``arrays`` replace fields."""
    t = np.arange(steps) * dt
    wheel = (steps, cars, axles, 2)
    base = dict(
        time=t,
        distance=speed * t,
        normal_force=np.full(wheel, normal),
        contact_angle=np.full(wheel, angle),
        creep_longitudinal=np.zeros(wheel),
        creep_lateral=np.zeros(wheel),
        flange_force=np.zeros(wheel),
        flange_contact=np.zeros(wheel, bool),
        wheel_rail_lateral=np.zeros(wheel[:3]),
        static_wheel_load=np.full(wheel[1:], normal * math.cos(angle)),
        carbody_ay=np.zeros((steps, cars)),
        carbody_roll=np.zeros((steps, cars)),
        midspan_uy=np.zeros((steps, 2)),
        midspan_uy_rel=np.zeros((steps, 2)),
        midspan_twist=np.zeros((steps, 2)),
        midspan_twist_rel=np.zeros((steps, 2)),
    )
    base.update(arrays)
    return Histories3D(**base)

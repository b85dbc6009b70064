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

# the sprung wheelset with a dashpot beside each spring (a damped test vehicle: the unilateral 3D
# steps and the 3D C loop)
_DASHPOTS = '[parameters.c]\nvalue = 4.0e4\nunit = "N s/m"\ndescription = "damping per side"\n'
_SPRINGS = 'stiffness = ["kl", "kl", "k / 2"]'
SPRUNG_WHEELSET_3D_DAMPED = (
    SPRUNG_WHEELSET_3D.replace('name = "sprung-wheelset-3d"', 'name = "sprung-wheelset-3d-damped"')
    .replace("[parameters.car_length]", _DASHPOTS + "[parameters.car_length]")
    .replace(_SPRINGS, _SPRINGS + '\ndamping = ["c", "c", "c"]')
)

SW_DECK = dict(mass_per_length=2303.0, youngs_modulus=2.87e9, area=1.0, second_moment=2.9)
"""The deck of the sprung-mass benchmark (kg/m, Pa, m^2, m^4): the spans that the sprung wheelset
crosses in the 3D step tests that compare with svbi's 2D run (:func:`sprung_mass_run2d`)."""
SW_SPEED = 100.0 / 3.6
"""The sprung wheelset's speed in those tests (m/s)."""
SW_CONICITY = 0.1
"""The cones' conicity in those tests: the normal forces lean by ``atan(0.1)``."""


def sprung_wheelset3d(damped: bool = False):
    """The 3D vehicle of :data:`SPRUNG_WHEELSET_3D` (or :data:`SPRUNG_WHEELSET_3D_DAMPED`)."""
    from svbi.codegen.topology3d import parse_topology3d
    from svbi.runtime.model.system3d import vehicle3d

    return vehicle3d(parse_topology3d(SPRUNG_WHEELSET_3D_DAMPED if damped else SPRUNG_WHEELSET_3D))


def sw_chain3d(
    spans: int, elements: int, damping: float = 0.0, lateral: float = 10.0, span_length: float = 10.0
):
    """A chain of ``spans`` simply supported spans of :data:`SW_DECK` as a 3D bridge
    (``Bridge3D``): lateral second moment ``lateral``, torsion constant 5 m^4, damping ratio
    ``damping`` (its Rayleigh matrix ``bridge.C``)."""
    from svbi.runtime.model.bridge import Girder, Section
    from svbi.runtime.model.bridge3d import Bridge3D, section3d

    plane = Section(**SW_DECK, damping_ratio=damping)
    return Bridge3D(
        [Girder((span_length,), plane)] * spans, elements, [section3d(plane, lateral, 5.0)] * spans
    )


def sprung_mass_run2d(
    spans: int,
    steps: int,
    *,
    method: str = "coupled-dynamic",
    start: float = 0.0,
    cars: int = 1,
    car_length: float | None = None,
    span_length: float = 10.0,
    elements: int = 8,
    dt: float = 2e-3,
    damping: float = 0.0,
    ground=None,
    girders: list[dict] | None = None,
):
    """svbi's 2D run (``svbi.simulate``, NumPy, every step written) of the sprung mass (the
    sprung wheelset's vertical plane: its masses and stiffness, no damper) at :data:`SW_SPEED` over
    ``spans`` spans of :data:`SW_DECK`: the independent truth of the 3D steps in the vertical plane.
    ``ground``: a ``FunctionGround`` set on the model (None: no earthquake). ``girders``: the
    bridge's long form (``[{"spans": [10.0, 16.0]}, ...]``) instead of ``spans`` equal spans."""
    import svbi
    from svbi.runtime.run.simulate import build_model
    from svbi.runtime.scenario.schema import validate_scenario

    parameters = dict(sprung_mass=5750.0, stiffness=1.595e6, wheel_mass=500.0, damping=0.0)
    if car_length is not None:
        parameters["car_length"] = car_length
    scenario = validate_scenario(
        {
            "bridge": dict(
                **(dict(girders=girders) if girders else dict(spans=spans, span_length=span_length)),
                **SW_DECK,
                damping_ratio=damping,
                elements_per_span=elements,
            ),
            "train": dict(
                vehicle="sprung-mass", cars=cars, speed=SW_SPEED, start_position=start, parameters=parameters
            ),
            "contact": dict(creep=False),
            "solver": dict(method=method, backend="numpy", time_step=dt, duration=steps * dt, output_every=1),
        }
    )
    if ground is None:
        return svbi.simulate(scenario)
    model = build_model(scenario)
    model.ground = ground
    return svbi.simulate(scenario, model=model)


def ground_bump(amplitude: float, omega: float, t0: float = 0.0, c: float | None = None):
    """``q = A (1 - cos(omega s))^2`` for ``s = t - t0 - x/c > 0``, else 0 (q, q', q'' vanish at
    the onset): a smooth ground motion and its exact partial time derivatives."""

    def f(t, x):
        x = np.asarray(x, dtype=float)
        s = t - t0 - (x / c if c else 0.0 * x)
        on = s > 0.0
        cs, sn = np.cos(omega * s), np.sin(omega * s)
        q = amplitude * (1 - cs) ** 2
        q1 = 2 * amplitude * omega * (1 - cs) * sn
        q2 = 2 * amplitude * omega**2 * (sn * sn + (1 - cs) * cs)
        return tuple(np.where(on, a, 0.0) for a in (q, q1, q2))

    return f


def copy_state3d(state):
    """A deep copy of a 3D step's ``State3D`` (two steppers from one static state)."""
    from svbi.runtime.methods.coupled3d import State3D

    return State3D(**{k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in vars(state).items()})


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

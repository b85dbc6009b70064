"""The 3D coupled-dynamic step (runtime/methods/coupled3d.py) against independent truth.

* In the vertical plane (a symmetric car, no lateral input) the 3D step is svbi's 2D
  coupled-dynamic run of the same case (``svbi.simulate``, sprung-mass, same dt, elements, kappa,
  zeta): midspan deflection, contact force and gap agree to round-off.
* Gaps: both normal gaps equal the 2D aux-bridge gap times ``cos(atan lam)`` to round-off: the
  stabilised rows hold them at Newmark's truncation of the moving contact (2e-9 m here, the same
  in 2D) without drift; at a standstill they stay at round-off.
* A static lateral load on the car body: the deck's lateral midspan deflection is the closed form
  ``F L^3 / (48 E I_z)``, and its twist is ``T L / (4 G J)`` with ``T`` the torque about the shear
  centre of the contact forces at the rails, written here from the solved normal forces and the
  cone's normals (rail top ``h_t`` above the shear centre, track ``e_t`` beside it); that torque is
  the car's moment balance to first order (residual of third order in the load).
* localized-dynamic (partitioned, interface iteration) = coupled-dynamic (monolithic Newton) to
  1e-10 of each series' peak, on a car rolling and swaying over an eccentric track.
"""

from __future__ import annotations

import numpy as np
import pytest

from svbi.codegen.topology3d import parse_topology3d
from svbi.runtime.methods.coupled3d import CoupledDynamic3D, static_state
from svbi.runtime.methods.localized3d import LocalizedDynamic3D
from svbi.runtime.model.span3d import Section3D, simply_supported_span
from svbi.runtime.model.system3d import GROUND, System3D, Track3D, vehicle3d
from tests.cases import (
    SPRUNG_WHEELSET_3D,
    SW_CONICITY,
    SW_DECK,
    SW_SPEED,
    sprung_mass_run2d,
    sprung_wheelset3d,
)

TOPOLOGY = SPRUNG_WHEELSET_3D

L = 25.0
V = SW_SPEED
DT, STEPS, ELEMENTS = 2e-3, 200, 8
LAM = SW_CONICITY
COS = 1.0 / np.sqrt(1.0 + LAM**2)


@pytest.fixture(scope="module")
def vehicle():
    return sprung_wheelset3d()


@pytest.fixture(scope="module")
def run3d(vehicle):
    deck = SW_DECK
    section = Section3D(
        E=deck["youngs_modulus"],
        A=deck["area"],
        I_y=deck["second_moment"],
        I_z=10.0,
        J=5.0,
        mass_per_length=deck["mass_per_length"],
    )
    span = simply_supported_span(section, L, ELEMENTS)
    system = System3D(vehicle, span, Track3D(conicity=LAM), speed=V, start=0.0)
    stepper = CoupledDynamic3D(system, static_state(system), DT)
    mid = ELEMENTS // 2
    rows = []
    for n in range(STEPS):
        st = stepper.step(n)
        rows.append(
            [
                st.u[span.dof(mid, "w")],
                st.u[span.dof(mid, "v")],
                st.u[span.dof(mid, "phi")],
                *st.P,
                *stepper.gaps(),
                st.q[vehicle.index("y_ws")],
                st.q[vehicle.index("phi_ws")],
            ]
        )
    return np.array(rows)


@pytest.fixture(scope="module")
def run2d():
    return sprung_mass_run2d(1, STEPS, span_length=L, elements=ELEMENTS, dt=DT)


def test_vertical_plane_is_the_2d_run(run3d, run2d):
    w2 = run2d.midspan_uz.values[1:, 0]
    peak = np.abs(w2).max()
    assert peak > 1e-3  # the wheel has loaded the span
    assert np.abs(run3d[:, 0] - w2).max() < 1e-11 * peak  # measured 1.1e-13
    # the two normal forces are equal and their vertical components carry the 2D contact force
    P2 = run2d.contact_force.values.reshape(STEPS + 1, -1)[1:, 0]
    assert np.abs(run3d[:, 3] - run3d[:, 4]).max() < 1e-11 * P2.max()
    assert np.abs(COS * (run3d[:, 3] + run3d[:, 4]) - P2).max() < 1e-11 * P2.max()
    # nothing lateral: sway and twist of the deck, lateral motion and roll of the wheelset
    assert np.abs(run3d[:, [1, 2, 7, 8]]).max() < 1e-14


def test_gaps_are_the_2d_gap_and_do_not_drift(run3d, run2d):
    g2 = (run2d.gap_bridge.values + run2d.gap_vehicle.values).reshape(STEPS + 1, -1)[1:, 0]
    scale = np.abs(run3d[:, 0]).max()
    for side in (5, 6):
        assert np.abs(run3d[:, side] - COS * g2).max() < 1e-12 * scale
    # Newmark's truncation of the moving contact (5e-6 of the deflection at this dt, as in 2D),
    # held by the stabilised rows: no drift, the second half of the run stays below the first
    g = np.abs(run3d[:, 5:7])
    assert g[STEPS // 2 :].max() <= g[: STEPS // 2].max()


def test_gaps_at_a_standstill_stay_at_round_off(vehicle):
    section = Section3D(E=3.0e10, A=5.0, I_y=3.0, I_z=20.0, J=4.0, mass_per_length=12000.0)
    span = simply_supported_span(section, 10.0, 4)
    system = System3D(vehicle, span, Track3D(conicity=LAM, rail_height=1.2), speed=0.0, start=3.7)
    stepper = CoupledDynamic3D(system, static_state(system), 1e-3)
    # a vertical load on the car body set on at t = 0: the car bounces on the span
    system.load = np.zeros(len(vehicle.dof_names))
    system.load[vehicle.index("z_body")] = -2.0e4
    gaps = []
    for n in range(100):
        stepper.step(n)
        gaps.append(stepper.gaps())
    assert np.abs(stepper.state.q[vehicle.index("z_body")]) > 1e-3
    assert np.abs(gaps).max() < 1e-15


E3, IZ, J, LB, H_T, E_T = 3.0e10, 20.0, 4.0, 10.0, 1.2, 0.3
SECTION = Section3D(E=E3, A=5.0, I_y=3.0, I_z=IZ, J=J, mass_per_length=12000.0)
H_LOAD = 1.5  # the car body's centre of mass above the rail top, where the lateral load acts


def lateral_static(vehicle, force: float):
    span = simply_supported_span(SECTION, LB, 4)
    load = np.zeros(len(vehicle.dof_names))
    load[vehicle.index("y_body")] = force
    track = Track3D(conicity=LAM, eccentricity=E_T, rail_height=H_T)
    system = System3D(vehicle, span, track, speed=0.0, start=LB / 2, load=load)
    return span, static_state(system)


@pytest.mark.parametrize("force", [100.0, 5000.0])
def test_static_lateral_load_sways_and_twists_the_span(vehicle, force):
    span, st = lateral_static(vehicle, force)
    mid = 2
    v, phi = st.u[span.dof(mid, "v")], st.u[span.dof(mid, "phi")]
    assert v == pytest.approx(force * LB**3 / (48 * E3 * IZ), rel=1e-12)
    # the torque of the contact forces at the rails: normal of side s, (0, -s lam, 1) / sqrt(1 + lam^2)
    # turned by the wheelset's roll; the deck takes -P n at (e + s b, h) from its shear centre
    roll = st.q[vehicle.index("phi_ws")]
    b = 0.75
    torque, lateral = 0.0, 0.0
    for P, s in zip(st.P, (1, -1), strict=True):
        ny = COS * (-s * LAM * np.cos(roll) - np.sin(roll))
        nz = COS * (-s * LAM * np.sin(roll) + np.cos(roll))
        fy, fz = -P * ny, -P * nz
        torque += -H_T * fy + (E_T + s * b) * fz
        lateral += fy
        assert P > 0
    # a closed flange (5000 N: the cones cannot hold the car within the clearance) pushes the deck
    # towards its side at the rail top
    for Q, s in zip(st.flange, (1, -1), strict=True):
        torque += -H_T * s * Q
        lateral += s * Q
    assert (st.flange > 0).any() == (force > 1000.0)
    assert lateral == pytest.approx(force, rel=1e-10)
    assert phi == pytest.approx(torque * LB / (4 * SECTION.shear * J), rel=1e-12)  # measured 2e-16


def test_transmitted_torque_to_first_order(vehicle):
    """The moment balance of the car about the track centreline at the rail top, to first order:
    ``T = -(H + h_t) F - e_t W - W (y_w - y_r) + tan(delta) W b phi_d``: the lateral load at its
    height above the shear centre, the weight at the eccentricity, the weight moved with the
    wheelset's lateral shift on the cones relative to the track (``y_r = v - h_t phi_d``; it doubles
    the twist of this car: the bilateral cones alone hold it laterally), and the inward lean of the
    normals (lateral components ``+-W tan(delta) / 2``) on the twisted rails. The residual is of
    third order in ``F``: a tenth of the load leaves a thousandth of it."""
    W = -(vehicle.F[vehicle.index("z_body")] + vehicle.F[vehicle.index("z_ws")])
    b = 0.75
    residual = []
    for force in (10.0, 100.0):
        span, st = lateral_static(vehicle, force)
        v, phi = st.u[span.dof(2, "v")], st.u[span.dof(2, "phi")]
        torque = phi * 4 * SECTION.shear * J / LB  # the closed form of the fork-supported bar, inverted
        y_w = st.q[vehicle.index("y_ws")]
        closed = -(H_LOAD + H_T) * force - E_T * W - W * (y_w - (v - H_T * phi)) + LAM * W * b * phi
        residual.append(abs(torque - closed) / abs(torque))
    assert residual[0] < 1e-10  # measured 1.8e-11
    assert 300 < residual[1] / residual[0] < 3000  # third order: measured 970


def test_localized_is_coupled(vehicle):
    """A lateral and a vertical load on the car body set on as the car rolls along an eccentric,
    raised track at 20 m/s: sway, roll, yaw, bounce; both steppers from the same static state."""
    span = simply_supported_span(SECTION, LB, 4)
    track = Track3D(conicity=LAM, eccentricity=E_T, rail_height=H_T)
    load = np.zeros(len(vehicle.dof_names))
    load[vehicle.index("y_body")] = 5.0e3
    load[vehicle.index("z_body")] = -2.0e4
    series = []
    for cls in (CoupledDynamic3D, LocalizedDynamic3D):
        system = System3D(vehicle, span, track, speed=20.0, start=1.0)
        state = static_state(system)
        system.load = load
        stepper = cls(system, state, 1e-3)
        rows = []
        for n in range(150):
            st = stepper.step(n)
            deck = [st.u[span.dof(2, name)] for name in ("v", "w", "phi")]
            rows.append([*deck, *st.P, *st.q[:6], *stepper.gaps()])
        series.append(np.array(rows))
    coupled, localized = series
    peak = np.abs(coupled).max(axis=0)
    assert peak[0] > 1e-8 and peak[2] > 1e-7 and peak[5] > 1e-3  # it sways, twists and rolls
    diff = np.abs(localized - coupled).max(axis=0)
    assert (diff[:-2] <= 1e-10 * peak[:-2]).all(), diff / peak  # measured 2e-12 at most
    # the gaps are Newmark's truncation (2e-8 m): compared with the deflection they follow
    assert (diff[-2:] <= 1e-10 * peak[1]).all()


def test_manchester_car_on_a_span():
    """One car of manchester-3d (four wheelsets, 31 DOFs without the wheelsets' spin) on a 40 m
    span: the static normal forces carry the car's weight (vertical components), and the two
    steppers agree over a few steps at 50 m/s."""
    vehicle = vehicle3d("manchester-3d")
    assert len(vehicle.wheelsets) == 4
    section = Section3D(E=3.5e10, A=8.63, I_y=6.58, I_z=85.86, J=15.21, mass_per_length=2.3e4)
    span = simply_supported_span(section, 40.0, 8)
    lam = 0.15
    system = System3D(vehicle, span, Track3D(conicity=lam, rail_height=1.0), speed=50.0, start=30.0)
    state = static_state(system)
    weight = -vehicle.F.sum()
    assert np.sum(state.P) / np.sqrt(1 + lam**2) == pytest.approx(weight, rel=1e-12)
    series = []
    for cls in (CoupledDynamic3D, LocalizedDynamic3D):
        stepper = cls(system, static_state(system), 1e-3)
        rows = []
        for n in range(30):
            st = stepper.step(n)
            rows.append([st.u[span.dof(4, "w")], *st.P])
        series.append(np.array(rows))
    peak = np.abs(series[0]).max(axis=0)
    assert (np.abs(series[1] - series[0]).max(axis=0) <= 1e-10 * peak).all()


def test_set_up_errors(vehicle):
    """A wheelset off the span is on the approach track (``GROUND``); a body carrying wheels that is
    not a wheelset is refused."""
    span = simply_supported_span(SECTION, LB, 4)
    system = System3D(vehicle, span, Track3D(conicity=LAM), speed=10.0, start=LB - 0.5)
    assert system.contact_location(0.1) == [(GROUND, 0.0)]
    no_roll = TOPOLOGY.replace('dofs = ["y", "z", "phi", "psi"]', 'dofs = ["y", "z", "psi"]').replace(
        'roll_inertia = "100"\n', ""
    )
    with pytest.raises(ValueError, match="body 'ws' carries wheels but is not a wheelset"):
        vehicle3d(parse_topology3d(no_roll))

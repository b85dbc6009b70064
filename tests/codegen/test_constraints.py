"""Constraint identities: b-vectors, constraint masses, exact gap derivatives, discrete rows."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from svbi.codegen import beam
from svbi.codegen import constraints as c
from svbi.codegen.vehicle import a_split, derive_vehicle, validate_split


@pytest.mark.parametrize("name", ["sprung-mass", "pioneer-2d"])
def test_vehicle_b_vectors_and_masses(name: str) -> None:
    model = derive_vehicle(name)
    nw = model.contact_normal.shape[1]
    active, aux = model.active_mass_matrix(), model.aux_masses()
    for i in range(nw):
        e = sp.zeros(nw, 1)
        e[i] = 1
        b = c.b_vehicle(model.contact_normal[:, i], e)
        stacked = sp.Matrix.vstack(model.contact_normal[:, i], -e)
        assert sp.simplify((b.T * stacked)[0, 0]) == 1  # b_i . [W_i; -E_i] = 1
        mbar = c.mass_vehicle_constraint(b, active, aux)
        # Rigid wheel contact: the constraint mass does not depend on the split a (docs/method.md.1),
        # and equals a quarter of the wheel mass for a unit contact direction.
        assert sp.diff(mbar, a_split) == 0
        assert sp.simplify(mbar - model.wheel_masses[i] / 4) == 0


def test_bridge_b_vector_identity_and_positive_mass() -> None:
    b = c.b_bridge()
    n_row = beam.normal_row(0)
    stacked = sp.Matrix.vstack(sp.Matrix([[1]]), -n_row.T)
    assert sp.simplify((b.T * stacked)[0, 0]) == 1
    m_g = sp.Symbol("m_g", positive=True)
    mbar = c.mass_bridge_constraint(m_g)
    # b^T diag(m_g, M_e) b written out independently.
    direct = (b.T * sp.diag(m_g, beam.element_mass()) * b)[0, 0]
    xs = np.linspace(0.0, 1.0, 41)
    subs = {beam.le: 2.0, beam.mu: 22.4e3, m_g: 950.0}
    f = sp.lambdify(beam.xi, mbar.subs(subs))
    g = sp.lambdify(beam.xi, direct.subs(subs))
    vals = np.array([f(x) for x in xs])
    assert np.all(vals > 0)
    assert np.allclose(vals, [g(x) for x in xs], rtol=1e-13)


@pytest.mark.parametrize("dof", range(6))
def test_support_b_vector_and_mass(dof: int) -> None:
    b = c.b_support(dof)
    assert (b.T * b)[0, 0] == 1
    assert sp.simplify(c.mass_support_constraint(dof) - beam.element_mass()[dof, dof]) == 0


def test_bridge_gap_derivatives_are_exact_time_derivatives() -> None:
    # Differentiate g(t) = u_g(t) - N(xi(t))^T u_e(t) - r(x(t)) with xi = (x0 + v t) / le directly.
    t, x0 = sp.symbols("t x0", real=True)
    gap = c.gap_bridge()
    ug_f = sp.Function("ug")(t)
    ue_f = sp.Matrix([sp.Function(f"u{i}")(t) for i in range(6)])
    r_f = sp.Function("rr")
    x_t = x0 + c.v * t
    xi_t = x_t / beam.le
    g_t = ug_f - (beam.normal_row(0).subs(beam.xi, xi_t) * ue_f)[0, 0] - r_f(x_t)
    ue, ue1, ue2 = gap.u_elem
    ug, ug1, ug2 = gap.u_aux
    to_symbols = {}
    for i in range(6):
        to_symbols[ue_f[i].diff(t, 2)] = ue2[i]
        to_symbols[ue_f[i].diff(t)] = ue1[i]
        to_symbols[ue_f[i]] = ue[i]
    to_symbols.update({ug_f.diff(t, 2): ug2, ug_f.diff(t): ug1, ug_f: ug})
    for expr, order in ((gap.g, 0), (gap.g_t, 1), (gap.g_tt, 2)):
        direct = sp.diff(g_t, t, order).doit()
        # r and its derivatives at x(t)
        direct = direct.subs(
            {sp.Subs(sp.Derivative(r_f(sp.Symbol("_x")), sp.Symbol("_x"), 2), sp.Symbol("_x"), x_t): c.r2}
        )
        direct = direct.replace(
            lambda e: isinstance(e, sp.Subs), lambda e: c.r1 if e.expr.args[1][1] == 1 else c.r2
        )
        direct = direct.subs(r_f(x_t), c.r).subs(to_symbols).subs(x0, beam.xi * beam.le - c.v * t)
        assert sp.simplify(sp.expand(direct - expr)) == 0, order


def test_discrete_row_matches_method_notes_closed_forms() -> None:
    # docs/design.md section 4b: kappa = 2, zeta = 1 gives W_hat = N + (v dt/2) N' + (v dt)^2/16 N'';
    # kappa = 0 gives N + v dt N' + (v dt)^2/4 N''.
    row, _ = c.discrete_bridge_row()
    n0, n1, n2 = (beam.normal_row(k) for k in range(3))
    v, dt = c.v, c.dt
    for kappa, zeta, (k1, k2) in (
        (2, 1, (v * dt / 2, (v * dt) ** 2 / 16)),
        (0, 1, (v * dt, (v * dt) ** 2 / 4)),
    ):
        got = row.row.subs({c.kappa: kappa, c.zeta: zeta})
        assert sp.simplify(got - (n0 + k1 * n1 + k2 * n2)) == sp.zeros(1, 6)
    assert sp.simplify(row.d.subs({c.kappa: 2, c.zeta: 1}) - 16 / dt**2) == 0


def test_discrete_point_row_reproduces_prescribed_motion() -> None:
    # If the history is consistent with y(t) = q(t) exactly, the discrete constraint returns q.
    row, names = c.discrete_point_row()
    dt = c.dt
    y_n, yd_n, ydd_n = sp.symbols("y_n yd_n ydd_n")
    p_y = 4 / dt**2 * y_n + 4 / dt * yd_n + ydd_n
    q_y = 2 / dt * y_n + yd_n
    # Choose the target at t_{n+1} as the Newmark-consistent continuation.
    y_new = sp.Symbol("y_new")
    rhs = row.rhs.subs(
        {
            names["P_y"]: p_y,
            names["Q_y"]: q_y,
            c.q: y_new,
            c.q1: 2 / dt * y_new - q_y,
            c.q2: 4 / dt**2 * y_new - p_y,
        }
    )
    assert sp.simplify(rhs - y_new) == 0


@pytest.mark.parametrize("bad", [0.0, 1.0, -0.2, 1.5, True])
def test_split_outside_unit_interval_is_rejected(bad: float) -> None:
    with pytest.raises(ValueError, match=r"solver\.contact_split"):
        validate_split(bad)
    with pytest.raises(ValueError):
        derive_vehicle("sprung-mass").active_mass_matrix(bad)

"""The runtime's numeric evaluation of the symbolic core, and the bridge assembly.

* the polynomial-in-xi evaluation of the codegen rows equals SymPy's own evaluation;
* the discrete aux-bridge row equals the closed form of docs/design.md section 4b, which the notes
  derived by hand (an independent check of both codegen and its evaluation);
* span frequencies against (n pi / L)^2 sqrt(EI/m), Rayleigh damping ratios on the first two modes,
  and the quasi-static support field is strain-free.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from svbi.codegen import beam, constraints
from svbi.examples import paper_section
from svbi.runtime.model.bridge import Bridge
from svbi.runtime.model.contact_rows import (
    BridgeConstraintMass,
    ContactRowKernel,
    ShapeKernel,
    point_row,
    vehicle_constraint_masses,
)

LE, V, DT = 2.0, 83.3, 1e-4
RNG = np.random.default_rng(7)


@pytest.mark.parametrize(("kappa", "zeta"), [(1.0, 1.0), (2.0, 1.0), (0.0, 0.0), (0.5, 0.7)])
def test_contact_rows_equal_sympy(kappa, zeta):
    row, names = constraints.discrete_bridge_row()
    subs = {
        beam.le: LE,
        constraints.v: V,
        constraints.dt: DT,
        constraints.kappa: kappa,
        constraints.zeta: zeta,
    }
    kernel = ContactRowKernel(LE, V, DT, kappa, zeta)
    xi = RNG.random(5)
    got = kernel(xi)
    hist = {
        s: RNG.normal()
        for s in [
            names["P_ug"],
            names["Q_ug"],
            constraints.r,
            constraints.r1,
            constraints.r2,
            *names["P_ue"],
            *names["Q_ue"],
        ]
    }
    for k, x in enumerate(xi):
        at = {**subs, beam.xi: x}
        w_hat = np.array([float(e.xreplace(at)) for e in row.row])
        np.testing.assert_allclose(got.W_hat[k], w_hat, rtol=1e-12, atol=1e-14)
        h_sym = float(row.rhs.xreplace({**at, **hist}))
        pe = np.array([hist[s] for s in names["P_ue"]])
        qe = np.array([hist[s] for s in names["Q_ue"]])
        h_num = (
            got.c_P_ug[k] * hist[names["P_ug"]]
            + got.c_Q_ug[k] * hist[names["Q_ug"]]
            + got.c_P_ue[k] @ pe
            + got.c_Q_ue[k] @ qe
            + got.c_r[k] * hist[constraints.r]
            + got.c_r_x[k] * hist[constraints.r1]
            + got.c_r_xx[k] * hist[constraints.r2]
        )
        assert h_num == pytest.approx(h_sym, rel=1e-11, abs=1e-15)
        for order, arr in ((0, got.N0), (1, got.N1), (2, got.N2)):
            exact = [float(e.xreplace(at)) for e in beam.normal_row(order)]
            np.testing.assert_allclose(arr[k], exact, rtol=1e-12, atol=1e-12)


def test_discrete_row_matches_the_hand_derivation():
    """docs/design.md section 4: W_hat = [d N + (2 v a1 + 2 zeta omega v) N' + v^2 N''] / d; with kappa = 2,
    zeta = 1 that is N + (v dt / 2) N' + (v dt)^2 / 16 N''."""
    xi = np.linspace(0, 1, 7)
    N0, N1, N2 = ShapeKernel(LE, (0, 1, 2))(xi)
    got = ContactRowKernel(LE, V, DT, 2.0, 1.0)(xi).W_hat
    np.testing.assert_allclose(got, N0 + (V * DT / 2) * N1 + (V * DT) ** 2 / 16 * N2, rtol=1e-12, atol=1e-15)
    kappa, zeta = 0.7, 0.9
    a0, a1, w = 4 / DT**2, 2 / DT, kappa / DT
    d = a0 + 2 * zeta * w * a1 + w * w
    expected = (d * N0 + (2 * V * a1 + 2 * zeta * w * V) * N1 + V * V * N2) / d
    np.testing.assert_allclose(
        ContactRowKernel(LE, V, DT, kappa, zeta)(xi).W_hat, expected, rtol=1e-12, atol=1e-15
    )
    p = point_row(DT, kappa, zeta)
    assert p.d == pytest.approx(d) and p.c_P == pytest.approx(1 / d) and p.c_q == pytest.approx(w * w / d)


def test_constraint_masses():
    """Eq. (27): a wheel in rigid contact has mbar = m_w / 4 whatever the split a; Eq. (31) at a node
    (xi = 0) is (m_g + 13 mu le / 35) / (1 + 1)^2."""
    for a in (0.1, 0.5, 0.9):
        m = vehicle_constraint_masses("pioneer-2d", {"wheelset_mass": 1900.0}, a)
        np.testing.assert_allclose(m, 1900.0 / 4, rtol=1e-12)
    mb = BridgeConstraintMass(LE, 22.4e3, 950.0)(np.array([0.0, 0.37]))
    assert mb[0] == pytest.approx((950.0 + 13 * 22.4e3 * LE / 35) / 4, rel=1e-12)
    m_g = sp.Symbol("m_g", positive=True)
    exact = float(
        constraints.mass_bridge_constraint(m_g).xreplace(
            {m_g: 950.0, beam.le: LE, beam.mu: 22.4e3, beam.xi: 0.37}
        )
    )
    assert mb[1] == pytest.approx(exact, rel=1e-12)


@pytest.fixture(scope="module")
def span():
    L, mu, E, A, Iy = paper_section()
    return Bridge(2, L, mu, E, A, Iy, 0.02, 16, 1.2)


def test_span_frequencies(span):
    n = np.arange(1, 4)
    L, mu, E, _, Iy = paper_section()
    exact = (n * np.pi / L) ** 2 * np.sqrt(E * Iy / mu)
    np.testing.assert_allclose(span.vertical_frequencies[:3], exact, rtol=1e-3)
    assert span.vertical_frequencies[0] / (2 * np.pi) == pytest.approx(4.95, abs=0.01)  # the paper's 4.95 Hz


def test_rayleigh_damping_ratio_on_the_first_two_modes(span):
    import scipy.linalg as sla

    free = np.setdiff1d(np.arange(span.ndof), span.support_dofs)
    sub = np.ix_(free, free)
    w2, phi = sla.eigh(span.K[sub], span.M[sub])
    bending = [
        k for k in range(len(w2)) if np.abs(phi[free % 3 == 0, k]).max() < 1e-9 * np.abs(phi[:, k]).max()
    ]
    for k in bending[:2]:
        f = phi[:, k]
        ratio = (f @ span.C[sub] @ f) / (2 * np.sqrt(w2[k]) * (f @ span.M[sub] @ f))
        assert ratio == pytest.approx(0.02, rel=1e-9)


def test_quasi_static_field_is_strain_free(span):
    """Support motion moves a simply supported span rigidly: K T = 0, and T matches the supports."""
    assert np.abs(span.K @ span.T).max() < 1e-6 * np.abs(span.K).max()
    np.testing.assert_allclose(span.E.T @ span.T, np.eye(span.nsupport), atol=1e-15)


def test_locate_uses_the_span_ahead_at_joints(span):
    loc = span.locate(np.array([-0.1, 0.0, 31.999, 32.0, 63.0, 64.0]))
    np.testing.assert_array_equal(loc.on, [False, True, True, True, True, False])
    np.testing.assert_array_equal(loc.span[loc.on], [0, 0, 1, 1])
    np.testing.assert_array_equal(loc.element[loc.on], [0, 15, 0, 15])
    np.testing.assert_allclose(loc.xi[loc.on], [0.0, 0.9995, 0.0, 0.5], atol=1e-12)

"""Frame element against textbook closed forms, and span frequencies against (n pi / L)^2 sqrt(EI/m)."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from svbi.codegen import beam
from svbi.examples import paper_section
from svbi.runtime.model.modes import span_modes

L, m, EA, EI = beam.le, beam.mu, beam.E * beam.A, beam.E * beam.I


def test_bending_mass_matches_textbook() -> None:
    textbook = (
        m
        * L
        / 420
        * sp.Matrix(
            [
                [156, 22 * L, 54, -13 * L],
                [22 * L, 4 * L**2, 13 * L, -3 * L**2],
                [54, 13 * L, 156, -22 * L],
                [-13 * L, -3 * L**2, -22 * L, 4 * L**2],
            ]
        )
    )
    idx = list(beam.BENDING)
    assert sp.simplify(beam.element_mass().extract(idx, idx) - textbook) == sp.zeros(4, 4)


def test_bending_stiffness_matches_textbook() -> None:
    textbook = (
        EI
        / L**3
        * sp.Matrix(
            [
                [12, 6 * L, -12, 6 * L],
                [6 * L, 4 * L**2, -6 * L, 2 * L**2],
                [-12, -6 * L, 12, -6 * L],
                [6 * L, 2 * L**2, -6 * L, 4 * L**2],
            ]
        )
    )
    idx = list(beam.BENDING)
    assert sp.simplify(beam.element_stiffness().extract(idx, idx) - textbook) == sp.zeros(4, 4)


def test_axial_matrices_match_textbook_and_decouple() -> None:
    ax = list(beam.AXIAL)
    assert sp.simplify(
        beam.element_mass().extract(ax, ax) - m * L / 6 * sp.Matrix([[2, 1], [1, 2]])
    ) == sp.zeros(2)
    assert sp.simplify(
        beam.element_stiffness().extract(ax, ax) - EA / L * sp.Matrix([[1, -1], [-1, 1]])
    ) == sp.zeros(2)
    bend = list(beam.BENDING)
    assert beam.element_mass().extract(ax, bend) == sp.zeros(2, 4)
    assert beam.element_stiffness().extract(ax, bend) == sp.zeros(2, 4)


def test_shape_functions_interpolate_nodes() -> None:
    n0, n1 = beam.normal_row(0), beam.normal_row(1)
    assert list(n0.subs(beam.xi, 0)) == [0, 1, 0, 0, 0, 0]
    assert list(n0.subs(beam.xi, 1)) == [0, 0, 0, 0, 1, 0]
    assert list(n1.subs(beam.xi, 0)) == [0, 0, 1, 0, 0, 0]
    assert list(n1.subs(beam.xi, 1)) == [0, 0, 0, 0, 0, 1]
    # A rigid rotation about the left node, w = theta x, is reproduced exactly.
    theta, x = sp.symbols("theta x")
    rigid = sp.Matrix([0, 0, theta, 0, theta * L, theta])
    assert sp.simplify((n0 * rigid)[0] - theta * beam.xi * L) == 0


def test_tangential_row_couples_rail_height() -> None:
    # Rail head at height h: u_rail = u - h dw/dx (plane sections stay plane).
    t_row = beam.tangential_row(0)
    u = sp.Matrix(sp.symbols("u1 w1 t1 u2 w2 t2"))
    expected = (beam.axial_shape() * u)[0] - beam.h * sp.diff((beam.bending_shape() * u)[0], beam.xi) / L
    assert sp.simplify((t_row * u)[0] - expected) == 0
    # Derivative rows are the x-derivatives of the base rows.
    assert sp.simplify(beam.tangential_row(1) - t_row.diff(beam.xi) / L) == sp.zeros(1, 6)
    assert sp.simplify(beam.normal_row(2) - beam.normal_row(0).diff(beam.xi, 2) / L**2) == sp.zeros(1, 6)


@pytest.mark.parametrize("order", [3, -1])
def test_row_orders_are_checked(order: int) -> None:
    with pytest.raises(ValueError, match="order"):
        beam.normal_row(order)


def test_span_frequencies_converge_to_closed_form() -> None:
    span, mass, e_mod, area, inertia = paper_section()
    exact = [(n * np.pi / span) ** 2 * np.sqrt(e_mod * inertia / mass) / (2 * np.pi) for n in (1, 2, 3)]
    errors = []
    for nel in (4, 8, 16):
        fb, fa = span_modes(span, nel, e_mod, area, inertia, mass)
        errors.append(abs(fb[0] / exact[0] - 1))
    assert errors[-1] < 1e-3  # better than 0.1 % for mode 1 at 16 elements
    assert errors[0] > errors[1] > errors[2]  # converges with refinement
    fb, fa = span_modes(span, 16, e_mod, area, inertia, mass)
    assert np.allclose(fb[:3], exact, rtol=1e-3)
    # Axial: fixed-free bar, f_n = (2n - 1) c / (4 L) with c = sqrt(E A / m).
    c = np.sqrt(e_mod * area / mass)
    assert fa[0] == pytest.approx(c / (4 * span), rel=1e-3)
    # The paper's span: first vertical frequency 4.95 Hz.
    assert fb[0] == pytest.approx(4.95, abs=0.01)

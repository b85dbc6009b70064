"""The 3D frame element: its planes are the 2D element, its torsion the textbook bar, and the
generated NumPy module is the SymPy derivation."""

from __future__ import annotations

import numpy as np
import sympy as sp

from svbi.codegen import beam, frame3d
from svbi.runtime.model.kernels import FRAME3D, load


def test_vertical_plane_is_the_2d_element() -> None:
    idx = list(frame3d.VERTICAL_PLANE)
    mass = frame3d.element_mass().extract(idx, idx)
    stiffness = frame3d.element_stiffness().extract(idx, idx).subs(frame3d.I_y, beam.I)
    assert sp.simplify(mass - beam.element_mass()) == sp.zeros(6, 6)
    assert sp.simplify(stiffness - beam.element_stiffness()) == sp.zeros(6, 6)


def test_lateral_plane_is_the_2d_element_with_i_z() -> None:
    idx = list(frame3d.LATERAL_PLANE)
    mass = frame3d.element_mass().extract(idx, idx)
    stiffness = frame3d.element_stiffness().extract(idx, idx).subs(frame3d.I_z, beam.I)
    assert sp.simplify(mass - beam.element_mass()) == sp.zeros(6, 6)
    assert sp.simplify(stiffness - beam.element_stiffness()) == sp.zeros(6, 6)


def test_torsion_is_the_linear_bar() -> None:
    # textbook two-node bar: G J / L [[1, -1], [-1, 1]] and I_m L / 6 [[2, 1], [1, 2]]
    idx = [frame3d.DOF_NAMES.index("phi1"), frame3d.DOF_NAMES.index("phi2")]
    le, gj, im = frame3d.le, frame3d.G * frame3d.J, frame3d.I_m
    assert sp.simplify(
        frame3d.element_stiffness().extract(idx, idx) - gj / le * sp.Matrix([[1, -1], [-1, 1]])
    ) == sp.zeros(2, 2)
    assert sp.simplify(
        frame3d.element_mass().extract(idx, idx) - im * le / 6 * sp.Matrix([[2, 1], [1, 2]])
    ) == sp.zeros(2, 2)


def test_families_do_not_couple() -> None:
    # symmetric section, shear centre on the centroid: no entry joins axial, lateral, vertical, torsion
    families = {"u": 0, "v": 1, "psi": 1, "w": 2, "theta": 2, "phi": 3}
    names = [n[:-1] for n in frame3d.DOF_NAMES]
    for m in (frame3d.element_mass(), frame3d.element_stiffness()):
        for i, a in enumerate(names):
            for j, b in enumerate(names):
                if families[a] != families[b]:
                    assert m[i, j] == 0, (a, b)


def test_rigid_body_motions_are_free() -> None:
    # six rigid motions of the element (node DOFs [u, v, w, phi, theta, psi], theta = dw/dx,
    # psi = dv/dx): no strain energy
    le = frame3d.le
    modes = [
        [1, 0, 0, 0, 0, 0] * 2,  # translation x
        [0, 1, 0, 0, 0, 0] * 2,  # y
        [0, 0, 1, 0, 0, 0] * 2,  # z
        [0, 0, 0, 1, 0, 0] * 2,  # twist about x
        [0, 0, 0, 0, 1, 0, 0, 0, le, 0, 1, 0],  # w = x: slope 1
        [0, 0, 0, 0, 0, 1, 0, le, 0, 0, 0, 1],  # v = x
    ]
    k = frame3d.element_stiffness()
    for mode in modes:
        assert sp.simplify(k * sp.Matrix(mode)) == sp.zeros(12, 1)


def test_shear_modulus_from_poisson() -> None:
    assert sp.simplify(frame3d.shear_modulus(200, sp.Rational(1, 4)) - 80) == 0


def test_generated_module_is_the_derivation() -> None:
    k = load(FRAME3D)
    s = frame3d.SAMPLE
    subs = {
        sym: s[sym.name]
        for sym in (
            frame3d.E,
            frame3d.G,
            frame3d.A,
            frame3d.I_y,
            frame3d.I_z,
            frame3d.J,
            frame3d.mu,
            frame3d.I_m,
            frame3d.le,
        )
    }
    mass = np.array(frame3d.element_mass().subs(subs).evalf(17).tolist(), dtype=float)
    stiffness = np.array(frame3d.element_stiffness().subs(subs).evalf(17).tolist(), dtype=float)
    got_m = k.element_mass([s["mu"], s["I_m"]], s["le"])
    got_k = k.element_stiffness([s["E"], s["G"], s["A"], s["I_y"], s["I_z"], s["J"]], s["le"])
    np.testing.assert_allclose(got_m, mass, rtol=1e-14, atol=1e-14 * np.abs(mass).max())
    np.testing.assert_allclose(got_k, stiffness, rtol=1e-14, atol=1e-14 * np.abs(stiffness).max())
    assert k.DATA["dof_names"] == frame3d.DOF_NAMES


def test_generated_shape_functions_are_the_derivation() -> None:
    """The rows the 3D runs read the deck with (``u``, ``v``, ``w``, ``phi`` at ``xi``) against the
    SymPy shape functions, at a few points of two element lengths."""
    k = load(FRAME3D)
    n = frame3d.shape_functions()
    for le_value in (0.7, 2.5):
        for xi_value in (0.0, 0.21, 0.5, 0.93, 1.0):
            got = k.shape_functions(le_value, xi_value)
            subs = {beam.le: le_value, beam.xi: xi_value}
            for row, name in enumerate(("u", "v", "w", "phi")):
                want = np.array(n[name].subs(subs), dtype=float).ravel()
                assert np.allclose(got[row], want, rtol=0.0, atol=1e-15 * le_value), (
                    name,
                    le_value,
                    xi_value,
                )

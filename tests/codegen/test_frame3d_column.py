"""The vertical 3D column element (codegen/frame3d.py ``column_mass``/``column_stiffness``, a pier):
restricted to ``(u, w, theta)`` it is the 2D column of codegen/beam.py (symbolic identity); its
rotation is orthogonal; rigid-body motions of the vertical element cost no strain energy; the
generated kernels are the derivation."""

from __future__ import annotations

import numpy as np
import sympy as sp

from svbi.codegen import beam, frame3d
from svbi.runtime.model.kernels import FRAME3D, load


def test_vertical_plane_is_the_2d_column() -> None:
    idx = list(frame3d.VERTICAL_PLANE)
    mass = frame3d.column_mass().extract(idx, idx)
    stiffness = frame3d.column_stiffness().extract(idx, idx).subs(frame3d.I_y, beam.I)
    assert sp.simplify(mass - beam.column_mass()) == sp.zeros(6, 6)
    assert sp.simplify(stiffness - beam.column_stiffness()) == sp.zeros(6, 6)


def test_rotation_is_orthogonal() -> None:
    r = frame3d.column_rotation()
    assert r.T * r == sp.eye(12)
    assert r.det() == 1


def test_rigid_body_motions_of_the_column_are_free() -> None:
    # node DOFs [u, v, w, phi, theta, psi] in global axes; the element runs from z = 0 to z = le.
    # A small rotation (r_x, r_y, r_z) moves a point at height z by (r_y z, -r_x z, 0) and turns it
    # by phi = r_x, theta = -r_y, psi = r_z
    le = frame3d.le
    modes = [
        [1, 0, 0, 0, 0, 0] * 2,
        [0, 1, 0, 0, 0, 0] * 2,
        [0, 0, 1, 0, 0, 0] * 2,
        [0, 0, 0, 1, 0, 0, 0, -le, 0, 1, 0, 0],  # r_x = 1
        [0, 0, 0, 0, -1, 0, le, 0, 0, 0, -1, 0],  # r_y = 1
        [0, 0, 0, 0, 0, 1] * 2,  # r_z = 1: the column twists about its axis rigidly
    ]
    k = frame3d.column_stiffness()
    for mode in modes:
        assert sp.simplify(k * sp.Matrix(mode)) == sp.zeros(12, 1)


def test_generated_column_is_the_derivation() -> None:
    k = load(FRAME3D)
    s = frame3d.SAMPLE
    syms = (
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
    subs = {sym: s[sym.name] for sym in syms}
    mass = np.array(frame3d.column_mass().subs(subs).evalf(17).tolist(), dtype=float)
    stiffness = np.array(frame3d.column_stiffness().subs(subs).evalf(17).tolist(), dtype=float)
    got_m = k.column_mass([s["mu"], s["I_m"]], s["le"])
    got_k = k.column_stiffness([s["E"], s["G"], s["A"], s["I_y"], s["I_z"], s["J"]], s["le"])
    np.testing.assert_allclose(got_m, mass, rtol=1e-14, atol=1e-14 * np.abs(mass).max())
    np.testing.assert_allclose(got_k, stiffness, rtol=1e-14, atol=1e-14 * np.abs(stiffness).max())

"""The gravitational stiffness of a coned wheelset on knife-edge rails, from the constraint
geometry of codegen.contact3d, against statics and virtual work written out here.

Independent truth. A wheelset (axle load ``W``) with cones of slope ``lam`` rests on knife edges at
``+-b``. Displaced laterally by ``y`` it rolls by ``phi`` and its centre rises to ``z_c(y)``: both
follow from the cones touching both edges, written here as "the edge lies on the tread line"
(a cross product, not the gap formula of the module). Virtual work with frictionless contacts: the
lateral force that holds the wheelset at ``y`` is ``F = W dz_c/dy``. In closed form (the two touch
conditions, subtracted and added): ``tan phi = lam y / (b - lam z_c)`` and
``z_c cos phi = r0 + y sin phi + lam b (1 - cos phi)``, so ``phi = phi1 y + O(y^3)`` with
``phi1 = lam / (b - lam r0)`` and ``z_c = r0 + (phi1 + (r0 + lam b) phi1^2 / 2) y^2 + O(y^4)``: the
gravitational stiffness is ``K = W (2 phi1 + (r0 + lam b) phi1^2)``, about ``2 W lam / b`` for small
``lam``. (The textbook ``W lam / b`` of the linear wheelset, codegen.wheelset3d, keeps both wheel
loads at ``W/2``; the load moving to the wheel whose contact comes nearer to the centre doubles it.)
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
import sympy as sp

from svbi.codegen import contact3d as c3

R0, B, W = 0.46, 0.75, 109e3


def newton(residual: Callable[[np.ndarray], list[float]], start: np.ndarray) -> np.ndarray:
    """Newton's method with a central-difference Jacobian, to a residual of round-off."""
    x = start.astype(float)
    for _ in range(30):
        r = np.array(residual(x))
        if np.abs(r).max() < 1e-16:
            return x
        jac = np.empty((2, 2))
        for k in range(2):
            dx = np.zeros(2)
            dx[k] = 1e-7
            jac[:, k] = (np.array(residual(x + dx)) - np.array(residual(x - dx))) / 2e-7
        x = x - np.linalg.solve(jac, r)
    assert np.abs(np.array(residual(x))).max() < 1e-15, residual(x)
    return x


def touch_height(y: float, lam: float) -> tuple[float, float]:
    """(z_c, phi) with both cones touching both edges: the edge (s b, 0) lies on the tread line
    through the tape-circle point ``c + R(phi) (s b, -r0)`` with direction ``R(phi) (s, lam)``."""

    def residual(unknowns: np.ndarray) -> list[float]:
        zc, phi = unknowns
        rot = np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])
        out = []
        for s in (1, -1):
            point = np.array([y, zc]) + rot @ np.array([s * B, -R0])
            direction = rot @ np.array([s, lam])
            edge = np.array([s * B, 0.0]) - point
            out.append(edge[0] * direction[1] - edge[1] * direction[0])
        return out

    sol = newton(residual, np.array([R0, lam * y / B]))
    return float(sol[0]), float(sol[1])


def model_force(y: float, lam: float) -> tuple[float, float, float]:
    """(F, z_c, phi) from the module: the constraint equations solved for z_w and phi_w, and the
    multipliers of ``[F, -W, 0] + J^T Lambda = 0`` over ``[y_w, z_w, phi_w]``."""
    fixed = {**c3.centred_state(), c3.r0: R0, c3.b: B, c3.lam: lam}
    fixed.pop(c3.y_w), fixed.pop(c3.z_w), fixed.pop(c3.phi_w)
    q = (c3.y_w, c3.z_w, c3.phi_w)
    gaps = [c.gap.subs(fixed) for c in c3.contacts()]
    jac = sp.Matrix([[sp.diff(g, s) for s in q] for g in gaps])
    g_f = sp.lambdify(q, gaps)
    j_f = sp.lambdify(q, jac)

    def residual(unknowns: np.ndarray) -> list[float]:
        return [float(v) for v in g_f(y, unknowns[0], unknowns[1])]

    z, phi = newton(residual, np.zeros(2))
    jt = np.array(j_f(y, z, phi), dtype=float).T  # 3 x 2
    multipliers = np.linalg.solve(jt[1:], np.array([W, 0.0]))
    force = -float(jt[0] @ multipliers)
    assert np.all(multipliers > 0)  # both wheels pressed on their rails
    return force, R0 + float(z), float(phi)


@pytest.mark.parametrize("lam", [0.05, 0.15, 0.3])
def test_lateral_force_is_the_virtual_work_of_lifting_the_axle_load(lam: float) -> None:
    for y in (1e-3, 4e-3):
        force, zc, phi = model_force(y, lam)
        zc_ref, phi_ref = touch_height(y, lam)
        assert zc == pytest.approx(zc_ref, abs=1e-13)
        assert phi == pytest.approx(phi_ref, rel=1e-9)
        step = 1e-6
        slope = (touch_height(y + step, lam)[0] - touch_height(y - step, lam)[0]) / (2 * step)
        # central difference: truncation ~ step^2 z''' / 6 relative to the slope, far below 1e-6
        assert force == pytest.approx(W * slope, rel=1e-6)


@pytest.mark.parametrize("lam", [0.05, 0.15, 0.3])
def test_gravitational_stiffness_closed_form(lam: float) -> None:
    phi1 = lam / (B - lam * R0)
    stiffness = W * (2 * phi1 + (R0 + lam * B) * phi1**2)
    y = 1e-4
    force, _, phi = model_force(y, lam)
    assert phi == pytest.approx(phi1 * y, rel=1e-6)  # phi = phi1 y + O(y^3)
    assert force / y == pytest.approx(stiffness, rel=1e-6)  # F = K y + O(y^3)

"""Newmark's update in total and increment form (runtime/methods/newmark.py).

The vehicles are stepped in increment form: the same scheme, but the car-body acceleration (a
plotted result) no longer carries the ``a0 eps |u|`` round-off of ``a0 u_{n+1} - P``.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import sympy as sp

from svbi.runtime.methods.newmark import Newmark


def test_increment_form_is_the_total_form_in_exact_arithmetic() -> None:
    u, du, v, a, dt = sp.symbols("u du v a dt", positive=True)
    nm = Newmark(dt)
    P, Q = nm.history(u, v, a)
    Pt, Qt = nm.increment_history(v, a)
    total = nm.update(u + du, P, Q)
    increment = nm.update_increment(du, Pt, Qt)
    for x, y in zip(total, increment, strict=True):
        assert sp.simplify(x - y) == 0


def test_increment_form_keeps_the_acceleration_digits_of_a_far_displaced_body() -> None:
    # a car body 9 cm off its start (the quake moves the whole train), one step at dt = 1e-4
    dt, u, v, a, du = 1e-4, 0.0937, 0.21, 0.35, 2.1002e-5
    nm = Newmark(dt)
    F = Fraction
    a0, a2 = 4 / F(dt) ** 2, 4 / F(dt)
    exact = a0 * F(du) - a2 * F(v) - F(a)  # a_{n+1} for the increment du, in rational arithmetic

    Pt, Qt = nm.increment_history(np.float64(v), np.float64(a))
    _, a_inc = nm.update_increment(np.float64(du), Pt, Qt)
    P, Q = nm.history(np.float64(u), np.float64(v), np.float64(a))
    _, a_tot = nm.update(np.float64(u) + np.float64(du), P, Q)

    err_inc = abs(F(float(a_inc)) - exact)
    err_tot = abs(F(float(a_tot)) - exact)
    scale = a0 * F(du)  # the largest term of the increment form
    assert err_inc <= 4 * np.finfo(float).eps * scale
    # the total form loses the digits of a0 u ~ 4e7 (why the vehicles use the increment form)
    assert err_tot > 100 * err_inc

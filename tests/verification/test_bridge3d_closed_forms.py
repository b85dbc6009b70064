"""The 3D bridge (runtime/model/bridge3d.py) against closed forms and hand-assembled solutions.

* lateral and torsional frequencies of a simply supported span and of a two-span continuous girder:
  Euler-Bernoulli bending (``(n pi / L)^2``; the continuous girder's second mode from
  ``tan(beta L) = tanh(beta L)``) and the exact discrete dispersion of linear torsion elements;
* a pier column's top stiffness: the cantilever's ``3 E I / h^3`` in both planes with different
  ``I``, its top rotations (signs of the axes), axial ``E A / h`` and torsional ``G J / h``;
* the static lateral deflection and twist of a span on two piers of different heights under a
  lateral midspan load, against a solution assembled by hand here: the span laterally simply
  supported on the pier tops, the piers cantilevers with the tip flexibility of a force and a
  moment, the deck's torsion joining the tops' rotations about ``x``;
* the quasi-static field of a uniform support motion in x, y or z is the rigid translation of the
  whole bridge (no strain), with piers, bearing springs and a continuous girder.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import eigh
from scipy.optimize import brentq

from svbi.runtime.model.bridge import Girder, Pier, Section
from svbi.runtime.model.bridge3d import Bridge3D, column_matrices, section3d
from svbi.runtime.model.span3d import Section3D

E, A, MU, I_Y, I_Z, J = 3.5e10, 8.63, 22.4e3, 6.58, 85.86, 15.21
DECK2D = Section(MU, E, A, I_Y, 0.0)
DECK = section3d(DECK2D, lateral_second_moment=I_Z, torsion_constant=J)
G = E / 2.4
I_M = MU * (I_Y + I_Z) / A
GROUPS = {"lateral": (1, 5), "vertical": (2, 4), "torsion": (3,), "axial": (0,)}


def family(bridge: Bridge3D, name: str, count: int) -> np.ndarray:
    """The ``count`` lowest frequencies (Hz) whose kinetic energy lies mostly in the family's DOFs
    (a deck-only bridge: global DOF ``6 node + j``)."""
    f = bridge.free
    lam, vec = eigh(bridge.K[np.ix_(f, f)], bridge.M[np.ix_(f, f)])
    kind = np.arange(bridge.ndof) % 6
    out = []
    for k in range(len(f)):
        phi = np.zeros(bridge.ndof)
        phi[f] = vec[:, k]
        energy = {
            g: (np.where(np.isin(kind, d), phi, 0.0) @ bridge.M @ np.where(np.isin(kind, d), phi, 0.0))
            for g, d in GROUPS.items()
        }
        if max(energy, key=energy.__getitem__) == name:
            out.append(math.sqrt(lam[k]) / (2 * math.pi))
    return np.array(out[:count])


def bending(beta_l: float, length: float, inertia: float) -> float:
    return beta_l**2 / length**2 * math.sqrt(E * inertia / MU) / (2 * math.pi)


def torsion_discrete(n: int, length: float, elements: int) -> float:
    """The n-th frequency of a bar of ``elements`` linear elements with consistent mass, fixed at
    both ends: ``w^2 = (6 G J / (I_m h^2)) (1 - cos kh) / (2 + cos kh)``, ``k = n pi / length``."""
    h = length / elements
    c = math.cos(n * math.pi / length * h)
    return math.sqrt(6 * G * J / (I_M * h * h) * (1 - c) / (2 + c)) / (2 * math.pi)


def test_simply_supported_span_lateral_and_torsion() -> None:
    L, ne = 32.0, 16
    b = Bridge3D([Girder((L,), DECK2D)], ne, [DECK])
    lateral = family(b, "lateral", 3)
    exact = np.array([bending(n * math.pi, L, I_Z) for n in (1, 2, 3)])
    assert np.abs(lateral / exact - 1).max() < 1e-4  # Hermite cubics, 16 elements (as span3d's test)
    torsion = family(b, "torsion", 3)
    np.testing.assert_allclose(torsion, [torsion_discrete(n, L, ne) for n in (1, 2, 3)], rtol=1e-10)
    # ... which converges to the continuum's n / (2 L) sqrt(G J / I_m)
    assert abs(torsion[0] / (1 / (2 * L) * math.sqrt(G * J / I_M)) - 1) < 2e-3


def test_two_span_continuous_girder_lateral_and_torsion() -> None:
    L, ne = 30.0, 16
    b = Bridge3D([Girder((L, L), DECK2D)], ne, [DECK])
    lateral = family(b, "lateral", 2)
    # antisymmetric: a simply supported span's first mode; symmetric: tan(bL) = tanh(bL)
    root = brentq(lambda x: math.tan(x) - math.tanh(x), 3.5, 4.5)
    exact = np.array([bending(math.pi, L, I_Z), bending(root, L, I_Z)])
    assert abs(root - 3.9266) < 1e-4
    assert np.abs(lateral / exact - 1).max() < 1e-4
    # the fork over the interior support holds the twist: each span a fixed-fixed bar, the first
    # torsional frequency twice
    torsion = family(b, "torsion", 3)
    np.testing.assert_allclose(torsion[:2], torsion_discrete(1, L, ne), rtol=1e-10)
    np.testing.assert_allclose(torsion[2], torsion_discrete(2, L, ne), rtol=1e-10)


def test_pier_top_stiffness_in_both_planes() -> None:
    h, ne = 12.0, 6
    pier = Section3D(E=3.0e10, A=5.0, I_y=4.0, I_z=9.0, J=6.0, mass_per_length=12e3)
    M, K = column_matrices(pier, h, ne)
    free = np.arange(6, K.shape[0])  # the base (node 0) fixed
    top = 6 * ne
    flex = np.zeros((K.shape[0], 6))
    flex[free] = np.linalg.solve(K[np.ix_(free, free)], np.eye(K.shape[0])[np.ix_(free, top + np.arange(6))])
    EIy, EIz = pier.E * pier.I_y, pier.E * pier.I_z
    # a unit force along x at the top: the longitudinal sway bends about the lateral axis (I_y)
    assert 1 / flex[top + 0, 0] == pytest.approx(3 * EIy / h**3, rel=1e-12)
    assert flex[top + 4, 0] == pytest.approx(-(h**2) / (2 * EIy), rel=1e-12)  # theta = -dU/dZ
    # along y: the lateral sway bends about the longitudinal axis (I_z)
    assert 1 / flex[top + 1, 1] == pytest.approx(3 * EIz / h**3, rel=1e-12)
    assert flex[top + 3, 1] == pytest.approx(-(h**2) / (2 * EIz), rel=1e-12)  # phi = -dV/dZ
    # along z: axial; a moment about z: the pier's torsion
    assert 1 / flex[top + 2, 2] == pytest.approx(pier.E * pier.A / h, rel=1e-12)
    assert 1 / flex[top + 5, 5] == pytest.approx(pier.shear * pier.J / h, rel=1e-12)
    # nothing couples the two planes
    assert abs(flex[top + 1, 0]) < 1e-12 * flex[top, 0] and abs(flex[top + 0, 1]) < 1e-12 * flex[top + 1, 1]


def test_lateral_load_on_a_deck_on_piers() -> None:
    """A span on two piers (rigid bearings) under a lateral midspan force, against a hand solution."""
    L, ne, F = 30.0, 8, 1.0e6
    h = (8.0, 14.0)
    pier2d = Section(12e3, 3.0e10, 5.0, 4.0, 0.0)
    pier = section3d(pier2d, lateral_second_moment=9.0, torsion_constant=6.0)
    b = Bridge3D(
        [Girder((L,), DECK2D)], ne, [DECK], [Pier(0, h[0], pier2d), Pier(1, h[1], pier2d)], [pier, pier]
    )
    load = np.zeros(b.ndof)
    mid = b.midspan_node(0)
    load[b.dof(mid, "v")] = F
    f = b.free
    x = np.zeros(b.ndof)
    x[f] = np.linalg.solve(b.K[np.ix_(f, f)], load[f])

    # by hand: laterally the span is statically determinate: F / 2 on each pier top. A pier top
    # under a force P along y and a moment M about x moves V = P h^3/(3EI) - M h^2/(2EI) and turns
    # phi = -P h^2/(2EI) + M h/(EI). The fork ties each top's phi to the deck's end twist; the deck
    # (G J / L) twisting between them loads the tops with M_1 = k (phi_2 - phi_1) = -M_2.
    EI = pier.E * pier.I_z
    k = DECK.shear * DECK.J / L
    P = F / 2
    # phi_i = -P h_i^2/(2EI) + M_i h_i/EI, M_1 = k (phi_2 - phi_1), M_2 = -M_1
    a = np.array([[1 + k * h[0] / EI, -k * h[0] / EI], [-k * h[1] / EI, 1 + k * h[1] / EI]])
    rhs = np.array([-P * h[0] ** 2 / (2 * EI), -P * h[1] ** 2 / (2 * EI)])
    phi = np.linalg.solve(a, rhs)
    moment = np.array([k * (phi[1] - phi[0]), -k * (phi[1] - phi[0])])
    V = np.array([P * hi**3 / (3 * EI) - m * hi**2 / (2 * EI) for hi, m in zip(h, moment, strict=True)])
    v_mid = 0.5 * (V[0] + V[1]) + F * L**3 / (48 * DECK.E * DECK.I_z)
    for i in (0, 1):
        assert x[b.dof(b.pier_top(i), "v")] == pytest.approx(V[i], rel=1e-10)
        assert x[b.dof(b.pier_top(i), "phi")] == pytest.approx(phi[i], rel=1e-10)
    assert x[b.dof(mid, "v")] == pytest.approx(v_mid, rel=1e-10)
    assert x[b.dof(mid, "phi")] == pytest.approx(0.5 * (phi[0] + phi[1]), rel=1e-10)
    assert abs(phi[1] - phi[0]) > 0.1 * abs(phi[0])  # the piers differ: the deck does twist
    # nothing vertical or longitudinal
    assert np.abs(x[[b.dof(n, d) for n in range(b.nodes) for d in ("w", "u")]]).max() < 1e-12 * v_mid


@pytest.mark.parametrize("direction", ["x", "y", "z"])
def test_uniform_support_motion_is_a_rigid_translation(direction: str) -> None:
    pier2d = Section(12e3, 3.0e10, 5.0, 4.0, 0.05)
    pier = section3d(pier2d, lateral_second_moment=9.0, torsion_constant=6.0)
    deck2d = Section(MU, E, A, I_Y, 0.02)
    b = Bridge3D(
        [Girder((24.0,), deck2d), Girder((30.0, 40.0), deck2d, fixed_support=1)],
        6,
        [DECK, DECK],
        [Pier(1, 10.0, pier2d), Pier(2, 12.0, pier2d, bearing_vertical=4e9, bearing_longitudinal=2e8)],
        [pier, pier],
        [None, 3e8],
    )
    j = "xyz".index(direction)
    motion = np.zeros((b.spans + 1, 3))
    motion[:, j] = 1.0
    q = b.support_motion(motion)
    assert set(q) == {0.0, 1.0}
    field = b.quasi_static(q)
    expected = np.zeros(b.ndof)
    expected[b.global_dof[:, j]] = 1.0  # u, v or w of every node
    assert np.abs(field - expected).max() < 1e-10
    assert np.abs(b.K @ field).max() < 1e-12 * np.abs(b.K).max()  # no strain
    # wave passage: each line its own motion; the field holds the supports at their targets
    motion[:, j] = np.arange(b.spans + 1)
    q = b.support_motion(motion)
    assert np.array_equal(b.quasi_static(q)[b.support_dofs], q)

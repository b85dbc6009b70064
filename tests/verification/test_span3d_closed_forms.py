"""A simply supported 3D span (generated frame3d kernels, runtime.model.span3d) against closed forms:
Euler-Bernoulli bending frequencies in both planes, torsional frequencies (continuum and the exact
discrete dispersion of linear elements), and static midspan deflection and twist."""

from __future__ import annotations

import math

import numpy as np
import pytest

from svbi.runtime.model.span3d import (
    Section3D,
    family_frequencies,
    modes,
    simply_supported_span,
    static_displacement,
)

# The 17WCEE example's box girder: 32 m, 22.4 t/m, E 35.5 GPa, A 8.63, I_yy (vertical) 6.58,
# I_zz (lateral) 85.86, J 15.21 m^4; nu = 0.2.
L = 32.0
SECTION = Section3D(E=35.5e9, A=8.63, I_y=6.58, I_z=85.86, J=15.21, mass_per_length=22.4e3)
G = 35.5e9 / (2 * 1.2)
I_M = 22.4e3 * (6.58 + 85.86) / 8.63


def bending(n: int, inertia: float) -> float:
    return n**2 * math.pi / (2 * L**2) * math.sqrt(SECTION.E * inertia / SECTION.mass_per_length)


def torsion(n: int) -> float:
    return n / (2 * L) * math.sqrt(G * 15.21 / I_M)


def test_defaults_documented() -> None:
    assert SECTION.shear == pytest.approx(G, rel=1e-15)
    assert SECTION.polar_inertia == pytest.approx(I_M, rel=1e-15)
    # rho J = m J / A is several times smaller for this box girder
    assert I_M / (22.4e3 * 15.21 / 8.63) > 6.0


@pytest.mark.parametrize(("family", "inertia"), [("vertical", 6.58), ("lateral", 85.86)])
def test_bending_frequencies(family: str, inertia: float) -> None:
    errors = []
    for n_el in (4, 8, 16):
        got = family_frequencies(simply_supported_span(SECTION, L, n_el), family, 3)
        exact = np.array([bending(n, inertia) for n in (1, 2, 3)])
        errors.append(np.abs(got / exact - 1))
    errors = np.array(errors)
    assert np.all(np.diff(errors, axis=0) < 0)  # converges with elements
    assert errors[-1].max() < 1e-4  # 16 elements: 4 digits on the first three modes
    # Hermite cubics with consistent mass converge at fourth order: halving h divides the error by 16
    np.testing.assert_allclose(errors[-2] / errors[-1], 16.0, rtol=0.05)


def test_torsional_frequencies() -> None:
    errors = []
    for n_el in (4, 8, 16, 32):
        span = simply_supported_span(SECTION, L, n_el)
        got = family_frequencies(span, "torsion", 3)
        # exact eigenvalues of n_el linear bar elements with consistent mass, ends held:
        # omega^2 = (GJ/I_m) (6/h^2) (1 - cos kh) / (2 + cos kh), k = n pi / L
        h = L / n_el
        discrete = [
            math.sqrt(
                G
                * 15.21
                / I_M
                * 6
                / h**2
                * (1 - math.cos(n * math.pi * h / L))
                / (2 + math.cos(n * math.pi * h / L))
            )
            / (2 * math.pi)
            for n in (1, 2, 3)
        ]
        np.testing.assert_allclose(got, discrete, rtol=1e-10)
        errors.append(np.abs(got / np.array([torsion(n) for n in (1, 2, 3)]) - 1))
    errors = np.array(errors)
    assert np.all(np.diff(errors, axis=0) < 0)
    # second order: halving h quarters the error (within 2% of the ratio)
    np.testing.assert_allclose(errors[-2] / errors[-1], 4.0, rtol=0.02)
    assert errors[-1, 0] < 5e-4


def test_every_mode_is_one_family() -> None:
    span = simply_supported_span(SECTION, L, 8)
    _, families, _ = modes(span)
    # free DOFs per family: axial 9 - 1, lateral and vertical 2 * 9 - 2, torsion 9 - 2
    assert {f: families.count(f) for f in set(families)} == {
        "axial": 8,
        "lateral": 16,
        "vertical": 16,
        "torsion": 7,
    }


@pytest.mark.parametrize(
    ("dof", "expected"), [("v", 1e6 * L**3 / (48 * 35.5e9 * 85.86)), ("w", 1e6 * L**3 / (48 * 35.5e9 * 6.58))]
)
def test_static_midspan_deflection(dof: str, expected: float) -> None:
    span = simply_supported_span(SECTION, L, 8)
    load = np.zeros(span.M.shape[0])
    load[span.dof(4, dof)] = 1e6
    got = static_displacement(span, load)[span.dof(4, dof)]
    assert got == pytest.approx(expected, rel=1e-12)


def test_static_midspan_twist() -> None:
    span = simply_supported_span(SECTION, L, 8)
    load = np.zeros(span.M.shape[0])
    load[span.dof(4, "phi")] = 1e6
    displacement = static_displacement(span, load)
    assert displacement[span.dof(4, "phi")] == pytest.approx(1e6 * L / (4 * G * 15.21), rel=1e-12)
    # the torque twists only: no bending, no stretching
    others = [i for i in range(len(displacement)) if i % 6 != 3]
    assert np.abs(displacement[others]).max() == 0.0


def test_given_shear_modulus_and_torsional_mass_are_used() -> None:
    section = Section3D(
        E=35.5e9, A=8.63, I_y=6.58, I_z=85.86, J=15.21, mass_per_length=22.4e3, G=1.0e10, torsional_mass=5.0e4
    )
    got = family_frequencies(simply_supported_span(section, L, 64), "torsion", 1)[0]
    assert got == pytest.approx(1 / (2 * L) * math.sqrt(1.0e10 * 15.21 / 5.0e4), rel=2e-4)


def test_bad_section_is_refused() -> None:
    with pytest.raises(ValueError, match="Section3D.J"):
        Section3D(E=35.5e9, A=8.63, I_y=6.58, I_z=85.86, J=0.0, mass_per_length=22.4e3)

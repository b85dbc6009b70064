"""Kalker's C11, C22, C23 (runtime.model.kalker3d) at tabulated points and the table's identities."""

from __future__ import annotations

import numpy as np
import pytest

from svbi.runtime.model.kalker3d import kalker_coefficients


@pytest.mark.parametrize(
    ("a_over_b", "nu", "expected"),
    [
        (1.0, 0.25, (4.12, 3.67, 1.47)),
        (0.1, 0.0, (2.51, 2.51, 0.334)),
        (0.8, 0.25, (3.91, 3.41, 1.25)),  # C23 1.25, not the 1.15 of some copies
        (1 / 0.3, 0.5, (7.34, 7.51, 5.01)),
        (10.0, 0.25, (11.7, 12.8, 14.6)),
    ],
)
def test_tabulated_points(a_over_b: float, nu: float, expected: tuple[float, float, float]) -> None:
    np.testing.assert_allclose(kalker_coefficients(a_over_b, nu), expected, rtol=1e-12)


def test_c11_equals_c22_without_poisson_effect() -> None:
    # for nu = 0 the longitudinal and lateral problems are the same (Kalker): C11 = C22
    for g in np.linspace(0.1, 10.0, 37):
        c11, c22, _ = kalker_coefficients(float(g), 0.0)
        assert c11 == pytest.approx(c22, rel=1e-12)


def test_c23_is_monotone_and_continuous_at_a_circle() -> None:
    values = [kalker_coefficients(float(g), 0.3)[2] for g in np.linspace(0.1, 1.0, 10)]
    assert np.all(np.diff(values) > 0)
    below, above = kalker_coefficients(1.0 - 1e-12, 0.3), kalker_coefficients(1.0 + 1e-12, 0.3)
    np.testing.assert_allclose(below, above, rtol=1e-9)


def test_outside_the_table_is_refused() -> None:
    with pytest.raises(ValueError, match="outside Kalker's table"):
        kalker_coefficients(0.05, 0.3)
    with pytest.raises(ValueError, match="Poisson"):
        kalker_coefficients(1.0, 0.6)

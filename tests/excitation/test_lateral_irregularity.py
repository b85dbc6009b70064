"""Lateral track irregularities for the 3D model: alignment and cross-level samples of the German
high-speed spectra, and measured profiles with optional alignment and cross-level columns."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy import integrate, signal

from svbi.runtime.excitation.irregularity import (
    GermanSpectrum,
    SpectralIrregularity,
    make_irregularity,
    measured_profile_3d,
    read_profile,
    read_profile_3d,
)

# German high-speed spectra, written out here (not imported from the module).
OMEGA_C, OMEGA_R, OMEGA_S, HALF_GAUGE = 0.8246, 0.0206, 0.4380, 0.75
A_V = {"low": 4.032e-7, "high": 1.080e-6}
A_A = {"low": 2.119e-7, "high": 6.125e-7}


def density(omega: np.ndarray | float, level: str, component: str) -> np.ndarray:
    w2 = np.asarray(omega, dtype=float) ** 2
    if component == "alignment":
        return A_A[level] * OMEGA_C**2 / ((w2 + OMEGA_R**2) * (w2 + OMEGA_C**2))
    # cross-level as an angle: A_v / b^2 Omega_c^2 Omega^2 / ((..r)(..c)(..s))
    return (
        A_V[level]
        / HALF_GAUGE**2
        * OMEGA_C**2
        * w2
        / ((w2 + OMEGA_R**2) * (w2 + OMEGA_C**2) * (w2 + OMEGA_S**2))
    )


COMPONENTS = ["alignment", "cross-level"]


@pytest.mark.parametrize("component", COMPONENTS)
@pytest.mark.parametrize("level", ["low", "high"])
def test_density_and_band_variance(level: str, component: str) -> None:
    spectrum = GermanSpectrum(level, component)  # type: ignore[arg-type]
    omega = np.geomspace(0.01, 20.0, 50)
    np.testing.assert_allclose(spectrum.density(omega), density(omega, level, component), rtol=1e-14)
    lo, hi = 2 * math.pi / 80.0, 2 * math.pi / 0.5
    quad = integrate.quad(density, lo, hi, args=(level, component), limit=400, points=[OMEGA_S, OMEGA_C])[0]
    assert spectrum.variance(lo, hi) == pytest.approx(quad, rel=1e-10)


@pytest.mark.parametrize("component", COMPONENTS)
def test_welch_psd_follows_target_spectrum(component: str) -> None:
    """As the vertical profile's test (tests/excitation/test_irregularity.py): a 204.8 m Hann
    segment over 3000 m, ~28 averages; the mean log ratio over ~300 bins has a standard error near
    0.02, the tolerances 0.1 (band) and 0.15 (halves) are about 5 sigma and catch a factor 2."""
    dx = 0.1
    profile = SpectralIrregularity(GermanSpectrum("low", component), seed=5, length=3000.0)  # type: ignore[arg-type]
    r, _, _ = profile.evaluate_unramped(np.arange(0.0, 3000.0, dx))
    f, psd = signal.welch(r, fs=1.0 / dx, nperseg=2048)
    omega = 2 * math.pi * f
    s_est = psd / (2 * math.pi)
    inside = (omega > 2 * (2 * math.pi / 80.0)) & (omega < 0.8 * (2 * math.pi / 0.5))
    log_ratio = np.log(s_est[inside] / density(omega[inside], "low", component))
    assert abs(log_ratio.mean()) < 0.1
    low_half = omega[inside] < 1.0
    assert abs(log_ratio[low_half].mean()) < 0.15
    assert abs(log_ratio[~low_half].mean()) < 0.15


@pytest.mark.parametrize("component", COMPONENTS)
def test_rms_matches_integral_of_spectrum(component: str) -> None:
    lo, hi = 2 * math.pi / 80.0, 2 * math.pi / 0.5
    target = math.sqrt(integrate.quad(density, lo, hi, args=("high", component), limit=400)[0])
    for seed in (1, 7):
        profile = SpectralIrregularity(GermanSpectrum("high", component), seed=seed, length=1000.0)  # type: ignore[arg-type]
        r, _, _ = profile.evaluate_unramped(np.arange(0.0, 1000.0, 0.05))
        assert abs(math.sqrt(np.mean(r**2)) / target - 1.0) < 0.05


def test_seeds_reproducible_and_components_independent() -> None:
    x = np.arange(0.0, 2000.0, 0.25)

    def sample(component: str, seed: int) -> np.ndarray:
        spectrum = GermanSpectrum("low", component)  # type: ignore[arg-type]
        return SpectralIrregularity(spectrum, seed=seed, length=2000.0).evaluate_unramped(x)[0]

    for component in COMPONENTS:
        assert np.array_equal(sample(component, 3), sample(component, 3))
        assert not np.array_equal(sample(component, 3), sample(component, 4))
    # one seed, three components: different phase streams (the same phases would correlate fully)
    phases = {
        c: SpectralIrregularity(GermanSpectrum("low", c), seed=3, length=2000.0).phases  # type: ignore[arg-type]
        for c in ("vertical", "alignment", "cross-level")
    }
    for a, b in (("vertical", "alignment"), ("vertical", "cross-level"), ("alignment", "cross-level")):
        corr = np.corrcoef(np.cos(phases[a]), np.cos(phases[b]))[0, 1]
        assert abs(corr) < 5 / math.sqrt(phases[a].size)  # uncorrelated: |r| ~ 1/sqrt(N)


@pytest.mark.parametrize("level", ["low", "high"])
@pytest.mark.parametrize("seed", [1, 42])
def test_vertical_samples_unchanged(level: str, seed: int) -> None:
    """The vertical profile keeps its phases (the first N draws of ``default_rng(seed)``) and its
    bin amplitudes (the closed-form bin integrals, written out here in the same operations), so a
    scenario's vertical sample is bit-identical to what it was before the lateral components."""
    profile = make_irregularity(f"german-{level}", seed=seed, length=1500.0)
    assert isinstance(profile, SpectralIrregularity)
    n = profile.frequencies.size
    np.testing.assert_array_equal(profile.phases, np.random.default_rng(seed).uniform(0.0, 2.0 * math.pi, n))
    edges = np.linspace(2.0 * math.pi / 80.0, 2.0 * math.pi / 0.5, n + 1)
    factor = A_V[level] * OMEGA_C**2 / (OMEGA_C**2 - OMEGA_R**2)
    cumulative = factor * (np.arctan(edges / OMEGA_R) / OMEGA_R - np.arctan(edges / OMEGA_C) / OMEGA_C)
    np.testing.assert_array_equal(profile.amplitudes, np.sqrt(2.0 * np.diff(cumulative)))


def _write(path: Path, rows: list[str]) -> Path:
    path.write_text("\n".join(rows) + "\n")
    return path


def test_measured_profile_with_lateral_columns(tmp_path: Path) -> None:
    k = 2 * math.pi / 9.0
    xs = np.arange(0.0, 60.0 + 1e-9, 0.25)
    rows = ["# x vertical alignment cross-level"]
    rows += [
        f"{x:.4f}, {1e-3 * math.sin(k * x):.12e}, {2e-3 * math.cos(k * x):.12e}, {5e-4 * x / 60:.12e}"
        for x in xs
    ]
    path = _write(tmp_path / "profile3d.txt", rows)
    table = read_profile_3d(path)
    assert set(table) == {"x", "vertical", "alignment", "cross-level"}
    profiles = measured_profile_3d(path)
    x = np.linspace(5.0, 55.0, 101)
    a, da, _ = profiles["alignment"].evaluate(x)
    np.testing.assert_allclose(a, 2e-3 * np.cos(k * x), atol=2e-3 * 1e-4)
    np.testing.assert_allclose(da, -2e-3 * k * np.sin(k * x), atol=2e-3 * k * 1e-3)
    c, dc, ddc = profiles["cross-level"].evaluate(x)
    np.testing.assert_allclose(c, 5e-4 * x / 60, rtol=1e-9)
    np.testing.assert_allclose(dc, 5e-4 / 60, rtol=1e-7)
    r, _, _ = profiles["vertical"].evaluate(x)
    np.testing.assert_allclose(r, 1e-3 * np.sin(k * x), atol=1e-3 * 1e-4)
    # the optional columns are optional: x r a, and the 2D file x r
    three = _write(tmp_path / "three.txt", [f"{x} {x * 1e-4} {x * 2e-4}" for x in range(6)])
    assert set(read_profile_3d(three)) == {"x", "vertical", "alignment"}
    two = _write(tmp_path / "two.txt", [f"{x} {x * 1e-4}" for x in range(6)])
    assert set(read_profile_3d(two)) == {"x", "vertical"}
    xs2, rs2 = read_profile(two)
    np.testing.assert_array_equal(rs2, read_profile_3d(two)["vertical"])


@pytest.mark.parametrize(
    ("body", "line", "what"),
    [
        ("0 0 0\n1 0 0\n2 0\n3 0 0\n", 3, "expected 3 columns like the first data line, got 2"),
        ("# header\n0 0 0 0 0\n1 0 0 0 0\n", 2, "expected 2 to 4 columns"),
        ("0 0 0\n1 0 x\n2 0 0\n3 0 0\n", 2, "not a number"),
        ("0 0 0\n1 0 inf\n2 0 0\n3 0 0\n", 2, "non-finite"),
        ("0 0 0\n2 0 0\n1 0 0\n3 0 0\n", 3, "does not increase"),
    ],
)
def test_measured_3d_profile_errors_name_file_and_line(
    tmp_path: Path, body: str, line: int, what: str
) -> None:
    path = tmp_path / "bad3d.txt"
    path.write_text(body)
    with pytest.raises(ValueError) as err:
        read_profile_3d(path)
    message = str(err.value)
    assert str(path) in message and f"line {line}" in message and what in message


def test_unknown_component_is_refused() -> None:
    with pytest.raises(ValueError, match="cross-level"):
        GermanSpectrum("low", "gauge")  # type: ignore[arg-type]

"""Track irregularity: spectrum convention, exact derivatives, onset ramp, measured profiles."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, signal
from scipy.interpolate import BPoly

from svbi.runtime.excitation.irregularity import (
    GermanSpectrum,
    NoIrregularity,
    OnsetRamp,
    SampledIrregularity,
    SpectralIrregularity,
    horner,
    make_irregularity,
    quintic_hermite,
)

# German high-speed spectra, written out here from shared/data/vehicles.md (not imported).
OMEGA_C, OMEGA_R = 0.8246, 0.0206
A_V = {"low": 4.032e-7, "high": 1.080e-6}


def german_density(omega: np.ndarray | float, level: str) -> np.ndarray:
    w2 = np.asarray(omega, dtype=float) ** 2
    return A_V[level] * OMEGA_C**2 / ((w2 + OMEGA_R**2) * (w2 + OMEGA_C**2))


def band_variance(level: str, lam_min: float, lam_max: float) -> float:
    lo, hi = 2 * math.pi / lam_max, 2 * math.pi / lam_min
    return integrate.quad(german_density, lo, hi, args=(level,), limit=400, points=[OMEGA_C])[0]


@pytest.mark.parametrize("level", ["low", "high"])
def test_rms_matches_integral_of_spectrum(level: str) -> None:
    """One-sided convention: RMS² = ∫ S dΩ over the band (a two-sided reading would be off by √2)."""
    target = math.sqrt(band_variance(level, 0.5, 80.0))
    for seed in (1, 7):
        profile = SpectralIrregularity(GermanSpectrum(level), seed=seed, length=1000.0)
        r, _, _ = profile.evaluate_unramped(np.arange(0.0, 1000.0, 0.05))
        assert abs(math.sqrt(np.mean(r**2)) / target - 1.0) < 0.05
        assert abs(np.mean(r)) < 0.1 * target


def test_welch_psd_follows_target_spectrum() -> None:
    """Welch PSD of a sampled profile follows S(Ω) across the band.

    With a 204.8 m Hann segment over 3000 m (about 28 averages, 50 % overlap) one bin's log-PSD
    scatters by about 1/sqrt(28) ≈ 0.2; the mean over ~300 bins (half of them independent) has a
    standard error near 0.02. Tolerances 0.1 on the whole band and 0.15 on each half (≈ 5σ) still
    catch a factor-2 convention error (log 2 = 0.69) or a wrong corner frequency.
    """
    dx = 0.1
    profile = SpectralIrregularity(GermanSpectrum("low"), seed=5, length=3000.0)
    r, _, _ = profile.evaluate_unramped(np.arange(0.0, 3000.0, dx))
    f, psd = signal.welch(r, fs=1.0 / dx, nperseg=2048)
    omega = 2 * math.pi * f
    s_est = psd / (2 * math.pi)  # one-sided per Hz -> one-sided per rad/m
    inside = (omega > 2 * (2 * math.pi / 80.0)) & (omega < 0.8 * (2 * math.pi / 0.5))
    log_ratio = np.log(s_est[inside] / german_density(omega[inside], "low"))
    assert abs(log_ratio.mean()) < 0.1
    low_half = omega[inside] < 1.0
    assert abs(log_ratio[low_half].mean()) < 0.15
    assert abs(log_ratio[~low_half].mean()) < 0.15


def test_fast_sum_equals_direct_cosine_sum() -> None:
    profile = SpectralIrregularity(GermanSpectrum("high"), seed=3, length=600.0)
    x = np.linspace(-30.0, 700.0, 997)
    w, a, phi = profile.frequencies, profile.amplitudes, profile.phases
    arg = np.multiply.outer(x, w) + phi
    direct = (np.cos(arg) @ a, -np.sin(arg) @ (a * w), -np.cos(arg) @ (a * w**2))
    fast = profile.evaluate_unramped(x)
    for got, ref in zip(fast, direct, strict=True):
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-10 * np.abs(ref).max())


def test_derivatives_match_finite_differences() -> None:
    ramp = OnsetRamp(start=10.0, length=20.0)
    profile = SpectralIrregularity(GermanSpectrum("low"), seed=2, length=200.0, ramp=ramp)
    x = np.concatenate([np.linspace(0.0, 200.0, 801), [10.0, 30.0]])  # ramp ends included
    h = 1e-3
    r_p, dr_p, _ = profile.evaluate(x + h)
    r_m, dr_m, _ = profile.evaluate(x - h)
    _, dr, ddr = profile.evaluate(x)
    np.testing.assert_allclose((r_p - r_m) / (2 * h), dr, atol=1e-4 * np.abs(dr).max())
    np.testing.assert_allclose((dr_p - dr_m) / (2 * h), ddr, atol=1e-4 * np.abs(ddr).max())


def test_ramp_gives_zero_start_and_full_profile_after() -> None:
    ramp = OnsetRamp(start=-5.0, length=20.0)
    profile = SpectralIrregularity(GermanSpectrum("high"), seed=4, length=500.0, ramp=ramp)
    before = np.linspace(-100.0, -5.0, 50)
    for v in profile.evaluate(before):
        assert np.all(v == 0.0)
    after = np.linspace(15.0, 400.0, 50)
    for got, ref in zip(profile.evaluate(after), profile.evaluate_unramped(after), strict=True):
        np.testing.assert_array_equal(got, ref)


def test_seed_reproducible_and_distinct() -> None:
    x = np.linspace(0.0, 100.0, 101)
    a = SpectralIrregularity(GermanSpectrum("low"), seed=11, length=300.0).evaluate(x)[0]
    b = SpectralIrregularity(GermanSpectrum("low"), seed=11, length=300.0).evaluate(x)[0]
    c = SpectralIrregularity(GermanSpectrum("low"), seed=12, length=300.0).evaluate(x)[0]
    np.testing.assert_array_equal(a, b)
    assert np.abs(a - c).max() > 1e-4


def test_period_covers_length_and_cap_errors() -> None:
    band = 2 * math.pi / 0.5 - 2 * math.pi / 80.0
    auto = SpectralIrregularity(GermanSpectrum("low"), seed=1, length=5000.0)
    assert 2 * math.pi / (auto.frequencies[1] - auto.frequencies[0]) >= 5000.0
    assert auto.period >= 5000.0
    n_needed = math.ceil(band * 5000.0 / (2 * math.pi))
    SpectralIrregularity(GermanSpectrum("low"), seed=1, length=5000.0, n_frequencies=n_needed)
    with pytest.raises(ValueError, match=r"period .* shorter than the simulated track length"):
        SpectralIrregularity(GermanSpectrum("low"), seed=1, length=5000.0, n_frequencies=n_needed - 2)


def test_wavelength_order_error() -> None:
    with pytest.raises(ValueError, match="wavelength_min"):
        SpectralIrregularity(GermanSpectrum("low"), seed=1, length=100.0, wavelength_min=80.0)
    with pytest.raises(ValueError, match="wavelength_min"):
        make_irregularity("german-low", length=100.0, wavelength_min=10.0, wavelength_max=5.0)


def test_tabulated_profile_matches_exact() -> None:
    profile = SpectralIrregularity(GermanSpectrum("low"), seed=8, length=200.0)
    table = profile.tabulate(-10.0, 210.0)
    x = np.random.default_rng(0).uniform(0.0, 200.0, 500)
    for got, ref in zip(table.evaluate(x), profile.evaluate(x), strict=True):
        np.testing.assert_allclose(got, ref, atol=1e-5 * np.abs(ref).max())


def _direct_sum_extended(profile: SpectralIrregularity, x: np.ndarray) -> list[np.ndarray]:
    """r, r', r'' of the stored realisation (frequencies, amplitudes, phases) summed term by term
    in extended precision (``np.longdouble``), so that the reference's own round-off is far below
    the double-precision values compared with it."""
    ld = np.longdouble
    w, a, phi = (v.astype(ld) for v in (profile.frequencies, profile.amplitudes, profile.phases))
    out = [np.empty(x.size, dtype=ld) for _ in range(3)]
    for i in range(0, x.size, 256):
        arg = np.multiply.outer(x[i : i + 256].astype(ld), w) + phi
        cos, sin = np.cos(arg), np.sin(arg)
        out[0][i : i + 256] = cos @ a
        out[1][i : i + 256] = -(sin @ (a * w))
        out[2][i : i + 256] = -(cos @ (a * w * w))
    return [v.astype(float) for v in out]


@pytest.mark.parametrize(
    ("length", "x_min", "x_max", "allow_roundoff"),
    [
        (200.0, -30.0, 205.0, False),  # N = 1024, period 515 m: the grid within one period
        (2000.0, -80.0, 2300.0, True),  # N = 4096, period 2061 m: the grid wraps past one period
    ],
)
def test_fft_table_nodes_equal_direct_sum(length: float, x_min: float, x_max: float, allow_roundoff: bool):
    """The FFT evaluation of the set-up gives the realisation's exact sums at the table nodes.

    Reference: the direct sum over the stored frequencies, amplitudes and phases, written here.
    Tolerance 1e-12 of each series' RMS. On the long track a round-off allowance is added: every
    term's phase Ω_k x is fixed by double inputs only to about ε Ω_k |x| (x and Ω_k are rounded to
    ε), which at Ω_max = 4π rad/m and |x| = 2300 m is 6e-12; any double evaluation, the direct sum
    included, carries it. An index or frequency off by one node or bin errs by 1e-2 or more.
    """
    profile = SpectralIrregularity(GermanSpectrum("high"), seed=3, length=length)
    dx = 0.5 / 50
    x, values = profile.table_nodes(x_min, x_max, dx)
    h = np.diff(x)
    assert x[0] <= x_min and x[-1] >= x_max and x[1] - x[0] <= dx
    np.testing.assert_allclose(h, h[0], rtol=1e-9)
    assert (x[-1] - x[0] > profile.period) == allow_roundoff  # the long grid wraps
    pick = np.random.default_rng(0).choice(x.size, 1500, replace=False)
    wrap = np.searchsorted(x, profile.period)
    pick = np.unique(np.concatenate([pick, [0, 1, x.size - 2, x.size - 1], np.arange(wrap - 2, wrap + 2)]))
    pick = pick[(pick >= 0) & (pick < x.size)]
    reference = _direct_sum_extended(profile, x[pick])
    tol = 1e-12
    if allow_roundoff:
        tol += 2.0 * np.finfo(float).eps * profile.frequencies[-1] * np.abs(x).max()
    for got, ref in zip(values, reference, strict=True):
        rms = math.sqrt(np.mean(got**2))
        assert np.abs(got[pick] - ref).max() <= tol * rms


def test_table_setup_never_evaluates_the_direct_sum(monkeypatch) -> None:
    """The run path (``tabulate``) is O(K log K + M): it must not fall back to the O(N M) sum."""
    profile = SpectralIrregularity(GermanSpectrum("low"), seed=1, length=300.0)

    def forbidden(self, x):  # noqa: ANN001, ANN202
        raise AssertionError("tabulate evaluated the direct sum")

    monkeypatch.setattr(SpectralIrregularity, "evaluate_unramped", forbidden)
    table = profile.tabulate(-30.0, 300.0)
    assert table.x_min <= -30.0 and table.x_max >= 300.0


def test_table_error_at_solver_spacing() -> None:
    """The quintic table at λ_min/50 against the exact sum between the nodes (docs/excitations.md:
    at most 7e-13, 5.7e-10 and 1.7e-7 of the RMS measured for r, r', r'')."""
    profile = SpectralIrregularity(GermanSpectrum("high"), seed=3, length=400.0)
    table = profile.tabulate(-30.0, 400.0)
    x = np.random.default_rng(1).uniform(0.0, 400.0, 3000)
    got = table.spline(x), table.spline(x, 1), table.spline(x, 2)  # unramped
    for g, ref, tol in zip(got, _direct_sum_extended(profile, x), (1e-12, 1e-9, 3e-7), strict=True):
        assert np.abs(g - ref).max() <= tol * math.sqrt(np.mean(ref**2))


def test_tabulated_profile_keeps_the_onset_ramp() -> None:
    """The table is ramped like the exact profile: zero up to the start, the same C2 onset after."""
    ramp = OnsetRamp(start=-30.0, length=20.0)
    profile = SpectralIrregularity(GermanSpectrum("high"), seed=6, length=300.0, ramp=ramp)
    table = profile.tabulate(-30.0, 280.0)
    assert table.ramp == ramp
    before = np.linspace(-200.0, -30.0, 40)
    for v in table.evaluate(before):
        assert np.all(v == 0.0)
    x = np.linspace(-30.0, 0.0, 301)  # the ramp and just after it
    base = horner(table.spline, x)  # what the loops evaluate: Horner on the table's pieces
    for got, ref in zip(table.evaluate(x), ramp.apply(x, base), strict=True):
        np.testing.assert_array_equal(got, ref)
    for got, ref in zip(table.evaluate(x), profile.evaluate(x), strict=True):
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-6 * np.abs(ref).max())


def test_quintic_hermite_reproduces_quintics_and_matches_scipy() -> None:
    """A quintic is its own Hermite interpolant (any breaks); on other data the pieces equal
    ``scipy.interpolate.BPoly.from_derivatives`` of the same value, slope and curvature."""
    rng = np.random.default_rng(4)
    x = np.cumsum(rng.uniform(0.05, 0.3, 40)) - 2.0
    poly = np.polynomial.Polynomial(rng.normal(size=6))
    pp = quintic_hermite(x, poly(x), poly.deriv(1)(x), poly.deriv(2)(x))
    xe = np.linspace(x[0], x[-1], 997)
    for nu in range(3):
        np.testing.assert_allclose(pp(xe, nu), poly.deriv(nu)(xe), rtol=1e-10, atol=1e-10)
    f, f1, f2 = rng.normal(size=(3, x.size))
    ref = BPoly.from_derivatives(x, np.stack([f, f1, f2], axis=1))
    pp = quintic_hermite(x, f, f1, f2)
    for nu in range(3):
        np.testing.assert_allclose(pp(xe, nu), ref(xe, nu), rtol=0, atol=1e-9 * np.abs(ref(xe, nu)).max())


def test_measured_profile_interpolates_with_c2_spline(tmp_path) -> None:
    k = 2 * math.pi / 7.0
    xs = np.arange(0.0, 100.0 + 1e-9, 0.25)
    path = tmp_path / "profile.txt"
    path.write_text("# x r\n" + "\n".join(f"{x:.4f} {1e-3 * math.sin(k * x):.12e}" for x in xs) + "\n")
    profile = SampledIrregularity.from_file(path, OnsetRamp(start=0.0, length=0.0))
    x = np.linspace(5.0, 95.0, 333)
    r, dr, ddr = profile.evaluate(x)
    np.testing.assert_allclose(r, 1e-3 * np.sin(k * x), atol=1e-3 * 1e-4)
    np.testing.assert_allclose(dr, 1e-3 * k * np.cos(k * x), atol=1e-3 * k * 1e-3)
    np.testing.assert_allclose(ddr, -1e-3 * k**2 * np.sin(k * x), atol=1e-3 * k**2 * 1e-2)
    with pytest.raises(ValueError, match="outside the profile's range"):
        profile.evaluate(np.array([50.0, 120.0]))


@pytest.mark.parametrize(
    ("body", "line", "what"),
    [
        ("0 0\n1 1e-3\n1 2e-3\n3 0\n4 0\n", 3, "does not increase"),
        ("0 0\n1 1e-3\n2 nan\n3 0\n4 0\n", 3, "non-finite"),
        ("0 0\n1 1e-3\n2 abc\n3 0\n4 0\n", 3, "not a number"),
        ("0 0\n1 1e-3 5\n2 0\n3 0\n", 2, "two columns"),
    ],
)
def test_measured_profile_errors_name_file_and_line(tmp_path, body: str, line: int, what: str) -> None:
    path = tmp_path / "bad_profile.txt"
    path.write_text(body)
    with pytest.raises(ValueError) as err:
        SampledIrregularity.from_file(path)
    message = str(err.value)
    assert str(path) in message and f"line {line}" in message and what in message


def test_factory_kinds(tmp_path) -> None:
    none = make_irregularity("none", length=100.0)
    assert isinstance(none, NoIrregularity)
    assert all(np.all(v == 0) for v in none.evaluate(np.linspace(0, 1, 5)))
    high = make_irregularity("german-high", seed=3, length=100.0, start=2.0)
    assert isinstance(high, SpectralIrregularity) and high.spectrum.level == "high"
    assert high.ramp.start == 2.0
    with pytest.raises(ValueError, match="german-low"):
        make_irregularity("german-medium", length=100.0)


def test_fast_length_is_scipy_next_fast_len() -> None:
    """The table's FFT length (irregularity.fast_length: factors 2, 3, 5, 7, 11) is SciPy's
    next_fast_len for complex data, so the table has the nodes it had with scipy.fft."""
    import scipy.fft

    from svbi.runtime.excitation.irregularity import fast_length

    targets = [*range(1, 3000), *np.random.default_rng(4).integers(3000, 10**7, 300).tolist()]
    assert [fast_length(int(n)) for n in targets] == [scipy.fft.next_fast_len(int(n)) for n in targets]
    with pytest.raises(ValueError, match="positive"):
        fast_length(0)

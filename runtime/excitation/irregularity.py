"""Vertical track irregularity r(x) and its x-derivatives (paper Eqs. 16, 20: r_c, r_c', r_c'').

Two sources, both behind the same ``evaluate(x) -> (r, dr, ddr)``:

* :class:`SpectralIrregularity` — a sample of the German high-speed spectra (low and high
  interference) by the spectral representation (sum of cosines with random phases). Values and
  derivatives are the exact analytic sums, at any x.
* :class:`SampledIrregularity` — a profile given at points (a measured profile read from a
  two-column file, or a tabulated spectral sample), interpolated by a C2 spline.

Every profile is multiplied by a C2 :class:`OnsetRamp`, so that r = r' = r'' = 0 where the train
stands at t = 0 (the static start of docs/design.md section 3).

Convention (pinned by ``tests/excitation/test_irregularity.py``): ``S(Ω)`` is one-sided in the spatial
angular frequency Ω (rad/m), so that the variance of the profile is ``σ² = ∫ S(Ω) dΩ`` over the
band ``[2π/λ_max, 2π/λ_min]``. The sample is

    r(x) = Σ_k A_k cos(Ω_k x + φ_k),   A_k = sqrt(2 ∫_{bin k} S(Ω) dΩ),

with N bins of equal width ΔΩ over the band, Ω_k the bin centres and φ_k uniform on [0, 2π).
Each bin's power is the exact integral of S over the bin (closed form), so Σ A_k²/2 = ∫ S dΩ over
the band exactly, and the RMS of a long sample converges to sqrt(∫ S dΩ).
"""

from __future__ import annotations

import functools
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...codegen.input_files import MAX_DATA_BYTES, InputFileError, TextFileError, decode_text, read_bytes
from .piecewise import Pieces, PiecewisePolynomial, horner

Level = Literal["low", "high"]
Component = Literal["vertical", "alignment", "cross-level"]
Triple = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]

OMEGA_C = 0.8246
"""German spectra cut-off frequency Ω_c (rad/m)."""
OMEGA_R = 0.0206
"""German spectra frequency Ω_r (rad/m)."""
GERMAN_A = {
    ("low", "vertical"): 4.032e-7,
    ("high", "vertical"): 1.080e-6,
    ("low", "alignment"): 2.119e-7,
    ("high", "alignment"): 6.125e-7,
    ("low", "cross-level"): 4.032e-7,
    ("high", "cross-level"): 1.080e-6,
}
"""Roughness coefficients A_v (vertical profile and cross-level) and A_a (alignment), m² rad/m.

Low interference is "very good" track. Source: the German high-speed track spectra
(docs/excitations.md). Alignment and cross-level are for 3D models; the 2D models use "vertical".
"""
OMEGA_S = 0.4380
"""Third corner frequency Ω_s of the German cross-level spectrum (rad/m)."""
CROSS_LEVEL_HALF_GAUGE = 0.75
"""Half the distance b between the rails' contact points in the cross-level spectrum (m)."""
_PHASE_STREAM = {"vertical": None, "alignment": 1, "cross-level": 2}
"""Seed stream of each component: the vertical profile draws from ``default_rng(seed)`` (as it
always has), the lateral ones from ``default_rng((seed, stream))``, independent of it."""

_CHUNK = 1 << 22  # elements of the (points x frequencies) work array evaluated at once (32 MiB)


@dataclass(frozen=True)
class GermanSpectrum:
    """German high-speed spectrum ``S(Ω) = A Ω_c² / ((Ω² + Ω_r²)(Ω² + Ω_c²))`` (one-sided, m³/rad)
    of the vertical profile and the alignment (m); of the cross-level (an angle, rad: the height
    difference of the rails over their distance ``2b``)
    ``S(Ω) = (A_v / b²) Ω_c² Ω² / ((Ω² + Ω_r²)(Ω² + Ω_c²)(Ω² + Ω_s²))`` (rad²/(rad/m))."""

    level: Level = "low"
    component: Component = "vertical"

    def __post_init__(self) -> None:
        if (self.level, self.component) not in GERMAN_A:
            raise ValueError(
                f"unknown German spectrum level={self.level!r}, component={self.component!r}: "
                "level is 'low' or 'high', component 'vertical', 'alignment' or 'cross-level'"
            )

    @property
    def coefficient(self) -> float:
        """The roughness coefficient A (m² rad/m)."""
        return GERMAN_A[(self.level, self.component)]

    def density(self, omega: ArrayLike) -> NDArray[np.float64]:
        """S(Ω) at spatial angular frequency Ω (rad/m)."""
        w2 = np.asarray(omega, dtype=float) ** 2
        if self.component == "cross-level":
            scale = self.coefficient * OMEGA_C**2 / CROSS_LEVEL_HALF_GAUGE**2
            return scale * w2 / ((w2 + OMEGA_R**2) * (w2 + OMEGA_C**2) * (w2 + OMEGA_S**2))
        return self.coefficient * OMEGA_C**2 / ((w2 + OMEGA_R**2) * (w2 + OMEGA_C**2))

    def cumulative(self, omega: ArrayLike) -> NDArray[np.float64]:
        """∫_0^Ω S dΩ in closed form (partial fractions), so bin powers are exact."""
        w = np.asarray(omega, dtype=float)
        if self.component == "cross-level":
            # Ω²/Π(Ω² + p_i²) = Σ K_i / (Ω² + p_i²), K_i = -p_i² / Π_{j≠i}(p_j² - p_i²)
            poles = (OMEGA_R, OMEGA_C, OMEGA_S)
            total = np.zeros_like(w)
            for i, p in enumerate(poles):
                others = [q for j, q in enumerate(poles) if j != i]
                k = -(p**2) / ((others[0] ** 2 - p**2) * (others[1] ** 2 - p**2))
                total = total + k * np.arctan(w / p) / p
            return self.coefficient * OMEGA_C**2 / CROSS_LEVEL_HALF_GAUGE**2 * total
        factor = self.coefficient * OMEGA_C**2 / (OMEGA_C**2 - OMEGA_R**2)
        return factor * (np.arctan(w / OMEGA_R) / OMEGA_R - np.arctan(w / OMEGA_C) / OMEGA_C)

    def variance(self, omega_min: float, omega_max: float) -> float:
        """σ² = ∫ S dΩ over [omega_min, omega_max] (m²)."""
        return float(self.cumulative(omega_max) - self.cumulative(omega_min))


@dataclass(frozen=True)
class OnsetRamp:
    """C2 onset: the profile is multiplied by h(s), s = (x - start)/length clipped to [0, 1].

    h(s) = 10 s³ - 15 s⁴ + 6 s⁵ (the quintic smoothstep) has h = h' = h'' = 0 at s = 0 and
    h = 1, h' = h'' = 0 at s = 1, so the ramped profile and its first two x-derivatives are
    continuous and vanish for x <= start. ``length = 0`` disables the ramp (a step at ``start``).
    """

    start: float = 0.0
    length: float = 20.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.start) and math.isfinite(self.length)) or self.length < 0.0:
            raise ValueError(
                f"onset ramp: start={self.start} and length={self.length} must be finite, length >= 0"
            )

    def weights(self, x: NDArray[np.float64]) -> Triple:
        """h, dh/dx, d²h/dx² at x."""
        if self.length == 0.0:
            h = (x >= self.start).astype(float)
            return h, np.zeros_like(x), np.zeros_like(x)
        s = np.clip((x - self.start) / self.length, 0.0, 1.0)
        h = s**3 * (10.0 - 15.0 * s + 6.0 * s**2)
        dh = 30.0 * s**2 * (1.0 - s) ** 2 / self.length
        ddh = 60.0 * s * (1.0 - s) * (1.0 - 2.0 * s) / self.length**2
        return h, dh, ddh

    def apply(self, x: NDArray[np.float64], r: Triple) -> Triple:
        """Product rule: (h r), (h r)', (h r)''."""
        h, dh, ddh = self.weights(x)
        r0, r1, r2 = r
        return h * r0, dh * r0 + h * r1, ddh * r0 + 2.0 * dh * r1 + h * r2


class Irregularity(Protocol):
    """Anything the runtime can ask for r, r', r'' along the track."""

    def evaluate(self, x: ArrayLike) -> Triple:
        """r, dr/dx, d²r/dx² (m, -, 1/m) at positions x (any shape; outputs have that shape)."""
        ...


class NoIrregularity:
    """Perfect track: r ≡ 0."""

    def evaluate(self, x: ArrayLike) -> Triple:
        """Zeros shaped like x."""
        xa = np.asarray(x, dtype=float)
        return np.zeros_like(xa), np.zeros_like(xa), np.zeros_like(xa)


def fast_length(target: int) -> int:
    """The smallest length >= ``target`` whose prime factors are all at most 11: the lengths that
    pocketfft (NumPy's and SciPy's FFT) transforms fastest, as ``scipy.fft.next_fast_len(target)``
    for complex data (tests check it)."""
    if target < 1:
        raise ValueError(f"FFT length must be positive (got {target})")
    n = target
    while True:
        m = n
        for p in (2, 3, 5, 7, 11):
            while m % p == 0:
                m //= p
        if m == 1:
            return n
        n += 1


def required_frequencies(band: float, length: float) -> int:
    """Smallest N whose sample period 2π/ΔΩ = 2π N / band is at least ``length``."""
    return max(1, math.ceil(band * length / (2.0 * math.pi) - 1e-9))


@dataclass(frozen=True, eq=False)
class SpectralIrregularity:
    """A seeded sample of a German spectrum, with exact analytic r, r', r''.

    Parameters
    ----------
    spectrum:
        The target spectrum (level and component).
    seed:
        Seed of ``numpy.random.default_rng``; the phases are its first N uniform draws on [0, 2π).
        The vertical profile draws from ``default_rng(seed)``; the alignment and the cross-level
        from ``default_rng((seed, 1))`` and ``default_rng((seed, 2))``, so that the three components
        of one seed are independent.
    length:
        Track length (m) over which the profile is used, counted from ``ramp.start``. The sample
        repeats its statistics after 2π/ΔΩ; that period must exceed ``length``.
    wavelength_min, wavelength_max:
        The band, in m (default 0.5 to 80 m, as docs/scenario.md).
    n_frequencies:
        Number of frequencies N. ``None`` (default) chooses it: the smallest power of two, at least
        1024, whose period covers ``length``. Powers of two keep the profile of a given seed the
        same for all lengths that fall in the same bracket. Given explicitly, it is a cap, and a
        period shorter than ``length`` is an error.
    ramp:
        The C2 onset (default: 20 m starting at x = 0).
    """

    spectrum: GermanSpectrum
    seed: int
    length: float
    wavelength_min: float = 0.5
    wavelength_max: float = 80.0
    n_frequencies: int | None = None
    ramp: OnsetRamp = field(default_factory=OnsetRamp)
    frequencies: NDArray[np.float64] = field(init=False, repr=False)
    amplitudes: NDArray[np.float64] = field(init=False, repr=False)
    phases: NDArray[np.float64] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        lo, hi = self.wavelength_min, self.wavelength_max
        if not (math.isfinite(lo) and math.isfinite(hi)) or lo <= 0.0:
            raise ValueError(f"track wavelengths must be finite and positive (got {lo}, {hi})")
        if lo >= hi:
            raise ValueError(
                f"track.wavelength_min = {lo} m must be smaller than track.wavelength_max = {hi} m"
            )
        if not (math.isfinite(self.length) and self.length > 0.0):
            raise ValueError(f"irregularity length must be positive (got {self.length} m)")
        omega_min, omega_max = 2.0 * math.pi / hi, 2.0 * math.pi / lo
        band = omega_max - omega_min
        needed = required_frequencies(band, self.length)
        if self.n_frequencies is None:
            n = max(1024, 1 << (needed - 1).bit_length())
        else:
            n = int(self.n_frequencies)
            if n < 1:
                raise ValueError(f"n_frequencies must be positive (got {self.n_frequencies})")
            if n < needed:
                period = 2.0 * math.pi * n / band
                raise ValueError(
                    f"n_frequencies = {n} gives an irregularity sample period 2π/ΔΩ = {period:.1f} m, "
                    f"shorter than the simulated track length {self.length:.1f} m, so the profile "
                    f"would repeat; use n_frequencies >= {needed} or leave it unset"
                )
        edges = np.linspace(omega_min, omega_max, n + 1)
        power = np.diff(self.spectrum.cumulative(edges))
        stream = _PHASE_STREAM[self.spectrum.component]
        rng = np.random.default_rng(self.seed if stream is None else (self.seed, stream))
        phases = rng.uniform(0.0, 2.0 * math.pi, n)
        object.__setattr__(self, "frequencies", 0.5 * (edges[:-1] + edges[1:]))
        object.__setattr__(self, "amplitudes", np.sqrt(2.0 * power))
        object.__setattr__(self, "phases", phases)

    @property
    def period(self) -> float:
        """2π/ΔΩ (m): the sample repeats its statistics after this distance."""
        band = 2.0 * math.pi / self.wavelength_min - 2.0 * math.pi / self.wavelength_max
        return 2.0 * math.pi * self.frequencies.size / band

    @property
    def variance(self) -> float:
        """Target σ² = ∫ S dΩ over the band (m²); equals Σ A_k²/2 of the sample."""
        return self.spectrum.variance(
            2.0 * math.pi / self.wavelength_max, 2.0 * math.pi / self.wavelength_min
        )

    def evaluate_unramped(self, x: ArrayLike) -> Triple:
        """The stationary sample r, r', r'' without the onset ramp."""
        xa = np.asarray(x, dtype=float)
        flat = xa.reshape(-1)
        out = np.empty((3, flat.size))
        w = self.frequencies
        # r + i r_H = Σ c_k e^{iΩ_k x}, c_k = A_k e^{iφ_k}; derivatives multiply c_k by (iΩ_k)^j.
        c = self.amplitudes * np.exp(1j * self.phases)
        coef = np.stack([c, 1j * w * c, -(w**2) * c], axis=1)
        # The grid is uniform, Ω_k = Ω_0 + kΔΩ. Write k = jL + l: e^{iΩ_k x} = e^{i(Ω_0 + lΔΩ)x}
        # e^{ijLΔΩ x}, so each point needs L + J complex exponentials instead of N cosines and
        # sines, and the sums become one matrix product (BLAS) and one small contraction.
        n = w.size
        dw = w[1] - w[0] if n > 1 else 0.0
        n_low = 1 << max(0, math.ceil(math.log2(n) / 2))
        n_high = -(-n // n_low)
        padded = np.zeros((n_high * n_low, 3), dtype=complex)
        padded[:n] = coef
        blocks = padded.reshape(n_high, n_low, 3).transpose(1, 0, 2).reshape(n_low, n_high * 3)
        w_low = w[0] + dw * np.arange(n_low)
        w_high = dw * n_low * np.arange(n_high)
        step = max(1, _CHUNK // (n_high * 3))
        for i in range(0, flat.size, step):
            xs = flat[i : i + step]
            low = np.exp(1j * np.multiply.outer(xs, w_low))
            high = np.exp(1j * np.multiply.outer(xs, w_high))
            partial = (low @ blocks).reshape(xs.size, n_high, 3)
            out[:, i : i + step] = np.einsum("mj,mjk->km", high, partial).real
        return out[0].reshape(xa.shape), out[1].reshape(xa.shape), out[2].reshape(xa.shape)

    def evaluate(self, x: ArrayLike) -> Triple:
        """r, r', r'' (m, -, 1/m) at x (any shape), ramped."""
        xa = np.asarray(x, dtype=float)
        return self.ramp.apply(xa, self.evaluate_unramped(xa))

    def table_nodes(self, x_min: float, x_max: float, dx: float) -> tuple[NDArray[np.float64], Triple]:
        """The exact r, r', r'' (unramped) on a uniform grid that covers [x_min, x_max], spacing <= dx.

        The frequencies are evenly spaced, Ω_k = Ω_0 + kΔΩ, so ``r + i r_H = e^{iΩ_0 x} S(x)`` with
        ``S(x) = Σ_k c_k e^{ikΔΩ x}`` (c_k = A_k e^{iφ_k}), periodic with period P = 2π/ΔΩ. On the
        grid x_j = j h, h = P/K with an integer K >= N, ``S(x_j) = Σ_k c_k e^{2πi jk/K}`` is an
        inverse FFT of length K (read at j mod K), and r' and r'' are the same transforms of
        iΩ_k c_k and -Ω_k² c_k: the exact sums, to round-off, in O(K log K + M) operations for M
        nodes instead of the direct sum's O(N M). K is the smallest FFT-friendly length
        (:func:`fast_length`) with h <= dx; the grid runs from the last node at or before x_min to
        the first at or after x_max, at least 6 nodes. The transform is NumPy's (pocketfft, the
        same bits as ``scipy.fft`` here): importing ``scipy.fft`` costs 0.03 s of a fresh run, with
        ``scipy.special``.
        """
        if not (math.isfinite(x_min) and math.isfinite(x_max) and x_max > x_min and dx > 0.0):
            raise ValueError(
                f"irregularity table: need finite x_min < x_max and dx > 0 (got {x_min}, {x_max}, {dx})"
            )
        n = self.frequencies.size
        omega_min, omega_max = 2.0 * math.pi / self.wavelength_max, 2.0 * math.pi / self.wavelength_min
        period = 2.0 * math.pi * n / (omega_max - omega_min)  # 2π/ΔΩ, ΔΩ the bin width of the edges
        k = fast_length(max(n, math.ceil(period / dx - 1e-9)))
        h = period / k
        j0 = math.floor(x_min / h)
        j = np.arange(j0, max(math.ceil(x_max / h), j0 + 5) + 1)
        x = j * h
        w = self.frequencies
        c = self.amplitudes * np.exp(1j * self.phases)
        spectrum = np.zeros((3, k), dtype=complex)
        spectrum[0, :n] = c
        spectrum[1, :n] = 1j * w * c
        spectrum[2, :n] = -(w**2) * c
        # Σ_k coef_k e^{2πi jk/K}, unscaled
        periodic = np.fft.ifft(spectrum, axis=1, norm="forward")
        del spectrum
        # Re(e^{iΩ_0 x_j} S_j), one carrier per node, read period by period (no gather)
        cos, sin = np.cos(w[0] * x), np.sin(w[0] * x)
        r, dr, ddr = np.empty((3, j.size))
        start, done = j0 % k, 0
        while done < j.size:
            count = min(k - start, j.size - done)
            nodes = slice(done, done + count)
            for out, row in zip((r, dr, ddr), periodic, strict=True):
                part = row[start : start + count]
                np.multiply(cos[nodes], part.real, out=out[nodes])
                out[nodes] -= sin[nodes] * part.imag
            start, done = 0, done + count
        return x, (r, dr, ddr)

    def tabulate(self, x_min: float, x_max: float, dx: float | None = None) -> SampledIrregularity:
        """The same profile as a quintic piecewise polynomial on a uniform grid (the solver's table).

        The exact r, r', r'' at the nodes come from :meth:`table_nodes` (FFTs, spacing at or below
        ``dx``); between nodes the table is the quintic Hermite interpolant of the three
        (:func:`quintic_hermite`: C2, exact r, r', r'' at every node, local, O(M)), stored as a
        ``scipy.interpolate.PPoly`` (breaks = the grid, coefficients in powers of ``x - x_i``): what
        the C loop evaluates. With the default ``dx = λ_min / 50`` the table differs from the exact
        sum by at most about 5e-13 (r), 5.5e-10 (r') and 1.4e-7 (r'') of their RMS
        (``docs/excitations.md``).
        """
        if dx is None:
            dx = self.wavelength_min / 50.0
        grid, (r, dr, ddr) = self.table_nodes(x_min, x_max, dx)
        return SampledIrregularity(
            x_min=float(grid[0]),
            x_max=float(grid[-1]),
            spline=quintic_hermite(grid, r, dr, ddr),
            ramp=self.ramp,
            source=f"tabulated {self.spectrum.level} {self.spectrum.component} seed={self.seed}",
        )


def quintic_hermite(
    x: NDArray[np.float64], f: NDArray[np.float64], f1: NDArray[np.float64], f2: NDArray[np.float64]
) -> PiecewisePolynomial:
    """The piecewise quintic with value f, slope f1 and curvature f2 at every break x (C2).

    ``scipy.interpolate.BPoly.from_derivatives`` builds the same polynomial but loops over the
    intervals in Python (minutes for the millions of nodes of a long viaduct); here each piece is
    written directly in powers of ``s = x - x_i``, ``h = x_{i+1} - x_i``: the first three
    coefficients are f, f1, f2/2 at x_i, and the last three match the misfits at x_{i+1} of that
    quadratic Taylor polynomial, ``a = Δf``, ``b = Δf1``, ``c = Δf2``:
    ``c3 = (20a - 8bh + ch²)/(2h³)``, ``c4 = (-30a + 14bh - 2ch²)/(2h⁴)``,
    ``c5 = (12a - 6bh + ch²)/(2h⁵)``.
    """
    h = np.diff(x)
    f0, g0, k0 = f[:-1], f1[:-1], f2[:-1]
    a = f[1:] - (f0 + h * (g0 + 0.5 * h * k0))
    b = (f1[1:] - (g0 + h * k0)) * h
    c = (f2[1:] - k0) * h * h
    coef = np.empty((6, h.size))
    coef[0] = 0.5 * (12.0 * a - 6.0 * b + c) / h**5
    coef[1] = 0.5 * (-30.0 * a + 14.0 * b - 2.0 * c) / h**4
    coef[2] = 0.5 * (20.0 * a - 8.0 * b + c) / h**3
    coef[3] = 0.5 * k0
    coef[4] = g0
    coef[5] = f0
    return PiecewisePolynomial(np.ascontiguousarray(x, dtype=float), coef)


@dataclass(frozen=True, eq=False)
class SampledIrregularity:
    """A profile known on [x_min, x_max] through a C2 spline (values, first and second derivative).

    Measured profiles (:meth:`from_file`) use ``scipy.interpolate.CubicSpline`` with not-a-knot
    ends: C2, exact at the measured points. Outside [x_min, x_max] the profile is undefined and
    asking for it is an error, except where the onset ramp makes it zero (x <= ramp.start).
    """

    x_min: float
    x_max: float
    spline: Pieces  # the quintic table or a scipy CubicSpline
    ramp: OnsetRamp = field(default_factory=OnsetRamp)
    source: str = "profile"

    def evaluate(self, x: ArrayLike) -> Triple:
        """r, r', r'' at x (any shape), ramped."""
        xa = np.asarray(x, dtype=float)
        active = xa > self.ramp.start
        outside = active & ((xa < self.x_min) | (xa > self.x_max))
        if np.any(outside):
            bad = xa[outside]
            raise ValueError(
                f"{self.source}: irregularity asked at x = {bad.min():.3f}..{bad.max():.3f} m, "
                f"outside the profile's range [{self.x_min:.3f}, {self.x_max:.3f}] m"
            )
        xc = np.clip(xa, self.x_min, self.x_max)
        base = horner(self.spline, xc)
        base = tuple(np.where(active, b, 0.0) for b in base)
        return self.ramp.apply(xa, base)  # type: ignore[arg-type]

    @classmethod
    def from_file(cls, path: str | Path, ramp: OnsetRamp | None = None) -> SampledIrregularity:
        """Read a measured profile: two columns ``x r`` in m, strictly increasing x.

        Blank lines and lines starting with ``#`` are skipped; commas are accepted as separators.
        Errors name the file and the line.
        """
        from scipy.interpolate import CubicSpline

        xs, rs = read_profile(path)
        spline = CubicSpline(xs, rs, bc_type="not-a-knot")
        return cls(
            x_min=float(xs[0]),
            x_max=float(xs[-1]),
            spline=spline,
            ramp=ramp if ramp is not None else OnsetRamp(),
            source=str(path),
        )


def read_profile(path: str | Path) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Two-column (x, r) profile file → arrays; validated (numbers, finite, x strictly increasing)."""
    xs, columns = _read_columns(path, three_d=False)
    return xs, columns[0]


PROFILE_COLUMNS = ("vertical", "alignment", "cross-level")
"""The optional columns of a 3D measured profile, after ``x``: ``x r [a [c]]``."""


def read_profile_3d(path: str | Path) -> dict[str, NDArray[np.float64]]:
    """A measured profile with optional lateral columns: ``x r``, ``x r a`` or ``x r a c``.

    ``r`` is the vertical profile (m), ``a`` the alignment (m, positive left), ``c`` the cross-level
    (rad, positive with the left rail up: the rails' height difference over their distance). Every
    data line has the number of columns of the first. Returns ``{"x": ..., "vertical": ...,
    "alignment": ..., "cross-level": ...}`` with the columns the file has; the same checks and
    errors (file and line) as :func:`read_profile`.
    """
    xs, columns = _read_columns(path, three_d=True)
    out = {"x": xs}
    out.update(zip(PROFILE_COLUMNS, columns, strict=False))
    return out


def measured_profile_3d(path: str | Path) -> dict[str, SampledIrregularity]:
    """:func:`measured_profile` of each column of a :func:`read_profile_3d` file, by component."""
    from scipy.interpolate import CubicSpline

    table = read_profile_3d(path)
    xs = table["x"]
    return {
        name: SampledIrregularity(
            x_min=float(xs[0]),
            x_max=float(xs[-1]),
            spline=CubicSpline(xs, table[name], bc_type="not-a-knot"),
            ramp=OnsetRamp(start=float(xs[0]) - 1.0, length=0.0),
            source=f"{path} ({name})",
        )
        for name in PROFILE_COLUMNS
        if name in table
    }


def _read_columns(path: str | Path, three_d: bool) -> tuple[NDArray[np.float64], list[NDArray[np.float64]]]:
    """x and the value columns of a profile file (2 columns, or 2 to 4 when ``three_d``)."""
    p = Path(path)
    try:  # a regular file of bounded size (never /dev/zero, a FIFO or a folder), UTF-8
        text = decode_text(read_bytes(p, MAX_DATA_BYTES), str(p))
    except TextFileError as exc:  # file:line of the first bad byte
        raise ValueError(str(exc)) from None
    except InputFileError as exc:
        raise ValueError(f"{p}: cannot read irregularity profile: {exc.problem}") from None
    xs: list[float] = []
    rows: list[list[float]] = []
    prev_line = 0
    width = 0
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].replace(",", " ").strip()
        if not line:
            continue
        parts = line.split()
        if not three_d and len(parts) != 2:
            raise ValueError(f"{p}: line {lineno}: expected two columns 'x r', got {len(parts)}")
        if three_d and not width and not 2 <= len(parts) <= 4:
            raise ValueError(
                f"{p}: line {lineno}: expected 2 to 4 columns 'x r [alignment [cross-level]]', "
                f"got {len(parts)}"
            )
        if three_d and width and len(parts) != width:
            raise ValueError(
                f"{p}: line {lineno}: expected {width} columns like the first data line, got {len(parts)}"
            )
        width = len(parts)
        try:
            values = [float(part) for part in parts]
        except ValueError:
            raise ValueError(f"{p}: line {lineno}: not a number: {raw.strip()!r}") from None
        if not all(math.isfinite(value) for value in values):
            raise ValueError(f"{p}: line {lineno}: non-finite value (NaN or inf): {raw.strip()!r}")
        xv = values[0]
        if xs and xv <= xs[-1]:
            raise ValueError(
                f"{p}: line {lineno}: x = {xv} does not increase (previous x = {xs[-1]} at line "
                f"{prev_line}); x must be strictly increasing"
            )
        xs.append(xv)
        rows.append(values[1:])
        prev_line = lineno
    if len(xs) < 4:
        raise ValueError(f"{p}: an irregularity profile needs at least 4 points (found {len(xs)})")
    table = np.array(rows)
    return np.array(xs), [table[:, j].copy() for j in range(table.shape[1])]


def read_profile_cached(path: str | Path) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`read_profile`, read once per file version (path, size, modification time): the
    scenario's checks and the model build both need it. The arrays are read-only."""
    p = Path(os.path.realpath(path))  # Path.resolve raises on a symbolic-link loop
    try:
        st = p.stat()
    except OSError as exc:
        raise ValueError(f"{p}: cannot read irregularity profile ({exc.strerror})") from exc
    xs, rs = _read_profile_version(str(p), st.st_size, st.st_mtime_ns)
    return xs, rs


@functools.lru_cache(maxsize=8)
def _read_profile_version(path: str, size: int, mtime_ns: int) -> tuple[NDArray[np.float64], ...]:
    del size, mtime_ns  # the cache key only: a changed file is read again
    xs, rs = read_profile(path)
    xs.flags.writeable = False
    rs.flags.writeable = False
    return xs, rs


def measured_profile(path: str | Path) -> SampledIrregularity:
    """A measured profile used as given: no onset ramp (docs/scenario.md, ``[track]``).

    The ramp's step is put 1 m before the first point, so h = 1 wherever the profile is defined;
    a wheel outside [x_min, x_max] is an error (the scenario checks the wheels' path beforehand).
    """
    from scipy.interpolate import CubicSpline

    xs, rs = read_profile_cached(path)
    return SampledIrregularity(
        x_min=float(xs[0]),
        x_max=float(xs[-1]),
        spline=CubicSpline(xs, rs, bc_type="not-a-knot"),
        ramp=OnsetRamp(start=float(xs[0]) - 1.0, length=0.0),
        source=str(path),
    )


IRREGULARITY_KINDS = ("none", "german-low", "german-high")


def make_irregularity(
    kind: str,
    *,
    seed: int = 1,
    length: float,
    wavelength_min: float = 0.5,
    wavelength_max: float = 80.0,
    start: float = 0.0,
    ramp_length: float = 20.0,
    n_frequencies: int | None = None,
) -> Irregularity:
    """Build the irregularity of a scenario's ``[track]`` table.

    ``kind`` is ``"none"``, ``"german-low"``, ``"german-high"`` or the path of a measured profile
    file. ``start`` is where the onset ramp begins: the leading axle's position at t = 0
    (``train.start_position``), so that every wheel stands on r = 0 at t = 0. ``length`` is the
    track length the train covers from ``start`` during the run (m).
    """
    ramp = OnsetRamp(start=start, length=ramp_length)
    if kind == "none":
        return NoIrregularity()
    if kind in ("german-low", "german-high"):
        level: Level = "low" if kind == "german-low" else "high"
        return SpectralIrregularity(
            GermanSpectrum(level, "vertical"),
            seed=seed,
            length=length,
            wavelength_min=wavelength_min,
            wavelength_max=wavelength_max,
            n_frequencies=n_frequencies,
            ramp=ramp,
        )
    path = Path(kind)
    if path.is_file():
        return SampledIrregularity.from_file(path, ramp)
    raise ValueError(
        f"track.irregularity = {kind!r}: expected one of {', '.join(IRREGULARITY_KINDS)} or the path "
        "of an existing profile file"
    )

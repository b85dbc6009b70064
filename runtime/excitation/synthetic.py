"""The built-in ``"synthetic"`` ground motion: seeded Clough-Penzien filtered white noise.

Model (Clough & Penzien, *Dynamics of Structures*, 1975/1993): Gaussian white noise passes through
the Kanai-Tajimi soil filter (ω_g, ζ_g) and the Clough-Penzien high-pass filter (ω_f, ζ_f), which
removes the Kanai-Tajimi model's unphysical power at zero frequency (it would give infinite ground
velocity and displacement). The ground-acceleration power spectral density is

    S(ω) = S0 · (ω_g⁴ + 4ζ_g²ω_g²ω²) / ((ω_g² - ω²)² + 4ζ_g²ω_g²ω²)
              · ω⁴ / ((ω_f² - ω²)² + 4ζ_f²ω_f²ω²).

The stationary process is made non-stationary by a Jennings-type envelope (Jennings, Housner &
Tsai 1968): e(t) = (t/t1)² for t < t1, 1 up to t2, exp(-c (t - t2)) after. The result is scaled to
the documented PGA and then goes through the same processing as a real record
(:func:`svbi.runtime.excitation.processing.process_record`) with that PGA as target.

Parameter sets (``HORIZONTAL``, ``VERTICAL``):

* horizontal: firm-soil Clough-Penzien values ω_g = 15 rad/s, ζ_g = 0.6, ω_f = 1.5 rad/s,
  ζ_f = 0.6 (Der Kiureghian & Neuenhofer 1992, EESD 21:713), PGA 0.35 g;
* vertical (assumed): the same shape with both filter frequencies 5/3 higher, ω_g = 25 rad/s,
  ω_f = 2.5 rad/s, since vertical motion is richer in high frequencies (the ratio of vertical to
  horizontal predominant frequency is about 1.5-2, e.g. Bozorgnia & Campbell 2004), PGA 2/3 of the
  horizontal (the EN 1998-1 / ASCE rule of thumb), 0.2333 g.

Both: t1 = 2 s, t2 = 10 s, c = 0.4 1/s, duration 20 s, dt = 0.005 s. The sample is reproducible:
the white noise comes from ``numpy.random.default_rng([seed, k])``, k = 0 for vertical, 1 for
horizontal (longitudinal) and 2 for lateral (the transverse component of 3D scenarios, the
horizontal parameter set), so the components of one seed are independent.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .processing import MotionHistory, Processing, process_record
from .records import G, Record

DEFAULT_SEED = 1
"""Seed of the synthetic record when the scenario gives none."""


@dataclass(frozen=True)
class StochasticModel:
    """Parameters of a Clough-Penzien ground motion with a Jennings envelope (SI units)."""

    omega_g: float
    """Kanai-Tajimi (soil) frequency, rad/s."""
    zeta_g: float
    """Kanai-Tajimi damping ratio."""
    omega_f: float
    """Clough-Penzien high-pass frequency, rad/s."""
    zeta_f: float
    """Clough-Penzien damping ratio."""
    pga: float
    """Peak ground acceleration of the processed record, m/s²."""
    t_rise: float = 2.0
    """Envelope: end of the quadratic rise t1, s."""
    t_strong: float = 10.0
    """Envelope: end of the strong phase t2, s."""
    decay: float = 0.4
    """Envelope: exponential decay rate c after t2, 1/s."""
    duration: float = 20.0
    """Record length, s."""
    dt: float = 0.005
    """Time step, s."""

    def psd_shape(self, omega: NDArray[np.float64]) -> NDArray[np.float64]:
        """S(ω)/S0: the squared magnitude of the Clough-Penzien filter."""
        w2 = np.asarray(omega, dtype=float) ** 2
        kt = (self.omega_g**4 + 4 * self.zeta_g**2 * self.omega_g**2 * w2) / (
            (self.omega_g**2 - w2) ** 2 + 4 * self.zeta_g**2 * self.omega_g**2 * w2
        )
        hp = w2**2 / ((self.omega_f**2 - w2) ** 2 + 4 * self.zeta_f**2 * self.omega_f**2 * w2)
        return kt * hp

    def envelope(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """Jennings-type envelope e(t)."""
        t = np.asarray(t, dtype=float)
        rise = (t / self.t_rise) ** 2
        decay = np.exp(-self.decay * (t - self.t_strong))
        return np.where(t < self.t_rise, rise, np.where(t <= self.t_strong, 1.0, decay))


HORIZONTAL = StochasticModel(omega_g=15.0, zeta_g=0.6, omega_f=1.5, zeta_f=0.6, pga=0.35 * G)
"""Horizontal (longitudinal) component: firm soil, PGA 0.35 g."""
VERTICAL = StochasticModel(omega_g=25.0, zeta_g=0.6, omega_f=2.5, zeta_f=0.6, pga=0.35 * G * 2.0 / 3.0)
"""Vertical component (assumed): frequencies 5/3 of the horizontal ones, PGA 2/3 of it."""

_COMPONENTS = {
    "vertical": (VERTICAL, 0),
    "horizontal": (HORIZONTAL, 1),
    "longitudinal": (HORIZONTAL, 1),
    "lateral": (HORIZONTAL, 2),
}


def _model(component: str) -> tuple[StochasticModel, int]:
    if component not in _COMPONENTS:
        raise ValueError(
            f"synthetic ground motion: unknown component {component!r} "
            "(expected 'vertical', 'horizontal', 'longitudinal' or 'lateral')"
        )
    return _COMPONENTS[component]


def synthetic_record(component: str = "vertical", seed: int = DEFAULT_SEED) -> Record:
    """The raw synthetic accelerogram of a component (enveloped filtered noise at the documented PGA).

    ``"longitudinal"`` and ``"lateral"`` are the horizontal parameter set, with independent noise.
    """
    model, key = _model(component)
    n = int(round(model.duration / model.dt)) + 1
    n_fft = 1 << (2 * n - 1).bit_length()
    rng = np.random.default_rng([seed, key])
    noise = rng.standard_normal(n_fft)
    omega = 2.0 * math.pi * np.fft.rfftfreq(n_fft, model.dt)
    s = 1j * omega
    kt = (model.omega_g**2 + 2 * model.zeta_g * model.omega_g * s) / (
        s**2 + 2 * model.zeta_g * model.omega_g * s + model.omega_g**2
    )
    hp = s**2 / (s**2 + 2 * model.zeta_f * model.omega_f * s + model.omega_f**2)
    # Circular filtering of circular white noise is exactly stationary: no start-up transient.
    stationary = np.fft.irfft(np.fft.rfft(noise) * kt * hp, n_fft)[:n]
    accel = stationary * model.envelope(np.arange(n) * model.dt)
    accel *= model.pga / np.max(np.abs(accel))
    return Record(
        name=f"synthetic-{component}",
        dt=model.dt,
        accel=accel,
        source=f"svbi synthetic Clough-Penzien ({component}, seed={seed})",
    )


def synthetic_motion(
    component: str = "vertical",
    seed: int = DEFAULT_SEED,
    *,
    scale: float = 1.0,
    arrival: float = 0.0,
    options: Processing | None = None,
) -> MotionHistory:
    """The processed synthetic motion; its PGA is ``scale`` times the documented one, exactly."""
    model, _ = _model(component)
    return process_record(
        synthetic_record(component, seed),
        scale=scale,
        target_pga=model.pga,
        arrival=arrival,
        options=options,
    )

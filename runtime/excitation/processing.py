"""Record processing: baseline correction, consistent integration, scaling and arrival time.

The support constraints (paper Eqs. 22-24) follow a ground displacement q(t) together with its
exact derivatives q' and q''. Integrating a raw accelerogram gives a drifting displacement, and
integrating it with a rule other than the one that defines q'' from q gives q, q', q'' that do not
agree. This module fixes both, in this order (all steps are linear in the record):

1. **Pre-event mean** (off by default): subtract the mean of the first ``pre_event`` seconds, the
   usual zero-offset correction of *unprocessed* records. The baseline polynomial of step 3
   removes a constant offset anyway, and PEER records are already filtered and baseline-corrected
   (their first samples are filter transients, not an offset), so the default is 0.
2. **Consistent integration**: the acceleration is taken as *linear between samples* (the usual
   reading of a digitised record). Its exact integrals are the trapezoid rule for the velocity and
   the linear-acceleration (Newmark β = 1/6) rule for the displacement:

       v[n+1] = v[n] + dt (a[n] + a[n+1]) / 2
       d[n+1] = d[n] + dt v[n] + dt² (a[n]/3 + a[n+1]/6)

   So the displacement is a C2 piecewise cubic (a cubic spline) whose first and second
   derivatives *are* the velocity and the piecewise-linear acceleration, at every t, not only at
   samples: q, q', q'' agree exactly. Every integration below uses this rule.
3. **Taper and baseline correction** in one linear step:

       a_c(t) = w(t) · (a(t) - P(t / T)),   P(τ) = Σ_{k=0..degree} c_k τ^k  (degree 3 by default),

   where w is a half-cosine (Hann) taper over the first ``taper_start`` (0.5 s) and the last
   ``taper_end`` (1 s) of the record, T its length. The taper makes a_c = 0 with zero slope at
   both ends (a C2 onset and end). The baseline polynomial sits *under* the same window, so a
   constant or slowly varying acceleration offset is removed exactly, tapered ends included. Its
   coefficients minimise the displacement of a_c (least squares over the record) subject to one
   exact constraint: the velocity of a_c is zero at the end. After the record ends the ground
   stays at its final displacement, at rest: no drift, and q' and q'' are continuous.
4. **Scaling**: the processed acceleration is multiplied by ``scale`` and, if ``target_pga`` is
   given, first brought to that PGA (max |a| over the samples).
5. **Arrival**: record time 0 is placed at simulation time ``arrival`` (>= 0); q ≡ 0 before. The
   taper makes the onset C2 (q = q' = q'' = 0 at the arrival), so a train that starts in static
   equilibrium at t = 0 stays consistent.

A high-pass filter (e.g. an acausal Butterworth with zero padding) is the alternative used by PEER
for its own processing; a low-order polynomial is used here because it can be made to end the
velocity at exactly zero and leaves the (already PEER-filtered) records' frequency content alone
(the PGA of the shared records changes by 0.11 % at most).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .piecewise import PiecewisePolynomial
from .records import Record

Triple = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]


@dataclass(frozen=True)
class Processing:
    """Options of :func:`process_record` (defaults documented in the module doc)."""

    pre_event: float = 0.0
    """Seconds at the start whose mean is removed (0: none, the default for processed records)."""
    taper_start: float = 0.5
    """Length of the start taper (s)."""
    taper_end: float = 1.0
    """Length of the end taper (s)."""
    degree: int = 3
    """Degree of the baseline polynomial P (>= 0)."""

    def __post_init__(self) -> None:
        for name in ("pre_event", "taper_start", "taper_end"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"processing.{name} must be >= 0 (got {value})")
        if self.degree < 0:
            raise ValueError(f"processing.degree must be >= 0 (got {self.degree})")


def integrate(accel: NDArray[np.float64], dt: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Velocity and displacement of a piecewise-linear acceleration, from rest (exact integrals)."""
    a = np.asarray(accel, dtype=float)
    v = np.zeros_like(a)
    d = np.zeros_like(a)
    v[1:] = np.cumsum(0.5 * dt * (a[:-1] + a[1:]))
    d[1:] = np.cumsum(dt * v[:-1] + dt**2 * (a[:-1] / 3.0 + a[1:] / 6.0))
    return v, d


def hann_taper(n: int, dt: float, start: float, end: float) -> NDArray[np.float64]:
    """Weights rising as a half cosine over ``start`` seconds and falling over ``end`` seconds."""
    w = np.ones(n)
    t = np.arange(n) * dt
    total = (n - 1) * dt
    if start > 0.0:
        m = t < start
        w[m] *= 0.5 * (1.0 - np.cos(np.pi * t[m] / start))
    if end > 0.0:
        m = t > total - end
        w[m] *= 0.5 * (1.0 - np.cos(np.pi * (total - t[m]) / end))
    return w


def taper_and_baseline(
    accel: NDArray[np.float64], dt: float, window: NDArray[np.float64], degree: int = 3
) -> NDArray[np.float64]:
    """``w (a - P)`` of step 3 of the module doc: velocity exactly 0 at the end, least displacement."""
    a = np.asarray(accel, dtype=float)
    n = a.size
    tau = np.arange(n) / (n - 1)
    basis_a = np.stack([window * tau**k for k in range(degree + 1)], axis=1)
    basis_v = np.empty_like(basis_a)
    basis_d = np.empty_like(basis_a)
    for j in range(degree + 1):
        basis_v[:, j], basis_d[:, j] = integrate(basis_a[:, j], dt)
    v, d = integrate(window * a, dt)
    # Equality-constrained least squares (KKT): min |D c - d|² subject to V[-1] c = v[-1].
    scale = np.linalg.norm(basis_d, axis=0)
    scale[scale == 0.0] = 1.0
    dn = basis_d / scale
    cn = basis_v[-1] / scale
    m = degree + 1
    kkt = np.zeros((m + 1, m + 1))
    kkt[:m, :m] = dn.T @ dn
    kkt[:m, m] = cn
    kkt[m, :m] = cn
    rhs = np.concatenate([dn.T @ d, [v[-1]]])
    coef = np.linalg.solve(kkt, rhs)[:m] / scale
    return window * a - basis_a @ coef


@dataclass(frozen=True, eq=False)
class MotionHistory:
    """A processed ground motion: q, q', q'' at any simulation time (vectorised).

    ``accel``, ``vel`` and ``disp`` are the processed samples at record times ``i * dt``; between
    samples q is the cubic of the consistent integration (module doc, step 3). Record time 0 is at
    simulation time ``arrival``.
    """

    name: str
    source: str
    dt: float
    accel: NDArray[np.float64]
    vel: NDArray[np.float64]
    disp: NDArray[np.float64]
    arrival: float = 0.0

    @property
    def duration(self) -> float:
        """Length of the record (s)."""
        return (self.accel.size - 1) * self.dt

    @property
    def end_time(self) -> float:
        """Simulation time at which the record ends (the ground is at rest afterwards)."""
        return self.arrival + self.duration

    @property
    def pga(self) -> float:
        """max |q''| over the samples (m/s²)."""
        return float(np.max(np.abs(self.accel)))

    @cached_property
    def _pieces(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Breaks and PPoly coefficients ``[jerk/6, accel/2, vel, disp]`` (4 x pieces)."""
        a0, a1 = self.accel[:-1], self.accel[1:]
        jerk = (a1 - a0) / self.dt
        c = np.stack([jerk / 6.0, a0 / 2.0, self.vel[:-1], self.disp[:-1]])
        return self.arrival + self.dt * np.arange(self.accel.size), c

    def table(self) -> tuple[PiecewisePolynomial, Triple]:
        """The displacement as a piecewise cubic in simulation time (what the C loop evaluates).

        Breaks ``arrival + i dt``; on piece i, ``q = disp_i + vel_i s + accel_i s²/2 + jerk_i s³/6``
        with ``s = t - (arrival + i dt)``, i.e. ``scipy.interpolate.PPoly`` coefficients
        ``[jerk/6, accel/2, vel, disp]``. Returns the table and the constant ``(q, q', q'')`` after
        the record (before it, all are 0).
        """
        x, c = self._pieces
        return PiecewisePolynomial(x, c), (float(self.disp[-1]), 0.0, 0.0)

    def evaluate(self, t: ArrayLike) -> Triple:
        """q, q', q'' (m, m/s, m/s²) at simulation times t (any shape).

        Evaluates :meth:`table` exactly as the C loop does: the piece with ``x_i <= t < x_{i+1}``,
        Horner in ``s = t - x_i`` for the value and the two derivatives; 0 for ``t <= arrival``, the
        final displacement at rest from the end of the record on.
        """
        ta = np.asarray(t, dtype=float)
        x, c = self._pieces
        n = c.shape[1]
        i = np.clip(np.floor((ta - x[0]) / self.dt), 0, n - 1).astype(np.intp)
        i = np.where((i > 0) & (ta < x[i]), i - 1, i)
        i = np.where((i < n - 1) & (ta >= x[np.minimum(i + 1, n)]), i + 1, i)
        s = ta - x[i]
        c0, c1, c2, c3 = c[0, i], c[1, i], c[2, i], c[3, i]
        q = ((c0 * s + c1) * s + c2) * s + c3
        qd = (3.0 * c0 * s + 2.0 * c1) * s + c2
        qdd = 6.0 * c0 * s + 2.0 * c1
        before = ta <= x[0]
        after = ta >= x[n]
        q = np.where(before, 0.0, np.where(after, self.disp[-1], q))
        qd = np.where(before | after, 0.0, qd)
        qdd = np.where(before | after, 0.0, qdd)
        return q, qd, qdd


def process_record(
    record: Record,
    *,
    scale: float = 1.0,
    target_pga: float | None = None,
    arrival: float = 0.0,
    options: Processing | None = None,
) -> MotionHistory:
    """Baseline-correct, integrate, scale and place a record in time (module doc, steps 1-5)."""
    opts = options if options is not None else Processing()
    if not (math.isfinite(arrival) and arrival >= 0.0):
        raise ValueError(
            f"{record.name}: earthquake.arrival = {arrival} s: must be >= 0; a negative arrival would "
            "start the run in the middle of the record, breaking the static start at t = 0"
        )
    if not math.isfinite(scale):
        raise ValueError(f"{record.name}: earthquake.scale must be finite (got {scale})")
    dt = record.dt
    a = np.array(record.accel, dtype=float)
    min_len = opts.taper_start + opts.taper_end + 2.0 * dt
    if record.duration <= min_len:
        raise ValueError(
            f"{record.name} ({record.source}): the record lasts {record.duration:.3f} s, too short for "
            f"its start and end tapers ({opts.taper_start} s + {opts.taper_end} s)"
        )
    if opts.pre_event > 0.0:
        n_pre = max(1, int(round(opts.pre_event / dt)))
        a -= a[:n_pre].mean()
    a = taper_and_baseline(a, dt, hann_taper(a.size, dt, opts.taper_start, opts.taper_end), opts.degree)
    factor = scale
    if target_pga is not None:
        if not (math.isfinite(target_pga) and target_pga > 0.0):
            raise ValueError(f"{record.name}: target PGA must be positive (got {target_pga})")
        peak = np.max(np.abs(a))
        if peak == 0.0:
            raise ValueError(f"{record.name}: the processed record is zero; it cannot be scaled")
        factor = scale * target_pga / peak
    a *= factor
    v, d = integrate(a, dt)
    return MotionHistory(
        name=record.name, source=record.source, dt=dt, accel=a, vel=v, disp=d, arrival=arrival
    )

"""The deck acceleration EN 1990 A2.4.4.2.1 limits, by modal truncation of the span's response.

EN 1990:2002+A1:2005 A2.4.4.2.1(4)P limits the peak deck acceleration "for frequencies (including
consideration of associated mode shapes) up to the greater of 30 Hz, 1.5 times the frequency of the
fundamental mode of the member and the frequency of the third mode". Read as the standard's own
background (ERRI D214) and the tools built on it (e.g. CALDINTAV) read it, the deck response counts
every vertical bending mode up to that frequency ``fc`` in full, each with the damping EN 1991-2
6.4.6.3.1 (Table 6.6) gives the structure, and no mode above it. Here:

* the modes are those of one simply supported span (supports held), from the generated span
  matrices (:func:`svbi.runtime.model.modes.span_matrices`), mass normalised; every bending mode of
  frequency ``<= fc`` is kept, ``fc = max(30 Hz, 1.5 f1, f3)``;
* each mode has the damping ratio ``bridge.damping_ratio`` (the scenario's, which is where EN 1991-2
  Table 6.6's ζ goes);
* the modal load is the run's own wheel forces (``contact_force``, each at its wheel's position,
  through the element's shape functions): the prescribed axle loads of a moving-load train, the
  interaction forces of a vehicle model;
* the modal equations are integrated exactly for loads that vary linearly between the stored times
  (first-order hold: the matrix exponential of the oscillator with the load's value and slope);
* the acceleration is taken at every node of the span and the peak is the envelope over nodes and
  time (the second mode has its node at midspan, so midspan alone misses it).

The simulation's own deck (Rayleigh damping fitted to modes 1 and 2, every mode of the mesh) is not
changed; this is the post-processing the check needs. It applies to traffic runs on bridges of
simply supported spans (the ``[bridge]`` shorthand): with an earthquake the deck's motion is not
the traffic's, and a long-form bridge's modes are not those of one span.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as sla

from ...codegen.plain_types import builtin_topologies
from ..model.hslm import hslm_parameters
from ..model.kernels import frame2d
from ..model.modes import span_matrices, span_support_dofs
from ..model.train import Kinematics, vehicle_model

EN1990_MIN_CUTOFF_HZ = 30.0
"""EN 1990 A2.4.4.2.1(4)P: the deck acceleration counts frequencies up to max(30 Hz, 1.5 f1, f3)."""


@dataclass(frozen=True)
class SpanModeSet:
    """The bending modes of one simply supported span that the EN 1990 deck check counts."""

    frequencies_hz: np.ndarray
    """Frequencies of the modes kept (Hz, ascending)."""
    shapes: np.ndarray
    """Mass-normalised mode shapes over the span's DOFs ``(u, w, theta)`` per node, one row per mode."""
    f1: float
    f3: float
    span_length: float
    elements: int
    damping_ratio: float

    @property
    def cutoff_hz(self) -> float:
        return max(EN1990_MIN_CUTOFF_HZ, 1.5 * self.f1, self.f3)

    @property
    def node_x(self) -> np.ndarray:
        """Positions of the span's nodes from its left support (m)."""
        return np.linspace(0.0, self.span_length, self.elements + 1)


def is_simply_supported(bridge: Mapping[str, Any]) -> bool:
    """True for the ``[bridge]`` shorthand: a chain of identical simply supported spans."""
    return not bridge.get("girders") and not bridge.get("piers") and bridge.get("span_length") is not None


def has_earthquake(table: Mapping[str, Any]) -> bool:
    """True when the scenario moves the ground: an ``[earthquake]`` with a component not "none"."""
    eq = table.get("earthquake")
    if not eq:
        return False
    for component in ("vertical", "longitudinal", "lateral"):  # lateral: 3D runs
        value = eq.get(component, "none")
        sources = value if isinstance(value, list) else [value]
        scale = float(eq.get("scale", 1.0)) * float(eq.get(f"{component}_scale", 1.0))
        if any(str(s) != "none" for s in sources) and (scale > 0.0 or eq.get("target_pga") is not None):
            return True
    return False


def span_mode_set(bridge: Mapping[str, Any]) -> SpanModeSet:
    """The modes up to the EN 1990 cutoff of one span of the shorthand ``[bridge]``."""
    length = float(bridge["span_length"])
    elements = int(bridge.get("elements_per_span", 16))
    m, k = span_matrices(
        length,
        elements,
        float(bridge["youngs_modulus"]),
        float(bridge["area"]),
        float(bridge["second_moment"]),
        float(bridge["mass_per_length"]),
    )
    free = np.setdiff1d(np.arange(m.shape[0]), span_support_dofs(elements))
    bending = np.array([i for i in free if i % 3 != 0])
    eig, vec = sla.eigh(k[np.ix_(bending, bending)], m[np.ix_(bending, bending)])  # vᵀ M v = I
    freq = np.sqrt(np.clip(eig, 0.0, None)) / (2 * np.pi)
    f1, f3 = float(freq[0]), float(freq[min(2, freq.size - 1)])
    cutoff = max(EN1990_MIN_CUTOFF_HZ, 1.5 * f1, f3)
    keep = freq <= cutoff * (1.0 + 1e-9)
    shapes = np.zeros((int(keep.sum()), m.shape[0]))
    shapes[:, bending] = vec[:, keep].T
    # sign: positive deflection at the largest entry (only for reading the shapes; a mode's sign
    # does not change the response)
    for row in shapes:
        w = row[1::3]
        if w[np.argmax(np.abs(w))] < 0:
            row *= -1.0
    return SpanModeSet(freq[keep], shapes, f1, f3, length, elements, float(bridge.get("damping_ratio", 0.02)))


def shape_values(modes: SpanModeSet, x: np.ndarray) -> np.ndarray:
    """The mode shapes' vertical deflection at points ``x`` of the span (m from its left support):
    ``(..., modes)``; zero outside ``0 <= x <= L``. The element's Hermite shape functions are the
    generated ones (``frame2d.shape_coefficients``), the same that load the deck in a run."""
    le = modes.span_length / modes.elements
    n0 = np.asarray(frame2d().shape_coefficients(le, 0.0)[0], dtype=float)  # 4 powers of xi x 6 DOFs
    x = np.asarray(x, dtype=float)
    on = (x >= 0.0) & (x <= modes.span_length)
    s = np.where(on, x, 0.0) / le
    e = np.clip(np.floor(s).astype(np.int64), 0, modes.elements - 1)
    xi = s - e
    powers = np.stack([np.ones_like(xi), xi, xi * xi, xi * xi * xi], axis=-1)
    rows = powers @ n0  # (..., 6): the element's shape functions at xi
    dofs = 3 * e[..., None] + np.arange(6)  # (..., 6)
    values = np.einsum("...j,m...j->...m", rows, modes.shapes[:, dofs])
    return np.where(on[..., None], values, 0.0)


def _foh_matrices(omega: np.ndarray, zeta: float, h: float) -> tuple[np.ndarray, ...]:
    """Exact step of ``q'' + 2ζω q' + ω² q = f`` over ``h`` for ``f`` linear in time: ``z_{n+1} =
    Φ z_n + g0 f_n + g1 (f_{n+1} - f_n)``, ``z = (q, q')``, one set per ω (first-order hold)."""
    phi = np.empty((omega.size, 2, 2))
    g0 = np.empty((omega.size, 2))
    g1 = np.empty((omega.size, 2))
    for i, w in enumerate(omega):
        aug = np.zeros((4, 4))
        aug[:2, :2] = [[0.0, 1.0], [-w * w, -2.0 * zeta * w]]
        aug[1, 2] = 1.0  # the load enters q''
        aug[2, 3] = 1.0 / h  # the load grows by (f_{n+1} - f_n) over the step
        e = sla.expm(aug * h)
        phi[i], g0[i], g1[i] = e[:2, :2], e[:2, 2], e[:2, 3]
    return phi, g0, g1


def modal_acceleration(
    modal_load: np.ndarray, t: np.ndarray, frequencies_hz: np.ndarray, zeta: float
) -> np.ndarray:
    """Modal accelerations ``q''`` (time x ...modes) of unit-mass oscillators under ``modal_load``
    (time x ...modes, linear between the equally spaced times ``t``), starting in static equilibrium
    with the first load (at rest when nothing is on the span at t = 0).

    The exact step (:func:`_foh_matrices`) is a second-order recursion in time, run as the
    equivalent IIR filter (``scipy.signal.lfilter``): ``q''_n = f_n - 2ζω q'_n - ω² q_n``, with
    ``(zI - Φ) z(z) = (g1 z + g0 - g1) f(z)``.
    """
    from scipy.signal import lfilter, lfilter_zi  # noqa: PLC0415 - 0.4 s of import, only here

    f = np.asarray(modal_load, dtype=float)
    shape = f.shape[1:]
    omega_b = np.broadcast_to(2 * np.pi * np.asarray(frequencies_hz, dtype=float), shape).reshape(-1)
    f = f.reshape(f.shape[0], -1)
    n = f.shape[0]
    t = np.asarray(t, dtype=float)
    if n < 2:
        return np.zeros((n, *shape))
    steps = np.diff(t)
    h = float(np.median(steps))
    if np.max(np.abs(steps - h)) > 1e-6 * h:
        raise ValueError("the stored times are not equally spaced")
    phi, g0, g1 = _foh_matrices(omega_b, zeta, h)
    acc = np.empty_like(f)
    for i, w in enumerate(omega_b):
        p = phi[i]
        d = g0[i] - g1[i]
        c0, c1 = w * w, 2.0 * zeta * w  # q'' = f - c0 q - c1 q'
        # c . adj(zI - Φ) = (r1 z + r0, s1 z + s0), adj = [[z - p11, p01], [p10, z - p00]]
        r1, r0 = c0, -c0 * p[1, 1] + c1 * p[1, 0]
        s1, s0 = c1, c0 * p[0, 1] - c1 * p[0, 0]
        # N(z) = (r1 z + r0)(g1_0 z + d_0) + (s1 z + s0)(g1_1 z + d_1)
        num = np.array(
            [
                r1 * g1[i, 0] + s1 * g1[i, 1],
                r1 * d[0] + r0 * g1[i, 0] + s1 * d[1] + s0 * g1[i, 1],
                r0 * d[0] + s0 * d[1],
            ]
        )
        den = np.array([1.0, -(p[0, 0] + p[1, 1]), p[0, 0] * p[1, 1] - p[0, 1] * p[1, 0]])
        b = den - num  # H(z) = 1 - N(z) / det(zI - Φ)
        zi = lfilter_zi(b, den) * f[0, i]  # the steady (static) state under the first load
        acc[:, i] = lfilter(b, den, f[:, i], zi=zi)[0]
    return acc.reshape(n, *shape)


@dataclass(frozen=True)
class DeckEnvelope:
    """Peak |deck acceleration| per span over nodes and time, with when and where."""

    peak: np.ndarray
    time: np.ndarray
    x: np.ndarray
    """Where along the span (m from its left support) the peak occurs."""
    modes: SpanModeSet


def wheel_positions(table: Mapping[str, Any], t: np.ndarray, contacts: int) -> np.ndarray:
    """x of every wheel (time x contact, contacts car by car) from the scenario's ``[train]``, as the
    run places them (``Train.positions``)."""

    train = table.get("train", {})
    name = str(train.get("vehicle", "pioneer-2d"))
    model = vehicle_model(name if name in builtin_topologies() else name)
    values = model.topology.values(dict(train.get("parameters", {})), where="train.parameters")
    if train.get("hslm"):
        values.update(hslm_parameters(str(train["hslm"])))
    vehicle = model.numeric(values)
    offsets = np.asarray(
        vehicle.axle_offsets if vehicle.kind == "moving-load" else vehicle.wheel_offsets, dtype=float
    )
    cars = int(train.get("cars", 1))
    all_offsets = (np.arange(cars)[:, None] * float(vehicle.car_length) + offsets[None, :]).reshape(-1)
    if all_offsets.size != contacts:
        raise ValueError(f"the scenario's train has {all_offsets.size} wheels, the results {contacts}")
    speed = train.get("speed")
    speed = float(speed) if speed is not None else float(train["speed_kmh"]) / 3.6
    travel = Kinematics(speed, float(train.get("acceleration", 0.0))).travel(np.asarray(t, dtype=float))
    return float(train.get("start_position", 0.0)) + np.asarray(travel)[:, None] - all_offsets[None, :]


def deck_envelope(
    table: Mapping[str, Any], t: np.ndarray, forces: np.ndarray, positions: np.ndarray | None = None
) -> DeckEnvelope:
    """The EN 1990 deck acceleration of every span of a shorthand bridge by modal truncation
    (module docstring): ``forces`` are the wheel forces (time x contact, N, compression positive,
    pushing the deck down), ``positions`` their x (time x contact; from the scenario when None)."""
    bridge = table["bridge"]
    modes = span_mode_set(bridge)
    t = np.asarray(t, dtype=float)
    forces = np.asarray(forces, dtype=float).reshape(t.size, -1)
    if positions is None:
        positions = wheel_positions(table, t, forces.shape[1])
    spans = int(bridge.get("spans", 1))
    length = modes.span_length
    nm = modes.frequencies_hz.size
    load = np.zeros((t.size, spans, nm))
    span = np.floor(positions / length).astype(np.int64)  # a wheel on a joint is on the span ahead
    row, col = np.nonzero((span >= 0) & (span < spans))
    s_on = span[row, col]
    phi = shape_values(modes, positions[row, col] - s_on * length)  # (on, modes)
    # deflection is up positive and the wheel force (compression positive) pushes the deck down
    np.add.at(load, (row, s_on), -forces[row, col, None] * phi)
    acc = modal_acceleration(load, t, np.broadcast_to(modes.frequencies_hz, (spans, nm)), modes.damping_ratio)
    nodes = modes.shapes[:, 1::3]  # (modes, nodes): vertical deflection at the nodes
    peak = np.full(spans, np.nan)
    when = np.full(spans, np.nan)
    where = np.full(spans, np.nan)
    node_x = modes.node_x
    for s in range(spans):
        a = np.abs(acc[:, s, :] @ nodes)  # (time, nodes)
        if a.size == 0:
            continue
        k = int(np.argmax(a))
        i, j = np.unravel_index(k, a.shape)
        peak[s], when[s], where[s] = a[i, j], t[i], node_x[j]
    return DeckEnvelope(peak, when, where, modes)

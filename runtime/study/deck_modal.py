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

The long form (``[[bridge.girders]]``, ``[[bridge.piers]]``) is read the same way over the whole
structure, since a continuous girder's or a pier's modes are not those of one span:

* the modes are those of the whole bridge (girders, continuity, bearings and piers; ground held),
  from the run's own assembled matrices (:class:`svbi.runtime.model.bridge.Bridge`);
* ``f1`` and ``f3`` are the first and third **vertical deck modes**: those with at least half of
  their kinetic energy in the deck's vertical DOFs (a pier's sway mode is not the member's
  fundamental mode); every mode of the structure up to ``fc`` is kept, whatever its kind (a mode
  the vertical wheel loads do not excite contributes nothing);
* every mode kept has the girders' damping ratio (the smallest, if the girders differ: the
  conservative reading);
* the envelope is taken over each span's nodes, span by span.

The simulation's own deck (Rayleigh damping fitted to modes 1 and 2, every mode of the mesh) is not
changed; this is the post-processing the check needs. It applies to traffic runs: with an
earthquake the deck's motion is not the traffic's.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
import scipy.linalg as sla

from ...codegen.plain_types import builtin_topologies
from ..model.bridge import Bridge
from ..model.hslm import hslm_parameters
from ..model.kernels import frame2d
from ..model.modes import span_matrices, span_support_dofs
from ..model.train import Kinematics, vehicle_model
from ..scenario.schema import BridgeSpec

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


VERTICAL_DECK_SHARE = 0.5
"""A mode of a long-form bridge is a vertical deck mode (for ``f1`` and ``f3``) when at least this
share of its kinetic energy is in the deck's vertical DOFs."""
LONG_FORM_DOF_LIMIT = 3000
"""The long form's modes come from one dense solve of the whole structure (every mode at once, about
a second at 1,000 free DOFs); above this many free DOFs (some 60 spans of 16 elements) the check
falls back to the filtered midspan acceleration and says why."""


@dataclass(frozen=True)
class BridgeModeSet:
    """The modes of a whole long-form bridge that the EN 1990 deck check counts (module docstring)."""

    frequencies_hz: np.ndarray
    """Frequencies of the modes kept (Hz, ascending)."""
    shapes: np.ndarray
    """Mass-normalised mode shapes over the bridge's global DOFs, one row per mode."""
    f1: float
    f3: float
    damping_ratio: float
    bridge: Bridge

    @property
    def cutoff_hz(self) -> float:
        return max(EN1990_MIN_CUTOFF_HZ, 1.5 * self.f1, self.f3)


def long_form_bridge(bridge: Mapping[str, Any]) -> Bridge:
    """The run's :class:`Bridge` of a long-form ``[bridge]`` table (every default filled in), with
    its global numbering (``global_dof``, ``nglobal``, ``K_global``, ``M_global``, ``free_global``)
    even where the long form describes the paper's chain, which a run keeps span by span."""
    spec = BridgeSpec.model_validate(dict(bridge), strict=False)
    girders, piers = spec.layout()
    b = Bridge(0, 0.0, 1.0, 1.0, 1.0, 1.0, 0.0, spec.elements_per_span, spec.rail_height, girders, piers)
    if b.uniform:  # independent identical spans: the global numbering is span after span
        import scipy.sparse as sps  # noqa: PLC0415 - with the long form's check only

        M, K, free = b.assembled()
        b.global_dof = np.arange(b.spans * b.ndof).reshape(b.spans, b.ndof)
        b.nglobal = b.spans * b.ndof
        b.M_global, b.K_global, b.free_global = sps.csc_matrix(M), sps.csc_matrix(K), free
    return b


def long_form_mode_set(bridge: Mapping[str, Any]) -> BridgeModeSet:
    """The modes up to the EN 1990 cutoff of a long-form ``[bridge]`` (module docstring); the same
    table gives the same modes, computed once per process."""
    return _long_form_mode_set(json.dumps(bridge, sort_keys=True, default=str))


@lru_cache(maxsize=8)
def _long_form_mode_set(key: str) -> BridgeModeSet:
    b = long_form_bridge(json.loads(key))
    free = b.free_global
    if free.size > LONG_FORM_DOF_LIMIT:
        raise ValueError(
            f"the bridge has {free.size} free DOFs, more than the {LONG_FORM_DOF_LIMIT} of the"
            " dense modal solve of the EN 1990 deck check"
        )
    K = b.K_global.tocsc()[free][:, free].toarray()
    M = b.M_global.tocsc()[free][:, free].toarray()
    eig, vec = sla.eigh(K, M)  # every mode, vᵀ M v = I
    freq = np.sqrt(np.clip(eig, 0.0, None)) / (2 * np.pi)
    deck = np.zeros(b.nglobal, dtype=bool)
    for s in range(b.spans):
        deck[b.global_dof[s][1::3]] = True
    d = deck[free]
    share = np.einsum("im,im->m", vec[d], M[np.ix_(d, d)] @ vec[d])  # kinetic energy in the deck's w
    vertical = freq[share >= VERTICAL_DECK_SHARE]
    if vertical.size == 0:
        raise ValueError("the bridge has no vertical deck mode")
    f1, f3 = float(vertical[0]), float(vertical[min(2, vertical.size - 1)])
    cutoff = max(EN1990_MIN_CUTOFF_HZ, 1.5 * f1, f3)
    keep = freq <= cutoff * (1.0 + 1e-9)
    shapes = np.zeros((int(keep.sum()), b.nglobal))
    shapes[:, free] = vec[:, keep].T
    zeta = min(g.section.damping_ratio for g in b.girders)
    return BridgeModeSet(freq[keep], shapes, f1, f3, float(zeta), b)


def deck_values(b: Bridge, x: np.ndarray, field: np.ndarray, include_end: bool = False) -> np.ndarray:
    """The vertical deck deflection at points ``x`` (m from the bridge's start, 1-D) of every column
    of ``field`` (global DOFs x columns): ``(points, columns)``, zero off the bridge (``include_end``:
    the bridge's last point counts as on it); the generated Hermite shape functions of each span's
    elements, as a run loads the deck."""
    x = np.asarray(x, dtype=float)
    loc = b.locate(x)
    out = np.zeros((x.size, field.shape[1]))
    on = np.nonzero(loc.on | (include_end & np.isclose(x, b.length)))[0]
    if on.size == 0:
        return out
    span, element, xi = loc.span[on], loc.element[on], loc.xi[on]
    powers = np.stack([np.ones_like(xi), xi, xi * xi, xi * xi * xi], axis=-1)
    rows = np.empty((xi.size, 6))
    for le in np.unique(b.span_element_length[span]):
        at = b.span_element_length[span] == le
        rows[at] = powers[at] @ np.asarray(frame2d().shape_coefficients(float(le), 0.0)[0], dtype=float)
    dofs = b.global_dof[span[:, None], 3 * element[:, None] + np.arange(6)]  # (on, 6)
    out[on] = np.einsum("pj,pjn->pn", rows, field[dofs])
    return out


def long_form_shape_values(modes: BridgeModeSet, x: np.ndarray) -> np.ndarray:
    """The long form's mode shapes' vertical deck deflection at points ``x`` (m from the bridge's
    start): ``(..., modes)``, zero off the bridge (:func:`deck_values`)."""
    x = np.asarray(x, dtype=float)
    return deck_values(modes.bridge, x.reshape(-1), modes.shapes.T).reshape(*x.shape, -1)


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
    modes: SpanModeSet | BridgeModeSet


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
    """The EN 1990 deck acceleration of every span by modal truncation (module docstring: one
    span's modes for the shorthand, the whole structure's for the long form): ``forces`` are the
    wheel forces (time x contact, N, compression positive, pushing the deck down), ``positions``
    their x (time x contact; from the scenario when None)."""
    bridge = table["bridge"]
    t = np.asarray(t, dtype=float)
    forces = np.asarray(forces, dtype=float).reshape(t.size, -1)
    if positions is None:
        positions = wheel_positions(table, t, forces.shape[1])
    if not is_simply_supported(bridge):
        return _long_form_envelope(long_form_mode_set(bridge), t, forces, positions)
    modes = span_mode_set(bridge)
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


def _long_form_envelope(
    modes: BridgeModeSet, t: np.ndarray, forces: np.ndarray, positions: np.ndarray
) -> DeckEnvelope:
    """:func:`deck_envelope` of a long-form bridge: one modal load over the whole structure, the
    envelope over each span's nodes."""
    b = modes.bridge
    phi = long_form_shape_values(modes, positions)  # (time, contact, modes), zero off the bridge
    # deflection is up positive and the wheel force (compression positive) pushes the deck down
    load = -np.einsum("tc,tcm->tm", forces, phi)
    acc = modal_acceleration(load, t, modes.frequencies_hz, modes.damping_ratio)  # (time, modes)
    peak = np.full(b.spans, np.nan)
    when = np.full(b.spans, np.nan)
    where = np.full(b.spans, np.nan)
    for s in range(b.spans):
        nodes = modes.shapes[:, b.global_dof[s][1::3]]  # (modes, nodes of span s)
        a = np.abs(acc @ nodes)
        if a.size == 0:
            continue
        i, j = np.unravel_index(int(np.argmax(a)), a.shape)
        node_x = np.linspace(0.0, float(b.span_lengths[s]), b.elements + 1)
        peak[s], when[s], where[s] = a[i, j], t[i], node_x[j]
    return DeckEnvelope(peak, when, where, modes)

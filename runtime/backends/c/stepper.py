"""The ``"c"`` backend: the whole Newmark loop in C (``svbi.runtime.backends.c.build``), in chunks of steps.

The numeric model is built exactly as for the NumPy backend: the NumPy stepper of the method is
constructed first (it factors the constant matrices, sets the initial multipliers of the coupled
method, and ties the wheel to its aux point for coupled-classic), and its matrices are handed to C.
The C loop then runs whole chunks of steps per call, writing straight into the
:class:`~svbi.runtime.run.results.Recorder`'s arrays; Python only shows progress between chunks, so
Ctrl-C stops a run between two chunks and the chunk size never changes the results.

Excitations reach the loop in one of two ways:

* **tables**, evaluated in C: a rail profile given as a piecewise polynomial
  (:class:`~svbi.runtime.excitation.irregularity.SampledIrregularity`, e.g. a tabulated spectral
  sample or a measured profile) times its onset ramp, and ground motions given as processed records
  (:class:`~svbi.runtime.excitation.processing.MotionHistory`: a piecewise cubic in t), synchronous
  or travelling with an apparent velocity;
* **streams**, for anything else (an analytic spectral irregularity, a user-defined ground): Python
  evaluates the very objects the NumPy backend uses, vectorised over each chunk, and the loop reads
  the values. Slower, but it agrees with NumPy to round-off whatever the excitation is.

A run that diverges in C stops with the step and the quantity; the message and the partial results
are those of the NumPy backend (``simulate.DivergenceGuard``). With no C compiler the backend falls back to
NumPy with one warning (:func:`c_stepper`).
"""

from __future__ import annotations

import ctypes
import math
import time
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np

from ....codegen import loop_abi
from ....codegen.plain_types import GRAVITY
from ...excitation.ground import GroundMotion
from ...excitation.irregularity import NoIrregularity, SampledIrregularity
from ...excitation.piecewise import horner
from ...methods.guard import Diverged
from ...methods.newmark import Newmark
from ...methods.steppers import numpy_steppers
from ...model.contact_rows import AxialShapeKernel, ShapeKernel, shape_tables
from ...model.system import FlatTrack, GroundAtRest, Model, State
from ...toolchain import CompilerError
from ..base import BackendFallback
from . import build as c_solver_build

CHUNK_SECONDS = 0.1
"""Target wall time of one call into C: progress and Ctrl-C are handled between calls."""
STREAM_CHUNK = 2048
"""Most steps per call when Python streams an excitation into the loop."""


class CLoopError(RuntimeError):
    """The C loop stopped for an internal reason (not a divergence of the run)."""


# --------------------------------------------------------------------------------------------------
# small helpers


def _csr(matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """CSR arrays of a dense matrix (exact zeros dropped)."""
    rows, cols = np.nonzero(matrix)
    ptr = np.zeros(matrix.shape[0] + 1, dtype=np.int32)
    np.cumsum(np.bincount(rows, minlength=matrix.shape[0]), out=ptr[1:])
    return ptr, cols.astype(np.int32), np.ascontiguousarray(matrix[rows, cols])


def _lower_band(matrix: Any) -> tuple[np.ndarray, int]:
    """Lower band of a symmetric matrix (dense or scipy.sparse), element (i, j) at ``[j, i - j]``,
    and its half bandwidth."""
    rows, cols = matrix.nonzero()
    p = int(np.abs(rows - cols).max(initial=0))
    n = matrix.shape[0]
    band = np.zeros((n, p + 1))
    for k in range(p + 1):
        band[: n - k, k] = matrix.diagonal(-k)
    return band, p


def _band_order(matrix: np.ndarray, dofs: np.ndarray) -> np.ndarray:
    """``dofs`` reordered to narrow the band of ``matrix[dofs][:, dofs]`` (reverse Cuthill-McKee;
    the axial and bending DOFs of a frame decouple), unless the natural order is as narrow."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    sub = matrix[np.ix_(dofs, dofs)]
    perm = reverse_cuthill_mckee(csr_matrix(sub != 0), symmetric_mode=True)
    if _lower_band(sub[np.ix_(perm, perm)])[1] < _lower_band(sub)[1]:
        return dofs[perm]
    return dofs


def _support_slots(bridge: Any) -> int:
    """Support slots of the C loop: ``nsupport`` per span (the paper's bridge), else three per
    substructure (``Bridge.support_dof``)."""
    return bridge.spans * bridge.nsupport if bridge.uniform else 3 * bridge.nsub


def _window_count(offsets: np.ndarray, width: float) -> int:
    """Largest number of contacts within any closed window of length ``width``."""
    o = np.sort(offsets)
    if o.size == 0:
        return 0
    hi = np.searchsorted(o, o + width, side="right")
    return int((hi - np.arange(o.size)).max())


# --------------------------------------------------------------------------------------------------
# excitation tables


def _ppoly_struct(
    keep: list[Any],
    x: np.ndarray,
    c: np.ndarray,
    left: tuple[float, float, float],
    right: tuple[float, float, float],
) -> c_solver_build.PPoly:
    x = np.ascontiguousarray(x, dtype=float)
    # one interval's coefficients side by side: an evaluation reads one cache line, not k + 1
    c = np.ascontiguousarray(np.asarray(c, dtype=float).T)
    keep += [x, c]
    n = c.shape[0] if c.ndim == 2 else 0
    steps = np.diff(x)
    # "uniform" only seeds the interval search, which then steps to the exact interval, so breaks
    # equally spaced up to round-off (a table over [250, 283.37] steps by h (1 +- 3e-12)) qualify
    uniform = bool(n > 0 and np.allclose(steps, steps[0], rtol=1e-6, atol=0.0))
    return c_solver_build.PPoly(
        n=n,
        k=(c.shape[1] - 1) if n else 0,
        uniform=int(uniform),
        h=float((x[-1] - x[0]) / n) if n else 0.0,
        x=x.ctypes.data,
        c=c.ctypes.data,
        left0=left[0],
        left1=left[1],
        left2=left[2],
        right0=right[0],
        right1=right[1],
        right2=right[2],
    )


def _empty_ppoly() -> c_solver_build.PPoly:
    return c_solver_build.PPoly()


def _ramp_table(ramp: Any) -> tuple[np.ndarray, np.ndarray] | None:
    """The onset ramp h(x) as one polynomial piece on [start, start + length], found by fitting its
    own ``weights`` (an exact polynomial: the fit is checked), or None if it is not a polynomial."""
    if ramp.length == 0.0:
        return np.array([ramp.start]), np.zeros((1, 0))
    x = ramp.start + ramp.length * 0.5 * (1.0 - np.cos(np.linspace(0.0, np.pi, 24)))
    h, dh, ddh = ramp.weights(x)
    s = x - ramp.start
    for degree in range(1, 12):
        coef = np.polynomial.polynomial.polyfit(s, h, degree)
        p = np.polynomial.Polynomial(coef)
        ok = (
            np.abs(p(s) - h).max() <= 1e-14
            and np.abs(p.deriv(1)(s) - dh).max() <= 1e-12 * max(np.abs(dh).max(), 1e-300)
            and np.abs(p.deriv(2)(s) - ddh).max() <= 1e-10 * max(np.abs(ddh).max(), 1e-300)
        )
        if ok:
            return np.array([ramp.start, ramp.start + ramp.length]), coef[::-1].reshape(-1, 1)
    return None


class ExcitationInput:
    """How the irregularity and the ground motion of a model reach the C loop (tables or streams)."""

    def __init__(self, model: Model) -> None:
        self.model = model
        self.keep: list[Any] = []
        self.struct = c_solver_build.Excitation()
        self.irr_stream = False
        self.ground_stream = False
        self._irregularity()
        self._ground()
        b = model.bridge
        self.struct.ground_per_support = int(not model.ground.uniform)
        self.nrec = len(b.support_table.flat)
        self.describe = (
            f"irregularity: {'stream' if self.irr_stream else 'table'}, "
            f"ground: {'stream' if self.ground_stream else 'table'}"
        )

    # ----------------------------------------------------------------------------------------------
    def _irregularity(self) -> None:
        irr, e = self.model.irregularity, self.struct
        if isinstance(irr, FlatTrack | NoIrregularity):
            e.irr_mode = 0
            return
        if isinstance(irr, SampledIrregularity):
            ramp = _ramp_table(irr.ramp)
            if ramp is not None:
                x, c = np.asarray(irr.spline.x), np.asarray(irr.spline.c)
                keep = np.flatnonzero(np.diff(x) > 0)
                if keep.size < x.size - 1:  # drop zero-length pieces (a copy: only when there are any)
                    x = np.concatenate([x[keep], [x[keep[-1] + 1]]])
                    c = c[:, keep]
                ends = horner(irr.spline, np.array([irr.x_min, irr.x_max]))  # r, r', r'' at both
                lo, hi = (tuple(float(v[k]) for v in ends) for k in (0, 1))
                e.irr_base = _ppoly_struct(self.keep, x, c, lo, hi)
                e.irr_onset = _ppoly_struct(self.keep, ramp[0], ramp[1], (0.0, 0.0, 0.0), (1.0, 0.0, 0.0))
                e.irr_ramp = 1
                e.irr_start = float(irr.ramp.start)
                e.irr_mode = 1
                return
        e.irr_mode = 2
        self.irr_stream = True

    def _ground(self) -> None:
        g, e = self.model.ground, self.struct
        if type(g) is GroundAtRest:
            e.gv_mode = e.gh_mode = 0
            return
        motion = _ground_motion(g)
        if motion is not None:
            lines = self.model.bridge.line_x
            modes: list[tuple[int, Any, Any]] = []
            for name in ("vertical", "longitudinal"):
                comp = motion.component(name)
                if comp is None:
                    modes.append((0, _empty_ppoly(), None))
                elif comp.positions is None and len(comp.histories) == 1:
                    travelling = motion.apparent_velocity is not None
                    modes.append((2 if travelling else 1, self._history(comp.histories[0]), None))
                elif comp.positions is not None and np.array_equal(comp.positions, lines):
                    tables = (c_solver_build.PPoly * len(comp.histories))(
                        *[self._history(h) for h in comp.histories]
                    )
                    self.keep.append(tables)
                    modes.append((4, _empty_ppoly(), tables))
                else:
                    modes = []
                    break
            if modes:
                (e.gv_mode, e.gv, v_lines), (e.gh_mode, e.gh, h_lines) = modes
                e.gv_lines = ctypes.addressof(v_lines) if v_lines is not None else None
                e.gh_lines = ctypes.addressof(h_lines) if h_lines is not None else None
                mids = np.ascontiguousarray(0.5 * (lines[1:] + lines[:-1]))
                self.keep.append(mids)
                e.mids = mids.ctypes.data
                e.apparent_velocity = float(motion.apparent_velocity or 0.0)
                e.x_ref = float(motion.reference_position)
                return
        e.gv_mode = e.gh_mode = 3
        self.ground_stream = True

    def _history(self, h: Any) -> c_solver_build.PPoly:
        """A processed record (``MotionHistory``) as the piecewise cubic of its integration."""
        table, after = h.table()
        return _ppoly_struct(self.keep, table.x, table.c, (0.0, 0.0, 0.0), after)

    # ----------------------------------------------------------------------------------------------
    @property
    def streamed(self) -> bool:
        return self.irr_stream or self.ground_stream

    def fill(self, n0: int, count: int) -> None:
        """Evaluate the streamed excitations for steps n0 .. n0 + count - 1 (t = (n + 1) dt)."""
        if not self.streamed:
            return
        m = self.model
        b, tr, e = m.bridge, m.train, self.struct
        nc, nsup = tr.contacts, _support_slots(b)
        t = (np.arange(n0, n0 + count) + 1) * m.dt
        e.s_n0, e.s_count = n0, count
        if self.irr_stream:
            x = tr.start_position + tr.motion.travel(t)[:, None] - tr.offsets[None, :]
            r = np.stack(m.irregularity.evaluate(x), axis=1)  # count x 3 x nc
            self._rail = np.ascontiguousarray(r, dtype=float)
            e.s_rail = self._rail.ctypes.data
        if self.ground_stream:
            under = np.zeros((count, 4, nc))
            sup = np.empty((count, 3, nsup))
            rec = np.zeros((count, 2, self.nrec))
            per_support = bool(e.ground_per_support)
            creep = m.creep is not None and m.creep.longitudinal_ground
            for j, tj in enumerate(t):
                x = tr.positions(float(tj))
                v, a = tr.speed_at(float(tj)), tr.acceleration_at(float(tj))
                under[j, :3] = np.stack(m.ground.under(float(tj), x, v, a))
                if creep:
                    under[j, 3] = m.ground.under_longitudinal(float(tj), x, v, a)[1]
                sup[j] = np.stack([a.reshape(-1) for a in m.supports(float(tj))])  # Newmark targets
                qz, qx = m.ground.recorded(float(tj), b)
                if per_support:
                    rec[j, 0], rec[j, 1] = qz, qx
                else:  # one value each, where the loop's recording reads a uniform ground: [uz, ux]
                    rec[j].reshape(-1)[:2] = qz, qx
            self._under, self._sup, self._rec = under, sup, rec
            e.s_under, e.s_sup, e.s_rec = under.ctypes.data, sup.ctypes.data, rec.ctypes.data


def _ground_motion(ground: Any) -> Any:
    """The ``GroundMotion`` behind a ``FunctionGround`` built by ``ground_from_scenario``, or None."""
    direct = getattr(ground, "source", None) or getattr(ground, "motion_source", None)
    if isinstance(direct, GroundMotion):
        return direct
    found = None
    for fn in (getattr(ground, "_v", None), getattr(ground, "_h", None)):
        for cell in getattr(fn, "__closure__", None) or ():
            try:
                value = cell.cell_contents
            except ValueError:
                continue
            if isinstance(value, GroundMotion):
                if found is not None and value is not found:
                    return None
                found = value
    if found is not None and getattr(ground, "apparent_velocity", None) != found.apparent_velocity:
        return None
    return found


HANDBACK_STEPS = 20
"""Unilateral contact: NumPy steps with every wheel on its rail and no active-set change before the
C loop takes over again (a slope kink's transient lasts a few steps; this avoids ping-pong)."""

# --------------------------------------------------------------------------------------------------
# the stepper


class CStepper:
    """Runs one method's whole loop in C; see the module docstring."""

    backend = "c"

    def __init__(self, model: Model, state: State, method: str) -> None:
        self.model = model
        self.name = method
        self.method = method
        self.library = c_solver_build.load_loop(c_solver_build.loop_spec(model.train))
        # The NumPy stepper builds the constant matrices and the initial multipliers; coupled-classic
        # also ties each wheel to its aux point in the state.
        self.reference = numpy_steppers()[method](model, state)
        self.unilateral = getattr(self.reference, "act", None) is not None
        self.active_set_in_c = self.unilateral and method == "localized-dynamic"
        """localized-dynamic keeps the whole active set in the C loop (lift-offs, airborne wheels' P = 0
        rows, landings and their impact); a step whose active set does not settle goes to NumPy."""
        self.handovers = 0
        """Unilateral runs: how many times NumPy took steps over from the C loop."""
        self.numpy_steps = 0
        """Steps the NumPy stepper took over (results attribute ``numpy_steps``)."""
        self.state = state
        self.contacts = None
        self.keep: list[Any] = []
        self._state_arrays(state)
        self.c_arrays = {k: getattr(state, k) for k in self.STATE_NAMES}
        self.setup = self._setup()
        self.excitation = ExcitationInput(model)
        # The C tables clamp beyond their ends; NumPy raises there: ask NumPy where the run ends.
        model.irregularity.evaluate(model.train.positions(model.settings.steps * model.dt))
        n_double, n_int = ctypes.c_long(), ctypes.c_long()
        self.library.workspace(ctypes.byref(self.setup), ctypes.byref(n_double), ctypes.byref(n_int))
        self.work = np.zeros(n_double.value)
        self.iwork = np.zeros(n_int.value, dtype=np.int32)
        status = self.library.init(ctypes.byref(self.setup), self.work.ctypes.data, self.iwork.ctypes.data)
        if status:
            raise CLoopError(f"C loop set-up failed: {loop_abi.STATUS_NAMES.get(status, status)}")
        self.info = c_solver_build.Info()
        self._scratch: dict[str, np.ndarray] = {}

    # ----------------------------------------------------------------------------------------------
    def _arr(self, value: Any, dtype: Any = float) -> int | None:
        if value is None:
            return None
        a = np.ascontiguousarray(value, dtype=dtype)
        self.keep.append(a)
        return a.ctypes.data

    def _state_arrays(self, st: State) -> None:
        tr, b = self.model.train, self.model.bridge
        nc = tr.contacts
        for name in ("uV", "vV", "aV", "uB", "vB", "aB", "ug", "vg", "ag", "P", "PV"):
            setattr(st, name, np.array(getattr(st, name), dtype=float, order="C"))
        if tr.moving_load:
            st.ug, st.vg, st.ag = (np.zeros(nc) for _ in range(3))
        self.lam = {
            "lamV": np.zeros((3, nc)),
            "lamB": np.zeros((3, nc)),
            "lamG": np.zeros((3, _support_slots(b))),
        }
        ref = self.reference
        for key in ("lamV", "lamB", "lamG"):
            triple = getattr(ref, key, None)
            if triple is not None:
                self.lam[key][:] = np.stack([np.asarray(v, dtype=float).reshape(-1) for v in triple])
        for name in ("creepage", "creep_force"):
            value = getattr(st, name, None)
            setattr(st, name, np.zeros(nc) if value is None else np.array(value, dtype=float, order="C"))
        self.cstate = c_solver_build.State(
            t=st.t,
            **{
                k: getattr(st, k).ctypes.data
                for k in (
                    "uV",
                    "vV",
                    "aV",
                    "uB",
                    "vB",
                    "aB",
                    "ug",
                    "vg",
                    "ag",
                    "P",
                    "PV",
                    "creepage",
                    "creep_force",
                )
            },
            **{k: v.ctypes.data for k, v in self.lam.items()},
        )
        if self.active_set_in_c:  # C reads the NumPy active set's own array (one byte per wheel)
            act = self.reference.act
            assert act.in_contact.dtype == np.bool_ and act.in_contact.flags.c_contiguous
            self.cstate.in_contact = act.in_contact.ctypes.data

    def _setup(self) -> Any:
        m, ref = self.model, self.reference
        b, tr, s = m.bridge, m.train, m.settings
        nm = Newmark(s.time_step)
        code = loop_abi.METHOD_CODES[self.method]
        classic = self.method == "coupled-classic"
        kappa, zeta = (0.0, 0.0) if classic else (s.kappa, s.zeta)
        point = ref.point
        nc, nw = tr.contacts, tr.wheels
        S = c_solver_build.Setup()
        S.method, S.moving_load = code, int(tr.moving_load)
        S.unilateral = int(self.active_set_in_c)
        S.cars, S.nw, S.nc = tr.cars, nw, nc
        S.spans, S.elements, S.nd, S.ns = b.spans, b.elements, b.ndof, b.nsupport if b.uniform else 3
        S.output_every, S.steps = s.output_every, s.steps
        S.dt, S.a0, S.a1, S.a2 = s.time_step, nm.a0, nm.a1, nm.a2
        S.gravity, S.speed, S.start = GRAVITY, tr.speed, tr.start_position
        S.span_length, S.inv_span_length = b.span_length, 1.0 / b.span_length
        S.inv_element_length = 1.0 / b.span_element_length[0]
        S.p_P, S.p_Q, S.p_q2, S.p_q1, S.p_q = point.c_P, point.c_Q, point.c_q2, point.c_q1, point.c_q
        S.d = point.d
        omega = kappa / s.time_step
        S.c2 = 2 * zeta * omega
        S.w2 = omega * omega

        S.gap_limit = m.settings.max_gap
        S.force_limit = math.inf

        # contacts, in track order (front to back)
        order = np.argsort(tr.offsets, kind="stable").astype(np.int32)
        pos = np.empty(nc, dtype=np.int64)
        pos[order] = np.arange(nc)
        per_car = pos.reshape(tr.cars, nw) if nc else np.zeros((0, 1))
        S.bw_car = int((per_car.max(axis=1) - per_car.min(axis=1)).max(initial=0))
        S.order, S.offsets = self._arr(order, np.int32), self._arr(tr.offsets)
        S.axle_loads = self._arr(tr.axle_loads if tr.moving_load else np.zeros(nc))
        S.acceleration = tr.acceleration
        S.stop_time = min(tr.motion.stop_time, 1e300)
        if b.uniform:
            self._one_span(S, nm, kappa, zeta, code, classic)

        # one car
        S.carbody_z = S.carbody_theta = -1
        if not tr.moving_load:
            v = tr.vehicle
            mass = v.M if classic else tr.M_active
            S.V_K, S.V_M, S.V_C = self._arr(v.K), self._arr(mass), self._arr(v.C)
            S.V_F = self._arr(tr.F_full if classic else tr.F_active)
            S.V_W = self._arr(tr.W)
            S.V_khat = self._arr(v.K + nm.a1 * v.C + nm.a0 * mass)
            for key, mat in {"VW": tr.W.T}.items():
                ptr, idx, val = _csr(np.asarray(mat, dtype=float))
                setattr(S, f"{key}_ptr", self._arr(ptr, np.int32))
                setattr(S, f"{key}_idx", self._arr(idx, np.int32))
                setattr(S, f"{key}_val", self._arr(val))
            S.m_g = self._arr(tr.aux_masses)
            if code == 0:
                S.V_kinv, S.V_A, S.V_B = self._arr(ref.k_inv), self._arr(ref.A), self._arr(ref.B)
                S.V_Fstar = self._arr(ref.F_star[:nw, :nw])
                S.c_g = self._arr(ref.c_g[:nw])
            if code == 1:
                S.mV = self._arr(ref.mV[:nw])
                num, den = ref.mB_kernel.tables
                S.mb_num = self._arr(num)
                S.mb_den = self._arr(den)
                S.mb_num_n = num.shape[0]
                S.mb_den_n = den.shape[0]
            creep = m.creep
            if creep is not None:
                S.creep = 1
                S.creep_ground = int(creep.longitudinal_ground)
                S.creep_min_speed = creep.min_speed
                ptr, idx, val = _csr(np.asarray(creep.W_T, dtype=float).T)
                S.VT_ptr, S.VT_idx, S.VT_val = (
                    self._arr(ptr, np.int32),
                    self._arr(idx, np.int32),
                    self._arr(val),
                )
                S.creep_rolling = self._arr(creep.rolling[:nw].astype(np.int32), np.int32)
                params = np.zeros((nw, 8))
                for law, mask in creep.laws:
                    params[mask[:nw]] = law.params.vector()
                S.creep_params = self._arr(params)
            if tr.carbody_z is not None:
                S.carbody_z = int(tr.carbody_z)
            if tr.carbody_theta is not None:
                S.carbody_theta = int(tr.carbody_theta)
        if not b.uniform:
            self._general(S, kappa, zeta)
        if self.active_set_in_c:
            self._impact(S)
        S.bw_max = self._bandwidth_bound(code)
        return S

    def _one_span(self, S: Any, nm: Newmark, kappa: float, zeta: float, code: int, classic: bool) -> None:
        """The setup of the paper's bridge: one span's matrices serve every span."""
        m, ref = self.model, self.reference
        b, tr, s = m.bridge, m.train, m.settings
        S.rows = self._arr(
            c_solver_build.row_coefficients(
                b.element_length, tr.speed, s.time_step, kappa, zeta, b.rail_height
            )
        )
        if tr.acceleration != 0.0:  # the rows of each step's speed and acceleration
            S.rows_va = self._arr(
                c_solver_build.row_coefficients_changing_speed(
                    b.element_length, s.time_step, kappa, zeta, b.rail_height
                )
            )

        # one span
        k_hat = b.K + nm.a1 * b.C + nm.a0 * b.M
        sup = np.asarray(b.support_dofs)
        free = _band_order(k_hat, np.setdiff1d(np.arange(b.ndof), sup))
        S.nfree = free.size
        S.sup, S.free = self._arr(sup, np.int32), self._arr(free, np.int32)
        S.sup_vertical = self._arr(b.support_vertical.astype(np.int32), np.int32)
        S.sup_x = self._arr(b.support_x[0] - 0.0)
        ptr, idx, val = _csr(b.C)  # the damping rows of the plastic impact (impact.c)
        S.C_ptr, S.C_idx, S.C_val = self._arr(ptr, np.int32), self._arr(idx, np.int32), self._arr(val)
        union = (b.M != 0) | (b.C != 0)
        ptr, idx, _ = _csr(union.astype(float))
        rows = np.repeat(np.arange(b.ndof), np.diff(ptr))
        S.MC_ptr, S.MC_idx = self._arr(ptr, np.int32), self._arr(idx, np.int32)
        S.MC_m, S.MC_c = self._arr(b.M[rows, idx]), self._arr(b.C[rows, idx])
        S.CT = self._arr(b.CT)
        sup_rows = np.asarray(b.support_dofs)
        S.react_rows = self._arr(np.stack([b.M[sup_rows], b.C[sup_rows], b.K[sup_rows]]))
        band, p = _lower_band(k_hat)
        S.Khat_band, S.band_p = self._arr(band), p
        band_f, pf = _lower_band(k_hat[np.ix_(free, free)])
        S.Khat_ff_band, S.band_pf = self._arr(band_f), pf
        S.Khat_fs = self._arr(k_hat[np.ix_(free, sup)])
        if code == 0:
            S.S = self._arr(ref.bridge.S[0])
        em, xim = b.midspan_location()
        S.mid_first = 3 * em
        S.mid_w = self._arr(ShapeKernel(b.element_length)(np.array([xim]))[0][0])
        S.mid_u = self._arr(AxialShapeKernel()(np.array([xim]))[0])
        if code == 1:
            S.mG = self._arr(ref.mG[: b.nsupport])
        if classic:
            S.sG = self._arr(ref.sG[: b.nsupport])
            S.sC = float(ref.sC)

    def _impact(self, S: Any) -> None:
        """The plastic impact of landing wheels in C (impact.c): the NumPy stepper's constant
        matrices (``unilateral.Impact``), the generated shape tables ``N1, N2`` of every element
        length; for a bridge with links, the mass compliance's columns at the rigid links' ends and
        ``L S_M L^T`` in the C loop's link order (a spring passes no impulse: a zero column and an
        identity row that keeps its force at 0)."""
        import scipy.sparse as sps

        imp, b = self.reference.impact, self.model.bridge
        S.I_MinvW, S.I_MinvC, S.I_GV = self._arr(imp.MinvW), self._arr(imp.MinvC), self._arr(imp.GV)
        S.I_SM = self._arr(np.stack(imp.S_M.S))
        lengths = [b.element_length] if b.uniform else np.unique(b.span_element_length)  # g_rclass order
        shapes = np.array([[shape_tables(le)[k] for k in ("N1", "N2")] for le in lengths])
        assert shapes.shape[2] == c_solver_build.row_structure()[0] + 1  # the C loop's ROW_DEG
        S.I_shapes = self._arr(shapes)
        if b.uniform or not S.nlinks:
            return
        links, perm = self.reference.bridge.links, self.link_perm
        rigid = np.flatnonzero(~links.spring)
        col_a, col_b = np.zeros((len(links), b.ndof)), np.zeros((len(links), b.ndof))
        A = sps.diags(links.spring.astype(float)).tocsr()
        if imp.S_M.nlinks:  # the rigid links (S_M's own subset, in order), placed among all links
            col_a[rigid], col_b[rigid] = imp.S_M.col_a, imp.S_M.col_b
            E = sps.csr_matrix(
                (np.ones(rigid.size), (rigid, np.arange(rigid.size))), shape=(len(links), rigid.size)
            )
            A = A + E @ imp.S_M.A @ E.T
        band, p = _lower_band(A.tocsr()[perm][:, perm])
        full = np.zeros((len(links), S.band_links + 1))
        full[:, : p + 1] = band
        S.I_lk_col_a, S.I_lk_col_b = self._arr(col_a[perm]), self._arr(col_b[perm])
        S.I_lk_A = self._arr(full)

    def _general(self, S: Any, kappa: float, zeta: float) -> None:
        """The setup of a bridge of substructures (substructures.c; localized-dynamic only)."""
        m, ref = self.model, self.reference
        b, tr, s = m.bridge, m.train, m.settings
        comp = ref.bridge
        nd = b.ndof
        S.general, S.nsub, S.nkind, S.ns = 1, b.nsub, len(b.kinds), 3
        S.g_kind = self._arr(b.kind, np.int32)
        S.g_line_x = self._arr(b.line_x)
        S.g_inv_el = self._arr(1.0 / b.span_element_length)
        # one contact-row table per element length (svbi.runtime.model.contact_rows.SpanPolynomials)
        lengths, rclass = np.unique(b.span_element_length, return_inverse=True)
        S.nrclass, S.g_rclass = len(lengths), self._arr(rclass, np.int32)
        build = c_solver_build
        S.rows = self._arr(
            np.stack(
                [
                    build.row_coefficients(le, tr.speed, s.time_step, kappa, zeta, b.rail_height)
                    for le in lengths
                ]
            )
        )
        if tr.acceleration != 0.0:
            S.rows_va = self._arr(
                np.stack(
                    [
                        build.row_coefficients_changing_speed(le, s.time_step, kappa, zeta, b.rail_height)
                        for le in lengths
                    ]
                )
            )
        S.g_S = self._arr(np.stack(comp.S))
        # every kind's K^ on the DOFs no support holds, banded (the predictor solves with its factor)
        nm = Newmark(s.time_step)
        nfree, frees, pfs, bands, kfs = [], np.zeros((len(b.kinds), nd), dtype=np.int32), [], [], []
        for i, k in enumerate(b.kinds):
            k_hat = nm.effective(k.K, k.C, k.M)
            held = k.support_dofs[k.support_active]
            free = _band_order(k_hat, np.setdiff1d(np.arange(nd), held))
            band, pf = _lower_band(k_hat[np.ix_(free, free)])
            nfree.append(free.size)
            frees[i, : free.size] = free
            pfs.append(pf)
            bands.append(band.ravel())
            fs = np.zeros((nd, 3))
            fs[: free.size][:, k.support_active] = k_hat[np.ix_(free, held)]
            kfs.append(fs)
        S.g_nfree, S.g_free = self._arr(nfree, np.int32), self._arr(frees, np.int32)
        S.g_pf, S.g_kfs = self._arr(pfs, np.int32), self._arr(np.stack(kfs))
        S.g_kff_ptr = self._arr(np.concatenate([[0], np.cumsum([x.size for x in bands])]), np.int32)
        S.g_kff = self._arr(np.concatenate(bands))
        self.kff_size = sum(x.size for x in bands)
        ptrs, idxs, vals = [], [], []
        count = 0
        for k in b.kinds:  # the union pattern of M, C and K of every kind, CSR with absolute pointers
            ptr, idx, _ = _csr(((k.M != 0) | (k.C != 0) | (k.K != 0)).astype(float))
            rows = np.repeat(np.arange(nd), np.diff(ptr))
            ptrs.append(ptr + count)
            idxs.append(idx)
            vals.append(np.stack([k.M[rows, idx], k.C[rows, idx], k.K[rows, idx]]))
            count += idx.size
        S.g_mck_ptr = self._arr(np.concatenate(ptrs), np.int32)
        S.g_mck_idx = self._arr(np.concatenate(idxs), np.int32)
        mck = np.concatenate(vals, axis=1)
        S.g_m, S.g_c, S.g_k = self._arr(mck[0]), self._arr(mck[1]), self._arr(mck[2])
        ct = b.CT_map.tocsr()
        S.g_ct_ptr, S.g_ct_idx = self._arr(ct.indptr, np.int32), self._arr(ct.indices, np.int32)
        S.g_ct_val = self._arr(ct.data)
        S.g_slot_dof = self._arr(b.support_dof.ravel(), np.int32)
        S.g_slot_active = self._arr(b.support_active.ravel().astype(np.int32), np.int32)
        S.g_slot_comp = self._arr(b.support_component.ravel(), np.int32)
        S.g_slot_x = self._arr(b.support_x_all.ravel())
        table = b.support_table
        S.nact, S.g_act_slot = len(table.flat), self._arr(table.flat, np.int32)
        # the (sub, dof) pairs that share each active support's global DOF, support after support
        flat = b.global_dof.ravel()
        rank = np.full(b.nglobal, -1)
        rank[b.support_global] = np.arange(len(b.support_global))
        members = np.flatnonzero(rank[flat] >= 0)
        members = members[np.argsort(rank[flat[members]], kind="stable")]
        counts = np.bincount(rank[flat[members]], minlength=len(b.support_global))
        S.g_rx_ptr = self._arr(np.concatenate([[0], np.cumsum(counts)]), np.int32)
        S.g_rx_sub, S.g_rx_dof = self._arr(members // nd, np.int32), self._arr(members % nd, np.int32)
        em, xim = b.midspan_location()
        S.mid_first = 3 * em
        S.g_mid_w = self._arr(
            ShapeKernel(b.contact_element_length)(np.full(b.spans, xim), np.arange(b.spans))[0]
        )
        S.mid_u = self._arr(AxialShapeKernel()(np.array([xim]))[0])
        S.nlinks = comp.nlinks
        self.setup_links, self.link_x = comp.nlinks, np.zeros(0)
        if comp.nlinks:
            L = comp.links
            # links in track order (front to back) at their support lines: end a is on a span
            node_x = b.span_starts[L.a_sub] + (L.a_dof // 3) * b.span_element_length[L.a_sub]
            x = b.line_x[np.abs(b.line_x[:, None] - node_x[None, :]).argmin(axis=0)]
            perm = np.argsort(-x, kind="stable")
            S.g_lk_a_sub = self._arr(L.a_sub[perm], np.int32)
            S.g_lk_a_dof = self._arr(L.a_dof[perm], np.int32)
            S.g_lk_b_sub = self._arr(L.b_sub[perm], np.int32)
            S.g_lk_b_dof = self._arr(L.b_dof[perm], np.int32)
            S.g_lk_spring = self._arr(L.spring[perm].astype(np.int32), np.int32)
            S.g_lk_x = self._arr(x[perm])
            self.link_x, self.link_perm = x, perm
            S.g_lk_col_a, S.g_lk_col_b = self._arr(comp.col_a[perm]), self._arr(comp.col_b[perm])
            band, p = _lower_band(comp.A.tocsr()[perm][:, perm])
            S.g_lk_A, S.band_links = self._arr(band), p
            touching = [
                np.flatnonzero((L.a_sub[perm] == sub) | (L.b_sub[perm] == sub)) for sub in range(b.nsub)
            ]
            S.g_sl_ptr = self._arr(np.concatenate([[0], np.cumsum([t.size for t in touching])]), np.int32)
            S.g_sl_link = self._arr(np.concatenate(touching), np.int32)
        else:
            S.g_sl_ptr = self._arr(np.zeros(b.nsub + 1), np.int32)

    def _bandwidth_bound(self, code: int) -> int:
        """An upper bound of the interface half bandwidth over the whole run (from the geometry)."""
        b, tr = self.model.bridge, self.model.train
        nc = tr.contacts
        extent = float(np.ptp(tr.vehicle.wheel_offsets)) if not tr.moving_load and nc else 0.0
        if not b.uniform:  # contacts and links (substructures.c: order_and_bandwidth)
            nl = int(self.setup_links)
            line = np.searchsorted(b.line_x, self.link_x)  # link_x: exactly on its line
            per_line = int(np.bincount(line, minlength=b.spans + 1).max(initial=0))
            lines = int(extent // b.span_lengths.min()) + 2
            m = max(
                _window_count(tr.offsets, float(b.span_lengths.max())) + 2 * per_line,
                _window_count(tr.offsets, extent) + per_line * lines,
            )
            return max(1, min(m + 2, max(nc + nl - 1, 1)))
        width = max(b.span_length, extent)
        m = _window_count(tr.offsets, width)
        if code == 0:
            return max(1, min(max(m, tr.wheels), max(nc - 1, 1)))
        per = 0 if tr.moving_load else (2 if code == 1 else 1)
        supports = b.nsupport * (int(width // b.span_length) + 3)
        nmult = per * nc + b.spans * b.nsupport
        return max(1, min(per * (m + tr.wheels) + supports + 2, nmult - 1))

    # ----------------------------------------------------------------------------------------------
    def _outputs(self, recorder: Any) -> Any:
        d = recorder.data
        out = c_solver_build.Outputs(row=recorder.count, nout=recorder.nout)
        for name in loop_abi.OUTPUT_NAMES:
            setattr(out, name, c_solver_build.pointer(d.get(name)))
        out.forces = c_solver_build.pointer(recorder.forces)
        if self.active_set_in_c:
            if recorder.in_contact is None:
                recorder.in_contact = np.ones(recorder.forces.shape, dtype=bool)
            out.contact_state = c_solver_build.pointer(d["contact_state"])
            out.wheel_uplift = c_solver_build.pointer(d["wheel_uplift"])
            out.contact_steps = c_solver_build.pointer(recorder.in_contact)
        return out

    def _call(self, out: Any, n0: int, count: int) -> int:
        self.excitation.fill(n0, count)
        return self.library.run(
            ctypes.byref(self.setup),
            ctypes.byref(self.cstate),
            ctypes.byref(self.excitation.struct),
            ctypes.byref(out),
            self.work.ctypes.data,
            self.iwork.ctypes.data,
            n0,
            count,
            ctypes.byref(self.info),
        )

    def run_loop(self, recorder: Any, guard: Any, bar: Any = None, chunk: int | None = None) -> None:
        """Run every step, writing into ``recorder``; raises ``simulate.Diverged`` like the NumPy loop.

        Unilateral contact (docs/method.md section 12): localized-dynamic keeps the per-wheel active
        set in C (lift-offs, flights, landings and their impact) and stops only at a step whose
        active set does not settle (``STATUS_EVENT``); the coupled methods run the bilateral step, so
        a chunk in which a contact force went tensile is not valid. Either way the chunk is rolled
        back, C redoes (bit for bit) the steps before the event, and the NumPy stepper of the same
        method (same state, multipliers and recorder) takes that step (localized) or the steps from
        the tensile one until every wheel has been on its rail, with no change of the active set, for
        ``HANDBACK_STEPS`` steps (coupled); the C loop goes on from there.
        """
        steps = self.model.settings.steps
        self.setup.force_limit = float(guard.force_limit)
        out = self._outputs(recorder)
        hybrid = self.unilateral
        n = 0
        size = chunk or 64
        while n < steps:
            count = min(size, steps - n)
            if self.excitation.streamed:
                count = min(count, STREAM_CHUNK)
            snap = self._snapshot(recorder) if hybrid else None
            t0 = time.perf_counter()
            status = self._call(out, n, count)
            elapsed = time.perf_counter() - t0
            done_before = recorder.steps_done
            recorder.count = int(out.row)
            recorder.steps_done = int(self.info.steps_done)
            self.state.t = self.cstate.t
            if self.active_set_in_c:
                hit = (int(self.info.step) + 1, -1) if status == loop_abi.STATUS_EVENT else None
            else:
                hit = self._tensile(recorder, done_before) if snap is not None else None
            if hit is not None:
                # back to the chunk's start; C redoes (bit for bit) the steps before the tensile
                # one, NumPy takes the steps from there
                self._restore(snap, recorder)
                good = hit[0] - 1 - n
                if good > 0:
                    out.row = recorder.count
                    status = self._call(out, n, good)
                    recorder.count = int(out.row)
                    recorder.steps_done = int(self.info.steps_done)
                    self.state.t = self.cstate.t
                    if status:
                        self._stop(status, recorder, guard)
                    if bar is not None:
                        bar.update(good)
                    n += good
                n = self._numpy_steps(n, recorder, guard, bar)
                out.row = recorder.count
                size = chunk or 16  # a short chunk first: the next event may be near
                continue
            if status:
                self._stop(status, recorder, guard)
            if bar is not None:
                bar.update(count)
            n += count
            if chunk is None:  # aim at CHUNK_SECONDS per call
                size = int(min(max(size * CHUNK_SECONDS / max(elapsed, 1e-6), 16), 1 << 20))

    # ----------------------------------------------------------------------------------------------
    # unilateral contact on the C loop
    STATE_NAMES = ("uV", "vV", "aV", "uB", "vB", "aB", "ug", "vg", "ag", "P", "PV", "creepage", "creep_force")

    def _snapshot(self, recorder: Any) -> dict[str, Any]:
        st = self.state
        snap: dict[str, Any] = {k: np.array(getattr(st, k)) for k in self.STATE_NAMES}
        snap["_rec"] = (recorder.count, recorder.steps_done, st.t)
        snap["_lam"] = {k: v.copy() for k, v in self.lam.items()}
        if self.active_set_in_c:  # the C loop releases wheels itself
            snap["_in_contact"] = self.reference.act.in_contact.copy()
        return snap

    def _restore(self, snap: dict[str, Any], recorder: Any) -> None:
        st = self.state
        for k in self.STATE_NAMES:
            np.copyto(self.c_arrays[k], snap[k])
            setattr(st, k, self.c_arrays[k])
        recorder.count, recorder.steps_done, st.t = snap["_rec"]
        self.cstate.t = st.t
        for k, v in snap["_lam"].items():
            np.copyto(self.lam[k], v)
        if "_in_contact" in snap:
            np.copyto(self.reference.act.in_contact, snap["_in_contact"])

    def _multipliers_to_reference(self) -> None:
        """coupled-dynamic: the C loop's dynamic multipliers (lambda, lambda', lambda'') to the NumPy
        stepper, which keeps them as three arrays each (the other methods have none)."""
        for key, arr in self.lam.items():
            triple = getattr(self.reference, key, None)
            if triple is not None:
                shape = np.shape(triple[0])
                for k in range(3):
                    triple[k] = arr[k].reshape(shape).copy()

    def _multipliers_from_reference(self) -> None:
        for key, arr in self.lam.items():
            triple = getattr(self.reference, key, None)
            if triple is not None:
                for k in range(3):
                    arr[k] = np.asarray(triple[k], dtype=float).reshape(-1)

    def _numpy_steps(self, n: int, recorder: Any, guard: Any, bar: Any) -> int:
        """NumPy steps of the run's method from step n: the event step alone (localized-dynamic,
        whose C loop keeps the active set), or until the wheels have been quietly on their rails for
        HANDBACK_STEPS steps (the coupled methods); returns the next step. The state and the multipliers go
        back to C's arrays."""
        ref, st = self.reference, self.state
        act = ref.act
        steps, every = self.model.settings.steps, self.model.settings.output_every
        aux_is_wheel = self.method == "coupled-classic"
        self._multipliers_to_reference()
        quiet = 0
        while n < steps:
            st = ref.step(n)
            guard.check_finite(st)
            recorder.force(n + 1, st.P, st.contact_state)
            if (n + 1) % every == 0:
                gaps = recorder.record(st, ref.contacts, aux_is_wheel)
                guard.check_gaps(st, gaps)
            if bar is not None:
                bar.update(1)
            n += 1
            self.numpy_steps += 1
            if self.active_set_in_c:  # C takes every step that changes no wheel's state
                break
            quiet = quiet + 1 if (act.all_in and act.in_contact.all()) else 0
            if quiet >= HANDBACK_STEPS:
                break
        for k in self.STATE_NAMES:
            np.copyto(self.c_arrays[k], getattr(st, k))
            setattr(st, k, self.c_arrays[k])
        self.cstate.t = st.t
        self._multipliers_from_reference()
        self.handovers += 1
        return n

    def _tensile(self, recorder: Any, done_before: int) -> tuple[int, int] | None:
        """(step, contact) of the first tensile contact force written since ``done_before``."""
        f = recorder.forces[done_before + 1 : recorder.steps_done + 1]
        if f.size and f.min() < 0.0:
            row, j = np.argwhere(f < 0.0)[0]
            return done_before + 1 + int(row), int(j)
        return None

    def _stop(self, status: int, recorder: Any, guard: Any) -> None:
        info, st = self.info, self.state
        st.t = self.cstate.t
        if status in (loop_abi.STATUS_NOT_FINITE, loop_abi.STATUS_FORCE_LIMIT):
            guard.check_finite(st)  # raises Diverged with the NumPy backend's message
        elif status == loop_abi.STATUS_GAP_LIMIT:
            k = recorder.count - 1
            gaps = {
                "support": recorder.data["gap_support"][k],
                "vehicle": recorder.data["gap_vehicle"][k].reshape(-1),
                "bridge": recorder.data["gap_bridge"][k].reshape(-1),
            }
            if "contact_state" in recorder.data:  # the state of that row (airborne wheels' gaps)
                st.contact_state = recorder.data["contact_state"][k].reshape(-1).astype(bool)
            guard.check_gaps(st, gaps)
        elif status == loop_abi.STATUS_SINGULAR:
            raise np.linalg.LinAlgError(
                f"singular interface matrix at t = {st.t:.6g} s (C loop, step {info.step})"
            )
        name = loop_abi.STATUS_NAMES.get(status, str(status))
        if status in (
            loop_abi.STATUS_NOT_FINITE,
            loop_abi.STATUS_FORCE_LIMIT,
            loop_abi.STATUS_GAP_LIMIT,
        ):
            raise Diverged(f"run diverged at t = {st.t:.6g} s: {name} ({info.value:.4g})")
        raise CLoopError(f"C loop stopped at t = {st.t:.6g} s (step {info.step}): {name}")

    # ----------------------------------------------------------------------------------------------
    def step(self, n: int) -> State:
        """One step through the C loop (for callers that drive the loop themselves)."""
        s = self.model.settings
        if "forces" not in self._scratch:
            nc = self.model.train.contacts
            self._scratch["forces"] = np.zeros((s.steps + 2, nc))
        out = c_solver_build.Outputs(row=0, nout=0, forces=self._scratch["forces"].ctypes.data)
        every = self.setup.output_every
        self.setup.output_every = 1 << 30
        try:
            status = self._call(out, n, 1)
        finally:
            self.setup.output_every = every
        self.state.t = self.cstate.t
        if status:
            name = loop_abi.STATUS_NAMES.get(status, str(status))
            if status not in (loop_abi.STATUS_NOT_FINITE, loop_abi.STATUS_FORCE_LIMIT):
                raise CLoopError(f"C loop stopped at t = {self.state.t:.6g} s: {name}")
        self.contacts = self.model.contacts(self.state.t)
        return self.state


# --------------------------------------------------------------------------------------------------
# registration


_FALLBACK_WARNED = False


def c_stepper(method: str) -> Callable[[Model, State], Any]:
    """Stepper factory of the ``"c"`` backend; falls back to NumPy (one warning) without a compiler."""

    def make(model: Model, state: State) -> Any:
        global _FALLBACK_WARNED
        try:
            c_solver_build.load_loop(c_solver_build.loop_spec(model.train))
        except CompilerError as exc:
            if not _FALLBACK_WARNED:
                _FALLBACK_WARNED = True
                warnings.warn(
                    f"solver.backend = 'c': no working C compiler ({str(exc).splitlines()[0]}); "
                    "running the NumPy backend instead (same results, slower). Install a C "
                    "compiler or set CC.",
                    BackendFallback,
                    stacklevel=3,
                )
            stepper = numpy_steppers()[method](model, state)
            stepper.backend = "numpy"
            return stepper
        return CStepper(model, state, method)

    make.__name__ = f"c_{method.replace('-', '_')}"
    return make


def steppers() -> dict[str, Callable[[Model, State], Any]]:
    """The ``"c"`` backend's steppers by method (``svbi.runtime.backends.registry``)."""
    return {m: c_stepper(m) for m in loop_abi.METHOD_CODES}

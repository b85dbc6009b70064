"""Results: the xarray Dataset of docs/design.md section 7, and its atomic NetCDF file.

A :class:`Recorder` stores every ``output_every``-th step while the run goes on. Contact forces are
also kept at *every* step, because the filtered force ``contact_force_filtered`` must be computed at
the full rate: the raw force has impulses at the slope kinks of span joints and bridge ends whose
peaks scale as 1/dt (docs/design.md section 3), and subsampling them first would alias. The filter is a
4th-order Butterworth low-pass applied forwards and backwards (zero phase), cutoff
``output.force_filter_hz`` (20 Hz by default), in the spirit of EN 14363 wheel-force processing.
"""

from __future__ import annotations

import importlib
import importlib.util
import os
import threading
from collections.abc import Collection, Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..methods.reactions import support_reactions
from ..methods.unilateral import ContactWarning
from ..model.contact_rows import AxialShapeKernel, ShapeKernel
from ..model.system import Contacts, Model, State
from . import force_filter as zero_phase
from .atomic import write_atomic
from .body_outputs import body_variables
from .force_filter import compiled, design, sosfiltfilt_rows

if TYPE_CHECKING:
    import xarray as xr

FILTER_ORDER = 4


class ContactInvariantError(RuntimeError):
    """A wheel in contact with a tensile force: a defect of svbi, reported, never written as a result."""


FILTER_BLOCK = 1 << 22  # samples (32 MiB) of forces filtered at once
FILTER_THREADS = max(1, int(os.environ.get("SVBI_FILTER_THREADS", min(2, os.cpu_count() or 1))))
"""Blocks of the force filter filtered at once: 2 (a second core while the run has it), or
``SVBI_FILTER_THREADS`` (a sweep's workers share the cores: ``sweep.worker_environment``)."""


NETCDF_WRITERS = (("netcdf4", "netCDF4"), ("h5netcdf", "h5netcdf"))
"""xarray's writers for results files (engine, module), in order of preference: the netCDF-C library
(``netCDF4``) builds the paper example's 42 MB image in about 0.04 s, where h5netcdf, whose
per-variable bookkeeping runs in Python through h5py, takes about 0.12 s (0.17 s on a process's
first write). Both write the same NetCDF-4 (HDF5) format; readers may use either engine. h5netcdf
writes when netCDF4 cannot be imported."""


def netcdf_engine() -> str:
    """The engine of the first writer of :data:`NETCDF_WRITERS` that imports."""
    for engine, module in NETCDF_WRITERS:
        try:
            importlib.import_module(module)
        except ImportError:
            continue
        return engine
    raise ImportError("no NetCDF-4 writer: install netCDF4 or h5netcdf")


class ImportAhead:
    """Imports modules in a background thread: the ones the results need only after the time loop.

    ``scipy.signal`` (the force filter), xarray (the Dataset) and the NetCDF writer take about a
    second to import, with nothing to do with the loop. A compiled loop runs in C through ctypes,
    which releases the GIL, so on a second core these imports overlap it instead of following it
    (``simulate`` starts this just before a compiled loop). ``optional`` modules (the writer's) are
    a head start only: their import errors are not reported, so that a writer that cannot load
    does not lose the run's results (``write_netcdf`` falls back to h5netcdf). :meth:`join` waits
    for the thread and re-raises its exception, if any, in the caller's thread; call it before using
    the modules. The imports are the ordinary ones (``importlib.import_module``): Python's
    per-module import locks make a later ``import`` of the same module in the main thread wait for
    the background one.
    """

    def __init__(self, names: Iterable[str], optional: Iterable[str] = ()) -> None:
        self.names = tuple(names)
        self.optional = tuple(optional)
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="svbi-import-ahead", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        try:
            for name in self.names:
                importlib.import_module(name)
        except BaseException as exc:  # noqa: BLE001 - handed to the caller's thread by join()
            self._error = exc
            return
        for name in self.optional:  # a head start only: whoever needs it imports it again
            try:
                importlib.import_module(name)
            except Exception:  # noqa: BLE001, S112 - e.g. a broken writer, which has a fallback
                continue

    def join(self) -> None:
        """Wait until every module is imported; raise here what the background import raised."""
        self._thread.join()
        if self._error is not None:
            error, self._error = self._error, None
            raise error


def stored_columns(
    spans: int, supports: int, uniform: bool, cars: int, wheels: int, vehicle_dofs: int, piers: int = 0
) -> dict[str, tuple[tuple[int, ...], type]]:
    """What the recorder stores per output row: name -> (shape of one row, dtype).

    The one description of the stored arrays: :class:`Recorder` allocates from it and
    ``resources.estimate_memory`` sizes a run from it before anything is built.
    """
    ground = () if uniform else (supports,)
    per_wheel = (cars, wheels)
    f = np.float64
    return {
        "time": ((), f),
        "midspan_uz": ((spans,), f),
        "midspan_ux": ((spans,), f),
        "deck_acceleration": ((spans,), f),
        "end_rotation": ((spans, 2), f),
        **({"pier_top_ux": ((piers,), f)} if piers else {}),
        "ground_uz": (ground, f),
        "ground_ux": (ground, f),
        "contact_force": (per_wheel, f),
        "creep_force": (per_wheel, f),
        "creepage": (per_wheel, f),
        "irregularity": (per_wheel, f),
        "carbody_uz": ((cars,), f),
        "carbody_az": ((cars,), f),
        "carbody_pitch": ((cars,), f),
        # every vehicle DOF, for the body_* variables (both backends write these rows)
        "vehicle_u": ((cars, vehicle_dofs), f),
        "vehicle_a": ((cars, vehicle_dofs), f),
        "gap_vehicle": (per_wheel, f),
        "gap_bridge": (per_wheel, f),
        "gap_support": ((supports,), f),
        "support_reaction": ((supports,), f),
        "contact_state": (per_wheel, np.int8),
        "wheel_uplift": (per_wheel, f),
    }


class Recorder:
    """Collects the output variables of one run."""

    def __init__(self, model: Model) -> None:
        self.model = model
        b, tr, s = model.bridge, model.train, model.settings
        self.nout = s.steps // s.output_every + 1
        n = self.nout
        self.count = 0
        self.cars, self.wheels = tr.cars, tr.wheels
        em, xim = b.midspan_location()
        self.mid_dofs = slice(3 * em, 3 * em + 6)
        spans = np.arange(b.spans)
        self.mid_w = ShapeKernel(b.contact_element_length)(np.full(b.spans, xim), spans)[0]
        """Midspan row of every span (their element lengths differ when the spans do)."""
        self.mid_u = AxialShapeKernel()(np.array([xim]))[0]
        self.shape = ShapeKernel(b.contact_element_length)
        self.uniform = model.ground.uniform
        self.supports = b.support_table
        nsup = len(self.supports.flat)
        self.piers = b.nsub - b.spans
        self.data: dict[str, np.ndarray] = {
            name: (np.ones if name == "contact_state" else np.zeros)((n, *shape), dtype=dtype)
            for name, (shape, dtype) in stored_columns(
                spans=b.spans,
                supports=nsup,
                uniform=self.uniform,
                cars=tr.cars,
                wheels=tr.wheels,
                vehicle_dofs=tr.vehicle.ndof,
                piers=self.piers,
            ).items()
        }
        self.forces = np.zeros((s.steps + 1, tr.contacts))
        self.in_contact: np.ndarray | None = None
        """Contact state at every step (unilateral runs; None: every wheel always on its rail)."""
        self.steps_done = 0

    def modules_after_loop(self) -> list[str]:
        """What :meth:`dataset` will import: scipy.signal when the forces are filtered, xarray, and
        dask.array when dask is installed (xarray imports it itself when it builds a Dataset: its
        ``as_compatible_data`` checks every array against ``dask.array.Array``)."""
        names = ["scipy.signal"] if self._filters() and not self._design_cached() else []
        names.append("xarray")
        if importlib.util.find_spec("dask") is not None:
            names.append("dask.array")
        return names

    def _design_cached(self) -> bool:
        """Whether the force filter's design is in the cache and the compiled filter is built, so
        that filtering imports no ``scipy.signal`` (``zero_phase.design``)."""
        cutoff, fs = self.model.settings.force_filter_hz, 1.0 / self.model.dt
        return zero_phase.design_cached(FILTER_ORDER, cutoff, fs) and zero_phase.compiled()

    def _filters(self) -> bool:
        """Whether the contact forces get the low-pass filter (a cutoff below the Nyquist rate)."""
        return self.model.settings.force_filter_hz < 0.5 / self.model.dt

    # ----------------------------------------------------------------------------------------------
    def force(self, n: int, P: np.ndarray, contact_state: np.ndarray | None = None) -> None:
        """Contact forces of step n (every step, for the filter) and, in a unilateral run, which
        wheels are on their rail (every step, for the flight statistics)."""
        self.forces[n] = P
        self.steps_done = n
        if contact_state is not None:
            if self.in_contact is None:
                self.in_contact = np.ones(self.forces.shape, dtype=bool)
            self.in_contact[n] = contact_state

    def record(self, state: State, contacts: Contacts, aux_is_wheel: bool = False) -> dict[str, np.ndarray]:
        """Store one output row; returns the gaps (used by the divergence guard)."""
        m, k, d = self.model, self.count, self.data
        b, tr = m.bridge, m.train
        d["time"][k] = state.t
        ns = b.spans
        mid = state.uB[:ns, self.mid_dofs]
        d["midspan_uz"][k] = np.einsum("ij,ij->i", mid, self.mid_w)
        d["midspan_ux"][k] = mid @ self.mid_u
        d["deck_acceleration"][k] = np.einsum("ij,ij->i", state.aB[:ns, self.mid_dofs], self.mid_w)
        d["end_rotation"][k] = state.uB[:ns, [2, b.ndof - 1]]  # theta of the first and last node
        if self.piers:
            d["pier_top_ux"][k] = state.uB[ns:, 3 * b.elements]
        d["ground_uz"][k], d["ground_ux"][k] = m.ground.recorded(state.t, b)
        shape = (tr.cars, tr.wheels)
        d["contact_force"][k] = state.P.reshape(shape)
        d["irregularity"][k] = contacts.r.reshape(shape)
        if state.creep_force is not None:
            d["creep_force"][k] = state.creep_force.reshape(shape)
            d["creepage"][k] = state.creepage.reshape(shape)
        q, _, _ = m.supports(state.t)
        gaps: dict[str, np.ndarray] = {
            "support": (q - b.at_supports(state.uB)).reshape(-1)[self.supports.flat]
        }
        d["gap_support"][k] = gaps["support"]
        d["support_reaction"][k] = support_reactions(m, state, contacts, state.P).reshape(-1)
        if tr.moving_load:
            gaps["vehicle"] = gaps["bridge"] = np.zeros(tr.contacts)
        else:
            wheel = (state.uV @ tr.W).reshape(-1)
            aux = wheel if aux_is_wheel else state.ug
            (N0,) = self.shape(contacts.loc.xi, contacts.loc.span)
            idx = contacts.element_dofs()
            rail_bridge = np.einsum("ij,ij->i", N0, state.uB[contacts.loc.span[:, None], idx])
            rail = np.where(contacts.on, rail_bridge, contacts.q) + contacts.r
            gaps["vehicle"] = wheel - aux
            gaps["bridge"] = aux - rail
            cz, ct = tr.carbody_z, tr.carbody_theta
            # vehicle DOFs are already measured from static equilibrium on rigid level track
            if cz is not None:
                d["carbody_uz"][k] = state.uV[:, cz]
                d["carbody_az"][k] = state.aV[:, cz]
            if ct is not None:
                d["carbody_pitch"][k] = state.uV[:, ct]
            d["vehicle_u"][k] = state.uV
            d["vehicle_a"][k] = state.aV
        d["gap_vehicle"][k] = gaps["vehicle"].reshape(shape)
        d["gap_bridge"][k] = gaps["bridge"].reshape(shape)
        if state.contact_state is not None:  # uplift: the wheel-rail gap of an airborne wheel
            cs = state.contact_state.reshape(shape)
            d["contact_state"][k] = cs
            # clipped at 0: a wheel that leaves at this step lies within its contact row's
            # constraint violation (gap_bridge) of the rail (docs/method.md section 12)
            d["wheel_uplift"][k] = np.where(cs, 0.0, np.maximum(gaps["bridge"].reshape(shape), 0.0))
        self.count += 1
        return gaps

    # ----------------------------------------------------------------------------------------------
    def dataset(self, attrs: dict[str, Any], variables: Collection[str] | None = None) -> xr.Dataset:
        """The Dataset of the rows recorded so far: every variable, or only ``variables`` (a sweep
        keeps what its metrics need, ``svbi.runtime.study.metrics.METRIC_INPUTS``)."""
        m, k = self.model, self.count
        b, tr = m.bridge, m.train
        d = {name: arr[:k] for name, arr in self.data.items()}
        u, a = d.pop("vehicle_u"), d.pop("vehicle_a")
        wanted = variables is None or any(v.startswith("body_") for v in variables)
        bodies, body_vars = body_variables(tr.vehicle.dof_names, u, a) if wanted else ([], {})
        filtered = self._filtered(k)
        if self.in_contact is not None:
            filtered = self._unilateral_filtered(filtered, k)
        static = self._static_loads()
        with np.errstate(divide="ignore", invalid="ignore"):
            unloading = np.where(static > 0, 1.0 - filtered / static, 0.0)
        attrs = {**attrs, **self._contact_summary(d, unloading)}
        per_wheel = ("time", "car", "wheel")
        support_dims = ("time",) if self.uniform else ("time", "support")
        ground_z, ground_x = self._ground_under_spans(d["ground_uz"], d["ground_ux"])
        data_vars = {
            "midspan_uz": (
                ("time", "span"),
                d["midspan_uz"],
                _a("m", "absolute vertical displacement at midspan"),
            ),
            "midspan_ux": (
                ("time", "span"),
                d["midspan_ux"],
                _a("m", "absolute longitudinal displacement of the neutral axis at midspan"),
            ),
            "midspan_uz_rel": (
                ("time", "span"),
                d["midspan_uz"] - ground_z,
                _a(
                    "m",
                    "vertical displacement at midspan relative to the ground under the span: less the "
                    "mean of the ground at its two vertical bearings (the span's rigid-body motion)",
                ),
            ),
            "midspan_ux_rel": (
                ("time", "span"),
                d["midspan_ux"] - ground_x,
                _a(
                    "m",
                    "longitudinal displacement at midspan relative to the ground at the span's fixed "
                    "bearing (which carries the deck along)",
                ),
            ),
            "deck_acceleration": (
                ("time", "span"),
                d["deck_acceleration"],
                _a("m/s^2", "absolute vertical acceleration at midspan (Newmark, unfiltered)"),
            ),
            "end_rotation": (
                ("time", "span", "end"),
                d["end_rotation"],
                _a("rad", "absolute rotation of the span's left and right end, counter-clockwise positive"),
            ),
            "ground_uz": (support_dims, d["ground_uz"], _a("m", "vertical ground displacement")),
            "ground_ux": (support_dims, d["ground_ux"], _a("m", "longitudinal ground displacement")),
            "contact_force": (
                per_wheel,
                d["contact_force"],
                _a("N", "normal wheel-rail force, compression positive (raw)"),
            ),
            "contact_force_filtered": (
                per_wheel,
                filtered,
                _a(
                    "N",
                    f"contact_force low-pass filtered: Butterworth order {FILTER_ORDER}, zero phase, "
                    f"cutoff {m.settings.force_filter_hz:g} Hz, at the full time-step rate",
                ),
            ),
            "creep_force": (
                per_wheel,
                d["creep_force"],
                _a("N", "longitudinal creep force on the wheel, +x forward (Eqs. 15-16)"),
            ),
            "creepage": (
                per_wheel,
                d["creepage"],
                _a("1", "longitudinal creepage: wheel minus rail velocity at the contact over v (Eq. 16)"),
            ),
            "irregularity": (
                per_wheel,
                d["irregularity"],
                _a("m", "vertical rail irregularity under the wheel, up positive (with its onset ramp)"),
            ),
            "carbody_uz": (
                ("time", "car"),
                d["carbody_uz"],
                _a("m", "car-body bounce from static equilibrium on rigid track"),
            ),
            "carbody_az": (
                ("time", "car"),
                d["carbody_az"],
                _a("m/s^2", "car-body absolute vertical acceleration"),
            ),
            "carbody_pitch": (
                ("time", "car"),
                d["carbody_pitch"],
                _a("rad", "car-body pitch from static equilibrium, front end up positive"),
            ),
            **body_vars,
            "gap_vehicle": (per_wheel, d["gap_vehicle"], _a("m", "wheel - auxiliary point gap (Eq. 18)")),
            "gap_bridge": (per_wheel, d["gap_bridge"], _a("m", "auxiliary point - rail gap (Eqs. 20-21)")),
            "gap_support": (("time", "support"), d["gap_support"], _a("m", "ground - support gap (Eq. 23)")),
            "support_reaction": (
                ("time", "support"),
                d["support_reaction"] + self.supports.dead_load,
                _a(
                    "N",
                    "force of each support constraint on the deck (support_component: its direction; "
                    "up or forward positive), the deck's own weight included",
                ),
            ),
            "contact_state": (
                per_wheel,
                d["contact_state"],
                _a("1", "1: wheel on its rail, 0: airborne (unilateral contact, docs/method.md section 12)"),
            ),
            "wheel_uplift": (
                per_wheel,
                d["wheel_uplift"],
                _a("m", "height of an airborne wheel's contact point above the rail (0 in contact)"),
            ),
            "unloading_ratio": (
                per_wheel,
                unloading,
                _a("1", "1 - contact_force_filtered / static wheel load on rigid track"),
            ),
        }
        coords = {
            "time": ("time", d["time"], _a("s", "time")),
            "car": ("car", np.arange(1, tr.cars + 1)),
            "wheel": ("wheel", np.arange(1, tr.wheels + 1)),
            "span": ("span", np.arange(1, b.spans + 1)),
            **({"body": ("body", np.array(bodies, dtype=object))} if bodies else {}),
            "end": ("end", np.array(["left", "right"], dtype=object)),
            "support": ("support", np.arange(1, len(self.supports.flat) + 1)),
            "support_x": ("support", self.supports.x, _a("m", "position of the support")),
            "support_span": (
                "support",
                np.where(self.supports.sub < b.spans, self.supports.sub + 1, 0),
                _a("1", "span whose bearing it holds (0: a pier base)"),
            ),
            "support_component": ("support", self.supports.component),
        }
        if tr.acceleration != 0.0:
            data_vars["train_speed"] = (
                ("time",),
                np.array([tr.speed_at(float(ti)) for ti in d["time"]]),
                _a("m/s", "the train's speed (train.acceleration: braking or accelerating)"),
            )
        if self.piers:
            coords["pier"] = ("pier", np.arange(1, self.piers + 1))
            coords["pier_line"] = ("pier", np.array([p.support for p in b.piers]), _a("1", "support line"))
            coords["support_pier"] = (
                "support",
                np.where(self.supports.sub >= b.spans, self.supports.sub - b.spans + 1, 0),
                _a("1", "pier whose base it holds (0: a span's bearing)"),
            )
            data_vars["pier_top_ux"] = (
                ("time", "pier"),
                d["pier_top_ux"],
                _a("m", "absolute longitudinal displacement of the pier top"),
            )
            data_vars["pier_drift"] = (
                ("time", "pier"),
                d["pier_top_ux"] - self._ground_under_piers(d["ground_ux"]),
                _a("m", "longitudinal displacement of the pier top relative to the ground at its base"),
            )
        if variables is not None:
            data_vars = {name: v for name, v in data_vars.items() if name in variables}
        import xarray as xr  # with pandas, 0.4 s of imports: needed only once the run is done

        return xr.Dataset(data_vars=data_vars, coords=coords, attrs=attrs)

    def _ground_under_spans(self, gz: np.ndarray, gx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The ground each span moves with as a rigid body (time x span): vertically, the mean of the
        ground at its two vertical bearings (a rigid simply supported span follows the line
        between them, at midspan their mean); longitudinally, the ground at its fixed bearing."""
        if self.uniform:
            return gz[:, None], gx[:, None]
        b = self.model.bridge
        if not b.uniform:
            return self._ground_under_general_spans()
        per_span = (gz.shape[0], b.spans, b.nsupport)
        vertical = b.support_vertical
        return (
            gz.reshape(per_span)[:, :, vertical].mean(axis=2),
            gx.reshape(per_span)[:, :, ~vertical].mean(axis=2),
        )

    def _ground_under_piers(self, gx: np.ndarray) -> np.ndarray:
        """Longitudinal ground motion at every pier base (time x pier)."""
        if self.uniform:
            return np.repeat(gx[:, None], self.piers, axis=1)
        b = self.model.bridge
        sup = self.supports
        cols = [
            int(np.flatnonzero((sup.sub == b.spans + i) & (sup.component == "longitudinal"))[0])
            for i in range(self.piers)
        ]
        return gx[:, cols]

    def _ground_under_general_spans(self) -> tuple[np.ndarray, np.ndarray]:
        """Continuous girders, piers: vertically the mean of the ground at the span's two support
        lines, longitudinally the ground at its girder's fixed line (evaluated at the stored times)."""
        m = self.model
        b = m.bridge
        t = self.data["time"][: self.count]
        fixed = []
        s0 = 0
        for g in b.girders:
            fixed += [s0 + g.fixed_support] * len(g.spans)
            s0 += len(g.spans)
        gz = np.zeros((len(t), b.spans))
        gx = np.zeros((len(t), b.spans))
        for i, ti in enumerate(t):
            (qz, _, _), (qx, _, _) = m.ground.motion(float(ti), b.line_x)
            gz[i] = 0.5 * (qz[:-1] + qz[1:])
            gx[i] = qx[fixed]
        return gz, gx

    def _static_loads(self) -> np.ndarray:
        tr = self.model.train
        loads = tr.axle_loads if tr.moving_load else tr.static_loads()
        return np.asarray(loads, dtype=float).reshape(tr.cars, tr.wheels)

    def _contact_summary(self, d: dict[str, np.ndarray], unloading: np.ndarray) -> dict[str, Any]:
        """Running-safety attributes: lift-offs and flights (from the contact state at every step),
        peak uplift and peak unloading ratio (at the stored steps), each with time, car and wheel.
        A bilateral run whose filtered force goes tensile warns (the rail pulled the wheel)."""
        m = self.model
        tr, dt = m.train, m.dt
        out: dict[str, Any] = {"contact_normal": m.settings.normal}
        t = d["time"]

        def where(arr: np.ndarray, prefix: str) -> None:
            if arr.size == 0:
                return
            i, c, w = np.unravel_index(int(np.argmax(arr)), arr.shape)
            out[f"{prefix}_time"] = float(t[i])
            out[f"{prefix}_car"] = int(c + 1)
            out[f"{prefix}_wheel"] = int(w + 1)

        n = self.steps_done + 1
        states = self.in_contact[:n] if self.in_contact is not None else None
        liftoffs, longest, at = 0, 0.0, (0.0, 0, 0)
        if states is not None and n > 1:
            off = ~states
            starts = off[1:] & ~off[:-1]
            liftoffs = int(starts.sum())
            for j in np.flatnonzero(off.any(axis=0)):  # runs of airborne steps, per wheel
                col = np.concatenate([[0], off[:, j].astype(np.int8), [0]])
                edges = np.flatnonzero(np.diff(col))
                begin, end = edges[::2], edges[1::2]
                lengths = end - begin
                r = int(np.argmax(lengths))
                if lengths[r] * dt > longest:
                    longest = float(lengths[r] * dt)
                    at = (begin[r] * dt, *divmod(int(j), tr.wheels))
        out["liftoffs"] = liftoffs
        out["longest_flight_s"] = longest
        out["airborne_time_s"] = float((~states).sum() * dt) if states is not None else 0.0
        if longest > 0:
            out["longest_flight_time"] = float(at[0])
            out["longest_flight_car"] = int(at[1]) + 1
            out["longest_flight_wheel"] = int(at[2]) + 1
        up = d["wheel_uplift"]
        out["peak_uplift_m"] = float(up.max(initial=0.0))
        where(up, "peak_uplift")
        out["peak_unloading_ratio"] = float(unloading.max(initial=-np.inf)) if unloading.size else 0.0
        where(unloading, "peak_unloading_ratio")
        if m.settings.normal == "bilateral" and not tr.moving_load and unloading.size:
            filtered = 1.0 - unloading  # in units of the static load
            if filtered.min() < 0:
                i, c, w = np.unravel_index(int(np.argmin(filtered)), filtered.shape)
                first = np.flatnonzero((filtered < 0).any(axis=(1, 2)))[0]
                c0, w0 = np.argwhere(filtered[first] < 0)[0]
                import warnings

                warnings.warn(
                    f"bilateral contact: the filtered contact force goes tensile (the rail pulls the "
                    f"wheel) first at t = {t[first]:.4g} s, car {c0 + 1}, wheel {w0 + 1}; lowest "
                    f"{filtered.min():.3g} x the static load at t = {t[i]:.4g} s, car {c + 1}, "
                    f'wheel {w + 1}. Use [contact] normal = "unilateral" to let wheels lift off',
                    ContactWarning,
                    stacklevel=4,
                )
        return out

    def _unilateral_filtered(self, filtered: np.ndarray, k: int) -> np.ndarray:
        """Check the contact invariant at every step, and keep the filtered force physical.

        A wheel in contact never carries a tensile force (the step's complementarity problem,
        ``svbi.runtime.methods.unilateral``): a sample that does is a defect of svbi, not a result, and
        stops the run. The zero-phase low-pass of a one-sided signal rings below zero after the
        impact spikes of a landing; a contact force is never tensile, so the filtered force is
        clipped at 0, and it is 0 while the wheel flies: a flying wheel is fully unloaded
        (``unloading_ratio`` = 1) (docs/method.md section 12).
        """
        tr = self.model.train
        n = self.steps_done + 1
        states = self.in_contact[:n]
        raw = self.forces[:n]
        bad = states & (raw < 0.0)
        if bad.any():
            i, j = np.argwhere(bad)[0]
            car, wheel = divmod(int(j), tr.wheels)
            raise ContactInvariantError(
                f"internal error: wheel {wheel + 1} of car {car + 1} is in contact with a tensile "
                f"force {raw[i, j]:.4g} N at t = {i * self.model.dt:.6g} s ({int(bad.sum())} such "
                "samples); the contact state must never allow this. Please report it with the scenario"
            )
        every = self.model.settings.output_every
        flying = ~states[::every][:k].reshape(filtered.shape)
        return np.where(flying, 0.0, np.maximum(filtered, 0.0))

    def _filtered(self, k: int) -> np.ndarray:
        m = self.model
        tr = m.train
        every = m.settings.output_every
        n = self.steps_done + 1
        raw = self.forces[:n]
        fs = 1.0 / m.dt
        fc = m.settings.force_filter_hz
        if n < 2 or not self._filters():
            return raw[::every][:k].reshape(-1, tr.cars, tr.wheels).copy()  # no view of the full-rate array
        sos, zi = design(FILTER_ORDER, fc, fs)  # SciPy's butter, cached: no scipy.signal import
        padlen = min(3 * (2 * len(sos) + 1), n - 1)
        rows = raw[::every][:k]
        out = np.empty_like(rows)
        # a few contacts at a time: the filter holds a full-rate copy of what it filters (SciPy's
        # several: 3 GB for 100 cars over a 32 km viaduct at dt = 1e-3 s); the blocks on two threads
        # (the compiled filter and scipy's sosfilt release the GIL): the filter is the largest part
        # of the work after the loop, and the columns are independent (bit-identical results)
        compiled()  # built (or found) once, before any thread asks for it
        ncol = raw.shape[1]
        threads = FILTER_THREADS if ncol > 1 else 1
        width = max(1, min(FILTER_BLOCK // n, -(-ncol // threads)))

        def block(j: int) -> None:
            # sosfiltfilt(axis=0)[::every][:k], compiled where a compiler works (the same bits)
            out[:, j : j + width] = sosfiltfilt_rows(sos, raw[:, j : j + width], padlen, every, k, zi)

        starts = range(0, ncol, width)
        if threads > 1 and len(starts) > 1:
            from concurrent.futures import ThreadPoolExecutor

            with ThreadPoolExecutor(threads) as pool:
                list(pool.map(block, starts))
        else:
            for j in starts:
                block(j)
        return out.reshape(-1, tr.cars, tr.wheels)


def _a(units: str, long_name: str) -> dict[str, str]:
    return {"units": units, "long_name": long_name}


def write_netcdf(ds: xr.Dataset, path: str | Path) -> Path:
    """Write atomically: a temporary file in the same folder, then ``os.replace``.

    The NetCDF image is built in memory first and written with plain file I/O: a short write (full
    disk, file-size limit) is then an ``OSError`` naming the cause, where HDF5 writing to the file
    itself crashed the process. On any error the previous file at ``path`` is untouched.
    """

    engine = netcdf_engine()

    def write(tmp: Path) -> None:
        out = ds.copy()
        for name in ("support_component", "end", "side"):
            if name in out.coords:
                out.coords[name] = out.coords[name].astype(str)
        try:
            image = out.to_netcdf(engine=engine)
        except ValueError:  # an xarray that writes this engine only to a path (HDF5: short writes)
            out.to_netcdf(tmp, engine=engine)
            return
        with open(tmp, "wb") as f:
            f.write(image)
            f.flush()
            os.fsync(f.fileno())  # a delayed allocation failure shows here, before the rename

    return write_atomic(path, write)

"""How much memory a run needs, estimated from the scenario before anything large is built.

:func:`estimate_memory` adds up the arrays whose size grows with the scenario (docs/design.md section 7
and ``svbi.runtime.run.results``): the stored output rows, the per-step contact-force buffer (the force
filter runs at the full step rate) and the filter's working copies, the NetCDF image built in memory
before the write, the rail-irregularity table and the spectral sum behind it, the ground-motion
tables, and the bridge and stepper workspace. :func:`check_memory` refuses a run above a limit
(``svbi run --max-memory``; default :data:`DEFAULT_SHARE` of the memory available when the run
starts), naming the keys that drive the size. ``tests/run/test_run_safety.py`` checks the stored arrays
exactly and the total against the traced peak of a run.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..excitation.irregularity import read_profile_cached
from ..scenario.build import IRREGULARITY_TABLE_DIVISIONS, run_extent
from .results import stored_columns

if TYPE_CHECKING:
    from ..scenario.schema import Scenario

DEFAULT_SHARE = 0.5
"""Default limit: this share of the memory available (``MemAvailable``, else physical memory)."""

F64 = 8
FILTER_COPIES = 3.0
"""Peak working arrays of the zero-phase force filter (``scipy.signal.sosfiltfilt``: padded input,
forward and backward passes), in units of the force buffer: measured 3.00 for 1 to 40 wheels. The
compiled filter (``zero_phase``) holds one padded copy; SciPy's, which runs without a compiler,
sets the bound."""
TABLE_BYTES_PER_POINT = 120.0
"""Bytes per grid point of the stored rail-profile table: quintic coefficients and breaks, and the
C loop's transposed copy (``c_steppers._ppoly_struct``)."""
TABULATION_BYTES_PER_POINT = 30.0
"""Transient bytes per grid point while the table is made, beside the stored table (the nodes'
carrier and the quintic's temporaries): 23 measured (``tracemalloc``, 1.5e4 to 3.2e6 points)."""
FFT_BYTES_PER_SAMPLE = 50.0
"""Transient bytes per sample of the table's inverse FFT (``SpectralIrregularity.table_nodes``:
three complex rows of the period's length K): 46-52 measured for K = 5e4 to 6.6e6."""
GROUND_BYTES_PER_SAMPLE = 400.0
"""Bytes per record sample and component once processed (acceleration, velocity, displacement,
filter copies, cubic table). Generous: records are short next to the other arrays."""
SYNTHETIC_DT = 0.005
"""Sample interval of a synthetic record (``excitation.synthetic``), s."""
WORKSPACE_PER_SPAN_DOF = 40
"""Doubles per bridge DOF of the state and stepper workspace (displacement, velocity, acceleration,
Newmark histories, factors and blocked copies of the C loop; ``csrc/solver.c``: ``carve``)."""


class MemoryLimitError(ValueError):
    """The run would need more memory than allowed; one line with the estimate and its keys."""


_UNITS = {
    "": 1,
    "b": 1,
    "k": 2**10,
    "kb": 10**3,
    "kib": 2**10,
    "m": 2**20,
    "mb": 10**6,
    "mib": 2**20,
    "g": 2**30,
    "gb": 10**9,
    "gib": 2**30,
    "t": 2**40,
    "tb": 10**12,
    "tib": 2**40,
}


def parse_size(text: str) -> int:
    """``"8GiB"`` -> bytes. Units B, kB/MB/GB/TB (powers of 1000), KiB/MiB/GiB/TiB and the bare
    K/M/G/T (powers of 1024), case-insensitive; a plain number is bytes."""
    m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([A-Za-z]*)\s*", text or "")
    if m is None or m.group(2).lower() not in _UNITS:
        raise ValueError(f"not a memory size: {text!r} (examples: 8GiB, 500MB, 2G)")
    value = float(m.group(1)) * _UNITS[m.group(2).lower()]
    if not math.isfinite(value) or value <= 0:
        raise ValueError(f"not a positive memory size: {text!r}")
    return int(value)


def format_size(n: float) -> str:
    """Bytes as a short binary-prefixed text: 1536 -> '1.5 KiB'."""
    for unit, scale in (("TiB", 2**40), ("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if abs(n) >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{n:.0f} B"


def available_memory() -> int:
    """Memory available to a new run: ``MemAvailable`` of /proc/meminfo, else physical memory."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return 2**34  # no way to know: 16 GiB


@dataclass
class MemoryEstimate:
    """Bytes per part of a run, and the scenario values that drive them (key -> value)."""

    parts: dict[str, int] = field(default_factory=dict)
    drivers: dict[str, str] = field(default_factory=dict)
    phases: dict[str, int] = field(default_factory=dict)

    @property
    def total(self) -> int:
        """The peak: the largest phase (set-up of the tables, loop and force filter, write)."""
        return max(self.phases.values(), default=sum(self.parts.values()))

    def largest(self, count: int = 2) -> list[tuple[str, int]]:
        return sorted(self.parts.items(), key=lambda kv: -kv[1])[:count]


def estimate_memory(scenario: Scenario) -> MemoryEstimate:
    """The memory a run of ``scenario`` will need (see the module docstring)."""
    # the bridge's layout only: the estimate comes from its sizes, before any matrix is built
    bridge, train, duration, steps = run_extent(scenario, matrices=False)
    ss = scenario.solver
    every = ss.output_every
    nout = steps // every + 1
    nc, cars, spans = train.contacts, train.cars, bridge.spans
    nsup = bridge.active_supports
    nsub = bridge.nsub
    uniform = _uniform_ground(scenario)
    columns = stored_columns(
        spans=spans,
        supports=nsup,
        uniform=uniform,
        cars=cars,
        wheels=train.wheels,
        vehicle_dofs=train.vehicle.ndof,
        piers=nsub - spans,
    )
    per_row = sum(math.prod(shape) * np.dtype(dtype).itemsize for shape, dtype in columns.values())
    est = MemoryEstimate()
    est.parts["results"] = nout * per_row
    est.parts["force buffer"] = (steps + 1) * nc * F64
    # a unilateral run's full-rate contact states (one byte per wheel and step, once a wheel lifts off)
    est.parts["contact states"] = (steps + 1) * nc if scenario.contact.normal == "unilateral" else 0
    fs = 1.0 / ss.time_step
    filtered = steps >= 1 and scenario.output.force_filter_hz < 0.5 * fs
    est.parts["force filter"] = int(FILTER_COPIES * est.parts["force buffer"]) if filtered else 0
    # the stored results again with the filtered force, as the NetCDF image of the write
    est.parts["NetCDF image"] = est.parts["results"] + nout * nc * F64
    table, tabulation = _irregularity_bytes(scenario, train, duration, steps)
    est.parts["irregularity table"] = table
    est.parts["irregularity tabulation"] = tabulation
    est.parts["ground motion"] = _ground_bytes(scenario, duration)
    est.parts["bridge and stepper"] = int(
        F64 * (WORKSPACE_PER_SPAN_DOF * nsub * bridge.ndof + (nsup + nc) * bridge.ndof * 4 + 200 * nc)
    )
    p = est.parts
    fixed = p["ground motion"] + p["bridge and stepper"]
    # not all parts live at once: the run's peak is the largest of its three phases
    est.phases = {
        "tables": fixed + table + tabulation,
        "loop and filter": fixed
        + table
        + p["results"]
        + p["force buffer"]
        + p["contact states"]
        + p["force filter"],
        "write": p["results"] + nout * nc * F64 + p["NetCDF image"],
    }
    est.drivers = {
        "solver.time_step": f"{ss.time_step:g} s",
        "solver.duration": f"{duration:g} s" + ("" if ss.duration is not None else " (crossing)"),
        "solver.output_every": str(every),
        "bridge.spans": str(spans),
        "train.cars": f"{cars} ({nc} wheel{'s' if nc != 1 else ''} in all)",
        "steps": str(steps),
    }
    if scenario.track.irregularity != "none":
        est.drivers["track.wavelength_min"] = f"{scenario.track.wavelength_min:g} m"
    return est


def _uniform_ground(scenario: Scenario) -> bool:
    eq = scenario.earthquake
    if eq is None:
        return True
    per_support = any(isinstance(getattr(eq, c), list) for c in ("vertical", "longitudinal"))
    return not per_support and eq.apparent_velocity is None


def _irregularity_bytes(scenario: Scenario, train: object, duration: float, steps: int) -> tuple[int, int]:
    """Stored and transient bytes of the table of ``simulate._irregularity``: a grid of
    ``wavelength_min / 50`` over the distance the train travels, its nodes from one inverse FFT of
    the N frequencies over a period (``SpectralIrregularity.table_nodes``)."""
    spec = scenario.track
    if spec.irregularity == "none":
        return 0, 0
    if spec.is_profile:  # the cubic spline of the measured points: x and 4 coefficients per piece
        try:
            points = read_profile_cached(scenario.resolve_path(spec.irregularity))[0].size
        except (OSError, ValueError):
            return 0, 0
        return 5 * points * F64, 2 * points * F64
    speed = float(getattr(train, "speed", 0.0))
    dx = spec.wavelength_min / IRREGULARITY_TABLE_DIVISIONS
    end_time = steps * scenario.solver.time_step
    points = (max(speed * end_time, 1.0) + 4 * dx) / dx + 1
    length = max(speed * duration, 1.0)
    # N: the smallest power of two >= 1024 whose period (about N wavelength_min) covers the length
    n = max(1024, 2 ** math.ceil(math.log2(max(length / spec.wavelength_min, 1.0))))
    # K: the FFT's length, one period 2π/ΔΩ at spacing dx (table_nodes rounds it up a little)
    d_omega = 2.0 * math.pi * (1.0 / spec.wavelength_min - 1.0 / spec.wavelength_max) / n
    k = 1.05 * max(n, 2.0 * math.pi / d_omega / dx)
    transient = points * TABULATION_BYTES_PER_POINT + k * FFT_BYTES_PER_SAMPLE
    return int(points * TABLE_BYTES_PER_POINT), int(transient)


def _ground_bytes(scenario: Scenario, duration: float) -> int:
    eq = scenario.earthquake
    if eq is None:
        return 0
    total = 0.0
    for comp in ("vertical", "longitudinal"):
        for name in eq.sources(comp):
            if name == "none":
                continue
            if name == "synthetic":
                samples = max(duration, 1.0) / (eq.record_dt or SYNTHETIC_DT)
            else:  # a text record holds at least one sample per 8 bytes of file
                try:
                    samples = scenario.resolve_path(name).stat().st_size / 8
                except OSError:
                    samples = 0.0
            total += samples * GROUND_BYTES_PER_SAMPLE
    return int(total)


def memory_limit(max_memory: str | None) -> tuple[int, str]:
    """The limit in bytes and how it was set (for the message)."""
    if max_memory is not None:
        try:
            return parse_size(max_memory), "--max-memory"
        except ValueError as exc:
            raise MemoryLimitError(f"--max-memory: {exc}") from None
    available = available_memory()
    return int(DEFAULT_SHARE * available), f"{DEFAULT_SHARE:.0%} of the {format_size(available)} available"


def check_memory(scenario: Scenario, max_memory: str | None = None) -> MemoryEstimate:
    """Refuse (:class:`MemoryLimitError`) a run whose estimate is above the limit."""
    limit, how = memory_limit(max_memory)
    est = estimate_memory(scenario)
    if est.total > limit:
        big = ", ".join(f"{name} {format_size(size)}" for name, size in est.largest() if size)
        keys = ", ".join(f"{k} = {v}" for k, v in est.drivers.items())
        larger = (
            "solver.time_step, solver.output_every or track.wavelength_min"
            if "track.wavelength_min" in est.drivers
            else "solver.time_step or solver.output_every"
        )
        raise MemoryLimitError(
            f"the run would need about {format_size(est.total)} of memory ({big}), above the limit of "
            f"{format_size(limit)} ({how}); it is driven by {keys}: use a larger {larger}, "
            "a shorter solver.duration, fewer bridge.spans or train.cars, or "
            "raise the limit with --max-memory"
        )
    return est

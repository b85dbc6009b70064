"""Engineering studies: many runs of one scenario on a Dask cluster (``svbi sweep``, docs/sweep.md).

A study file names a base scenario and axes of dotted scenario keys. ``[axes]`` are crossed (the
full grid, in the order written); ``[zip]`` lists are walked together and form one more dimension,
named by the first zipped key (the others are coordinates along it). Every grid point is one run:
the base scenario with the point's values as overrides (exactly ``svbi run --set key=value``).

Runs go to Dask workers (a ``LocalCluster`` with one single-threaded worker process per core, or any
running cluster by its scheduler address). A worker process keeps what does not change between runs
(the parsed base scenario, the vehicle model, the compiled C loop, every import), so only the first
run of a process pays for them. Each finished run writes its metrics (``svbi.runtime.study.metrics``) to
its own small NetCDF file in ``OUT.parts/``, atomically, named by a hash of the base scenario and
the run's overrides: an interrupted sweep loses no finished run, and the same command resumes with
the missing runs only. When every run has a part, the parts are assembled into the store ``OUT``
(NetCDF or Zarr, written atomically; ``svbi.runtime.study.store``): one dimension per axis, named
by the key's last part (``speed_kmh``), the metrics per run, the run's ``status`` (``ok``,
``diverged`` or ``failed``) and ``message``. A run that fails or diverges does not stop the sweep.

Before anything runs, the output path is checked (:func:`check_store_output`) and resolved, so that
workers in other folders write where the driver reads; the first missing run is run in the driver
as a probe, whose time, part and history sizes and memory give the study's estimate
(:func:`estimate`): a study that would fill the disk is refused.
"""

from __future__ import annotations

import contextlib
import hashlib
import itertools
import json
import os
import shutil
import signal
import sys
import threading
import time
import tomllib
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import numpy as np
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    StrictBool,
    StrictFloat,
    StrictInt,
    StrictStr,
    ValidationError,
)

from ... import __version__
from ...codegen.input_files import (
    MAX_TOML_BYTES,
    InputFileError,
    TextFileError,
    TOMLNestingError,
    decode_text,
    loads_toml,
    read_bytes,
)
from ..run.atomic import write_atomic
from ..run.output import folder_problem, same_file
from ..run.results import write_netcdf
from ..run.simulate import simulate
from ..scenario.kinds import wrong_kind
from ..scenario.schema import (
    Problem,
    ScenarioError,
    key_lines,
    load_scenario,
    loads_scenario,
    parse_literal,
)
from .metrics import METRIC_DIMS, METRIC_INPUTS, METRIC_UNITS, compute_metrics
from .store import (
    CONVENTIONS,
    STORE_SUFFIXES,
    dim_names,
    history_line,
    is_store,
    is_zarr_path,
    key_units,
    read_store,
    write_store,
)

if TYPE_CHECKING:
    import xarray as xr

Scalar = StrictStr | StrictInt | StrictFloat | StrictBool
Value = Scalar | list[Scalar]
STATUS_OK, STATUS_DIVERGED, STATUS_FAILED = "ok", "diverged", "failed"
RUN_TIMINGS = (
    "setup_time_s",
    "loop_time_s",
    "wall_time_s",
    "worker_time_s",
    "worker_peak_rss_mb",
    "started",
    "ended",
    "worker_pid",
)
"""Per-run figures kept in the store: timings (``worker_time_s`` is the whole task inside the
worker), the worker process's peak resident memory so far (MB), and when the task started and
ended (Unix time, s) and the worker process's id."""


__all__ = ["is_store", "read_store"]  # the store's readers, kept importable from here

_UNION_TAGS = {"str", "int", "float", "bool"}
_RUN_UNITS = {
    "setup_time_s": {"units": "s", "long_name": "set-up time of the run"},
    "loop_time_s": {"units": "s", "long_name": "time loop of the run"},
    "wall_time_s": {"units": "s", "long_name": "wall time of the run"},
    "worker_time_s": {"units": "s", "long_name": "the whole task in the worker"},
    "worker_peak_rss_mb": {"units": "MB", "long_name": "peak resident memory of the worker process"},
    "started": {"units": "seconds since 1970-01-01", "calendar": "standard", "long_name": "run started"},
    "ended": {"units": "seconds since 1970-01-01", "calendar": "standard", "long_name": "run ended"},
    "worker_pid": {"units": "1", "long_name": "process id of the worker that ran it"},
}
CUTOFF = "deck_acceleration_cutoff_hz"
"""The store's variable of each run's EN 1990 low-pass cutoff of the deck acceleration."""
INTEGER_METRICS = ("lift_offs", "flange_contacts", "complete")
"""Counts and flags: integers in the store (missing runs: the ``_FillValue`` -1; ``complete`` 0)."""
RESERVED_NAMES = (
    "run",
    "span",
    "car",
    "wheel",
    "side",
    "end",
    "joint",
    "pier",
    "status",
    "message",
    "run_id",
    CUTOFF,
    *RUN_TIMINGS,
    *METRIC_DIMS,
    *(f"{m}_time" for m in METRIC_DIMS),
)

"""Names of the store's own variables and dimensions: a swept key's name avoids them."""


class StudyError(ScenarioError):
    """An invalid study file: every problem names the key, the file and the line."""

    def __init__(self, problems: Sequence[Problem], source: str = "") -> None:
        super().__init__(problems, source)
        head = f"invalid study {source}" if source else "invalid study"
        self.args = (head + ":\n" + "\n".join(f"  {p}" for p in self.problems),)

    def __str__(self) -> str:
        return str(self.args[0])


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)


class OutputSpec(_Strict):
    """``[output]`` of a study file."""

    histories: StrictBool = False
    """Keep each run's full results file in ``OUT.histories/``."""


class StudySpec(_Strict):
    """A study file (docs/sweep.md)."""

    scenario: Annotated[StrictStr, Field(min_length=1)]
    title: StrictStr = ""
    axes: dict[str, Annotated[list[Value], Field(min_length=1)]] = Field(default_factory=dict)
    zip: dict[str, Annotated[list[Value], Field(min_length=1)]] = Field(default_factory=dict)
    output: OutputSpec = Field(default_factory=OutputSpec)


@dataclass(frozen=True)
class Run:
    """One grid point: its position in the grid, its overrides and its identity."""

    index: tuple[int, ...]
    overrides: dict[str, Any]
    run_id: str


@dataclass
class Study:
    """A validated study: base scenario, axes and the runs of the grid."""

    path: Path
    spec: StudySpec
    scenario_path: Path
    scenario_text: str
    text: str
    runs: list[Run] = field(default_factory=list)
    sets: dict[str, Any] = field(default_factory=dict)
    """``--set`` overrides applied to every run (before the axes' values)."""

    @property
    def keys(self) -> list[str]:
        """The dotted keys of the dimensions: the axes in order, then the first zipped key."""
        return [*self.spec.axes, *([next(iter(self.spec.zip))] if self.spec.zip else [])]

    @property
    def names(self) -> dict[str, str]:
        """Every swept key (axes and zipped) -> its name in the store (``store.dim_names``)."""
        return dim_names([*self.spec.axes, *self.spec.zip], RESERVED_NAMES)

    @property
    def dims(self) -> list[str]:
        """Dimension names of the store: ``speed_kmh`` for ``train.speed_kmh`` (``store.dim_names``)."""
        names = self.names
        return [names[k] for k in self.keys]

    @property
    def shape(self) -> tuple[int, ...]:
        sizes = [len(v) for v in self.spec.axes.values()]
        if self.spec.zip:
            sizes.append(len(next(iter(self.spec.zip.values()))))
        return tuple(sizes)


# --------------------------------------------------------------------------------------------------
# the study file


def parse_sets(sets: Sequence[str]) -> dict[str, Any]:
    """``key.path=value`` items of ``--set`` (values read as TOML literals, else as text)."""
    out: dict[str, Any] = {}
    for spec in sets:
        key, sep, raw = spec.partition("=")
        if not sep or not key.strip():
            raise StudyError([Problem(spec, "expected key.path=value", f"--set {spec}")], "--set")
        out[key.strip()] = parse_literal(raw.strip())
    return out


def load_study(path: str | Path, sets: Sequence[str] | dict[str, Any] = ()) -> Study:
    """Read and validate a study file; raises :class:`StudyError` naming key, file and line.

    ``sets``: ``--set`` overrides of the base scenario, applied to every run (an axis's value wins)."""
    path = Path(path)
    source = str(path)
    sets = dict(sets) if isinstance(sets, dict) else parse_sets(sets)
    try:  # a regular file of bounded size (never /dev/zero, a FIFO or a folder), UTF-8
        text = decode_text(read_bytes(path, MAX_TOML_BYTES), source)
    except TextFileError as exc:  # before InputFileError, of which it is one: it has the line
        raise StudyError([Problem("<file>", exc.problem, exc.where)], source) from None
    except InputFileError as exc:
        raise StudyError([Problem("<file>", exc.problem, source)], source) from None
    try:
        data = loads_toml(text)
    except TOMLNestingError as exc:
        raise StudyError([Problem("<toml>", f"malformed TOML: {exc}", source)], source) from None
    except tomllib.TOMLDecodeError as exc:
        line = getattr(exc, "lineno", None)
        where = f"{source}:{line}" if line else source
        raise StudyError([Problem("<toml>", f"malformed TOML: {exc}", where)], source) from None
    kind = wrong_kind(data, "study", source)
    if kind:
        raise StudyError([Problem("", kind, source)], source)
    lines = key_lines(text)

    def where(key: str) -> str:
        parts = key.split(".")
        while parts:
            if ".".join(parts) in lines:
                return f"{source}:{lines['.'.join(parts)]}"
            parts.pop()
        return source

    try:
        spec = StudySpec.model_validate(data)
    except ValidationError as exc:
        problems = []
        seen: dict[str, Problem] = {}
        for err in exc.errors():
            # pydantic tags each member of the value union ("str", "list[...]"): one problem per key
            parts = [str(p) for p in err["loc"]]
            tagged = any(p in _UNION_TAGS or p.startswith("list[") for p in parts)
            key = ".".join(p for p in parts if p not in _UNION_TAGS and not p.startswith("list["))
            message = err["msg"].lower()
            if tagged:
                message = f"expected a string, number, boolean or a list of them (got {err.get('input')!r})"
            seen.setdefault(key, Problem(key or "<study>", message, where(key)))
        problems = list(seen.values())
        raise StudyError(problems, source) from None

    problems: list[Problem] = []
    scenario_path = (path.resolve().parent / spec.scenario).resolve()
    if not scenario_path.is_file():
        problems.append(Problem("scenario", f"file not found: {scenario_path}", where("scenario")))
        raise StudyError(problems, source)
    if not spec.axes and not spec.zip:
        problems.append(Problem("axes", "a study needs [axes] or [zip] (at least one key)", source))
    lengths = {k: len(v) for k, v in spec.zip.items()}
    if len(set(lengths.values())) > 1:
        listed = ", ".join(f"{k}: {n}" for k, n in lengths.items())
        problems.append(Problem("zip", f"the lists must have the same length ({listed})", where("zip")))
    for key in set(spec.axes) & set(spec.zip):
        problems.append(Problem(f"zip.{key}", "is also an axis", where(f"zip.{key}")))
    if sets:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                load_scenario(scenario_path, overrides=sets)
        except ScenarioError as exc:
            raise StudyError(
                [Problem(f"--set {p.key}", p.message, "--set") for p in exc.problems], source
            ) from None
    # every value of every axis must make a valid scenario on its own (errors name the study line)
    for table, values in (("axes", spec.axes), ("zip", spec.zip)):
        for key, items in values.items():
            for item in items:
                try:
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        load_scenario(scenario_path, overrides={**sets, key: item})
                except ScenarioError as exc:
                    message = "; ".join(p.message for p in exc.problems)
                    problems.append(
                        Problem(f"{table}.{key}", f"value {item!r}: {message}", where(f"{table}.{key}"))
                    )
                    break
    if problems:
        raise StudyError(problems, source)
    study = Study(path, spec, scenario_path, scenario_path.read_text(encoding="utf-8-sig"), text, sets=sets)
    study.runs = grid_runs(study)
    return study


def grid_runs(study: Study) -> list[Run]:
    """Every run of the grid, in C order of :attr:`Study.dims` (the last dimension fastest)."""
    axes = list(study.spec.axes.items())
    zipped = list(study.spec.zip.items())
    nzip = len(zipped[0][1]) if zipped else 0
    ranges = [range(len(v)) for _, v in axes] + ([range(nzip)] if zipped else [])
    runs = []
    for index in itertools.product(*ranges):
        overrides = {**study.sets, **{k: v[i] for (k, v), i in zip(axes, index, strict=False)}}
        if zipped:
            overrides.update({k: v[index[-1]] for k, v in zipped})
        runs.append(Run(tuple(index), overrides, run_id(study.scenario_text, overrides)))
    return runs


def run_id(scenario_text: str, overrides: dict[str, Any]) -> str:
    """Identity of a run: hash of the base scenario's text and its overrides (a changed scenario or
    value is a new run; an unchanged one is found again on resume)."""
    blob = json.dumps({"scenario": scenario_text, "overrides": overrides}, sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()[:20]


# --------------------------------------------------------------------------------------------------
# inside a worker

_WORKER: dict[str, Any] = {"runs": 0}
"""Per worker process: runs done, and the base scenarios read (the compiled C loop, the vehicle
model and the imports are kept by their own modules' process-wide caches)."""


def run_one(
    scenario_path: str, overrides: dict[str, Any], part: str, history: str | None, stop: str | None = None
) -> dict[str, Any]:
    """Run one grid point and write its part file (atomically). Never raises for a run that fails:
    the failure is recorded with its message. When the file ``stop`` exists (the driver stopped
    while the run was in flight), the part is not written."""
    t0 = time.perf_counter()
    _WORKER["runs"] += 1
    import xarray as xr

    texts = _WORKER.setdefault("scenarios", {})
    if scenario_path not in texts:
        texts[scenario_path] = Path(scenario_path).read_text(encoding="utf-8-sig")
    status, message = STATUS_OK, ""
    timings: dict[str, float] = {}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sc = loads_scenario(
                texts[scenario_path],
                source=scenario_path,
                base_dir=Path(scenario_path).parent,
                overrides=overrides,
            )
            # with no history kept, only what the metrics read: the rest costs 10 % of a paper run
            ds = simulate(sc, clock_start=t0, variables=None if history is not None else METRIC_INPUTS)
        metrics = compute_metrics(ds)
        if not int(metrics["complete"].values):
            status, message = STATUS_DIVERGED, str(ds.attrs.get("incomplete", "stopped early"))
        timings = {k: float(ds.attrs[k]) for k in ("setup_time_s", "loop_time_s", "wall_time_s")}
        if history is not None and not (stop is not None and Path(stop).exists()):
            import dask

            # a local lock, not the cluster-wide one xarray takes inside a worker (see write_part)
            with dask.config.set(scheduler="synchronous"):
                write_netcdf(ds, history)
    except Exception as exc:  # a failed run is a result of the study, not an error of the sweep
        status, message = STATUS_FAILED, f"{type(exc).__name__}: {exc}"
        metrics = xr.Dataset()
    timings["worker_time_s"] = time.perf_counter() - t0
    timings["worker_peak_rss_mb"] = _peak_rss_mb()
    attrs = {
        "status": status,
        "message": message,
        "overrides": json.dumps(overrides, sort_keys=True),
        "worker_pid": os.getpid(),
        "worker_run": _WORKER["runs"],
        "started": time.time() - (time.perf_counter() - t0),
        "ended": time.time(),
        **timings,
    }
    if stop is not None and Path(stop).exists():
        return {"status": "stopped", "message": "the sweep was stopped"}
    write_part(metrics.assign_attrs(attrs), Path(part))
    return {"status": status, "message": message}


def run_batch(
    scenario_path: str, jobs: list[tuple[dict[str, Any], str, str | None]], stop: str | None = None
) -> list[dict[str, Any]]:
    """:func:`run_one` for each ``(overrides, part, history)`` of a batch, in order; a run whose part
    already exists (a batch retried after its worker died part-way) is not run again, and none
    starts once the file ``stop`` exists (the driver was stopped)."""
    out = []
    for overrides, part, history in jobs:
        if stop is not None and Path(stop).exists():
            out.append({"status": "stopped", "message": "the sweep was stopped"})
            continue
        if _finished(Path(part)):
            out.append({"status": "reused", "message": ""})
            continue
        out.append(run_one(scenario_path, overrides, part, history, stop))
    return out


def batch_size(runs: int, workers: int) -> int:
    """Runs per Dask task: short runs (an HSLM crossing takes 0.1 s) cost the scheduler and the
    client, which share the cores with the workers, as much as a run; a batch spreads that over a
    few runs, while at least 16 tasks per worker keep the workers' ends of the sweep even."""
    return max(1, min(8, runs // (16 * max(workers, 1))))


def worker_environment(workers: int = 1) -> dict[str, Any]:
    """The environment of the sweep's LocalCluster workers: Dask's (one BLAS / OpenMP thread), less
    ``MALLOC_TRIM_THRESHOLD_``. Setting it fixes glibc's mmap threshold, so every large array of a
    run (the force buffer, the filter's copies: tens of MB) is mapped and page-faulted afresh, run
    after run; unset, glibc keeps the run's blocks in its heap and the next run reuses them. Measured
    on the paper scenario: per-run overhead 10-16 % of the loop with it, 6-8 % without; the price is
    that a worker keeps its peak memory between runs (reported by ``bench_sweep``). The force
    filter's threads (``results.FILTER_THREADS``) get the cores per worker: two filter threads in
    each of two workers on two cores made every run 30 % slower."""
    import dask

    env = dict(dask.config.get("distributed.nanny.pre-spawn-environ", default={}) or {})
    env.pop("MALLOC_TRIM_THRESHOLD_", None)
    env["SVBI_FILTER_THREADS"] = str(max(1, (os.cpu_count() or 1) // max(workers, 1)))
    return env


def _peak_rss_mb() -> float:
    try:
        import resource
    except ImportError:  # not on Windows
        return float("nan")
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: kB


EMPTY_VARIABLES = "svbi_empty_variables"
"""A part's attribute: the variables of length 0 it leaves out, as JSON ``{name: [dims]}``."""


def write_part(ds: xr.Dataset, path: Path) -> Path:
    """A run's metrics as a small NetCDF-3 file, atomically (SciPy writes and reads these 10x faster
    than HDF5, which counts when a store assembles thousands of them). NetCDF-3 has no 64-bit
    integers: integer metrics are stored as floats."""
    out = ds.copy()
    for name, da in out.data_vars.items():
        if da.dtype.kind in "iub":
            out[name] = da.astype(float)
    out.attrs = {k: (v.item() if isinstance(v, np.generic) else v) for k, v in out.attrs.items()}
    # Variables of length 0 (the joints of a single span) are named in an attribute instead of
    # written: SciPy lays them out in a way the netCDF-C library, xarray's reader when netCDF4 is
    # installed, refuses ("unknown file format"). assemble puts them back in the store.
    empty = [d for d, size in out.sizes.items() if size == 0]
    if empty:
        gone = {n: list(v.dims) for n, v in out.variables.items() if set(v.dims) & set(empty)}
        out = out.drop_dims(empty)
        out.attrs[EMPTY_VARIABLES] = json.dumps(gone, sort_keys=True)
    # serialised in memory, then written as plain bytes: inside a Dask worker, xarray's file writes
    # take a cluster-wide lock through the scheduler, which cost 0.4 s a run on this machine
    data = bytes(out.to_netcdf(engine="scipy", format="NETCDF3_64BIT"))
    return write_atomic(path, lambda tmp: tmp.write_bytes(data))


# --------------------------------------------------------------------------------------------------
# the driver: the output path, the estimate


class SweepError(RuntimeError):
    """The sweep cannot go on (no output possible, no worker, a full disk); ``exit_code`` says how
    the command ends (2: nothing ran; 3: finished runs are kept, run the same command again)."""

    def __init__(self, message: str, exit_code: int = 2) -> None:
        super().__init__(message)
        self.exit_code = exit_code


def parts_dir(out: Path) -> Path:
    return Path(str(out) + ".parts")


def histories_dir(out: Path) -> Path:
    return Path(str(out) + ".histories")


def part_path(out: Path, run: Run) -> Path:
    return parts_dir(out) / f"{run.run_id}.nc"


def _finished(path: Path) -> bool:
    # a part exists only once complete (written atomically), so existence is enough
    return path.is_file()


def check_store_output(raw: str | os.PathLike[str], study: Study | None = None) -> Path:
    """The store's path, absolute, if a sweep can write there; else :class:`SweepError` (one line).

    Checked as ``svbi run`` checks its output (``run.output.check_output``), before any run: a
    name ending in ``.nc`` or ``.zarr``, not an existing folder (a Zarr store is one: only a store
    of an earlier sweep is replaced), not under a file, in an existing, writable folder (a missing
    folder is an error, not created: a typo would put the study where its resume does not look),
    not one of the study's inputs, and ``OUT.parts`` / ``OUT.histories`` free to be folders.
    """
    text = os.fspath(raw)
    if not text.strip():
        raise SweepError("-o: the output path is empty; give a name ending in .nc or .zarr")
    path = Path(text).expanduser()
    suffix = path.suffix.lower()
    if suffix not in STORE_SUFFIXES:
        got = "no suffix" if not path.suffix else repr(path.suffix)
        raise SweepError(f"-o {text}: give a name ending in .nc or .zarr (got {got})")
    path = Path(os.path.abspath(path))  # workers elsewhere must write where the driver reads
    if is_zarr_path(path):
        if path.exists() and not (path.is_dir() and is_store(path)):
            raise SweepError(f"-o {text}: {path} exists and is not the Zarr store of a sweep")
    elif path.is_dir():
        raise SweepError(f"-o {text}: {path} is a folder; give a file name ending in .nc")
    elif path.exists() and not path.is_file():
        raise SweepError(f"-o {text}: {path} exists and is not a regular file")
    if study is not None:
        for what, source in (("the study file", study.path), ("the scenario file", study.scenario_path)):
            if same_file(path, source):
                raise SweepError(f"-o {text}: {path} is {what}; the store would overwrite it")
    folder = path.parent
    existing = folder
    while not existing.exists() and existing.parent != existing:
        existing = existing.parent
    if existing.exists() and not existing.is_dir():
        raise SweepError(f"-o {text}: {existing} is a file, not a folder")
    if not folder.is_dir():
        raise SweepError(f"-o {text}: folder {folder} does not exist; create it first")
    problem = folder_problem(folder)
    if problem is not None:
        raise SweepError(f"-o {text}: {problem}")
    for side in (parts_dir(path), histories_dir(path)):
        if side.exists() and not side.is_dir():
            raise SweepError(f"-o {text}: {side} exists and is not a folder")
    return path


def free_disk_bytes(path: Path) -> int:
    """Free bytes on the file system of ``path`` (the nearest existing folder)."""
    while not path.exists() and path.parent != path:
        path = path.parent
    return shutil.disk_usage(path).free


@dataclass
class Probe:
    """One run done to measure a study: its time (warm: the imports and the compiled loop of the
    process were there already, when it could be measured so), sizes and the process's memory."""

    seconds: float
    cold_seconds: float
    part_bytes: int
    history_bytes: int
    peak_rss_mb: float
    status: str


@dataclass
class Estimate:
    """What a study will cost, from a probe run."""

    runs: int
    todo: int
    workers: int
    probe: Probe
    disk_bytes: int
    free_bytes: int
    histories: bool

    @property
    def cpu_seconds(self) -> float:
        return self.probe.seconds * self.todo

    @property
    def wall_seconds(self) -> float:
        return self.cpu_seconds / max(self.workers, 1)

    @property
    def fits(self) -> bool:
        return self.disk_bytes <= self.free_bytes

    def text(self) -> str:
        p = self.probe
        lines = [
            f"{self.runs} runs ({self.todo} to run, {self.runs - self.todo} finished already)",
            f"time: about {_duration(p.seconds)} a run (probe; its first run took "
            f"{_duration(p.cold_seconds)} with the imports and the compiled loop), "
            f"{_duration(self.cpu_seconds)} of CPU in all, about {_duration(self.wall_seconds)} "
            f"on {self.workers} workers",
            f"disk: about {_size(self.disk_bytes)} (parts {_size(p.part_bytes)} a run"
            + (f", histories {_size(p.history_bytes)} a run" if self.histories else ", no histories")
            + f", the store); {_size(self.free_bytes)} free",
            f"memory: about {p.peak_rss_mb:.0f} MB per worker (the probe process's peak)",
        ]
        return "\n".join(lines) + "\n"


def _duration(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.3g} s"
    if seconds < 7200:
        return f"{seconds / 60:.3g} min"
    return f"{seconds / 3600:.3g} h"


def _size(n: float) -> str:
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if n < 1000 or unit == "TB":
            return f"{n:.3g} {unit}" if unit != "B" else f"{int(n)} B"
        n /= 1000.0
    return f"{n:.3g} TB"


def probe_run(study: Study, run: Run, part: Path, history: Path | None, repeat: bool) -> Probe:
    """Run ``run`` in this process (writing ``part`` and ``history``) and measure it. With
    ``repeat``, a run shorter than 5 s is run a second time (into the same files) for a warm time."""
    result = run_one(str(study.scenario_path), run.overrides, str(part), str(history) if history else None)
    cold = _part_seconds(part)
    warm = cold
    if repeat and cold < 5.0:
        run_one(str(study.scenario_path), run.overrides, str(part), str(history) if history else None)
        warm = _part_seconds(part)
    hist = history.stat().st_size if history is not None and history.is_file() else 0
    return Probe(warm, cold, part.stat().st_size, hist, _peak_rss_mb(), result["status"])


def _part_seconds(part: Path) -> float:
    ds = _read_part(part)
    return float(ds.attrs.get("worker_time_s", np.nan)) if ds is not None else float("nan")


def estimate(study: Study, out: Path, probe: Probe, todo: int, workers: int) -> Estimate:
    """The study's cost from ``probe``: time, and disk for ``todo`` more runs (part, history) and the
    store (about the parts of every run: it holds what they hold, compressed)."""
    per_run = probe.part_bytes + (probe.history_bytes if study.spec.output.histories else 0)
    disk = per_run * todo + probe.part_bytes * len(study.runs)
    return Estimate(
        len(study.runs), todo, workers, probe, disk, free_disk_bytes(out.parent), study.spec.output.histories
    )


def dry_run(study: Study, out: str | Path, workers: int | None = None) -> Estimate:
    """The estimate of ``svbi sweep --dry-run``: one probe run in a temporary folder; nothing is
    written beside ``out``."""
    import tempfile

    out = check_store_output(out, study)
    todo = [r for r in study.runs if not _finished(part_path(out, r))]
    run = todo[0] if todo else study.runs[0]
    with tempfile.TemporaryDirectory(prefix="svbi-probe-") as tmp:
        history = Path(tmp) / "history.nc" if study.spec.output.histories else None
        probe = probe_run(study, run, Path(tmp) / "part.nc", history, repeat=True)
    return estimate(study, out, probe, len(todo), workers or os.cpu_count() or 1)


# --------------------------------------------------------------------------------------------------
# the driver: running


@dataclass
class SweepReport:
    """What a sweep did: runs in total, run now, found finished, and by status."""

    total: int
    ran: int
    reused: int
    statuses: dict[str, int]
    store: Path
    lost: list[str] = field(default_factory=list)
    estimate: Estimate | None = None


def run_sweep(
    study: Study,
    out: str | Path,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = True,
    on_done: Callable[[int], None] | None = None,
    worker_timeout: float = 60.0,
    command: str = "",
) -> SweepReport:
    """Run every missing run of ``study`` on Dask and assemble the store ``out``.

    The output is checked first (:func:`check_store_output`); the first missing run is run here as a
    probe, and a study whose estimate does not fit on the disk is refused (:class:`SweepError`)."""
    out = check_store_output(out, study)
    parts_dir(out).mkdir(exist_ok=True)
    for stale in parts_dir(out).glob(".stop-*"):  # the stop files of earlier, interrupted sweeps
        stale.unlink(missing_ok=True)
    keep = study.spec.output.histories
    if keep:
        histories_dir(out).mkdir(exist_ok=True)
    todo = [r for r in study.runs if not _finished(part_path(out, r))]
    reused = len(study.runs) - len(todo)
    ran = len(todo)
    lost: list[str] = []
    est = None
    if todo:
        first = todo.pop(0)
        history = histories_dir(out) / f"{first.run_id}.nc" if keep else None
        probe = probe_run(study, first, part_path(out, first), history, repeat=False)
        n = workers or os.cpu_count() or 1
        est = estimate(study, out, probe, len(todo), n)
        if not est.fits:
            raise SweepError(
                f"the study would need about {_size(est.disk_bytes)} of disk for its {len(todo)} "
                f"remaining runs and the store, and {out.parent} has {_size(est.free_bytes)} free "
                "(`svbi sweep --dry-run` gives the estimate)"
            )
        if on_done is not None:
            on_done(1)
    if todo:
        lost = _compute(study, out, todo, workers, scheduler, progress, reused, on_done, worker_timeout)
    store = assemble(study, out, command=command)
    statuses: dict[str, int] = {}
    for s in np.asarray(store["status"].values).ravel():
        statuses[str(s)] = statuses.get(str(s), 0) + 1
    return SweepReport(len(study.runs), ran, reused, statuses, out, lost, est)


@contextlib.contextmanager
def _sigint_ignored() -> Iterator[None]:
    """SIGINT ignored while the LocalCluster starts its worker processes, which inherit it: a
    terminal's Ctrl-C, sent to the whole process group, then stops the driver only, which closes the
    cluster, instead of raising KeyboardInterrupt (and printing tracebacks) in every worker."""
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _client(scheduler: str | None, workers: int | None, worker_timeout: float) -> tuple[Any, Any]:
    """The Dask client and, without ``scheduler``, the LocalCluster it runs on."""
    import dask
    from dask.distributed import Client, LocalCluster

    if scheduler:
        try:
            client = Client(scheduler, timeout=f"{max(worker_timeout, 1.0)}s")
        except (OSError, TimeoutError) as exc:
            raise SweepError(f"cannot reach the Dask scheduler at {scheduler} ({exc})") from None
        try:
            client.wait_for_workers(1, timeout=worker_timeout)
        except TimeoutError:
            client.close()
            raise SweepError(
                f"no worker is alive on {scheduler} after {worker_timeout:g} s: start workers with "
                f"`dask worker {scheduler} --nthreads 1`, then run the same command",
                exit_code=3,
            ) from None
        return client, None
    n = workers or os.cpu_count() or 1
    with dask.config.set({"distributed.nanny.pre-spawn-environ": worker_environment(n)}), _sigint_ignored():
        cluster = LocalCluster(
            n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=50
        )
    return Client(cluster), cluster


def _compute(
    study: Study,
    out: Path,
    todo: list[Run],
    workers: int | None,
    scheduler: str | None,
    progress: bool,
    reused: int,
    on_done: Callable[[int], None] | None,
    worker_timeout: float = 60.0,
) -> list[str]:
    """Run ``todo`` on the cluster (the probe, run before, counts as done); returns the messages of
    batches lost. On an interrupt (a
    KeyboardInterrupt, or ``RunInterrupted`` for SIGTERM) the outstanding tasks are cancelled and a
    stop file tells the runs still in flight not to write their parts."""
    from dask.distributed import wait

    client, cluster = _client(scheduler, workers, worker_timeout)
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(study.runs), initial=reused + 1, unit="run", dynamic_ncols=True)
    lost: list[str] = []

    def say(text: str) -> None:
        lost.append(text)
        if bar is not None:
            bar.write(text, file=sys.stderr)
        else:
            print(text, file=sys.stderr, flush=True)

    stop = parts_dir(out) / f".stop-{os.getpid()}-{time.time_ns()}"
    futures: dict[Any, int] = {}
    finished = False
    signals = _DeferredSignals()
    try:
        jobs = [
            (
                r.overrides,
                str(part_path(out, r)),
                str(histories_dir(out) / f"{r.run_id}.nc") if study.spec.output.histories else None,
            )
            for r in todo
        ]
        size = batch_size(len(jobs), sum(client.nthreads().values()) or 1)
        for i in range(0, len(jobs), size):
            batch = jobs[i : i + size]
            key = f"svbi-runs-{todo[i].run_id}-{len(batch)}"
            fut = client.submit(run_batch, str(study.scenario_path), batch, str(stop), key=key, pure=False)
            futures[fut] = len(batch)
        done = 1  # runs of this sweep done so far: the probe
        pending = set(futures)
        alone_since: float | None = None
        while pending:
            signals.act()  # a Ctrl-C or SIGTERM received while waiting stops the sweep here
            try:
                with signals:
                    result = wait(pending, timeout=0.5, return_when="FIRST_COMPLETED")
            except TimeoutError:  # none finished in 0.5 s: are there workers at all?
                result = None
            if result is None or not result.done:
                if scheduler and not client.nthreads():
                    alone_since = alone_since or time.monotonic()
                    if time.monotonic() - alone_since > worker_timeout:
                        raise SweepError(
                            f"no worker is alive on {scheduler} for {worker_timeout:g} s: the finished "
                            "runs are kept; start workers, then run the same command to resume",
                            exit_code=3,
                        )
                else:
                    alone_since = None
                continue
            pending = set(result.not_done)
            for fut in result.done:
                if fut.status == "error":
                    # the task itself died (e.g. its worker was killed too often): the runs of the
                    # batch that finished wrote their parts; the next sweep runs the others again
                    exc = fut.exception()
                    say(f"runs lost ({type(exc).__name__}: {exc}); run the sweep again to resume")
                for _ in range(futures[fut]):
                    done += 1
                    if bar is not None:
                        bar.update(1)
                    if on_done is not None:
                        on_done(done)
        signals.act()  # one received during the last wait
        finished = True
    finally:
        if not finished:
            # stopped: no run starts or writes its part from now on, and the queue is emptied
            stop.touch()
            try:
                client.cancel(list(futures), force=True)
            except Exception:  # the scheduler may be gone already
                pass
        if bar is not None:
            bar.close()
        client.close()
        if cluster is not None:
            cluster.close()
    return lost


class _DeferredSignals:
    """SIGINT and SIGTERM recorded while Dask waits, acted on by :meth:`act` outside Dask's calls.

    A KeyboardInterrupt raised inside ``distributed.wait`` interrupts the client's event-loop
    handshake half-way: the client can then no longer close, and its ``__del__`` prints a traceback
    at exit. Inside ``with signals:`` a signal is only recorded; :meth:`act` then delivers it to
    the handler that was in place (KeyboardInterrupt, or ``RunInterrupted`` for SIGTERM) from
    svbi's own code, at most one wait (0.5 s) later."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self) -> None:
        self.received: list[int] = []
        self.previous: dict[int, Any] = {}

    def __enter__(self) -> _DeferredSignals:
        if threading.current_thread() is threading.main_thread():
            for s in self.SIGNALS:
                self.previous[s] = signal.signal(s, lambda signum, _frame: self.received.append(signum))
        return self

    def __exit__(self, *exc: object) -> None:
        for s, handler in self.previous.items():
            signal.signal(s, handler)
        self.previous.clear()

    def act(self) -> None:
        if self.received:
            signal.raise_signal(self.received.pop(0))  # the handler in place raises


def _int_variable(values: np.ndarray, dims: list[str], attrs: dict[str, Any], missing: int) -> tuple:
    """An integer variable: NaN entries (runs without a value) stored as ``missing``, declared as the
    ``_FillValue`` only when there are some (a reader then sees NaN)."""
    bad = ~np.isfinite(values)
    if not bad.any():
        return (dims, values.astype(np.int64), attrs)
    import xarray as xr

    var = xr.Variable(dims, values.astype(float), attrs)
    var.encoding = {"dtype": "int64", "_FillValue": np.int64(missing)}
    return var


def assemble(study: Study, out: Path, command: str = "") -> xr.Dataset:
    """The store: every run's part in a grid with one dimension per axis; written atomically to
    ``out`` (``store.write_store``). A run without a part (lost) is marked ``missing``."""
    import xarray as xr

    parts: list[xr.Dataset] = []
    status, message, cutoff = [], [], []
    timings = {k: [] for k in RUN_TIMINGS}
    empty: dict[str, list[str]] = {}  # variables of length 0 in the parts (write_part): name -> dims
    for r in study.runs:
        path = part_path(out, r)
        ds = _read_part(path) if _finished(path) else None
        if ds is not None:
            empty.update(json.loads(ds.attrs.get(EMPTY_VARIABLES, "{}")))
            status.append(str(ds.attrs.get("status", STATUS_FAILED)))
            message.append(str(ds.attrs.get("message", "")))
            cutoff.append(float(ds.attrs.get(CUTOFF, np.nan)))
            for k in RUN_TIMINGS:
                timings[k].append(float(ds.attrs.get(k, np.nan)))
            ds.attrs = {}  # the run's attributes are in status, message and the timings
            parts.append(ds)
        else:
            status.append("missing")
            message.append("no result: run the sweep again to resume")
            cutoff.append(np.nan)
            for k in RUN_TIMINGS:
                timings[k].append(np.nan)
            parts.append(xr.Dataset())
    # a failed run has no metrics: NaN in the shape of a finished one (all NaN when none finished)
    template = next((p for p in parts if p.data_vars), None)
    if template is not None:
        blank = xr.full_like(template, np.nan, dtype=float)
        parts = [p if p.data_vars else blank for p in parts]
    # runs may differ in their numbers of spans, cars or wheels (e.g. HSLM trains): outer join, NaN
    stacked = xr.concat(
        [p.expand_dims(run=[i]) for i, p in enumerate(parts)],
        dim="run",
        join="outer",
        data_vars="all",
        coords="different",
        compat="equals",
        fill_value=np.nan,
    )
    shape = study.shape
    dims = study.dims
    names = study.names
    data_vars: dict[str, Any] = {}
    for name, da in stacked.data_vars.items():
        rest = [d for d in da.dims if d != "run"]
        values = np.asarray(da.transpose("run", *rest).values, dtype=float)
        values = values.reshape(*shape, *values.shape[1:])
        attrs = _metric_attrs(str(name))
        if name == "complete":  # a run without a part did not complete
            data_vars[name] = ([*dims, *rest], np.nan_to_num(values, nan=0.0).astype(np.int8), attrs)
        elif name in INTEGER_METRICS:
            data_vars[name] = _int_variable(values, [*dims, *rest], attrs, -1)
        else:
            data_vars[name] = ([*dims, *rest], values, attrs)
    for name, vdims in empty.items():  # in no part with a length: length 0 in the store too
        if name not in data_vars and name not in vdims:  # (a dimension's own coordinate is not kept)
            empty_shape = tuple(stacked.sizes.get(d, 0) for d in vdims)
            data_vars[name] = ([*dims, *vdims], np.full((*shape, *empty_shape), np.nan), _metric_attrs(name))
    data_vars[CUTOFF] = (
        dims,
        np.array(cutoff).reshape(shape),
        {
            "units": "Hz",
            "long_name": "low-pass cutoff of peak_deck_acceleration, max(30 Hz, 1.5 f1, f3) "
            "(EN 1990 A2.4.4.2.1(4))",
        },
    )
    data_vars["status"] = (
        dims,
        np.array(status, dtype=object).reshape(shape),
        {"long_name": "ok, diverged, failed or missing (no result: run the sweep again)"},
    )
    data_vars["message"] = (
        dims,
        np.array(message, dtype=object).reshape(shape),
        {"long_name": "why the run failed or stopped"},
    )
    for k, v in timings.items():
        values = np.array(v).reshape(shape)
        if k == "worker_pid":
            data_vars[k] = _int_variable(values, dims, dict(_RUN_UNITS[k]), -1)
        else:
            data_vars[k] = (dims, values, dict(_RUN_UNITS[k]))
    data_vars["run_id"] = (
        dims,
        np.array([r.run_id for r in study.runs], dtype=object).reshape(shape),
        {"long_name": "identity of the run: the name of its part and history files"},
    )
    coords: dict[str, Any] = {}
    for key, values in study.spec.axes.items():
        coords[names[key]] = (names[key], _coord(values), _key_attrs(key, values))
    if study.spec.zip:
        first = dims[-1]
        for key, values in study.spec.zip.items():
            coords[names[key]] = (first, _coord(values), _key_attrs(key, values))
    labels = {
        "span": "span (1 = first)",
        "car": "car (1 = leading)",
        "wheel": "wheel of the car (1 = leading; in 3D, the wheelset)",
        "side": "wheel of the wheelset (3D runs): left or right",
        "end": "end of the span",
        "joint": "joint between span j and span j + 1",
        "pier": "pier",
    }
    for d, label in labels.items():
        if d in stacked.coords:
            values = np.asarray(stacked.coords[d].values)
            attrs = {"long_name": label} | ({"units": "1"} if values.dtype.kind in "iuf" else {})
            coords[d] = (d, values.astype(str) if values.dtype == object else values, attrs)
    attrs = {
        "Conventions": CONVENTIONS,
        "title": study.spec.title,
        "history": history_line(command or f"svbi sweep {study.path} -o {out}"),
        "source": "svbi sweep",
        "svbi_version": __version__,
        "svbi_sweep": 1,
        "study": study.text,
        "scenario": study.scenario_text,
        "scenario_file": str(study.scenario_path),
        "axes": json.dumps(dims),
        "axis_keys": json.dumps({names[k]: k for k in [*study.spec.axes, *study.spec.zip]}),
        "set": json.dumps(study.sets, sort_keys=True),
    }
    store = xr.Dataset(data_vars, coords=coords, attrs=attrs)
    write_store(store, out)
    return store


def _metric_attrs(name: str) -> dict[str, str]:
    base = name[: -len("_time")] if name.endswith("_time") and name[: -len("_time")] in METRIC_DIMS else None
    if base is not None:
        return {"units": "s", "long_name": f"time of {base}"}
    long = {
        "peak_midspan_uz": "max |midspan_uz| (absolute vertical displacement)",
        "peak_deck_acceleration": "max |deck_acceleration| at midspan, low-pass filtered at "
        f"{CUTOFF} (EN 1990 A2.4.4.2.1(4))",
        "peak_carbody_az": "max |carbody_az| (vertical car-body acceleration)",
        "max_unloading_ratio": "max (P0 - P) / P0: P the filtered wheel force, P0 the static wheel load",
        "min_contact_force_filtered": "min contact_force_filtered",
        "lift_offs": "contact-to-lifted transitions",
        "peak_uplift": "max wheel_uplift",
        "peak_end_rotation": "max |end_rotation| of each span end",
        "peak_joint_rotation": "max angle between consecutive decks (theta1 + theta2)",
        "peak_pier_drift": "max |pier_drift| (pier top relative to the ground at its base)",
        "peak_derailment_quotient": "max Y/Q (filtered forces, Y outwards)",
        "peak_derailment_quotient_2m": "max of the 2 m sliding mean of Y/Q (EN 14363)",
        "peak_wheel_lateral_force": "max Y, outwards",
        "peak_axle_lateral_force": "max |sum Y| of a wheelset",
        "peak_axle_lateral_force_2m": "max |sum Y| of a wheelset, 2 m sliding mean (EN 14363)",
        "static_axle_load": "static load of the wheelset P0 (sum of Q0)",
        "flange_contacts": "flange contacts that begin",
        "peak_carbody_ay": "max |carbody_ay| (lateral car-body acceleration)",
        "complete": "1: the run finished; 0: it stopped early, failed or is missing",
    }.get(name, name)
    return {"units": METRIC_UNITS.get(name, "1"), "long_name": long}


def _key_attrs(key: str, values: list[Any]) -> dict[str, str]:
    numeric = all(isinstance(v, int | float) and not isinstance(v, bool) for v in values)
    return {**key_units(key, numeric), "scenario_key": key}


def _read_part(path: Path) -> xr.Dataset | None:
    """A run's part, or None when it cannot be read (then it is removed, and the next sweep runs
    the run again). The reader follows the file's signature: NetCDF-3 parts are SciPy's (the
    netCDF-C library refuses some of them as an "unknown file format"), NetCDF-4 parts are older
    versions'."""
    import xarray as xr

    try:
        with path.open("rb") as f:
            engine = "scipy" if f.read(3) == b"CDF" else "h5netcdf"
        with xr.open_dataset(path, engine=engine) as p:
            return p.load()
    except Exception:  # any reader failure: the part is not usable
        path.unlink(missing_ok=True)
        return None


def _coord(values: list[Any]) -> np.ndarray:
    if all(isinstance(v, int) and not isinstance(v, bool) for v in values):
        return np.asarray(values, dtype=np.int64)
    if all(isinstance(v, int | float) and not isinstance(v, bool) for v in values):
        return np.asarray(values, dtype=float)
    return np.array([v if isinstance(v, str) else json.dumps(v) for v in values], dtype=object)

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
(NetCDF, written atomically): one dimension per axis, the metrics per run, the run's ``status``
(``ok``, ``diverged`` or ``failed``) and ``message``. A run that fails or diverges does not stop the
sweep.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import os
import time
import tomllib
import warnings
from collections.abc import Callable, Sequence
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

from ..excitation.textfile import TextFileError, decode_text
from ..run.atomic import write_atomic
from ..run.results import write_netcdf
from ..run.simulate import simulate
from ..scenario.kinds import wrong_kind
from ..scenario.schema import Problem, ScenarioError, key_lines, load_scenario, loads_scenario
from .metrics import METRIC_INPUTS, compute_metrics

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


_UNION_TAGS = {"str", "int", "float", "bool"}
_RUN_UNITS = {
    "worker_peak_rss_mb": {"units": "MB"},
    "started": {"units": "seconds since 1970-01-01"},
    "ended": {"units": "seconds since 1970-01-01"},
    "worker_pid": {"long_name": "process id of the worker that ran it"},
}


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

    @property
    def dims(self) -> list[str]:
        """Dimension names: the axes in order, then the first zipped key."""
        return [*self.spec.axes, *([next(iter(self.spec.zip))] if self.spec.zip else [])]

    @property
    def shape(self) -> tuple[int, ...]:
        sizes = [len(v) for v in self.spec.axes.values()]
        if self.spec.zip:
            sizes.append(len(next(iter(self.spec.zip.values()))))
        return tuple(sizes)


# --------------------------------------------------------------------------------------------------
# the study file


def load_study(path: str | Path) -> Study:
    """Read and validate a study file; raises :class:`StudyError` naming key, file and line."""
    path = Path(path)
    source = str(path)
    try:
        text = decode_text(path.read_bytes(), source)  # UTF-8, a byte-order mark dropped
    except OSError as exc:
        raise StudyError([Problem("<file>", f"cannot read: {exc}", source)], source) from None
    except TextFileError as exc:
        raise StudyError([Problem("<file>", exc.problem, exc.where)], source) from None
    try:
        data = tomllib.loads(text)
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
    # every value of every axis must make a valid scenario on its own (errors name the study line)
    for table, values in (("axes", spec.axes), ("zip", spec.zip)):
        for key, items in values.items():
            for item in items:
                try:
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        load_scenario(scenario_path, overrides={key: item})
                except ScenarioError as exc:
                    message = "; ".join(p.message for p in exc.problems)
                    problems.append(
                        Problem(f"{table}.{key}", f"value {item!r}: {message}", where(f"{table}.{key}"))
                    )
                    break
    if problems:
        raise StudyError(problems, source)
    study = Study(path, spec, scenario_path, scenario_path.read_text(encoding="utf-8-sig"), text)
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
        overrides = {k: v[i] for (k, v), i in zip(axes, index, strict=False)}
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


def run_one(scenario_path: str, overrides: dict[str, Any], part: str, history: str | None) -> dict[str, Any]:
    """Run one grid point and write its part file (atomically). Never raises for a run that fails:
    the failure is recorded with its message."""
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
        if history is not None:
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
    write_part(metrics.assign_attrs(attrs), Path(part))
    return {"status": status, "message": message}


def run_batch(scenario_path: str, jobs: list[tuple[dict[str, Any], str, str | None]]) -> list[dict[str, Any]]:
    """:func:`run_one` for each ``(overrides, part, history)`` of a batch, in order; a run whose part
    already exists (a batch retried after its worker died part-way) is not run again."""
    out = []
    for overrides, part, history in jobs:
        if _finished(Path(part)):
            out.append({"status": "reused", "message": ""})
            continue
        out.append(run_one(scenario_path, overrides, part, history))
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
# the driver


def parts_dir(out: Path) -> Path:
    return Path(str(out) + ".parts")


def histories_dir(out: Path) -> Path:
    return Path(str(out) + ".histories")


def part_path(out: Path, run: Run) -> Path:
    return parts_dir(out) / f"{run.run_id}.nc"


def _finished(path: Path) -> bool:
    # a part exists only once complete (written atomically), so existence is enough
    return path.is_file()


@dataclass
class SweepReport:
    """What a sweep did: runs in total, run now, found finished, and by status."""

    total: int
    ran: int
    reused: int
    statuses: dict[str, int]
    store: Path


def run_sweep(
    study: Study,
    out: str | Path,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = True,
    on_done: Callable[[int], None] | None = None,
) -> SweepReport:
    """Run every missing run of ``study`` on Dask and assemble the store ``out``."""
    out = Path(out)
    parts_dir(out).mkdir(parents=True, exist_ok=True)
    keep = study.spec.output.histories
    if keep:
        histories_dir(out).mkdir(parents=True, exist_ok=True)
    todo = [r for r in study.runs if not _finished(part_path(out, r))]
    reused = len(study.runs) - len(todo)
    if todo:
        _compute(study, out, todo, workers, scheduler, progress, reused, on_done)
    store = assemble(study, out)
    statuses: dict[str, int] = {}
    for s in np.asarray(store["status"].values).ravel():
        statuses[str(s)] = statuses.get(str(s), 0) + 1
    return SweepReport(len(study.runs), len(todo), reused, statuses, out)


def _compute(
    study: Study,
    out: Path,
    todo: list[Run],
    workers: int | None,
    scheduler: str | None,
    progress: bool,
    reused: int,
    on_done: Callable[[int], None] | None,
) -> None:
    import dask
    from dask.distributed import Client, LocalCluster, as_completed

    cluster = None
    if scheduler:
        client = Client(scheduler, timeout="30s")
    else:
        n = workers or os.cpu_count() or 1
        with dask.config.set({"distributed.nanny.pre-spawn-environ": worker_environment(n)}):
            cluster = LocalCluster(
                n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=40
            )
        client = Client(cluster)
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(study.runs), initial=reused, unit="run", dynamic_ncols=True)
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
        futures = {}
        for i in range(0, len(jobs), size):
            batch = jobs[i : i + size]
            key = f"svbi-runs-{todo[i].run_id}-{len(batch)}"
            futures[client.submit(run_batch, str(study.scenario_path), batch, key=key, pure=False)] = len(
                batch
            )
        done = 0
        for fut in as_completed(list(futures)):
            if fut.status == "error":
                # the task itself died (e.g. its worker was killed too often): the runs of the
                # batch that finished wrote their parts; the next sweep runs the others again
                exc = fut.exception()
                if bar is not None:
                    bar.write(f"runs lost ({type(exc).__name__}: {exc}); re-run the sweep to resume")
            for _ in range(futures[fut]):
                done += 1
                if bar is not None:
                    bar.update(1)
                if on_done is not None:
                    on_done(done)
    finally:
        if bar is not None:
            bar.close()
        client.close()
        if cluster is not None:
            cluster.close()


def assemble(study: Study, out: Path) -> xr.Dataset:
    """The store: every run's part in a grid with one dimension per axis; written atomically to
    ``out``. A run without a part (lost) is marked ``missing``."""
    import xarray as xr

    parts: list[xr.Dataset] = []
    status, message = [], []
    timings = {k: [] for k in RUN_TIMINGS}
    empty: dict[str, list[str]] = {}  # variables of length 0 in the parts (write_part): name -> dims
    for r in study.runs:
        path = part_path(out, r)
        ds = _read_part(path) if _finished(path) else None
        if ds is not None:
            empty.update(json.loads(ds.attrs.get(EMPTY_VARIABLES, "{}")))
            status.append(str(ds.attrs.get("status", STATUS_FAILED)))
            message.append(str(ds.attrs.get("message", "")))
            for k in RUN_TIMINGS:
                timings[k].append(float(ds.attrs.get(k, np.nan)))
            ds.attrs = {}  # the run's attributes are in status, message and the timings
            parts.append(ds)
        else:
            status.append("missing")
            message.append("no result: re-run the sweep to resume")
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
    data_vars: dict[str, Any] = {}
    for name, da in stacked.data_vars.items():
        rest = [d for d in da.dims if d != "run"]
        values = np.asarray(da.transpose("run", *rest).values)
        if values.dtype.kind in "iub":
            values = values.astype(float)
        data_vars[name] = ([*dims, *rest], values.reshape(*shape, *values.shape[1:]), da.attrs)
    for name, vdims in empty.items():  # in no part with a length: length 0 in the store too
        if name not in data_vars and name not in vdims:  # (a dimension's own coordinate is not kept)
            empty_shape = tuple(stacked.sizes.get(d, 0) for d in vdims)
            data_vars[name] = ([*dims, *vdims], np.full((*shape, *empty_shape), np.nan))
    data_vars["status"] = (dims, np.array(status, dtype=object).reshape(shape))
    data_vars["message"] = (dims, np.array(message, dtype=object).reshape(shape))
    for k, v in timings.items():
        data_vars[k] = (dims, np.array(v).reshape(shape), _RUN_UNITS.get(k, {"units": "s"}))
    data_vars["run_id"] = (dims, np.array([r.run_id for r in study.runs], dtype=object).reshape(shape))
    coords: dict[str, Any] = {}
    for key, values in study.spec.axes.items():
        coords[key] = (key, _coord(values))
    if study.spec.zip:
        first = dims[-1]
        for key, values in study.spec.zip.items():
            coords[key] = (first, _coord(values))
    for d in ("span", "car", "wheel", "pier"):
        if d in stacked.coords:
            coords[d] = (d, stacked.coords[d].values)
    attrs = {
        "svbi_sweep": 1,
        "title": study.spec.title,
        "study": study.text,
        "scenario": study.scenario_text,
        "scenario_file": str(study.scenario_path),
        "axes": json.dumps(dims),
    }
    store = xr.Dataset(data_vars, coords=coords, attrs=attrs)
    write_netcdf(store, out)
    return store


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


def read_store(path: str | Path) -> xr.Dataset:
    """Load a sweep store (raises ValueError when the file is not one)."""
    import xarray as xr

    with xr.open_dataset(path, engine="h5netcdf", decode_times=False) as ds:
        data = ds.load()
    if not data.attrs.get("svbi_sweep"):
        raise ValueError(f"{path}: not a sweep store (no svbi_sweep attribute)")
    return data


def is_store(path: str | Path) -> bool:
    """True when ``path`` is a NetCDF file written by ``svbi sweep``."""
    try:
        import h5py

        with h5py.File(path, "r") as f:
            return bool(f.attrs.get("svbi_sweep", 0))
    except (OSError, ValueError):
        return False

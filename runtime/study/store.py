"""The store of a sweep as xarray and CF readers expect it: names, units, attributes, formats.

* **Dimension names a user can type**: each swept key's last part (``train.speed_kmh`` ->
  ``speed_kmh``, ``earthquake.scale`` -> ``scale``), with more of the key when two keys (or a key and
  one of the store's own names) would clash (``train.seed`` and ``track.seed`` -> ``train_seed``,
  ``track_seed``). The full dotted key is the coordinate's ``scenario_key`` attribute, and the
  store's ``axis_keys`` attribute maps every name to its key.
* ``units`` and ``long_name`` on every numeric variable and coordinate (text variables carry a
  ``long_name``: CF gives units no meaning for text), ``Conventions``, ``history`` and
  ``svbi_version`` attributes.
* **Formats**: NetCDF-4 with zlib compression (any name but ``.zarr``), or a Zarr store (a folder
  named ``*.zarr``). Both are written atomically: a temporary file or folder beside the target,
  renamed onto it once complete.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import tempfile
import warnings
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..run.atomic import write_atomic
from ..run.results import netcdf_engine

if TYPE_CHECKING:
    import xarray as xr

CONVENTIONS = "CF-1.10"
ZARR_SUFFIX = ".zarr"
STORE_SUFFIXES = (".nc", ".nc4", ZARR_SUFFIX)
"""Names ``svbi sweep -o`` accepts: NetCDF-4 files, or a Zarr store (a folder)."""

KEY_UNITS: dict[str, tuple[str | None, str]] = {
    "train.speed_kmh": ("km/h", "train speed"),
    "train.speed": ("m/s", "train speed"),
    "train.hslm": (None, "HSLM-A train of EN 1991-2"),
    "train.cars": ("1", "number of cars"),
    "train.acceleration": ("m/s^2", "train acceleration"),
    "train.start_position": ("m", "start position of the leading axle"),
    "train.vehicle": (None, "vehicle"),
    "earthquake.scale": ("1", "scale of the ground motion"),
    "earthquake.vertical_scale": ("1", "scale of the vertical ground motion"),
    "earthquake.longitudinal_scale": ("1", "scale of the longitudinal ground motion"),
    "earthquake.target_pga": ("m/s^2", "peak ground acceleration before earthquake.scale"),
    "earthquake.seed": ("1", "seed of the synthetic ground motion"),
    "earthquake.arrival": ("s", "arrival time of the ground motion"),
    "earthquake.record_dt": ("s", "time step of the record"),
    "earthquake.vertical": (None, "vertical ground motion"),
    "earthquake.longitudinal": (None, "longitudinal ground motion"),
    "track.seed": ("1", "seed of the rail irregularity"),
    "track.irregularity": (None, "rail irregularity"),
    "bridge.spans": ("1", "number of spans"),
    "bridge.span_length": ("m", "span length"),
    "bridge.mass_per_length": ("kg/m", "mass per length of the deck"),
    "bridge.youngs_modulus": ("Pa", "Young's modulus of the deck"),
    "bridge.area": ("m^2", "cross-section area of the deck"),
    "bridge.second_moment": ("m^4", "second moment of area of the deck"),
    "bridge.damping_ratio": ("1", "damping ratio of the bridge"),
    "bridge.elements_per_span": ("1", "finite elements per span"),
    "bridge.rail_height": ("m", "rail height above the deck's axis"),
    "bridge.track_form": (None, "track form"),
    "solver.time_step": ("s", "time step"),
    "solver.duration": ("s", "simulated duration"),
    "solver.output_every": ("1", "time steps per stored sample"),
}
"""Units and a description of the scenario keys a study usually sweeps."""

_SUFFIX_UNITS = (
    ("_kmh", "km/h"),
    ("_ratio", "1"),
    ("scale", "1"),
    ("seed", "1"),
    ("_length", "m"),
    ("_height", "m"),
    ("_position", "m"),
    ("_dt", "s"),
    ("time_step", "s"),
    ("duration", "s"),
    ("arrival", "s"),
    ("_pga", "m/s^2"),
)


def key_units(key: str, numeric: bool) -> dict[str, str]:
    """``units`` (numeric values only) and ``long_name`` of a swept scenario key."""
    if key in KEY_UNITS:
        units, name = KEY_UNITS[key]
    else:
        units = next((u for end, u in _SUFFIX_UNITS if key.endswith(end)), "1")
        name = key
    attrs = {"long_name": name}
    if numeric and units is not None:
        attrs["units"] = units
    return attrs


def dim_names(keys: Iterable[str], reserved: Iterable[str] = ()) -> dict[str, str]:
    """A name per dotted key that a user can type: the key's last part, lengthened (``a_b``) for the
    keys whose short name clashes with another key's or with a ``reserved`` name."""
    keys = list(keys)
    taken = set(reserved)
    parts = {k: [re.sub(r"\W+", "_", p).strip("_") or "key" for p in k.split(".")] for k in keys}
    depth = dict.fromkeys(keys, 1)
    while True:
        names = {k: "_".join(parts[k][-depth[k] :]) for k in keys}
        clash = [k for k in keys if list(names.values()).count(names[k]) > 1 or names[k] in taken]
        grow = [k for k in clash if depth[k] < len(parts[k])]
        if not grow:
            break
        for k in grow:
            depth[k] += 1
    out: dict[str, str] = {}
    used = set(taken)
    for k in keys:
        name, n = names[k], 2
        while name in used:  # clashes that the whole key cannot resolve: a number
            name, n = f"{names[k]}_{n}", n + 1
        used.add(name)
        out[k] = name
    return out


def history_line(command: str) -> str:
    """A CF ``history`` entry: the UTC time and the command."""
    import datetime as _dt

    now = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
    return f"{now} {command}"


def is_zarr_path(path: str | os.PathLike[str]) -> bool:
    return Path(path).suffix.lower() == ZARR_SUFFIX


def _encoding(ds: xr.Dataset) -> dict[str, dict[str, Any]]:
    """zlib on every numeric variable; integer counts with missing runs stored as integers with a
    ``_FillValue`` (the ``encoding`` set on the variable by the assembler)."""
    enc: dict[str, dict[str, Any]] = {}
    for name, var in ds.variables.items():
        e = dict(var.encoding)
        if var.dtype.kind in "iufb" and var.ndim > 0:
            e.update({"zlib": True, "complevel": 4, "shuffle": True})
        if e:
            enc[str(name)] = e
    return enc


def write_store(ds: xr.Dataset, path: str | os.PathLike[str]) -> Path:
    """Write the store to ``path`` atomically: NetCDF-4 (zlib), or Zarr for a ``.zarr`` name."""
    path = Path(path)
    out = ds.copy()
    for name in list(out.variables):
        if out[name].dtype == object:
            out[name] = out[name].astype(str)
    if is_zarr_path(path):
        return _write_zarr(out, path)
    encoding = _encoding(out)
    engine = netcdf_engine()

    def write(tmp: Path) -> None:
        image = out.to_netcdf(engine=engine, encoding=encoding)
        with open(tmp, "wb") as f:
            f.write(image)
            f.flush()
            os.fsync(f.fileno())

    return write_atomic(path, write)


def _write_zarr(ds: xr.Dataset, path: Path) -> Path:
    """A Zarr store written into a temporary folder beside ``path``, then renamed onto it (a store
    already there is moved aside first and removed once the new one is in place)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp"))
    old: Path | None = None
    encoding = {}
    for name, var in ds.variables.items():
        fill = var.encoding.get("_FillValue")
        if fill is not None:
            encoding[str(name)] = {"_FillValue": fill, "dtype": var.encoding.get("dtype")}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "consolidated metadata is not part of Zarr 3": read by xarray
            ds.to_zarr(tmp, mode="w", consolidated=True, encoding=encoding)
        if path.exists():
            old = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.", suffix=".old"))
            os.replace(path, old / "store")
        os.replace(tmp, path)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        if old is not None and (old / "store").exists() and not path.exists():
            os.replace(old / "store", path)  # put the previous store back
        raise
    finally:
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    return path


def read_store(path: str | os.PathLike[str]) -> xr.Dataset:
    """Load a sweep store, NetCDF or Zarr (raises ValueError when ``path`` is not one)."""
    import xarray as xr

    path = Path(path)
    try:
        if path.is_dir():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                opened = xr.open_zarr(path, decode_times=False)
        else:
            opened = xr.open_dataset(path, engine="h5netcdf", decode_times=False)
        with opened as ds:
            data = ds.load()
    except (OSError, ValueError, KeyError) as exc:
        raise ValueError(f"{path}: not a sweep store ({exc})") from None
    if not data.attrs.get("svbi_sweep"):
        raise ValueError(f"{path}: not a sweep store (no svbi_sweep attribute)")
    return data


def is_store(path: str | os.PathLike[str]) -> bool:
    """True when ``path`` is a store written by ``svbi sweep`` (a NetCDF file or a Zarr folder)."""
    path = Path(path)
    if os.path.isdir(path):  # os.path: a name too long is no store, not a traceback
        for meta in ("zarr.json", ".zattrs"):
            try:
                doc = json.loads((path / meta).read_text(encoding="utf-8"))
            except (OSError, ValueError):
                continue
            attrs = doc.get("attributes", doc) if isinstance(doc, dict) else {}
            if isinstance(attrs, dict) and attrs.get("svbi_sweep"):
                return True
        return False
    try:
        import h5py

        with h5py.File(path, "r") as f:
            return bool(f.attrs.get("svbi_sweep", 0))
    except (OSError, ValueError):
        return False

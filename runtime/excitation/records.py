"""Earthquake acceleration records: PEER AT2 files and plain text columns.

Supported layouts (detected from the file, not its name):

* PEER NGA-West2 AT2: 4 header lines, the 4th ``NPTS=   5372, DT=   .0100 SEC,``;
* PEER NGA AT2: the same, with filter poles after DT (``..., DT=   .0100 SEC,   0 POLE @ ...``);
* older PEER NGA AT2: the 4th line ``4096    0.0100    NPTS, DT``;
* PEER strong-motion database (SMD, c. 2000): ``NPTS=  1192, DT= .02000 SEC``;
* plain text: one column of accelerations (``dt`` must be given) or two columns ``t a`` (uniform
  t). Lines starting with ``#`` are comments.

AT2 units come from the header (``... IN UNITS OF G``); plain text units from ``units`` (default
``"g"``, the PEER convention). Accelerations are returned in m/s², with g = 9.81 m/s² (docs/design.md
section 2).
Every error names the file and, where there is one, the line.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ...codegen.input_files import MAX_DATA_BYTES, InputFileError, read_text

G = 9.81
"""Standard gravity used to convert records in g (docs/design.md section 2)."""

UNITS = {
    "g": G,
    "m/s2": 1.0,
    "m/s/s": 1.0,
    "m/s^2": 1.0,
    "m/s**2": 1.0,
    "cm/s2": 0.01,
    "cm/s/s": 0.01,
    "cm/s^2": 0.01,
    "cm/s**2": 0.01,
    "gal": 0.01,
    "mm/s2": 1e-3,
    "mm/s/s": 1e-3,
    "mm/s^2": 1e-3,
}
"""Known acceleration units and their factor to m/s² (lower case, ``sec`` written ``s``)."""

_NPTS_DT = re.compile(r"NPTS\s*=\s*(?P<npts>\S+?)\s*,\s*DT\s*=\s*(?P<dt>[^\s,]+)", re.IGNORECASE)
_NPTS_ONLY = re.compile(r"NPTS\s*=\s*(?P<npts>[^\s,]+)", re.IGNORECASE)
_OLD_NPTS_DT = re.compile(r"^\s*(?P<npts>\d+)\s+(?P<dt>\S+)\s+NPTS\s*,\s*DT", re.IGNORECASE)
_UNITS = re.compile(r"UNITS\s+OF\s+(?P<unit>[^\s.,;]+(?:\s*/\s*[^\s.,;]+)*)", re.IGNORECASE)
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[EeDd][-+]?\d+)?")
_NUMBERS = re.compile(rf"(?:{_NUMBER.pattern})+")


MAX_ACCELERATION = 50.0 * G
"""Largest accepted sample (m/s², 50 g): more than ten times the largest ground acceleration ever
recorded (about 4 g). A larger value is a unit or format slip, and it would make the run diverge
with a misleading hint about the time step."""


def _check_magnitude(value: float, factor: float, where: str) -> None:
    """A sample of a record, in file units times ``factor``, must lie within +-MAX_ACCELERATION."""
    if abs(value * factor) > MAX_ACCELERATION:
        raise RecordError(
            f"{where}: acceleration {value:g} ({value * factor:.3g} m/s²) is above the limit of 50 g "
            f"({MAX_ACCELERATION:g} m/s²): wrong units or a corrupt line?"
        )


class RecordError(ValueError):
    """A record file that cannot be read; the message names the file and the line."""


@dataclass(frozen=True, eq=False)
class Record:
    """A uniformly sampled ground acceleration history.

    ``accel[i]`` is the acceleration (m/s²) at record time ``i * dt``; ``source`` says where it
    came from (a file path, or the generator and seed of a synthetic record).
    """

    name: str
    dt: float
    accel: NDArray[np.float64]
    source: str

    @property
    def npts(self) -> int:
        """Number of samples."""
        return int(self.accel.size)

    @property
    def duration(self) -> float:
        """(npts - 1) · dt (s)."""
        return (self.npts - 1) * self.dt

    @property
    def time(self) -> NDArray[np.float64]:
        """Record time of each sample (s)."""
        return np.arange(self.npts) * self.dt

    @property
    def pga(self) -> float:
        """Peak ground acceleration max |a| (m/s²)."""
        return float(np.max(np.abs(self.accel)))


def unit_factor(unit: str, where: str) -> float:
    """Factor from ``unit`` to m/s²; ``where`` (file and line) goes into the error message."""
    key = re.sub(r"\s+", "", unit.lower()).replace("sec", "s").replace("²", "2")
    if key not in UNITS:
        known = ", ".join(sorted({"g", "m/s2", "cm/s2", "gal", "mm/s2"}))
        raise RecordError(f"{where}: unknown acceleration units {unit!r} (known: {known})")
    return UNITS[key]


def _parse_number(token: str, where: str) -> float:
    try:
        return float(token.replace("D", "E").replace("d", "e"))
    except ValueError:
        raise RecordError(f"{where}: not a number: {token!r}") from None


def _tokens(line: str, where: str) -> list[float]:
    """Numbers of a data line; tolerates fixed-width fields that run together (``-.1E-01-.2E-01``)."""
    values: list[float] = []
    for token in line.replace(",", " ").split():
        try:
            values.append(float(token.replace("D", "E").replace("d", "e")))
            continue
        except ValueError:
            pass
        pieces = _NUMBER.findall(token)
        if not pieces or "".join(pieces) != token:
            raise RecordError(f"{where}: not a number: {token!r}")
        values.extend(_parse_number(p, where) for p in pieces)
    return values


def _is_data_line(line: str) -> bool:
    stripped = line.replace(",", " ").split()
    if not stripped:
        return False
    return all(_NUMBERS.fullmatch(t) or t.lower().lstrip("+-") in ("nan", "inf") for t in stripped)


def read_record(
    path: str | Path,
    *,
    dt: float | None = None,
    units: str | None = None,
    name: str | None = None,
) -> Record:
    """Read an acceleration record (format detected from the content, see the module doc).

    ``dt`` is required for one-column files and must agree with the header or the time column when
    both are present. ``units`` overrides the header's units (AT2) or sets those of a plain file
    (default ``"g"``).
    """
    p = Path(path)
    try:  # a regular file of bounded size: never /dev/zero, a FIFO or a folder
        lines = read_text(p, MAX_DATA_BYTES, errors="replace").splitlines()  # a byte-order mark dropped
    except InputFileError as exc:
        raise RecordError(f"{p}: cannot read record: {exc.problem}") from None
    label = name if name is not None else p.name
    first = next((i for i, ln in enumerate(lines) if ln.strip() and not ln.lstrip().startswith("#")), None)
    if first is None:
        raise RecordError(f"{p}: empty record file")
    if _is_data_line(lines[first]):
        return _read_plain(p, lines, label, dt=dt, units=units)
    return _read_at2(p, lines, label, dt=dt, units=units)


def _read_at2(p: Path, lines: list[str], label: str, *, dt: float | None, units: str | None) -> Record:
    header_end = next((i for i, ln in enumerate(lines) if _is_data_line(ln)), len(lines))
    npts: int | None = None
    dt_file: float | None = None
    npts_line = 0
    unit_factor_: float | None = None
    for i in range(header_end):
        line, where = lines[i], f"{p}: line {i + 1}"
        match = _NPTS_DT.search(line) or _OLD_NPTS_DT.search(line)
        if match:
            npts_text, dt_text = match.group("npts"), match.group("dt")
            if not npts_text.isdigit():
                raise RecordError(f"{where}: NPTS is not a whole number: {npts_text!r}")
            npts, npts_line = int(npts_text), i + 1
            dt_file = _parse_number(dt_text, where)
            if not (math.isfinite(dt_file) and dt_file > 0.0):
                raise RecordError(f"{where}: DT must be positive (got {dt_text!r})")
        elif _NPTS_ONLY.search(line) or re.search(r"\bNPTS\b", line, re.IGNORECASE):
            raise RecordError(f"{where}: header gives NPTS but no DT (missing DT): {line.strip()!r}")
        unit_match = _UNITS.search(line)
        if unit_match and units is None:
            unit_factor_ = unit_factor(unit_match.group("unit"), where)
    if npts is None or dt_file is None:
        raise RecordError(
            f"{p}: line {header_end}: no 'NPTS=..., DT=...' or 'NPTS, DT' line in the {header_end} "
            "header lines (missing DT); for a header-less file give one or two numeric columns"
        )
    if units is not None:
        unit_factor_ = unit_factor(units, f"{p}")
    if unit_factor_ is None:
        raise RecordError(
            f"{p}: lines 1-{header_end}: the header does not state the units ('... UNITS OF G'); "
            "unknown units: pass units= explicitly"
        )
    if dt is not None and not math.isclose(dt, dt_file, rel_tol=1e-9):
        raise RecordError(f"{p}: line {npts_line}: DT = {dt_file} in the file, but dt = {dt} was given")
    values: list[float] = []
    last_line = header_end
    for i in range(header_end, len(lines)):
        if not lines[i].strip():
            continue
        where = f"{p}: line {i + 1}"
        row = _tokens(lines[i], where)
        for v in row:
            if not math.isfinite(v):
                raise RecordError(f"{where}: non-finite acceleration value (NaN or inf)")
            _check_magnitude(v, unit_factor_, where)
        values.extend(row)
        last_line = i + 1
    if len(values) < npts:
        raise RecordError(
            f"{p}: line {last_line}: truncated record: the header (line {npts_line}) declares "
            f"NPTS = {npts} but the data end after {len(values)} values"
        )
    if len(values) > npts:
        raise RecordError(
            f"{p}: line {npts_line}: NPTS = {npts} disagrees with the data: {len(values)} values "
            f"found (data end at line {last_line})"
        )
    if npts < 2:
        raise RecordError(f"{p}: line {npts_line}: a record needs at least 2 samples (NPTS = {npts})")
    accel = np.asarray(values) * unit_factor_
    return Record(name=label, dt=dt_file, accel=accel, source=str(p))


def _read_plain(p: Path, lines: list[str], label: str, *, dt: float | None, units: str | None) -> Record:
    factor = unit_factor(units if units is not None else "g", f"{p}")
    rows: list[list[float]] = []
    row_lines: list[int] = []
    for i, line in enumerate(lines):
        text = line.split("#", 1)[0]
        if not text.strip():
            continue
        where = f"{p}: line {i + 1}"
        row = _tokens(text, where)
        if rows and len(row) != len(rows[0]):
            raise RecordError(
                f"{where}: {len(row)} columns, but the file started with {len(rows[0])} "
                f"(line {row_lines[0]}); a truncated or mixed file?"
            )
        if len(row) not in (1, 2):
            raise RecordError(f"{where}: expected one column (a) or two columns (t a), got {len(row)}")
        if not all(math.isfinite(v) for v in row):
            raise RecordError(f"{where}: non-finite value (NaN or inf)")
        _check_magnitude(row[-1], factor, where)
        rows.append(row)
        row_lines.append(i + 1)
    data = np.asarray(rows)
    if data.shape[0] < 2:
        raise RecordError(f"{p}: a record needs at least 2 samples (found {data.shape[0]})")
    if data.shape[1] == 1:
        if dt is None:
            raise RecordError(
                f"{p}: line {row_lines[0]}: one-column record without a time step (missing DT): "
                "give dt, or write two columns 't a'"
            )
        if not (math.isfinite(dt) and dt > 0.0):
            raise RecordError(f"{p}: dt must be positive (got {dt})")
        return Record(name=label, dt=float(dt), accel=data[:, 0] * factor, source=str(p))
    t = data[:, 0]
    steps = np.diff(t)
    step = float(steps[0])
    if step <= 0.0:
        raise RecordError(f"{p}: line {row_lines[1]}: time does not increase")
    bad = np.flatnonzero(np.abs(steps - step) > 1e-6 * step)
    if bad.size:
        k = int(bad[0]) + 1
        raise RecordError(
            f"{p}: line {row_lines[k]}: non-uniform time step ({steps[k - 1]:g} s instead of "
            f"{step:g} s); resample the record to a uniform step"
        )
    if dt is not None and not math.isclose(dt, step, rel_tol=1e-6):
        raise RecordError(f"{p}: the time column has step {step:g} s, but dt = {dt} was given")
    if abs(t[0]) > 1e-9 * max(1.0, abs(step)):
        raise RecordError(f"{p}: line {row_lines[0]}: the time column must start at t = 0 (got {t[0]:g})")
    return Record(name=label, dt=(t[-1] - t[0]) / (t.size - 1), accel=data[:, 1] * factor, source=str(p))

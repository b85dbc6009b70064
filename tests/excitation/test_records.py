"""Record readers: the four PEER header variants, plain columns, units, and bad input."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from svbi.runtime.excitation.records import G, RecordError, read_record

RECORDS = Path(__file__).resolve().parents[3] / "shared" / "data" / "ground-motions"
HEADERLESS_DT = {"tabasFN.txt": 0.02, "tabasFP.txt": 0.02}  # README note 1 (OpenSees scripts)


def readme_table() -> dict[str, dict[str, float]]:
    """File -> NPTS, DT, PGA (g) parsed from the README's table (the independent reference)."""
    readme = RECORDS / "README.md"
    if not readme.is_file():
        pytest.skip(f"ground-motion records not found at {RECORDS} (../shared is absent)")
    rows = {}
    for line in readme.read_text().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 10 and cells[0].startswith("`"):
            rows[cells[0].strip("`")] = {"npts": int(cells[4]), "dt": float(cells[5]), "pga": float(cells[6])}
    assert len(rows) == 9, "README table format changed"
    return rows


@pytest.mark.parametrize(
    "name",
    [
        "RSN6_IMPVALL.I_I-ELC180.AT2",  # NGA-West2
        "Rinaldi228.AT2",  # NGA with poles
        "Rinaldi318.AT2",
        "RinaldiUP.AT2",
        "NIS090.AT2",  # old NGA 'NPTS, DT'
        "DAY-TR_AT2.txt",  # PEER SMD c. 2000
        "I-ELC180_AT2.txt",
        "tabasFN.txt",  # header-less one column
        "tabasFP.txt",
    ],
)
def test_shared_records_match_readme(name: str) -> None:
    table = readme_table()[name]
    rec = read_record(RECORDS / name, dt=HEADERLESS_DT.get(name))
    assert rec.npts == table["npts"]
    assert rec.dt == pytest.approx(table["dt"], rel=1e-12)
    assert rec.pga / G == pytest.approx(table["pga"], abs=5e-4 + 1e-12)
    assert rec.duration == pytest.approx((table["npts"] - 1) * table["dt"])
    assert np.all(np.isfinite(rec.accel))


def test_npts_from_header_equals_values_read() -> None:
    readme_table()  # skips when ../shared is absent
    for path in sorted(RECORDS.glob("*AT2*")):
        header = path.read_text().splitlines()[3]
        match = re.search(r"NPTS=\s*(\d+)", header) or re.match(r"\s*(\d+)\s", header)
        assert match, f"{path.name}: no NPTS in line 4"
        assert read_record(path).npts == int(match.group(1))


AT2_HEADER = "PEER NGA STRONG MOTION DATABASE RECORD\nTEST EVENT\nACCELERATION TIME SERIES IN UNITS OF G\n"


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def assert_error(path: Path, line: int | None, *words: str, **kwargs) -> None:
    with pytest.raises(RecordError) as err:
        read_record(path, **kwargs)
    message = str(err.value)
    assert str(path) in message, message
    if line is not None:
        assert f"line {line}:" in message, message
    for word in words:
        assert word in message, message


def test_truncated_record(tmp_path: Path) -> None:
    path = write(
        tmp_path, "trunc.AT2", AT2_HEADER + "NPTS=    10, DT=   .0100 SEC,\n .1 .2 .3 .4 .5\n .6 .7 .8\n"
    )
    assert_error(path, 6, "truncated", "NPTS = 10")


def test_npts_disagrees_with_data(tmp_path: Path) -> None:
    path = write(tmp_path, "long.AT2", AT2_HEADER + "NPTS=     4, DT=   .0100 SEC,\n .1 .2 .3 .4 .5\n .6\n")
    assert_error(path, 4, "disagrees", "6 values")


def test_nan_value(tmp_path: Path) -> None:
    path = write(tmp_path, "nan.AT2", AT2_HEADER + "NPTS=     6, DT=   .0100 SEC,\n .1 .2 .3\n .4 NaN .6\n")
    assert_error(path, 6, "NaN")


def test_missing_dt(tmp_path: Path) -> None:
    path = write(tmp_path, "nodt.AT2", AT2_HEADER + "NPTS=     3,\n .1 .2 .3\n")
    assert_error(path, 4, "missing DT")
    path = write(tmp_path, "noheader.AT2", AT2_HEADER + "SOMETHING ELSE\n .1 .2 .3\n")
    assert_error(path, 4, "missing DT")
    path = write(tmp_path, "onecol.txt", "0.1\n0.2\n0.3\n")
    assert_error(path, 1, "missing DT")


def test_unknown_units(tmp_path: Path) -> None:
    header = "PEER\nTEST\nACCELERATION TIME SERIES IN UNITS OF FURLONG/FORTNIGHT\n"
    path = write(tmp_path, "units.AT2", header + "NPTS=     3, DT=   .0100 SEC,\n .1 .2 .3\n")
    assert_error(path, 3, "unknown acceleration units")
    silent = write(
        tmp_path, "silent.AT2", "PEER\nTEST\nACCELERATION\nNPTS=     3, DT=   .0100 SEC,\n .1 .2 .3\n"
    )
    assert_error(silent, None, "unknown units")
    plain = write(tmp_path, "plain.txt", "0 0.1\n0.01 0.2\n")
    assert_error(plain, None, "unknown acceleration units", units="furlong")


def test_other_bad_plain_files(tmp_path: Path) -> None:
    uneven = write(tmp_path, "uneven.txt", "0 0.1\n0.01 0.2\n0.03 0.3\n")
    assert_error(uneven, 3, "non-uniform")
    mixed = write(tmp_path, "mixed.txt", "0 0.1\n0.01 0.2\n0.02\n")
    assert_error(mixed, 3, "columns")


def test_units_conversion_and_variants(tmp_path: Path) -> None:
    cm = AT2_HEADER.replace("UNITS OF G", "UNITS OF CM/SEC/SEC")
    path = write(tmp_path, "cm.AT2", cm + "NPTS=     3, DT=   .0200 SEC\n 100. -250. 50.\n")
    np.testing.assert_allclose(read_record(path).accel, [1.0, -2.5, 0.5])
    old = write(tmp_path, "old.AT2", AT2_HEADER + "3    0.0050    NPTS, DT\n .1 .2 .3\n")
    rec = read_record(old)
    assert rec.dt == 0.005 and rec.npts == 3
    np.testing.assert_allclose(rec.accel, np.array([0.1, 0.2, 0.3]) * 9.81)
    fused = write(
        tmp_path, "fused.AT2", AT2_HEADER + "NPTS=     3, DT=   .0100 SEC,\n-.1E-01-.2E-01  .3E-01\n"
    )
    np.testing.assert_allclose(read_record(fused).accel, np.array([-0.01, -0.02, 0.03]) * 9.81)
    two = write(tmp_path, "two.txt", "# t a\n0.0 0.5\n0.01 -1.0\n0.02 0.25\n")
    rec = read_record(two, units="m/s2")
    assert rec.dt == pytest.approx(0.01) and rec.npts == 3
    np.testing.assert_allclose(rec.accel, [0.5, -1.0, 0.25])

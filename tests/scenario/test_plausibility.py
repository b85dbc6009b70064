"""Plausibility warnings: a value outside the range of real railway bridges, trains and records is
one warning naming the key, the value, the band and the likely slip; the run goes on. The bands
are one table in code (``scenario/plausibility.py``) and in ``docs/scenario.md``; the shipped
examples warn about nothing."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import pytest

from svbi.runtime.scenario.plausibility import BANDS
from svbi.runtime.scenario.schema import ScenarioWarning, load_scenario

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = REPO / "examples"

BASE = """\
[bridge]
spans = 1
span_length = 32.0
mass_per_length = 22.40e3
youngs_modulus = 35.5e9
area = 8.63
second_moment = 6.58
elements_per_span = 8

[train]
vehicle = "moving-load"
hslm = "A1"
speed_kmh = 300.0

[solver]
time_step = 1.0e-3
output_every = 1
"""


def _warnings(path: Path, overrides: list[str] | None = None) -> list[str]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_scenario(path, overrides=overrides)
    found = [str(w.message) for w in caught if issubclass(w.category, ScenarioWarning)]
    return [m for m in found if "outside" in m]


def _scenario(tmp_path: Path, text: str = BASE) -> Path:
    path = tmp_path / "s.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_a_span_in_millimetres_warns_naming_the_key_value_band_and_slip(tmp_path: Path) -> None:
    path = _scenario(tmp_path, BASE.replace("span_length = 32.0", "span_length = 32000.0"))
    (w,) = _warnings(path)
    assert w == f"{path}:3: bridge.span_length = 32000 m is outside 2 … 300 m for railway spans; millimetres?"


def test_a_long_form_span_in_millimetres_names_its_list_entry(tmp_path: Path) -> None:
    text = BASE.replace("spans = 1\nspan_length = 32.0\n", "").replace(
        "elements_per_span = 8\n", "elements_per_span = 8\n\n[[bridge.girders]]\nspans = [32000.0]\n"
    )
    path = _scenario(tmp_path, text)
    (w,) = _warnings(path)
    assert w.startswith(f"{path}:9: bridge.girders[0].spans[0] = 32000 m is outside 2 … 300 m")


@pytest.mark.parametrize(
    ("override", "expected"),
    [
        ("bridge.youngs_modulus=1e3", "bridge.youngs_modulus = 1000 Pa is outside 1e+09 … 4e+11 Pa"),
        ("bridge.mass_per_length=22.4", "bridge.mass_per_length = 22.4 kg/m is outside 500 … 500000 kg/m"),
        ("bridge.second_moment=6.58e8", "bridge.second_moment = 6.58e+08 m⁴ is outside"),
        ("bridge.damping_ratio=0.5", "bridge.damping_ratio = 0.5 is outside 0 … 0.2 for structural damping"),
        ("train.speed_kmh=1000.0", "train.speed_kmh = 1000 km/h is outside 0 … 575 km/h"),
    ],
)
def test_each_slip_of_a_set_value_warns_naming_the_set(tmp_path: Path, override: str, expected: str) -> None:
    (w,) = _warnings(_scenario(tmp_path), [override])
    assert w.startswith(f"--set {override}: {expected}"), w


def test_braking_at_4_g_warns(tmp_path: Path) -> None:
    (w,) = _warnings(_scenario(tmp_path), ["train.acceleration=-39.24", "solver.duration=1.0"])
    assert "train.acceleration = -39.24 m/s² is outside -5 … 5 m/s²" in w and "g?" in w


def test_a_pier_a_million_metres_high_warns(tmp_path: Path) -> None:
    (w,) = _warnings(EXAMPLES / "viaduct.toml", ["bridge.piers[2].height=1e6"])
    assert w.startswith("--set bridge.piers[2].height=1e6: bridge.piers[2].height = 1e+06 m is outside")
    assert "0.5 … 200 m for railway bridge piers" in w
    assert w.endswith("millimetres?")


def test_a_profile_in_millimetres_warns(tmp_path: Path) -> None:
    rows = "\n".join(f"{x:.1f} {3.0 if x % 2 else -2.0}" for x in range(-500, 600))
    (tmp_path / "mm.txt").write_text(rows + "\n", encoding="utf-8")
    path = _scenario(tmp_path, BASE + '\n[track]\nirregularity = "mm.txt"\n')
    (w,) = _warnings(path)
    assert w.startswith(f"{path}:20: track.irregularity = 'mm.txt': the profile reaches |r| = 3 m")
    assert w.endswith("millimetres?")


def test_a_record_dt_of_1e9_s_warns(tmp_path: Path) -> None:
    (tmp_path / "r.txt").write_text("\n".join("0.01" for _ in range(50)) + "\n", encoding="utf-8")
    path = _scenario(tmp_path, BASE + '\n[earthquake]\nvertical = "r.txt"\nrecord_dt = 1e9\n')
    (w,) = _warnings(path)
    assert w.startswith(f"{path}:21: earthquake.record_dt = 1e+09 s is outside 0.0001 … 0.1 s")


def test_a_record_header_dt_of_1e9_s_warns_naming_the_component(tmp_path: Path) -> None:
    header = "PEER record\nunits of g\nacceleration\nNPTS=   50, DT= 1.0E+09 SEC\n"
    (tmp_path / "r.at2").write_text(header + "\n".join("0.01" for _ in range(50)) + "\n", encoding="utf-8")
    path = _scenario(tmp_path, BASE + '\n[earthquake]\nlongitudinal = "r.at2"\n')
    (w,) = _warnings(path)
    assert w.startswith(f"{path}:20: earthquake.longitudinal = 'r.at2': the record's time step DT = 1e+09 s")


def test_the_warning_does_not_stop_the_run_and_is_printed_once(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from svbi.runtime.cli.app import _register, app

    _register()
    path = _scenario(tmp_path)
    out = tmp_path / "r.nc"
    sets = ["--set", "bridge.rail_height=50.0", "--set", "solver.duration=0.05"]
    result = CliRunner().invoke(app, ["run", str(path), "-o", str(out), "-q", *sets])
    assert result.exit_code == 0, result.output
    assert out.is_file()
    lines = [line for line in result.output.splitlines() if "bridge.rail_height" in line]
    assert lines == [
        "warning: --set bridge.rail_height=50.0: bridge.rail_height = 50 m is outside -10 … 10 m for rail "
        "heads above a girder's axis; millimetres?"
    ]


def _example_scenarios() -> list[Path]:
    out = []
    for path in sorted(EXAMPLES.glob("*.toml")):
        text = path.read_text(encoding="utf-8")
        if re.search(r"^\[bridge\]", text, re.MULTILINE):
            out.append(path)
    return out


@pytest.mark.parametrize("path", _example_scenarios(), ids=lambda p: p.name)
def test_the_shipped_examples_warn_about_nothing(path: Path) -> None:
    try:
        found = _warnings(path)
    except Exception as exc:  # a record from ../shared that is not here
        pytest.skip(f"{path.name}: {exc}")
    assert found == []


def test_the_shipped_studies_warn_about_nothing() -> None:
    from svbi.runtime.study.sweep import load_study

    for path in sorted(EXAMPLES.glob("*.toml")):
        if path in _example_scenarios():
            continue
        study = load_study(path)
        for key, values in {**study.spec.axes, **study.spec.zip}.items():
            for value in values:
                with warnings.catch_warnings(record=True) as caught:
                    warnings.simplefilter("always")
                    load_scenario(study.scenario_path, overrides={key: value})
                found = [str(w.message) for w in caught if "outside" in str(w.message)]
                assert found == [], (path.name, key, value)


def test_the_bands_table_of_the_docs_is_the_codes() -> None:
    """docs/scenario.md lists every band of ``BANDS`` with the same numbers."""
    doc = (REPO / "docs" / "scenario.md").read_text(encoding="utf-8")
    section = doc.split("### Plausibility", 1)[1].split("\n## ", 1)[0]
    rows = {}
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) >= 4 and cells[0].startswith("`") and cells[0] != "`quantity`":
            rows[cells[0].strip("`")] = (cells[2], cells[3])
    assert set(rows) == set(BANDS)
    for name, band in BANDS.items():
        assert rows[name] == (f"{band.low:g}", f"{band.high:g}"), name

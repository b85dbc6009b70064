"""``svbi check`` applies the checks EN 1990 / EN 1991-2 call for, each against independent truth.

* the deck acceleration is the envelope over the deck, not the midspan value: one 200 kN axle at
  300 km/h over the 32 m span of ``examples/hslm-span.toml``, against closed-form modes integrated
  by odeint (the envelope is 8 % above the midspan value there);
* the LM71 deflection (EN 1990 A2.4.4.2.3(1)) against the closed-form deflection of a simply
  supported Euler-Bernoulli beam under the four axles and the distributed load, and the dynamic
  factors Φ2 and Φ3 of EN 1991-2 6.4.5.2 against their formulas at a few lengths;
* a traffic run gets the traffic set (deflection L/600, twist n/a, end rotations, comfort by δ/L
  without a car body, the HSLM-B flag on spans under 7 m), clauses named as in EN 1990:2002+A1;
* the paper example (an earthquake) gets the seismic running-safety set: ΔP/P against 0.8, no
  traffic limit on its absolute deck acceleration, and no 0.6 row.
"""

from __future__ import annotations

import math
import sys
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import svbi
from svbi.runtime.cli.app import _register, app
from svbi.runtime.run.results import write_netcdf
from svbi.runtime.scenario.schema import load_scenario, validate_scenario
from svbi.runtime.study.en1990 import CheckOptions, en1990_checks
from svbi.runtime.study.lm71 import dynamic_factor, lm71_deflection
from svbi.runtime.study.metrics import compute_metrics

sys.path.insert(0, str(Path(__file__).parent))
from test_deck_acceleration_en1990 import SPAN, unit_response  # noqa: E402

REPO = Path(__file__).resolve().parents[2]


def invoke(*args: str):
    """The command line in this process: exit status and output."""
    if not app.registered_commands:
        _register()
    return CliRunner().invoke(app, list(args))


def simulate(table: dict):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return svbi.simulate(validate_scenario(table))


def test_deck_acceleration_is_the_envelope_over_the_deck():
    L, v, p = SPAN["span_length"], 300.0 / 3.6, 2.0e5
    ds = simulate(
        {
            "bridge": SPAN,
            "train": {
                "vehicle": "moving-load",
                "speed": v,
                "parameters": {"axle_loads": [p], "axle_offsets": [0.0]},
            },
            "solver": {"time_step": 1e-3, "output_every": 1, "duration": L / v + 0.5},
        }
    )
    m = compute_metrics(ds)
    unit = unit_response(v, L / v + 0.5, 1e-4)
    x = np.linspace(0.0, L, 17)
    acc = np.abs(p * unit @ np.sin(np.outer(np.arange(1, unit.shape[1] + 1), x) * math.pi / L))
    envelope, midspan = acc.max(), acc[:, 8].max()
    assert envelope > 1.05 * midspan  # a midspan reading cannot pass
    assert float(m.peak_deck_acceleration[0]) == pytest.approx(envelope, rel=0.03)
    assert float(m.peak_deck_acceleration_x[0]) != pytest.approx(L / 2)


def closed_form_lm71(length: float, ei: float) -> float:
    """Largest deflection of a simply supported beam under LM71 (4 x 250 kN at 1.6 m, 80 kN/m
    beyond 0.8 m from the outer axles), the group centred at every L/64, read at every L/16."""

    def point(a: float | np.ndarray, x: np.ndarray) -> np.ndarray:  # unit load at a, deflection at x (down +)
        b = length - a
        left = b * x * (length**2 - b**2 - x**2) / (6 * length * ei)
        right = a * (length - x) * (length**2 - a**2 - (length - x) ** 2) / (6 * length * ei)
        return np.where(x <= a, left, right)

    x = np.linspace(0.0, length, 17)
    worst = 0.0
    for c in np.linspace(0.0, length, 65):
        w = np.zeros_like(x)
        for a in c + 1.6 * np.array([-1.5, -0.5, 0.5, 1.5]):
            if 0.0 <= a <= length:
                w += 250e3 * point(a, x)
        for lo, hi in ((0.0, c - 3.2), (c + 3.2, length)):
            if hi > lo:  # the distributed load by a fine midpoint sum
                n = 4000
                a = lo + (np.arange(n) + 0.5) * (hi - lo) / n  # the 4000 midpoints at once
                w += (80e3 * (hi - lo) / n * point(a[:, None], x)).sum(axis=0)
        worst = max(worst, float(w.max()))
    return worst


@pytest.mark.parametrize("length", [32.0, 5.0])
def test_lm71_deflection_is_the_beam_formula(length):
    bridge = {**SPAN, "span_length": length}
    ei = SPAN["youngs_modulus"] * SPAN["second_moment"]
    assert lm71_deflection(bridge) == pytest.approx(closed_form_lm71(length, ei), rel=1e-4)
    assert lm71_deflection(bridge, alpha=1.33) == pytest.approx(1.33 * lm71_deflection(bridge))


def test_dynamic_factors_of_en1991_2():
    for length in (4.0, 10.0, 32.0, 100.0):
        phi2 = 1.44 / (math.sqrt(length) - 0.2) + 0.82
        phi3 = 2.16 / (math.sqrt(length) - 0.2) + 0.73
        assert dynamic_factor(length, "careful") == pytest.approx(min(max(phi2, 1.0), 1.67))
        assert dynamic_factor(length, "standard") == pytest.approx(min(max(phi3, 1.0), 2.0))
    assert dynamic_factor(1.0, "standard") == 2.0 and dynamic_factor(1000.0, "careful") == 1.0


def _hslm_metrics(length: float = 32.0):
    bridge = {**SPAN, "span_length": length, "elements_per_span": 8}
    table = {
        "bridge": bridge,
        "train": {"vehicle": "moving-load", "hslm": "A1", "speed_kmh": 160.0},
        "solver": {"time_step": 2e-3, "output_every": 1},
    }
    return compute_metrics(simulate(table)), table


def test_traffic_set_of_a_moving_load_run():
    m, table = _hslm_metrics()
    rows = {r.name: r for r in en1990_checks(m, moving_load=True, table=table)}
    deflection = rows["vertical deflection, LM71 x alpha x Phi (A2.4.4.2.3(1))"]
    phi3 = 2.16 / (math.sqrt(32.0) - 0.2) + 0.73
    assert deflection.value == pytest.approx(lm71_deflection(table["bridge"]) * phi3)
    assert deflection.limit == pytest.approx(32.0 / 600) and deflection.passed is True
    assert "3D run" in rows["deck twist (A2.4.4.2.2)"].note and rows["deck twist (A2.4.4.2.2)"].passed is None
    assert "end rotation at abutments (A2.4.4.2.3(2))" in rows
    comfort = rows["comfort, deflection delta/L (acceptable, A2.4.4.3.2)"]
    assert comfort.passed is None and "Figure A2.3" in comfort.note
    assert not any("b_v" in name for name in rows)  # no car body: no b_v row
    # with Figure A2.3's L/δ: × 0.7 for one span, / b_v (2.0 for acceptable), at least 600
    opts = CheckOptions(comfort="very-good", comfort_l_over_delta=2000.0)
    rows = {r.name: r for r in en1990_checks(m, moving_load=True, table=table, options=opts)}
    comfort = rows["comfort, deflection delta/L (very-good, A2.4.4.3.2)"]
    assert comfort.limit == pytest.approx(32.0 / 1400.0)
    assert comfort.value == pytest.approx(lm71_deflection(table["bridge"]) * phi3)
    opts = CheckOptions(comfort="acceptable", comfort_l_over_delta=1000.0)
    rows = {r.name: r for r in en1990_checks(m, moving_load=True, table=table, options=opts)}
    assert rows["comfort, deflection delta/L (acceptable, A2.4.4.3.2)"].limit == pytest.approx(32.0 / 600.0)
    assert "load model (EN 1991-2 E, Table E.4)" not in rows


def test_hslm_a_on_a_span_under_7_m_is_flagged():
    m, table = _hslm_metrics(6.0)
    rows = {r.name: r for r in en1990_checks(m, moving_load=True, table=table)}
    assert "HSLM-B" in rows["load model (EN 1991-2 E, Table E.4)"].note


def test_check_of_the_paper_example_applies_the_seismic_set(tmp_path: Path):
    sc = load_scenario(REPO / "examples" / "paper-2020.toml", overrides=["solver.duration=0.8"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        ds = svbi.simulate(sc)
    write_netcdf(ds, tmp_path / "paper.nc")
    r = invoke("check", str(tmp_path / "paper.nc"))
    out = r.stdout
    assert "seismic set" in out and "earthquake" in out, out
    assert "dP/P <= 0.8 (transient)" in out and "dP/P <= 0.6" not in out, out
    deck = next(line for line in out.splitlines() if line.startswith("deck acceleration (absolute)"))
    assert "n/a" in deck and "FAIL" not in deck, out
    assert "deck acceleration (ballasted" not in out, out  # no traffic limit on a shaken deck
    m = compute_metrics(ds)
    rows = {row.name: row for row in en1990_checks(m, table=tomllib.loads(ds.attrs["scenario"]))}
    assert rows["deck displacement relative to the ground"].value == pytest.approx(
        float(np.abs(ds.midspan_uz_rel.values).max())
    )
    assert r.exit_code == (3 if any(row.passed is False for row in rows.values()) else 0), out


def test_seismic_rows_count_lift_offs_and_hold_uplift_to_the_flange():
    import xarray as xr

    m = xr.Dataset(
        {
            "max_unloading_ratio": (("car", "wheel"), [[0.9, 0.1]]),
            "lift_offs": (("car", "wheel"), [[2, 1]]),
            "longest_contact_loss": (("car", "wheel"), [[0.05, 0.01]]),
            "longest_contact_loss_time": (("car", "wheel"), [[1.2, 1.3]]),
            "peak_uplift": (("car", "wheel"), [[0.03, 0.001]]),
            "complete": ((), 1),
        },
        coords={"car": [1], "wheel": [1, 2]},
    )
    table = {"earthquake": {"vertical": "synthetic"}, "contact": {"normal": "unilateral"}}
    rows = {r.name: r for r in en1990_checks(m, table=table)}
    assert rows["wheel unloading dP/P <= 0.8 (transient)"].passed is False
    assert rows["lift-offs"].value == 3 and rows["lift-offs"].passed is None
    assert rows["longest contact loss"].value == 0.05 and rows["longest contact loss"].when == 1.2
    assert rows["wheel uplift <= flange height"].passed is False
    rows = {r.name: r for r in en1990_checks(m, table=table, options=CheckOptions(flange_height=0.05))}
    assert rows["wheel uplift <= flange height"].passed is True
    table["contact"]["normal"] = "bilateral"
    rows = {r.name: r for r in en1990_checks(m, table=table)}
    assert rows["lift-offs"].passed is None and "bilateral" in rows["lift-offs"].note

"""`svbi modes` of a 3D scenario: the span's lateral and torsional frequencies against the closed
forms of a simply supported beam; `svbi run` and `svbi sweep` refuse a 3D scenario in one line."""

from __future__ import annotations

import json
import math
import textwrap
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from svbi.runtime.cli.app import _register, app

_register()
runner = CliRunner()

REPO = Path(__file__).resolve().parents[2]
EXAMPLE_3D = REPO / "examples" / "paper-2020-3d.toml"

# the example's deck (paper-2020-3d.toml), typed here as the test's independent data
L, E, A, MU = 32.0, 35.5e9, 8.63, 22.40e3
I_Y, I_Z, J, NU = 6.58, 85.86, 15.21, 0.2
ELEMENTS = 16


def bending(n: int, stiffness: float) -> float:
    """f_n = n² π / (2 L²) sqrt(E I / mu) of a simply supported Euler-Bernoulli beam (Hz)."""
    return n**2 * math.pi / (2 * L**2) * math.sqrt(stiffness / MU)


def torsion(n: int, gj: float, polar: float) -> float:
    """f_n = n / (2 L) sqrt(G J / I_m) of a bar twisted between forks (Hz)."""
    return n / (2 * L) * math.sqrt(gj / polar)


def torsion_discrete(n: int, gj: float, polar: float, elements: int) -> float:
    """The same bar cut into ``elements`` equal linear elements with consistent mass: the exact
    eigenvalues of that discrete chain, omega² = (GJ / I_m) (6 / h²) (1 - cos k h) / (2 + cos k h)
    with k = n π / L."""
    h = L / elements
    c = math.cos(n * math.pi * h / L)
    return math.sqrt(gj / polar * 6.0 / h**2 * (1 - c) / (2 + c)) / (2 * math.pi)


def modes_json(*args: str) -> dict:
    result = runner.invoke(app, ["modes", str(EXAMPLE_3D), "--json", *args])
    assert result.exit_code == 0, result.output
    return json.loads(result.output)


def test_span_lateral_and_torsional_frequencies_are_the_closed_forms() -> None:
    data = modes_json("--count", "3")
    assert data["dimensions"] == 3 and data["model"] == "crh380a-3d"
    g = E / (2 * (1 + NU))
    polar = MU * (I_Y + I_Z) / A  # the documented default of torsional_mass_per_length
    lateral = data["span_lateral_frequencies_hz"]
    torsional = data["span_torsional_frequencies_hz"]
    vertical = data["span_frequencies_hz"]
    assert len(lateral) == len(torsional) == len(vertical) == 3
    # Hermite cubics with consistent mass converge from above as h^4: the relative error is
    # (k h)^4 / 1440 to leading order, k = n pi / L (measured 0.999, 0.996, 0.990 of it for n = 1, 2,
    # 3: 1.0e-6, 1.6e-5, 8.3e-5), in both planes alike
    for n in (1, 2, 3):
        bound = (n * math.pi / ELEMENTS) ** 4 / 1440
        for got, stiffness in ((lateral[n - 1], E * I_Z), (vertical[n - 1], E * I_Y)):
            error = got / bending(n, stiffness) - 1
            assert 0.98 * bound < error < bound, (n, error, bound)
    # linear torsion elements converge as h^2: to the discrete chain's own closed form to round-off,
    # and to the continuum within its discretisation error (1.6e-3 for n = 1 … 1.4e-2 for n = 3)
    for n in (1, 2, 3):
        assert torsional[n - 1] == pytest.approx(torsion_discrete(n, g * J, polar, ELEMENTS), rel=1e-10)
        exact = torsion(n, g * J, polar)
        bound = (n * math.pi / ELEMENTS) ** 2 / 24 * 1.05
        assert 0 < torsional[n - 1] / exact - 1 < bound
    # the first lateral mode of this girder, 17.9 Hz, and the first torsional one, 15.2 Hz
    assert lateral[0] == pytest.approx(17.894, abs=1e-3) and torsional[0] == pytest.approx(15.154, abs=1e-3)


def test_shear_modulus_and_torsional_mass_given() -> None:
    polar = 3.0e5
    data = modes_json(
        "--count",
        "1",
        "--set",
        "bridge.poisson_ratio=0.3",
        "--set",
        f"bridge.torsional_mass_per_length={polar}",
    )
    g = E / 2.6
    assert data["span_torsional_frequencies_hz"][0] == pytest.approx(
        torsion_discrete(1, g * J, polar, ELEMENTS), rel=1e-10
    )
    # the car body's five modes on its suspensions (crh380a-3d, the example's), below the bogies'
    # (docs/three-d.md)
    np.testing.assert_allclose(data["frequencies_hz"][:5], [0.41, 0.64, 0.72, 0.89, 0.91], atol=0.006)
    assert data["frequencies_hz"][5] > 7.0


def test_the_text_output_lists_every_family() -> None:
    result = runner.invoke(app, ["modes", str(EXAMPLE_3D), "--count", "2"])
    assert result.exit_code == 0, result.output
    for label in ("vertical bending", "lateral bending", "torsional", "axial", "crh380a-3d (3D)"):
        assert label in result.output
    assert "17.8939" in result.output and "15.1545" in result.output


def test_a_long_form_3d_bridge_lists_each_distinct_span(tmp_path: Path) -> None:
    text = EXAMPLE_3D.read_text(encoding="utf-8").replace(
        "spans = 10\nspan_length = 32.0              # m\n", ""
    ) + textwrap.dedent(
        """
        [[bridge.girders]]
        spans = [32.0]
        [[bridge.girders]]
        spans = [32.0]
        [[bridge.girders]]
        spans = [24.0]
        torsion_constant = 10.0
        """
    )
    # [[bridge.girders]] tables come after [output]: move them into [bridge] by appending keys there
    head, tail = text.split("[train]", 1)
    girders = tail[tail.index("[[bridge.girders]]") :]
    path = tmp_path / "long.toml"
    path.write_text(head + girders + "\n[train]" + tail[: tail.index("[[bridge.girders]]")], encoding="utf-8")
    result = runner.invoke(app, ["modes", str(path), "--json", "--count", "1"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.output)
    spans = data["distinct_spans"]
    assert [(s["span_length"], s["spans"]) for s in spans] == [(32.0, [0, 1]), (24.0, [2])]
    g = E / (2 * (1 + NU))
    polar = MU * (I_Y + I_Z) / A
    h24 = 24.0 / 32.0  # same element count on a shorter span: rescale L in the closed form
    assert spans[1]["span_lateral_frequencies_hz"][0] == pytest.approx(
        bending(1, E * I_Z) / h24**2, rel=(math.pi / ELEMENTS) ** 4 / 1440
    )
    assert spans[1]["span_torsional_frequencies_hz"][0] == pytest.approx(
        torsion_discrete(1, g * 10.0, polar, ELEMENTS) / h24, rel=1e-10
    )


def test_modes_of_a_3d_scenario_with_both_shear_keys_is_one_line(tmp_path: Path) -> None:
    result = runner.invoke(app, ["modes", str(EXAMPLE_3D), "--set", "bridge.shear_modulus=1.0e10"])
    assert result.exit_code == 2
    assert (
        "bridge.shear_modulus: give bridge.poisson_ratio or bridge.shear_modulus, not both" in result.output
    )


def test_train_parameters_reach_the_3d_vehicle() -> None:
    base = modes_json("--count", "1")["frequencies_hz"]
    heavier = modes_json("--count", "1", "--set", "train.parameters.carbody_mass=64000.0")["frequencies_hz"]
    assert heavier[0] < base[0] and heavier[2] < base[2]  # the car body's sway and bounce
    assert heavier[-1] == pytest.approx(base[-1], rel=1e-3)  # a bogie's highest mode barely moves

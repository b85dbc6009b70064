"""The bridge's deformation beside its absolute motion (issue 13 item 3): ``midspan_uz_rel`` and
``midspan_ux_rel``, and ``svbi modes SCENARIO.toml``.

A simply supported span that is much stiffer than the ground motion is fast moves as a rigid body
with its bearings: vertically along the line between its two vertical bearings (at midspan, their
mean), longitudinally with its fixed bearing. Under wave passage the bearings move differently, so
the absolute response is large while the relative one must vanish (independent of how svbi
computes it: a rigid body's kinematics), on both backends.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from svbi.examples import paper_section
from svbi.runtime.run.simulate import simulate
from svbi.runtime.scenario.schema import validate_scenario

SPAN, MU, E, AREA, I_Y = paper_section()


def quake_only(backend: str, stiffening: float, apparent_velocity: float | None) -> dict:
    """Two spans under a synthetic earthquake; the train (moving loads) stays far before the bridge."""
    quake = dict(vertical="synthetic", longitudinal="synthetic", arrival=0.8, seed=5)
    if apparent_velocity is not None:
        quake["apparent_velocity"] = apparent_velocity
    return dict(
        bridge=dict(
            spans=2,
            span_length=SPAN,
            mass_per_length=MU,
            youngs_modulus=E * stiffening,
            area=AREA,
            second_moment=I_Y,
            elements_per_span=8,
        ),
        train=dict(vehicle="moving-load", speed_kmh=100.0, start_position=-200.0),
        earthquake=quake,
        contact=dict(creep=False),
        solver=dict(backend=backend, time_step=2e-3, duration=4.0, output_every=1),
    )


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_a_stiff_span_under_wave_passage_moves_with_its_bearings(backend: str) -> None:
    ds = simulate(validate_scenario(quake_only(backend, 1e4, 300.0)))
    assert ds.attrs["backend"] == backend
    for comp in ("uz", "ux"):
        absolute = np.abs(ds[f"midspan_{comp}"].values).max()
        relative = np.abs(ds[f"midspan_{comp}_rel"].values).max()
        assert absolute > 5e-3  # the ground moves the span by millimetres to centimetres
        # quasi-static inertia of a span whose first frequency is 100x the ground's (~500 Hz): the
        # deformation is ~1e-5 of the motion; the ground's difference between the bearings is ~10 %
        assert relative < 1e-4 * absolute, (comp, relative, absolute)
    g = ds.ground_uz.values.reshape(ds.sizes["time"], 2, -1)
    lag = np.abs(g[:, 0, 1] - g[:, 0, 2]).max()  # the two vertical bearings of span 1
    assert lag > 0.02 * np.abs(ds.midspan_uz.values).max()  # so a wrong reference would show


def test_uniform_ground_is_subtracted_from_every_span() -> None:
    ds = simulate(validate_scenario(quake_only("c", 1.0, None)))
    assert ds.ground_uz.dims == ("time",)
    for comp in ("uz", "ux"):
        expected = ds[f"midspan_{comp}"].values - ds[f"ground_{comp}"].values[:, None]
        np.testing.assert_array_equal(ds[f"midspan_{comp}_rel"].values, expected)


def test_modes_of_a_scenario_print_its_vehicle_and_spans(tmp_path) -> None:
    from svbi.runtime.cli.app import _register, app

    _register()
    text = (
        f"[bridge]\nspans = 3\nspan_length = {SPAN!r}\nmass_per_length = {MU!r}\nyoungs_modulus = {E!r}\n"
        f"area = {AREA!r}\nsecond_moment = {I_Y!r}\nelements_per_span = 16\n\n"
        '[train]\nvehicle = "sprung-mass"\nspeed_kmh = 200.0\n\n[train.parameters]\nstiffness = 2.0e6\n\n'
        "[contact]\ncreep = false\n"
    )
    path = tmp_path / "s.toml"
    path.write_text(text, encoding="utf-8")
    runner = CliRunner()
    out = runner.invoke(app, ["modes", str(path), "--json"])
    assert out.exit_code == 0, out.output
    got = json.loads(out.output)
    # Euler-Bernoulli, simply supported: f_n = n^2 pi / (2 L^2) sqrt(E I / mu)
    f1 = np.pi / (2 * SPAN**2) * np.sqrt(E * I_Y / MU)
    assert got["span_frequencies_hz"][0] == pytest.approx(f1, rel=1e-4)
    # the same as the vehicle's name with the scenario's values given one by one
    bridge = (f"span_length={SPAN!r}", f"mass_per_length={MU!r}", f"youngs_modulus={E!r}", f"area={AREA!r}")
    bridge += (f"second_moment={I_Y!r}", "elements_per_span=16")
    sets = [a for k in ("stiffness=2.0e6", *bridge) for a in ("--set", k)]
    same = runner.invoke(app, ["modes", "sprung-mass", "--json", *sets])
    assert json.loads(same.output)["frequencies_hz"] == got["frequencies_hz"]
    assert json.loads(same.output)["span_frequencies_hz"] == got["span_frequencies_hz"]
    # sprung mass on rigid track with a 500 kg wheel held: sqrt(k / M) / 2 pi, M = 5750 kg
    assert got["frequencies_hz"][0] == pytest.approx(np.sqrt(2.0e6 / 5750.0) / (2 * np.pi), rel=1e-9)
    bad = runner.invoke(app, ["modes", str(path), "--set", "bridge.spans=0"])
    assert bad.exit_code == 2 and "bridge.spans" in bad.output

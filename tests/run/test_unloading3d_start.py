"""ΔQ/Q of a 3D run at its start (docs/scenario.md, "Results of a 3D run": ΔQ/Q and the start).

ΔQ/Q = (Q0 − Q)/Q0 takes Q0, ``static_wheel_load``, from the car on rigid level track (EN 14363's
static wheel load; the 2D run's P0 likewise). A train that stands on the deck at t = 0 carries
those loads: the raw ΔQ/Q at t = 0 is zero to round-off of the deck's own redistribution. What
follows is the start: the run sets the train going at full speed from rest, and where the deck
under a wheel slopes (its static deflection) the rail moves under the wheel at ``v w'`` while the
wheel is still; the first steps close that gap rate, and the wheel unloads or lifts off. A train
that starts on the approach track (level rail) or that does not move has no such transient.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from cases import SPRUNG_WHEELSET_3D

import svbi
from svbi.runtime.methods.coupled3d import static_state
from svbi.runtime.methods.localized3d import LocalizedDynamic3D
from svbi.runtime.run import simulate3d as sim3d
from svbi.runtime.scenario.schema import validate_scenario

V = 300.0 / 3.6
DT = 1e-4


@pytest.fixture(scope="module")
def topology(tmp_path_factory: pytest.TempPathFactory) -> str:
    path = tmp_path_factory.mktemp("dq3d") / "sprung-wheelset-3d.toml"
    path.write_text(SPRUNG_WHEELSET_3D, encoding="utf-8")
    return str(path)


def scenario(topology: str, start: float):
    """The symmetric car on a soft 10 m span (its static deflection slopes under the wheel)."""
    return validate_scenario(
        {
            "bridge": dict(
                spans=1,
                span_length=10.0,
                mass_per_length=2303.0,
                youngs_modulus=2.87e9,
                area=1.0,
                second_moment=0.05,
                damping_ratio=0.0,
                elements_per_span=8,
                lateral_second_moment=10.0,
                torsion_constant=5.0,
            ),
            "train": dict(vehicle=topology, speed=V, start_position=start),
            "contact": dict(creep=False, conicity=0.1),
            "solver": dict(
                method="localized-dynamic", backend="numpy", time_step=DT, duration=30 * DT, output_every=1
            ),
        }
    )


def run(topology: str, start: float, hold: bool = False):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return svbi.simulate(scenario(topology, start), hold_train=hold)


def raw_unloading(ds) -> np.ndarray:
    q0 = ds.static_wheel_load.values
    return (q0 - ds.contact_force.transpose("time", "car", "wheel", "side").values) / q0


def test_the_static_wheel_load_is_the_load_at_rest_on_the_deck(topology: str) -> None:
    ds = run(topology, 3.0, hold=True)
    car = (5750.0 + 500.0) * 9.81  # the car's weight (SPRUNG_WHEELSET_3D), on two wheels
    assert np.allclose(ds.static_wheel_load.values, car / 2, rtol=1e-12)
    r = raw_unloading(ds)
    assert np.abs(r).max() < 1e-9  # held on the deck: Q = Q0 at every step
    assert ds.attrs["peak_unloading_ratio"] < 1e-9


def test_starting_at_speed_on_a_sloping_deck_unloads_the_wheel(topology: str) -> None:
    """The start's transient: the gap rate ``v w'`` at t = 0 (the deck's static slope under the
    wheel, read from the gaps with the wheel moved by ``v dt`` and nothing else), the wheel off its
    rail in the first step; from the approach track nothing of it."""
    built = sim3d.build_run3d(scenario(topology, 3.0))
    stepper = LocalizedDynamic3D(built.system, static_state(built.system), DT)
    g0 = stepper.gaps()
    stepper.state.t = 1e-7
    rate = (stepper.gaps() - g0) / 1e-7
    assert rate.min() > 5e-3  # m/s: the rail drops away under both wheels (the slope at x = 3 m)
    deck = run(topology, 3.0)
    assert np.abs(raw_unloading(deck)[0]).max() < 1e-9  # at t = 0 the static load
    assert (deck.contact_state.values[1] == 0).all()  # the first step lifts both wheels
    assert deck.attrs["peak_unloading_ratio"] == 1.0 and deck.attrs["peak_unloading_ratio_time"] == DT
    level = run(topology, -1.0)  # on the approach track: level rail, no transient
    assert np.abs(raw_unloading(level)).max() < 1e-9
    assert abs(level.attrs["peak_unloading_ratio"]) < 1e-9


def test_a_lifted_wheel_reports_its_uplift(topology: str) -> None:
    """``wheel_uplift`` of a 3D run, as the 2D one: the normal gap of a wheel off its rail (above
    it), zero in contact; ``svbi metrics``' peak_uplift reads it, so ``svbi check`` can hold it
    against the flange height (the start's lift-off of the case above, 29 steps in the air)."""
    from svbi.runtime.study.metrics import compute_metrics

    deck = run(topology, 3.0)
    state = deck.contact_state.values
    up, gap = deck.wheel_uplift.values, deck.normal_gap.values
    assert (state == 0).any() and (up[state == 1] == 0.0).all()
    assert np.array_equal(up[state == 0], np.maximum(gap[state == 0], 0.0))
    assert up.max() > 1e-6  # m: the wheel flies
    metrics = compute_metrics(deck)
    assert float(metrics["peak_uplift"].max()) == up.max()

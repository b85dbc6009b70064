"""The three methods against each other (docs/method.md, step 4).

* localized-dynamic and coupled-dynamic solve the same discrete equations, one partitioned and one
  monolithic with dynamic multipliers: they agree to round-off, for any split ``a``, over a run
  where two cars enter, cross span joints and leave, with an earthquake and track irregularity;
* the split ``a`` does not change the results (docs/method.md);
* coupled-dynamic with ``kappa = 0`` is the classic acceleration-level method;
* over 1e5 steps the dynamic methods keep the gaps at round-off while classic multipliers drift.
"""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest

import svbi
from svbi.examples import paper_section_keys
from svbi.runtime.scenario.schema import validate_scenario

COMPARED = ("midspan_uz", "midspan_ux", "contact_force", "carbody_uz", "carbody_az", "carbody_pitch")


def paper_like(
    method: str,
    split: float = 0.5,
    kappa: float = 1.0,
    cars: int = 2,
    spans: int = 3,
    quake: bool = True,
    dt: float = 1e-3,
):
    data = {
        "bridge": dict(
            spans=spans,
            span_length=32.0,
            **paper_section_keys(),
            elements_per_span=8,
        ),
        "train": dict(vehicle="pioneer-2d", cars=cars, speed_kmh=300.0),
        "track": dict(irregularity="german-low", seed=3),
        "solver": dict(
            method=method,
            backend="numpy",
            time_step=dt,
            output_every=1,
            contact_split=split,
            constraint_kappa=kappa,
        ),
    }
    if quake:
        data["earthquake"] = dict(vertical="synthetic", longitudinal="synthetic", arrival=0.2)
    return validate_scenario(data)


@cache
def run(
    method: str, split: float = 0.5, kappa: float = 1.0, cars: int = 2, spans: int = 3, quake: bool = True
):
    return svbi.simulate(paper_like(method, split, kappa, cars, spans, quake))


def max_relative_difference(a, b, names=COMPARED) -> dict[str, float]:
    """max |a - b| / max |a| per variable (0 when both are identically zero)."""
    out = {}
    for n in names:
        scale = float(np.abs(a[n]).max())
        diff = float(np.abs(a[n] - b[n]).max())
        out[n] = diff / scale if scale > 0 else diff
    return out


# The split enters both methods only as a number (the aux point's share of the wheel mass, and
# coupled-dynamic's constraint masses), with no branch on its value: the two extremes bracket every
# split, the default 0.5 among them (and the default's equality is checked again on the viaduct,
# tests/model/test_continuous_bridges.py, and by the demo).
@pytest.mark.parametrize("split", [0.01, 0.99])
def test_localized_equals_coupled_dynamic(split):
    loc = run("localized-dynamic", split)
    cpl = run("coupled-dynamic", split)
    assert loc.attrs["complete"] == 1 and cpl.attrs["complete"] == 1
    # the run covers entry, joints and exit of both cars, on a shaking bridge
    assert loc.attrs["steps"] > 1500 and float(np.abs(loc.ground_uz).max()) > 1e-3
    diff = max_relative_difference(loc, cpl)
    # measured <= 4e-11 (raw contact force at a = 0.01), <= 1e-12 on the car body
    assert max(diff.values()) < 3e-10, diff
    for gap in ("gap_vehicle", "gap_bridge"):
        assert float(np.abs(loc[gap] - cpl[gap]).max()) < 1e-12


def test_split_does_not_change_the_results():
    """Each wheel and its aux point move as one body, whatever share of the mass the aux point has."""
    diff = max_relative_difference(run("localized-dynamic", 0.01), run("localized-dynamic", 0.99))
    assert max(diff.values()) < 1e-11, diff  # measured 8e-13


def test_coupled_dynamic_with_kappa_zero_is_classic():
    """With cbar = kbar = 0 the dynamic constraint is g'' = 0: classic index-1 multipliers.

    The partitioned solve (forces as unknowns) reproduces classic to round-off. The monolithic
    coupled-dynamic keeps the paper's multipliers lambda as unknowns; with kappa = 0, lambda grows
    like t^2 (docs/design.md pitfall 7). Solving for their increments
    (runtime/methods/coupled_dynamic.py) leaves lambda' growing like t in ``a0 dlambda - a2 lambda'``:
    measured over this 1000-step run, 1e-11 on the bridge and the contact force, 1.5e-9 on the
    car-body pitch (5e-7 in the total form).
    """
    classic = run("coupled-classic", cars=1, spans=2, quake=False)
    localized0 = run("localized-dynamic", kappa=0.0, cars=1, spans=2, quake=False)
    diff = max_relative_difference(classic, localized0)
    assert max(diff.values()) < 1e-9, diff
    dynamic0 = run("coupled-dynamic", kappa=0.0, cars=1, spans=2, quake=False)
    diff = max_relative_difference(classic, dynamic0)
    assert max(diff.values()) < 1e-8, diff
    assert max(diff[n] for n in ("midspan_uz", "contact_force")) < 1e-10, diff
    # and it is not trivially so: with kappa = 1 the dynamic method differs (it removes the drift)
    dynamic1 = run("coupled-dynamic", kappa=1.0, cars=1, spans=2, quake=False)
    assert max(max_relative_difference(classic, dynamic1).values()) > 1e-4


def drift_scenario(method: str):
    """One sprung mass over 12 spans of 25 m (coarse mesh): 1e5 steps of 1e-4 s, on the C loop (the
    NumPy backend gives the same to round-off: tests/backends; 1e5 NumPy steps a method took minutes)."""
    return validate_scenario(
        {
            "bridge": dict(
                spans=12,
                span_length=25.0,
                mass_per_length=2303.0,
                youngs_modulus=2.87e9,
                area=1.0,
                second_moment=2.9,
                damping_ratio=0.02,
                elements_per_span=4,
            ),
            "train": dict(vehicle="sprung-mass", speed_kmh=100.0),
            "contact": dict(creep=False),  # no wheel spin: no creep force to model
            "solver": dict(method=method, backend="c", time_step=1e-4, duration=10.0, output_every=100),
        }
    )


@pytest.mark.slow
def test_dynamic_multipliers_do_not_drift_classic_ones_do():
    results = {
        m: svbi.simulate(drift_scenario(m))
        for m in ("localized-dynamic", "coupled-dynamic", "coupled-classic")
    }
    for ds in results.values():
        assert ds.attrs["steps"] == 100_000 and ds.attrs["backend"] == "c"
        assert float(ds.time[-1]) > 250.0 / (100 / 3.6)  # the wheel has crossed 10 joints
    for m in ("localized-dynamic", "coupled-dynamic"):
        final = results[m].isel(time=-1)
        assert float(np.abs(final.gap_bridge).max()) <= 1e-9, m
        assert float(np.abs(final.gap_vehicle).max()) <= 1e-9, m
        assert float(np.abs(results[m].gap_support).max()) <= 1e-9, m
    classic = results["coupled-classic"]
    drift = np.abs(classic.gap_bridge.values[:, 0, 0])
    assert drift[-1] > 1e-3, "classic multipliers should drift (by millimetres) at the span joints"
    # the drift builds up joint after joint: it is larger in the second half of the run
    half = len(drift) // 2
    assert drift[half:].max() > 2 * drift[:half].max()

"""The wheel-rail forces and running-safety indices of a 3D run's results (``run/results3d.py``),
against force vectors built by hand in the test.

* ``Q`` and ``Y`` of a wheel on a cone: the force of the rail on the wheel is assembled from the
  contact normal and the lateral tangent of the contact plane, both obtained by turning the track's
  vertical and lateral unit vectors about x by the contact angle (a rotation matrix, not the
  module's formulas); ``Q`` is its vertical component, ``Y`` the outward push on the rail;
* a symmetric wheelset under a vertical load: each wheel carries half, the inclined normals push
  the two rails outwards by ``N sin δ`` each (opposite in track axes), ``ΣY = 0``;
* Prud'homme's limit for a given static wheel load and Nadal's limit from the flange angle;
* the Dataset: names, dimensions, units; ``ΔQ/Q``; ``Y/Q`` NaN off the rail; the 2 m sliding mean
  against a direct loop; the summary names the time, car, wheelset and side of each peak.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from cases import histories3d as histories

from svbi.runtime.run.results3d import (
    dataset3d,
    nadal_limit,
    prudhomme_limit,
    sliding_mean,
    summary_lines,
    wheel_forces,
)


def rotation_x(theta: float) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def by_hand(n: float, delta: float, t: float, flange: float, side: int) -> tuple[float, float, float]:
    """(Q, Y outwards, lateral force on the rail in track axes) from the vectors."""
    # the contact normal leans towards the centre: the left wheel's (side +1) towards -y
    turn = rotation_x(side * delta)
    normal, tangent = turn @ np.array([0.0, 0.0, 1.0]), turn @ np.array([0.0, 1.0, 0.0])
    assert normal[1] * side < 0 and abs(normal @ tangent) < 1e-15
    on_wheel = n * normal + t * tangent + flange * np.array([0.0, -side, 0.0])
    on_rail = -on_wheel
    return float(on_wheel[2]), float(on_rail[1] * side), float(on_rail[1])


@pytest.mark.parametrize("side", [1, -1])
@pytest.mark.parametrize(
    ("n", "delta", "t", "flange"),
    [
        (60e3, math.atan(0.05), 0.0, 0.0),
        (55e3, 0.12, 8e3, 0.0),
        (40e3, 0.3, -6e3, 25e3),
        (1e3, 1.2, 3e3, 0.0),
    ],
)
def test_q_and_y_of_a_wheel_on_a_cone(n, delta, t, flange, side):
    q, y = wheel_forces(np.array(n), np.array(delta), np.array(t), np.array(flange), np.array(float(side)))
    q_ref, y_ref, _ = by_hand(n, delta, t, flange, side)
    assert float(q) == pytest.approx(q_ref, rel=1e-14, abs=1e-9)
    assert float(y) == pytest.approx(y_ref, rel=1e-14, abs=1e-9)


def test_symmetric_wheelset_under_vertical_load():
    weight, delta = 110e3, math.atan(0.1)
    n = weight / (2 * math.cos(delta))  # vertical equilibrium of the two inclined normals
    sides = np.array([1.0, -1.0])
    q, y = wheel_forces(np.full(2, n), np.full(2, delta), np.zeros(2), np.zeros(2), sides)
    np.testing.assert_allclose(q, [weight / 2] * 2, rtol=1e-15)
    np.testing.assert_allclose(y, [n * math.sin(delta)] * 2, rtol=1e-15)  # both push outwards
    on_rails = [by_hand(n, delta, 0.0, 0.0, s)[2] for s in (1, -1)]
    assert on_rails[0] == pytest.approx(-on_rails[1], rel=1e-15) and on_rails[0] > 0
    ds = dataset3d(histories(normal=n, angle=delta, steps=5, cars=1, axles=1))
    assert float(np.abs(ds.axle_lateral_force).max()) < 1e-9 * weight
    np.testing.assert_allclose(ds.wheel_lateral_force.isel(time=0, car=0, wheel=0), y, rtol=1e-15)


def test_prudhomme_and_nadal_limits():
    q0 = 80e3  # static wheel load: axle load 160 kN
    assert float(prudhomme_limit(2 * q0)) == pytest.approx(1e3 * (10 + 160 / 3), rel=1e-15)
    assert float(prudhomme_limit(2 * q0, 0.85)) == pytest.approx(0.85e3 * (10 + 2 * 80 / 3), rel=1e-15)
    gamma, mu = math.radians(70), 0.3
    assert nadal_limit(gamma, mu) == pytest.approx(1.3416, abs=1e-4)
    assert round(nadal_limit(gamma, mu), 2) == 1.34


WHEEL_VARIABLES = {
    "contact_force": "N",
    "contact_force_filtered": "N",
    "normal_contact_force": "N",
    "contact_angle": "rad",
    "creep_force": "N",
    "lateral_creep_force": "N",
    "flange_force": "N",
    "wheel_lateral_force": "N",
    "wheel_lateral_force_filtered": "N",
    "derailment_quotient": "1",
    "derailment_quotient_2m": "1",
    "unloading_ratio": "1",
    "flange_contact": "1",
}
AXLE_VARIABLES = {
    "axle_lateral_force": "N",
    "axle_lateral_force_filtered": "N",
    "axle_lateral_force_2m": "N",
    "wheel_rail_lateral_displacement": "m",
}
OTHER = {
    "carbody_ay": (("time", "car"), "m/s^2"),
    "carbody_roll": (("time", "car"), "rad"),
    "midspan_uy": (("time", "span"), "m"),
    "midspan_uy_rel": (("time", "span"), "m"),
    "midspan_twist": (("time", "span"), "rad"),
    "midspan_twist_rel": (("time", "span"), "rad"),
    "pier_top_uy": (("time", "pier"), "m"),
    "pier_top_uy_rel": (("time", "pier"), "m"),
    "static_wheel_load": (("car", "wheel", "side"), "N"),
}


def test_dataset_names_dims_and_attributes():
    h = histories(pier_top_uy=np.zeros((400, 3)), pier_top_uy_rel=np.zeros((400, 3)))
    ds = dataset3d(h, {"method": "coupled-dynamic"}, output_every=4)
    for name, unit in WHEEL_VARIABLES.items():
        assert ds[name].dims == ("time", "car", "wheel", "side"), name
        assert ds[name].attrs["units"] == unit and ds[name].attrs["long_name"], name
    for name, unit in AXLE_VARIABLES.items():
        assert ds[name].dims == ("time", "car", "wheel"), name
        assert ds[name].attrs["units"] == unit and ds[name].attrs["long_name"], name
    for name, (dims, unit) in OTHER.items():
        assert ds[name].dims == dims and ds[name].attrs["units"] == unit, name
    assert ds["side"].values.tolist() == ["left", "right"]
    assert ds["car"].values.tolist() == [1, 2] and ds["wheel"].values.tolist() == [1, 2, 3, 4]
    assert ds.sizes["time"] == 100 and ds["time"].values[1] == pytest.approx(4e-3)
    assert ds.attrs["method"] == "coupled-dynamic" and ds.attrs["flange_contacts"] == 0
    # a standing train: no 2 m windows
    still = dataset3d(histories(speed=0.0))
    assert "derailment_quotient_2m" not in still and "axle_lateral_force_2m" not in still


def test_unloading_quotient_and_summary_pick_the_right_wheel():
    steps, dt = 400, 1e-3
    t = np.arange(steps) * dt
    n0, delta = 60e3, 0.05
    normal = np.full((steps, 2, 4, 2), n0)
    pulse = np.exp(-(((t - 0.2) / 0.01) ** 2))
    normal[:, 1, 2, 1] = n0 * (1 - 0.5 * pulse)  # car 2, wheelset 3, right: unloads by half at 0.2 s
    flange = np.zeros((steps, 2, 4, 2))
    flange[:, 1, 2, 1] = 30e3 * pulse  # and flanges there
    contact = np.ones((steps, 2, 4, 2), bool)
    contact[300:310, 0, 0, 0] = False  # car 1, wheelset 1, left: off its rail
    normal[300:310, 0, 0, 0] = 0.0
    ay = np.zeros((steps, 2))
    ay[250, 0] = -0.7
    h = histories(
        normal=n0,
        angle=delta,
        normal_force=normal,
        flange_force=flange,
        flange_contact=flange > 1e3,
        in_contact=contact,
        carbody_ay=ay,
    )
    ds = dataset3d(h, force_filter_hz=1e6)  # no filter: the values by hand
    q0 = n0 * math.cos(delta)
    i = 200
    q = normal[i, 1, 2, 1] * math.cos(delta)
    y = normal[i, 1, 2, 1] * math.sin(delta) + 30e3
    assert float(ds.contact_force[i, 1, 2, 1]) == pytest.approx(q, rel=1e-14)
    assert float(ds.unloading_ratio[i, 1, 2, 1]) == pytest.approx((q0 - q) / q0, rel=1e-12)
    assert float(ds.derailment_quotient[i, 1, 2, 1]) == pytest.approx(y / q, rel=1e-12)
    # the flanging right wheel pushes the track to the right
    sum_y = n0 * math.sin(delta) - y
    assert float(ds.axle_lateral_force[i, 1, 2]) == pytest.approx(sum_y, rel=1e-12)
    assert np.isnan(ds.derailment_quotient[305, 0, 0, 0]) and float(ds.unloading_ratio[305, 0, 0, 0]) == 1.0
    a = ds.attrs
    assert (a["peak_derailment_quotient_time"], a["peak_derailment_quotient_car"]) == (pytest.approx(0.2), 2)
    assert (a["peak_derailment_quotient_wheel"], a["peak_derailment_quotient_side"]) == (3, "right")
    assert a["peak_derailment_quotient"] == pytest.approx(y / q, rel=1e-12)
    assert a["peak_axle_lateral_force"] == pytest.approx(sum_y, rel=1e-12)
    assert (a["peak_axle_lateral_force_car"], a["peak_axle_lateral_force_wheel"]) == (2, 3)
    # the wheel off its rail is the most unloaded (ratio 1)
    assert a["peak_unloading_ratio"] == 1.0 and a["peak_unloading_ratio_side"] == "left"
    assert a["peak_unloading_ratio_time"] == pytest.approx(0.3)
    first = int(np.argmax(flange[:, 1, 2, 1] > 1e3))
    assert a["flange_contacts"] == 1 and a["flange_contact_time"] == pytest.approx(first * dt)
    assert (a["flange_contact_car"], a["flange_contact_wheel"], a["flange_contact_side"]) == (2, 3, "right")
    assert a["peak_carbody_ay"] == -0.7 and a["peak_carbody_ay_car"] == 1
    # the wheel off its rail over steps 300-309 lifted off once, at t = 0.3 s
    assert a["wheel_lift_offs"] == 1 and a["wheel_lift_off_time"] == pytest.approx(0.3)
    assert (a["wheel_lift_off_car"], a["wheel_lift_off_wheel"], a["wheel_lift_off_side"]) == (1, 1, "left")
    lines = summary_lines(a)
    lift = [line for line in lines if line.startswith("wheel lift-offs: 1, the first at t = 0.3 s, car 1")]
    assert len(lift) == 1 and "check them at half the step" in lift[0]
    assert lines[0].startswith("derailment quotient Y/Q: peak") and "car 2, wheelset 3, right" in lines[0]
    assert any(line.startswith("flange contacts: 1") for line in lines)
    assert summary_lines({"liftoffs": 0, "peak_unloading_ratio": 0.1}) == []  # a 2D run: nothing


def test_sliding_mean_over_two_metres_is_a_direct_average():
    rng = np.random.default_rng(7)
    s = np.cumsum(rng.uniform(0.05, 0.15, size=300))  # uneven steps of travel
    x = rng.normal(size=(300, 3))
    x[40, 1] = np.nan
    got = sliding_mean(x, s)
    for i in range(300):
        near = np.abs(s - s[i]) <= 1.0
        for j in range(3):
            values = x[near, j]
            assert got[i, j] == pytest.approx(np.nanmean(values), rel=1e-12)


def test_bad_histories_are_refused():
    with pytest.raises(ValueError, match="flange_force"):
        histories(flange_force=np.full((400, 2, 4, 2), -1.0))
    with pytest.raises(ValueError, match="carbody_ay"):
        histories(carbody_ay=np.zeros((400, 3)))


def test_peak_sum_y_is_read_from_the_filtered_forces_not_a_single_step_spike():
    """A rigid contact's flange closing is a force at a single step (its height is impulse / dt): the
    run's peak ΣY is that of the filtered forces, as Y/Q reads them, checked against SciPy's own
    zero-phase Butterworth filter of the same order and cutoff (an independent implementation)."""
    from scipy.signal import butter, sosfiltfilt

    steps, dt, every, cutoff = 4000, 1e-4, 10, 20.0
    t = np.arange(steps) * dt
    flange = np.zeros((steps, 2, 4, 2))
    flange[2000, 0, 1, 1] = 2e6  # car 1, wheelset 2, right: a 2 MN single-step closing (a stored row)
    flange[:, 1, 0, 0] = 40e3 * np.exp(-(((t - 0.2) / 0.025) ** 2))  # car 2, wheelset 1, left: flanging
    on_rail = np.ones(flange.shape, bool)
    on_rail[:50, 0, 3, 0] = False  # off its rail from the start: not a lift-off
    h = histories(steps=steps, dt=dt, flange_force=flange, flange_contact=flange > 1e3, in_contact=on_rail)
    ds = dataset3d(h, output_every=every, force_filter_hz=cutoff)
    sos = butter(4, cutoff, fs=1.0 / dt, output="sos")
    y = wheel_forces(
        np.asarray(h.normal_force),
        np.asarray(h.contact_angle),
        np.zeros(flange.shape),
        flange,
        np.array([1.0, -1.0]),
    )[1]
    sum_y = sosfiltfilt(sos, y[..., 0] - y[..., 1], axis=0)[::every]
    raw = ds.axle_lateral_force.values
    assert np.abs(raw).max() == pytest.approx(2e6, rel=1e-12)  # the spike is stored raw
    # the filters differ only by their start-up at the ends (none of the forces is near them) and
    # round-off: 2.3e-12 of the peak measured; a filter of another order or cutoff differs by percents
    assert np.abs(ds.axle_lateral_force_filtered.values - sum_y).max() < 1e-9 * np.abs(sum_y).max()
    a = ds.attrs
    assert (a["peak_axle_lateral_force_car"], a["peak_axle_lateral_force_wheel"]) == (2, 1)
    assert a["peak_axle_lateral_force"] == pytest.approx(sum_y[:, 1, 0].max(), rel=1e-9)
    assert 30e3 < a["peak_axle_lateral_force"] < 40e3  # the flanging, not the spike
    assert a["peak_axle_lateral_force_time"] == pytest.approx(0.2, abs=2e-3)
    assert a["wheel_lift_offs"] == 0 and "wheel lift-offs: 0" in summary_lines(a)

"""A 3D run (``svbi.simulate`` of a 3D scenario file) on a bridge whose spans differ in length
against svbi's 2D run of the same bridge, in the vertical plane.

The scenario's long form ``[[bridge.girders]] spans = [10.0, 16.0]``: one girder continuous over
a 10 m and a 16 m span, 5 elements a span (2 m and 3.2 m; an odd number puts each midspan inside an
element, where the recorded deflection takes the element's length). One symmetric car
(``SPRUNG_WHEELSET_3D``) crosses from the first span onto the second on the track's axis, so the 3D
run is the 2D model (docs/three-d.md): the 2D run of ``sprung-mass`` on the same file's bridge, dt,
elements, kappa and zeta is the independent truth for both midspan deflections and the contact
force, on both 3D methods' default backends (localized-dynamic on the compiled loop, coupled-dynamic
on NumPy).

The deck's lateral displacement under a wheelset that the run records, on elements of both spans,
against the generated flange-gap kernel: tests/verification/test_run3d_sprung_wheelset.py."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import svbi
from svbi.runtime.scenario.schema import load_scenario
from tests.cases import SPRUNG_WHEELSET_3D

E, IY, MU = 2.87e9, 2.9, 2303.0
V = 100.0 / 3.6
DT, STEPS, ELEMENTS = 2e-3, 300, 5
LAM = 0.1

BRIDGE = f"""
[bridge]
mass_per_length = {MU}
youngs_modulus = {E}
area = 1.0
second_moment = {IY}
damping_ratio = 0.0
elements_per_span = {ELEMENTS}
{{extra}}
[[bridge.girders]]
spans = [10.0, 16.0]
"""


def scenario_text(train: str, contact: str, method: str, extra: str = "") -> str:
    return (
        BRIDGE.format(extra=extra)
        + f"[train]\n{train}\n[contact]\n{contact}\n"
        + f'[solver]\nmethod = "{method}"\ntime_step = {DT}\nduration = {STEPS * DT}\noutput_every = 1\n'
    )


@pytest.fixture(scope="module")
def run2d(tmp_path_factory: pytest.TempPathFactory):
    path = tmp_path_factory.mktemp("unequal2d") / "two.toml"
    train = (
        f'vehicle = "sprung-mass"\nspeed = {V}\n'
        "parameters = { sprung_mass = 5750.0, stiffness = 1.595e6, wheel_mass = 500.0, damping = 0.0 }"
    )
    text = scenario_text(train, "creep = false", "coupled-dynamic").replace(
        "[solver]\n", '[solver]\nbackend = "numpy"\n'
    )
    path.write_text(text, encoding="utf-8")
    return svbi.simulate(load_scenario(path))


@pytest.mark.parametrize("method", ["localized-dynamic", "coupled-dynamic"])
def test_a_scenario_of_unequal_spans_runs_and_is_the_2d_run(tmp_path: Path, run2d, method: str) -> None:
    car = tmp_path / "sprung-wheelset-3d.toml"
    car.write_text(SPRUNG_WHEELSET_3D, encoding="utf-8")
    path = tmp_path / "three.toml"
    text = scenario_text(
        f'vehicle = "{car.as_posix()}"\nspeed = {V}',
        f'creep = false\nnormal = "bilateral"\nconicity = {LAM}',
        method,
        extra="lateral_second_moment = 10.0\ntorsion_constant = 5.0",
    )
    if method == "coupled-dynamic":  # on NumPy (the C loop steps localized-dynamic)
        text = text.replace("[solver]\n", '[solver]\nbackend = "numpy"\n')
    path.write_text(text, encoding="utf-8")
    three = svbi.simulate(load_scenario(path))
    assert three.attrs["complete"] == 1 and three.attrs["steps"] == STEPS
    w2 = run2d.midspan_uz.values
    w3 = three.midspan_uz.values
    assert w3.shape == w2.shape == (STEPS + 1, 2)
    peak = np.abs(w2).max()
    assert np.abs(w2[:, 0]).max() > 1e-4 and np.abs(w2[:, 1]).max() > 1e-4  # both spans loaded
    assert np.abs(w3 - w2).max() < 1e-11 * peak
    p2 = run2d.contact_force.values.reshape(STEPS + 1, -1)[:, 0]
    q = three.contact_force.transpose("time", "car", "wheel", "side").values[:, 0, 0, :]
    assert np.abs(q.sum(axis=1) - p2).max() < 1e-11 * p2.max()
    x = three.wheelset_position.values[:, 0]
    assert x[0] == 0.0 and x[-1] > 10.0 + 5.0  # onto the 16 m span, past its first element
    for name in ("midspan_uy", "midspan_twist", "wheel_rail_lateral_displacement"):
        assert np.abs(three[name].values).max() < 1e-14, name

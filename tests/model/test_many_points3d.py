"""The model's evaluations at many points or times at once that the chunked 3D recording uses
(docs/three-d.md, "Recording"), each against the one-point evaluation it replaces:

* ``Bridge3D.deck_locations`` = ``deck_location``, ``System3D.contact_locations`` =
  ``contact_location`` (on the deck, on the approach and past the last abutment);
* ``Ground.displacements`` and ``Ground.motions`` (q, q', q'') = ``motion`` / ``lateral`` at each
  time, for a synchronous, a travelling and a per-support-line record and for ground motion given as
  functions; ``System3D.ground_motions`` = ``ground_motion`` at each time (the excitation of a
  chunk of the 3D C loop);
* ``load_broadcasting``: a generated kernel at an array of inputs = the kernel at each input, bit for
  bit.
"""

from __future__ import annotations

import numpy as np
import pytest
from cases import SPRUNG_WHEELSET_3D

from svbi.codegen.topology3d import parse_topology3d
from svbi.runtime.excitation.ground import ground_motion
from svbi.runtime.model.bridge import Girder, Section
from svbi.runtime.model.bridge3d import Bridge3D, section3d
from svbi.runtime.model.ground import FunctionGround, RecordGround
from svbi.runtime.model.kernels import FRAME3D, load, load_broadcasting
from svbi.runtime.model.span3d import Section3D, Span3D, simply_supported_span
from svbi.runtime.model.system3d import GROUND, System3D, Track3D, vehicle3d


def bridge(spans: int = 3) -> Bridge3D:
    plane = Section(2303.0, 2.87e9, 1.0, 2.9, 0.0)
    return Bridge3D([Girder((10.0,), plane)] * spans, 8, [section3d(plane, 10.0, 5.0)] * spans)


def span() -> Span3D:
    section = Section3D(E=3.0e10, A=5.0, I_y=3.0, I_z=20.0, J=4.0, mass_per_length=1.2e4)
    return simply_supported_span(section, 10.0, 4)


@pytest.mark.parametrize("deck", [bridge, span], ids=["bridge", "span"])
def test_deck_locations_are_deck_location(deck) -> None:
    b = deck()
    x = np.concatenate([np.linspace(0.0, b.length, 241), [10.0, 1.25, 2.5, b.length - 1e-6]])
    element, xi = b.deck_locations(x)
    for i, xx in enumerate(x):
        assert (int(element[i]), float(xi[i])) == b.deck_location(float(xx))


@pytest.mark.parametrize("deck", [bridge, span], ids=["bridge", "span"])
def test_contact_locations_are_contact_location(deck) -> None:
    car = vehicle3d(parse_topology3d(SPRUNG_WHEELSET_3D))
    system = System3D(car, deck(), Track3D(conicity=0.1), speed=27.0, start=-2.0)
    t = np.linspace(0.0, 1.3, 157)  # from the approach track past the last abutment
    element, xi = system.contact_locations(t)
    assert (element == GROUND).any() and (element != GROUND).any()
    for i, ti in enumerate(t):
        for w, (e, x) in enumerate(system.contact_location(float(ti))):
            assert (int(element[i, w]), float(xi[i, w])) == (e, x)


def record(**kwargs) -> RecordGround:
    common = dict(vertical="synthetic", longitudinal="synthetic", lateral="synthetic", duration=2.0, seed=5)
    return RecordGround(ground_motion(**(common | kwargs)))


GROUNDS = {
    "synchronous": lambda: record(),
    "travelling": lambda: record(apparent_velocity=250.0, arrival=0.3),
    "per-line": lambda: record(
        lateral=["synthetic", "none", "synthetic", "synthetic"],
        vertical=["synthetic", "synthetic", "none", "synthetic"],
        support_positions=[0.0, 10.0, 20.0, 30.0],
    ),
    "functions": lambda: FunctionGround(
        vertical=lambda t, x: (np.sin(t + x), np.cos(t + x), -np.sin(t + x)),
        longitudinal=lambda t, x: (t * t + 0 * x, 2 * t + 0 * x, 2.0 + 0 * x),
        lateral=lambda t, x: (t * x, x + 0 * t, 0 * x),
    ),
}


@pytest.mark.parametrize("name", list(GROUNDS))
def test_ground_displacements_at_many_times_are_those_at_each_time(name: str) -> None:
    ground = GROUNDS[name]()
    t = np.linspace(0.0, 1.5, 61)
    lines = np.array([0.0, 10.0, 20.0, 30.0])
    moving = -3.0 + 27.0 * t[:, None] - np.array([0.0, 2.5])[None, :]  # points that move
    for component in ("vertical", "longitudinal", "lateral"):
        fixed = ground.displacements(component, t, lines)
        along = ground.displacements(component, t, moving)
        assert fixed.shape == (t.size, lines.size) and along.shape == moving.shape
        for i, ti in enumerate(t):
            for x, got in ((lines, fixed[i]), (moving[i], along[i])):
                if component == "lateral":
                    want = ground.lateral(float(ti), x)[0]
                else:
                    vertical, longitudinal = ground.motion(float(ti), x)
                    want = (vertical if component == "vertical" else longitudinal)[0]
                assert np.array_equal(got, want), (component, ti)
        assert np.abs(fixed).max() > 0


def _at_each_time(ground, component: str, t: float, x: np.ndarray):
    if component == "lateral":
        return ground.lateral(t, x)
    vertical, longitudinal = ground.motion(t, x)
    return vertical if component == "vertical" else longitudinal


@pytest.mark.parametrize("name", list(GROUNDS))
def test_ground_motions_at_many_times_are_those_at_each_time(name: str) -> None:
    """``Ground.motions``: q, q' and q'' (what the excitation of a chunk of the 3D C loop takes)."""
    ground = GROUNDS[name]()
    t = np.linspace(0.0, 1.5, 61)
    lines = np.array([0.0, 10.0, 20.0, 30.0])
    moving = -3.0 + 27.0 * t[:, None] - np.array([0.0, 2.5])[None, :]
    for component in ("vertical", "longitudinal", "lateral"):
        for points in (lines, moving):
            got = ground.motions(component, t, points)
            assert len(got) == 3 and all(g.shape == (t.size, points.shape[-1]) for g in got)
            for i, ti in enumerate(t):
                x = points if points.ndim == 1 else points[i]
                want = _at_each_time(ground, component, float(ti), x)
                for d in range(3):
                    assert np.array_equal(got[d][i], want[d]), (component, ti, d)
            assert all(np.abs(g).max() > 0 for g in got) or name == "functions"


@pytest.mark.parametrize("name", [*GROUNDS, None])
def test_system_ground_motions_are_ground_motion_at_each_time(name: str | None) -> None:
    car = vehicle3d(parse_topology3d(SPRUNG_WHEELSET_3D))
    ground = GROUNDS[name]() if name else None
    system = System3D(car, bridge(), Track3D(conicity=0.1), speed=27.0, start=-3.0, ground=ground)
    t = np.linspace(0.0, 1.5, 31)
    lines = np.array([0.0, 10.0, 20.0, 30.0])
    moving = -3.0 + 27.0 * t[:, None] - np.array([0.0, 2.5])[None, :]
    for points in (lines, moving):
        got = system.ground_motions(t, points)
        assert all(g.shape == (t.size, points.shape[-1], 3) for g in got)
        for i, ti in enumerate(t):
            want = system.ground_motion(float(ti), points if points.ndim == 1 else points[i])
            for d in range(3):
                assert np.array_equal(got[d][i], want[d]), (ti, d)


def test_a_broadcasting_kernel_is_the_kernel_at_each_point() -> None:
    one, many = load(FRAME3D), load_broadcasting(FRAME3D)
    xi = np.random.default_rng(1).random(40)
    rows = many.shape_functions(1.25, xi)
    assert rows.shape == (40, 4, 12)
    for i, x in enumerate(xi):
        assert np.array_equal(rows[i], one.shape_functions(1.25, float(x)))
    grid = many.shape_functions(1.25, xi.reshape(5, 8))
    assert grid.shape == (5, 8, 4, 12) and np.array_equal(grid.reshape(40, 4, 12), rows)
    assert np.array_equal(many.element_mass((2303.0, 5.0), 1.25), one.element_mass((2303.0, 5.0), 1.25))

"""A 3D run steps and records whole chunks of steps (docs/three-d.md, "Recording"): the chunk
interface of the NumPy steps (:class:`svbi.runtime.methods.chunk3d.SteppedChunks`), the vectorised
recording (``_Recorder3D.record_chunk``) and what the run keeps when a step fails or is interrupted
part-way through a chunk.

* a chunk holds exactly the states of ``step(n)`` called one at a time, the gaps at output steps
  only (NaN elsewhere), ``irregularity_at`` of many times is that of each time;
* the recorded lateral variables of a chunk are the per-step formulas written here (the deck read
  with :func:`deck_rows` at one point at a time, the ground with ``Ground.lateral`` at one time);
* a run's results do not depend on the chunk size (bit for bit);
* an interrupt, a singular matrix or a non-finite state in the middle of a chunk: the steps finished
  before it are kept, with the messages of a per-step loop.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from cases import SPRUNG_WHEELSET_3D

import svbi
from svbi.codegen.loop3d_abi import STATUS3D_CODES, STATUS3D_NAMES
from svbi.runtime.backends.c.stepper3d import LocalizedDynamic3DC
from svbi.runtime.methods.chunk3d import ChunkStopped, SteppedChunks
from svbi.runtime.methods.coupled3d import CoupledDynamic3D, State3D, static_state
from svbi.runtime.methods.localized3d import LocalizedDynamic3D
from svbi.runtime.model.system3d import GROUND
from svbi.runtime.run import simulate3d as sim3d
from svbi.runtime.run.output import RunInterrupted
from svbi.runtime.run.results3d import SIDE_SIGN
from svbi.runtime.run.simulate import SimulationIncomplete
from svbi.runtime.scenario.schema import validate_scenario

DT, STEPS, EVERY = 1e-3, 90, 3


@pytest.fixture(scope="module")
def topology(tmp_path_factory: pytest.TempPathFactory) -> str:
    path = tmp_path_factory.mktemp("rec3d") / "sprung-wheelset-3d.toml"
    path.write_text(SPRUNG_WHEELSET_3D, encoding="utf-8")
    return str(path)


def scenario(topology: str, method: str = "localized-dynamic", steps: int = STEPS, backend: str = "numpy"):
    """A car entering a 2-span deck from the approach track (start 1.2 m before it) on a rough
    track, under a travelling three-component earthquake."""
    return validate_scenario(
        {
            "bridge": dict(
                spans=2,
                span_length=10.0,
                mass_per_length=2303.0,
                youngs_modulus=2.87e9,
                area=1.0,
                second_moment=2.9,
                damping_ratio=0.01,
                elements_per_span=8,
                lateral_second_moment=10.0,
                torsion_constant=5.0,
            ),
            "train": dict(vehicle=topology, speed=100.0 / 3.6, start_position=-1.2),
            "track": dict(irregularity="german-high", seed=4, wavelength_min=1.0, wavelength_max=40.0),
            "contact": dict(creep=False, normal="bilateral", conicity=0.1),
            "earthquake": dict(
                vertical="synthetic",
                longitudinal="synthetic",
                lateral="synthetic",
                scale=2.0,
                apparent_velocity=300.0,
                arrival=0.02,
            ),
            "solver": dict(
                method=method, backend=backend, time_step=DT, duration=steps * DT, output_every=EVERY
            ),
        }
    )


def stepper(run: sim3d.Run3D, method=LocalizedDynamic3D):
    return method(run.system, static_state(run.system), DT, normal="bilateral")


@pytest.mark.parametrize("method", [LocalizedDynamic3D, CoupledDynamic3D], ids=["localized", "coupled"])
def test_a_chunk_is_the_steps_one_at_a_time(topology: str, method) -> None:
    run = sim3d.build_run3d(scenario(topology))
    one, many = stepper(run, method), SteppedChunks(stepper(run, method))
    k, n0 = 40, 0
    times = (np.arange(k) + 1) * DT
    level = run.irregularity_at(times)
    for j, t in enumerate(times):  # many times at once = each time alone
        assert np.array_equal(level[j], run.irregularity_at(t))
    first = many.current(run.irregularity_at(0.0))
    assert len(first) == 1 and first.t[0] == 0.0 and np.isfinite(first.gaps[0]).all()
    chunk = many.advance(n0, 25, level[:25], EVERY)
    rest = many.advance(25, k - 25, level[25:], EVERY)
    assert len(chunk) == 25 and len(rest) == k - 25
    for j in range(k):
        for kernel, r in zip(one.kernels, level[j], strict=True):
            kernel.irregularity = r
        st = one.step(j)
        c, i = (chunk, j) if j < 25 else (rest, j - 25)
        assert c.t[i] == st.t
        for name in ("q", "qd", "qdd", "u", "ud", "udd", "P", "flange", "contact"):
            assert np.array_equal(getattr(c, name)[i], getattr(st, name)), name
        assert np.array_equal(c.creep[i], st.creep)
        assert np.array_equal(c.irregularity[i], level[j])
        if (j + 1) % EVERY == 0:
            assert np.array_equal(c.gaps[i], one.gaps())
        else:
            assert np.isnan(c.gaps[i]).all()


def test_a_failing_step_stops_the_chunk_with_the_steps_before_it(topology: str, monkeypatch) -> None:
    run = sim3d.build_run3d(scenario(topology))
    chunks = SteppedChunks(stepper(run))
    real = LocalizedDynamic3D.step

    def step(self, n: int) -> State3D:
        if n == 7:
            raise np.linalg.LinAlgError("Singular matrix")
        return real(self, n)

    monkeypatch.setattr(LocalizedDynamic3D, "step", step)
    level = run.irregularity_at((np.arange(20) + 1) * DT)
    with pytest.raises(ChunkStopped) as info:
        chunks.advance(0, 20, level, EVERY)
    assert len(info.value.chunk) == 7 and isinstance(info.value.cause, np.linalg.LinAlgError)
    assert np.array_equal(info.value.chunk.t, (np.arange(7) + 1) * DT)


def test_the_recording_of_a_chunk_is_the_per_step_formulas(topology: str) -> None:
    run = sim3d.build_run3d(scenario(topology))
    chunks = SteppedChunks(stepper(run))
    state = chunks.stepper.state
    recorder = sim3d._Recorder3D(run, state, STEPS + 1, EVERY)
    states = [chunks.current(run.irregularity_at(0.0))]
    recorder.record_chunk(states[0])
    n = 0
    while n < STEPS:  # chunks of 32 (not a multiple of the output interval)
        k = min(32, STEPS - n)
        states.append(chunks.advance(n, k, run.irregularity_at((np.arange(n, n + k) + 1) * DT), EVERY))
        recorder.record_chunk(states[-1])
        n += k
    h = recorder.histories(run.system.speed)
    rows = [(c, i) for c in states for i in range(len(c))]
    assert recorder.steps == STEPS + 1 == len(rows)
    sys_, b = run.system, run.bridge
    lam, h_t = np.arctan(0.1), sys_.track.rail_height
    offsets = [w.offset for w in sys_.vehicle.wheelsets]
    approach = deck = 0
    for r, (c, i) in enumerate(rows):
        t, u, q = c.t[i], c.u[i], c.q[i]
        for w, (ws, (e, xi)) in enumerate(zip(sys_.vehicle.wheelsets, sys_.contact_location(t), strict=True)):
            irr = c.irregularity[i, w]
            if e == GROUND:
                approach += 1
                x = sys_.start + sys_.speed * t - offsets[w]
                y_r = sys_.ground.lateral(t, np.array([x]))[0][0] + irr[1]
                phi_d = 0.0
            else:
                deck += 1
                rows_e = sim3d.deck_rows(b, e, xi)
                dofs, rv = rows_e["v"]
                phi_d = rows_e["phi"][1] @ u[dofs]
                y_r = rv @ u[dofs] - h_t * phi_d + irr[1]
            lateral = q[ws.dofs[0]] - y_r
            angle = lam + SIDE_SIGN * (q[ws.dofs[2]] - (phi_d + irr[2]))
            assert abs(h.wheel_rail_lateral[r].reshape(-1)[w] - lateral) <= 1e-12 * max(abs(lateral), 1e-6)
            assert np.allclose(h.contact_angle[r].reshape(-1, 2)[w], angle, rtol=1e-13, atol=0.0)
        mid = [sim3d.deck_rows(b, *b.midspan(s)) for s in range(b.spans)]
        uy = np.array([m["v"][1] @ u[m["v"][0]] for m in mid])
        gy = sys_.ground.lateral(t, np.asarray(b.line_x))[0]
        assert np.allclose(h.midspan_uy[r], uy, rtol=1e-13, atol=1e-18)
        assert np.allclose(h.midspan_uy_rel[r], uy - 0.5 * (gy[:-1] + gy[1:]), rtol=1e-12, atol=1e-18)
    assert approach > 0 and deck > 0  # both kinds of track were read
    base = recorder.base()
    stored = [rows[r] for r in range(0, STEPS + 1, EVERY)]
    assert base.sizes["time"] == len(stored)
    for s, (c, i) in enumerate(stored):
        assert np.array_equal(base.normal_gap.values[s].reshape(-1), c.gaps[i])
        gz, gx = (m[0] for m in sys_.ground.motion(c.t[i], np.asarray(b.line_x)))
        assert base.ground_uz.values[s] == gz[0] and base.ground_ux.values[s] == gx[0]


def results(topology: str, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SimulationIncomplete)
        return svbi.simulate(scenario(topology, **kwargs))


@pytest.fixture(scope="module")
def whole(topology: str):
    return results(topology)


def same(a, b, steps: int | None = None) -> None:
    """Every variable of ``a`` is that of ``b`` (its first ``steps`` rows), bit for bit."""
    for name in a.variables:
        x, y = a[name].values, b[name].values
        if steps is not None and "time" in a[name].dims:
            y = y[: x.shape[0]]
            assert x.shape[0] == steps, name
        if name in (
            "contact_force_filtered",
            "wheel_lateral_force_filtered",
            "axle_lateral_force_filtered",
            "derailment_quotient",
        ):
            continue  # filtered over the whole record: a shorter record filters differently
        if name in ("unloading_ratio", "derailment_quotient_2m", "axle_lateral_force_2m"):
            continue
        assert np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), name


def test_the_results_do_not_depend_on_the_chunk_size(topology: str, whole, monkeypatch) -> None:
    monkeypatch.setattr(sim3d, "CHUNK_STEPS", 5)  # chunks of 6 steps
    assert sim3d.chunk_steps(EVERY) == 6
    small = results(topology)
    same(small, whole)
    assert small.attrs["steps"] == STEPS and small.attrs["complete"] == 1


@pytest.mark.parametrize("failure", ["interrupt", "singular", "non-finite"])
def test_a_stop_in_the_middle_of_a_chunk_keeps_the_steps_before_it(
    topology, whole, failure, monkeypatch
) -> None:
    real = LocalizedDynamic3D.step
    bad = 41  # step n = 41 (t_42) fails: 42 states recorded (t = 0 to t_41)

    def step(self, n: int) -> State3D:
        if n == bad:
            if failure == "interrupt":
                raise KeyboardInterrupt
            if failure == "singular":
                raise np.linalg.LinAlgError("Singular matrix")
        st = real(self, n)
        if n == bad:
            st.q = st.q * np.nan
        return st

    monkeypatch.setattr(LocalizedDynamic3D, "step", step)
    assert sim3d.chunk_steps(EVERY) > bad + 1  # the failure is inside the first chunk
    if failure == "interrupt":
        with pytest.raises(RunInterrupted) as info:
            svbi.simulate(scenario(topology))
        ds = info.value.results
        at = f"interrupted by SIGINT at t = {bad * DT:.6g} s (step {bad} of {STEPS})"
        assert ds.attrs["incomplete"] == at
    else:
        with pytest.warns(SimulationIncomplete) as caught:
            ds = svbi.simulate(scenario(topology))
        message = str(caught[0].message)
        if failure == "singular":
            assert message == (
                f"the 3D step failed at step {bad + 1} of {STEPS}: Singular matrix; likely cause: the time "
                "step may be too large for this model; try a smaller one"
            )
        else:
            assert message == (
                f"the 3D step diverged at t = {(bad + 1) * DT:.6g} s (step {bad + 1} of {STEPS}): "
                "non-finite state"
            )
    assert ds.attrs["complete"] == 0 and ds.attrs["steps"] == bad
    stored = bad // EVERY + 1  # t = 0, 3 dt, ..., 39 dt
    assert np.array_equal(ds.time.values, whole.time.values[:stored])
    same(ds, whole, steps=stored)


@pytest.mark.parametrize("status", ["SINGULAR", "ACTIVE_SET", "IMPULSE", "FORCE_JUMP", "NOT_FINITE"])
def test_a_c_loop_that_stops_names_the_step_the_reason_and_the_likely_cause(
    topology, status, monkeypatch
) -> None:
    """The C loop stops in the middle of a chunk (the statuses of svbi_loop3d_types.h): the steps
    before it are kept, and a contact problem with no solution or one that did not settle names the
    time step as the likely cause (a non-finite state is the divergence guard's)."""
    real = LocalizedDynamic3DC.advance
    bad = 41  # step n = 41 (t_42) fails

    def advance(self, n0: int, k: int, irregularity, every: int, reuse: bool = False):
        if not n0 <= bad < n0 + k:
            return real(self, n0, k, irregularity, every, reuse)
        chunk = real(self, n0, bad - n0, irregularity[: bad - n0], every, reuse)
        self.status, self.stopped = STATUS3D_CODES[status], "stopped"
        return chunk

    monkeypatch.setattr(LocalizedDynamic3DC, "advance", advance)
    assert sim3d.chunk_steps(EVERY) > bad + 1  # the failure is inside the first chunk
    with pytest.warns(SimulationIncomplete) as caught:
        ds = svbi.simulate(scenario(topology, backend="c"))
    why = STATUS3D_NAMES[STATUS3D_CODES[status]]
    expected = f"the 3D step failed at t = {(bad + 1) * DT:.6g} s (step {bad + 1} of {STEPS}): {why}"
    if status != "NOT_FINITE":
        expected += "; likely cause: the time step may be too large for this model; try a smaller one"
    assert str(caught[0].message) == expected
    assert ds.attrs["complete"] == 0 and ds.attrs["steps"] == bad

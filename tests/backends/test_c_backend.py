"""The C backend (the whole Newmark loop in C, ``svbi.runtime.backends.c.stepper``) against the NumPy
reference.

The NumPy backend is the truth: the C loop must reproduce every output variable of docs/design.md
section 7 (and the creep and irregularity outputs) to round-off, for every method, on multi-car, multi-span
runs with rail irregularity, an earthquake (synchronous, travelling, one record per support line)
and creep forces; for the sprung mass and the moving loads; when a run diverges (same step, same
message, same partial results); and whatever the chunks Python runs it in.

What "round-off" means per variable (measured, not assumed):

* positions and forces (midspan, contact and creep forces, car-body bounce and pitch): 1e-10 of the
  variable's peak;
* accelerations (``carbody_az``, ``deck_acceleration``): also 1e-10 of the peak. The vehicles step
  in increment form (``Newmark.update_increment``); in the total form ``a = a0 u - P`` a one-ulp
  difference of ``u`` moved them by ``eps a0 |u|``, and this test had to allow 16 such ulps;
* gaps are differences of positions (constraint violations at round-off level): they are compared
  with 1e-10 of the displacement scale they are differences of;
* coupled-classic drifts by construction (index-1 multipliers), and its velocity-level outputs (the
  creepage and the creep force) amplify round-off at the exit kink: the reference moves by 1e-10
  when only SuperLU's column ordering changes, and the C elimination order (blocks first) is further
  from SuperLU's: we allow 1e-8 there, 1e-10 on everything else.
"""

from __future__ import annotations

import math
import shutil
import subprocess
import sys
import warnings
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from conftest import c_compiler_works, export_and_run

import svbi
from svbi.examples import paper_section_keys
from svbi.runtime import toolchain as kernel_cache
from svbi.runtime.backends.c import build as c_solver_build
from svbi.runtime.backends.c import stepper as c_steppers
from svbi.runtime.excitation.ground import ground_motion
from svbi.runtime.excitation.synthetic import synthetic_record
from svbi.runtime.methods.initial import initial_state
from svbi.runtime.model.ground import RecordGround
from svbi.runtime.run.results import Recorder
from svbi.runtime.run.simulate import BackendFallback, DivergenceGuard, build_model
from svbi.runtime.scenario.schema import validate_scenario

METHODS = ("localized-dynamic", "coupled-dynamic", "coupled-classic")
RTOL = 1e-10
POSITION_LIKE = (
    "midspan_uz",
    "midspan_ux",
    "end_rotation",
    "contact_force",
    "contact_force_filtered",
    "carbody_uz",
    "carbody_pitch",
    "irregularity",
    "ground_uz",
    "ground_ux",
    "creep_force",
    "creepage",
)
GAPS = ("gap_vehicle", "gap_bridge", "gap_support")


pytestmark = pytest.mark.skipif(
    not c_compiler_works(),
    reason="no working C compiler: the C backend falls "
    "back to NumPy (tested in test_no_compiler_falls_back_to_numpy)",
)


def scenario(
    method: str,
    backend: str,
    vehicle: str = "pioneer-2d",
    cars: int = 2,
    spans: int = 2,
    quake: bool = True,
    irregularity: str = "german-low",
    dt: float = 1e-3,
    every: int = 2,
    normal: str = "unilateral",
    **solver: float,
):
    data = {
        "bridge": dict(
            spans=spans,
            span_length=32.0,
            **paper_section_keys(),
            elements_per_span=8,
        ),
        "train": dict(vehicle=vehicle, cars=cars, speed_kmh=300.0),
        "track": dict(irregularity=irregularity, seed=3),
        "contact": dict(normal=normal, creep=vehicle == "pioneer-2d"),  # only its wheels spin
        "solver": dict(method=method, backend=backend, time_step=dt, output_every=every, **solver),
    }
    if quake:
        data["earthquake"] = dict(vertical="synthetic", longitudinal="synthetic", arrival=0.2)
    return validate_scenario(data)


def simulate(sc, model=None):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # records shorter than the run, coarse time step
        return svbi.simulate(sc, model=model)


@cache
def pair(method: str, **kw):
    """NumPy and C results of the same scenario."""
    return simulate(scenario(method, "numpy", **kw)), simulate(scenario(method, "c", **kw))


def assert_agree(ref, out, method: str, velocity_rtol: float = RTOL) -> None:
    assert out.attrs["backend"] == "c" and ref.attrs["backend"] == "numpy"
    assert out.attrs["steps"] == ref.attrs["steps"] and out.attrs["complete"] == ref.attrs["complete"]
    np.testing.assert_array_equal(out.time.values, ref.time.values)
    problems = {}
    displacement = max(float(np.abs(ref[v]).max()) for v in ("midspan_uz", "midspan_ux", "carbody_uz"))
    for name in (*POSITION_LIKE, "carbody_az", "deck_acceleration", *GAPS):
        x, y = ref[name].values, out[name].values
        assert x.shape == y.shape, name
        peak = float(np.abs(x).max())
        rtol = velocity_rtol if name in ("creep_force", "creepage") else RTOL
        tol = rtol * peak
        if name in GAPS:
            tol = RTOL * max(peak, displacement)
        diff = float(np.abs(x - y).max())
        if not diff <= tol:
            problems[name] = (diff, tol)
    assert not problems, problems


# --------------------------------------------------------------------------------------------------
# agreement with the reference


@pytest.mark.parametrize("method", METHODS)
def test_pioneer_train_with_quake_irregularity_and_creep(method):
    """Two 14-DOF cars over two spans: entry, joint and exit, a synchronous earthquake in both
    components, a German-low rail profile and creep forces."""
    ref, out = pair(method)
    assert ref.attrs["steps"] > 1200 and float(np.abs(ref.ground_uz).max()) > 1e-3
    assert float(np.abs(ref.creep_force).max()) > 10.0 and float(np.abs(ref.irregularity).max()) > 1e-4
    assert float(np.abs(ref.midspan_ux).max()) > 1e-4
    assert_agree(ref, out, method, velocity_rtol=1e-8 if method == "coupled-classic" else RTOL)


def _record_ground(kind: str, spans: int) -> RecordGround:
    if kind == "travelling":
        return RecordGround(
            ground_motion(
                vertical="synthetic", longitudinal="synthetic", arrival=0.3, apparent_velocity=400.0
            )
        )
    lines = list(np.arange(spans + 1) * 32.0)
    return RecordGround(
        ground_motion(
            vertical=[synthetic_record("vertical", seed=k) for k in range(1, spans + 2)],
            longitudinal=[synthetic_record("longitudinal", seed=k) for k in range(11, spans + 12)],
            arrival=0.2,
            support_positions=lines,
        )
    )


@pytest.mark.parametrize(
    ("vehicle", "ground", "method"),
    [
        ("sprung-mass", "travelling", "localized-dynamic"),
        ("pioneer-2d", "lines", "localized-dynamic"),
        ("moving-load", "lines", "localized-dynamic"),
        ("moving-load", "travelling", "coupled-dynamic"),
        ("moving-load", "lines", "coupled-classic"),
    ],
)
def test_other_vehicles_and_ground_models(vehicle, ground, method):
    """The sprung mass and moving loads; a travelling wave (apparent velocity) and one record per
    support line (the nearest line moves each point), distinct records on every line."""
    out = {}
    for backend in ("numpy", "c"):
        sc = scenario(method, backend, vehicle=vehicle, cars=1 if vehicle == "sprung-mass" else 2)
        model = build_model(sc)
        model.ground = _record_ground(ground, sc.bridge.spans)
        out[backend] = simulate(sc, model)
    ref = out["numpy"]
    if ground == "lines":
        assert ref.attrs["backend"] == "numpy" and ref.ground_uz.dims == ("time", "support")
        assert float(np.ptp(ref.ground_uz.values[-1])) > 1e-5  # the lines move differently
    assert_agree(ref, out["c"], method)


@pytest.mark.parametrize("method", ["localized-dynamic", "coupled-dynamic"])
def test_hslm_train_many_axles_in_one_unit(method):
    """An EN 1991-2 HSLM-A train: dozens of axles in one "car", several on each span."""
    out = {}
    for backend in ("numpy", "c"):
        data = scenario(method, backend, vehicle="moving-load", cars=1, duration=0.4).to_dict()
        data["train"]["hslm"] = "A3"
        out[backend] = simulate(validate_scenario(data))
    assert out["numpy"].sizes["wheel"] > 20
    assert_agree(out["numpy"], out["c"], method)


def test_divergence_stops_with_the_same_message_and_partial_results():
    """A huge kappa makes the gap correction overshoot until the contact force exceeds its limit."""
    res = {}
    for backend in ("numpy", "c"):
        sc = scenario(
            "localized-dynamic",
            backend,
            cars=1,
            quake=False,
            irregularity="none",
            every=3,
            constraint_kappa=1e4,
            normal="bilateral",  # unilateral, the overshooting force would release the wheel
        )
        with pytest.warns(svbi.runtime.run.simulate.SimulationIncomplete, match="diverged"):
            res[backend] = svbi.simulate(sc)
    ref, out = res["numpy"], res["c"]
    assert ref.attrs["complete"] == 0 and out.attrs["complete"] == 0
    assert out.attrs["incomplete"] == ref.attrs["incomplete"]
    assert "contact_force" in out.attrs["incomplete"] and "kappa" in out.attrs["incomplete"]
    assert 0 < out.attrs["steps"] < 1000
    assert np.isfinite(out.contact_force_filtered).all()
    assert_agree(ref, out, "localized-dynamic")


def test_chunk_size_does_not_change_the_results():
    """Python calls the loop in chunks (progress bar, Ctrl-C): any chunking gives identical bits."""
    rows = []
    for chunk in (None, 1, 37):
        sc = scenario("localized-dynamic", "c", cars=1, spans=2)
        model = build_model(sc)
        state = initial_state(model)
        stepper = c_steppers.CStepper(model, state, "localized-dynamic")
        recorder = Recorder(model)
        recorder.force(0, state.P)
        recorder.record(state, model.contacts(0.0))
        stepper.run_loop(recorder, DivergenceGuard(model), None, chunk=chunk)
        assert recorder.steps_done == model.settings.steps
        rows.append(
            {k: v[: recorder.count].copy() for k, v in recorder.data.items()} | {"f": recorder.forces}
        )
    for other in rows[1:]:
        for key, value in rows[0].items():
            np.testing.assert_array_equal(other[key], value, err_msg=key)


def test_no_compiler_falls_back_to_numpy(monkeypatch, tmp_path):
    monkeypatch.setenv("CC", str(tmp_path / "no-such-compiler"))
    monkeypatch.setenv("SVBI_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(c_solver_build, "_LIBRARIES", {})
    monkeypatch.setattr(c_steppers, "_FALLBACK_WARNED", False)
    sc = scenario(
        "localized-dynamic",
        "c",
        vehicle="moving-load",
        cars=1,
        spans=1,
        quake=False,
        irregularity="none",
        duration=0.05,
    )
    with pytest.warns(BackendFallback, match="no working C compiler") as caught:
        ds = svbi.simulate(sc)
    assert ds.attrs["backend"] == "numpy" and ds.attrs["backend_requested"] == "c"
    assert len([w for w in caught if issubclass(w.category, BackendFallback)]) == 1
    ref = simulate(
        scenario(
            "localized-dynamic",
            "numpy",
            vehicle="moving-load",
            cars=1,
            spans=1,
            quake=False,
            irregularity="none",
            duration=0.05,
        )
    )
    np.testing.assert_array_equal(ds.midspan_uz.values, ref.midspan_uz.values)


# --------------------------------------------------------------------------------------------------
# the loop's sources: static C (runtime/csrc) and the generated glue


@pytest.mark.parametrize(
    "spec", [c_solver_build.LoopSpec("pioneer-2d", 14, 4), c_solver_build.LoopSpec("moving-load", 0, 0)]
)
def test_loop_source_builds_with_the_strict_warning_set(spec, tmp_path):
    """The kernels' warning policy: -std=c99 -Wall -Wextra -Werror (and -pedantic) on the loop's
    static sources and glue (CasADi's creep-law file has its one documented exception)."""
    files = c_solver_build.render_sources(spec)
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
    sources = sorted(n for n in files if n.endswith(".c") and not n.endswith("_kernels.c"))
    assert {"solver.c", "band.c", "tables.c", "localized.c", "coupled.c", "record.c"} <= set(sources)
    cc = kernel_cache.compiler_command()
    done = subprocess.run(
        [*cc, "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-c", *sources],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr


def test_loop_library_exports_its_interface_and_hides_the_rest():
    """The loop library's entry points are the three of solver.h; svbi's internal functions
    (internal.h) and CasADi's scalar helpers are hidden or file-local, so that their calls are
    direct and can be inlined (codegen/c_emit.py, _internal_helpers)."""
    library = c_solver_build.load_loop(c_solver_build.LoopSpec("pioneer-2d", 14, 4))._library
    for name in ("svbi_solver_workspace", "svbi_solver_init", "svbi_solver_run"):
        assert hasattr(library, name), name
    for name in (
        "svbi_place",
        "svbi_gb_factor_solve_r",
        "svbi_cube_root",
        "svbi_creep_update",
        "svbi_creep_split_cg_sq",
    ):
        assert not hasattr(library, name), name


def test_builtin_loop_imports_neither_jinja2_nor_casadi():
    """A built-in model's loop is the static C plus committed glue: building and loading it
    imports no template engine and no CasADi (svbi.codegen.loop_glue is for generation only)."""
    code = (
        "import sys\n"
        "from svbi.runtime.backends.c import build as c_solver_build\n"
        "c_solver_build.load_loop(c_solver_build.LoopSpec('pioneer-2d', 14, 4))\n"
        "c_solver_build.load_loop(c_solver_build.LoopSpec('moving-load', 0, 0))\n"
        "print(sorted(m for m in ('jinja2', 'casadi', 'svbi.codegen.loop_glue') if m in sys.modules))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "[]", done.stdout + done.stderr


def test_committed_glue_is_what_a_topology_file_gets():
    """A topology file has its svbi_topology.h rendered at run time; for a built-in topology that
    is byte for byte the committed header, and the rest of the glue is the committed files."""
    from svbi.codegen import loop_glue as c_glue

    spec = c_solver_build.LoopSpec("pioneer-2d", 14, 4)
    committed = c_solver_build.glue_sources(spec)
    assert committed[c_glue.TOPOLOGY_HEADER] == c_glue.topology("pioneer-2d", 14, 4)[c_glue.TOPOLOGY_HEADER]
    assert committed[c_glue.TYPES_HEADER] == c_glue.solver_types()[c_glue.TYPES_HEADER]
    assert committed[c_glue.ROWS_HEADER] == c_glue.contact_rows()[c_glue.ROWS_HEADER]
    # the row table's structure the generator renders (from the kernels) is the one the runtime
    # reads (the plain data of the generated bridge module)
    assert c_glue.row_structure() == c_solver_build.row_structure()
    # a topology that is not built in (or disagrees with the committed header) gets its own
    other = c_solver_build.glue_sources(c_solver_build.LoopSpec("pioneer-2d", 12, 2))[
        c_glue.TOPOLOGY_HEADER
    ].decode()
    assert "#define SVBI_NV 12 " in other and "#define SVBI_NW 2 " in other


def test_workspace_is_sized_up_front():
    """One workspace for the whole run, its size known before the first step (docs/c-backend.md)."""
    sc = scenario("coupled-dynamic", "c", cars=3, spans=4)
    model = build_model(sc)
    stepper = c_steppers.CStepper(model, initial_state(model), "coupled-dynamic")
    doubles = stepper.work.size
    assert 0 < doubles < 10 * (model.bridge.spans * model.bridge.ndof) ** 2
    assert math.isfinite(float(stepper.work.sum()))


def test_render_is_deterministic():
    spec = c_solver_build.LoopSpec("pioneer-2d", 14, 4)
    assert c_solver_build.render_sources(spec) == c_solver_build.render_sources(spec)
    assert Path(kernel_cache.generated_root(), "frame2d", "frame2d_kernels.c").is_file()


# --------------------------------------------------------------------------------------------------
# the embedded solver: `svbi export MODEL DIR --solver`


@pytest.mark.skipif(shutil.which("make") is None, reason="needs make")
def test_exported_solver_builds_with_make_and_reproduces_svbi_run(tmp_path):
    """The exported folder builds with `make` under the strict warning set and, with no Python,
    writes the same numbers as `svbi run` on the scenario baked into it."""
    table, ref, build = export_and_run(tmp_path)
    assert "-Werror" in build
    assert ref.attrs["backend"] == "c" and len(table) == ref.sizes["time"] > 100
    np.testing.assert_array_equal(table["time"], ref.time.values)
    columns = {
        "midspan_uz": [f"midspan_uz_{s}" for s in ref.span.values],
        "midspan_ux": [f"midspan_ux_{s}" for s in ref.span.values],
        "contact_force": [f"contact_force_{c}_{w}" for c in ref.car.values for w in ref.wheel.values],
        "creep_force": [f"creep_force_{c}_{w}" for c in ref.car.values for w in ref.wheel.values],
        "carbody_uz": [f"carbody_uz_{c}" for c in ref.car.values],
    }
    for name, cols in columns.items():
        expected = ref[name].values.reshape(len(table), -1)
        got = np.stack([table[c] for c in cols], axis=1)
        peak = float(np.abs(expected).max())
        assert peak > 0, name
        assert float(np.abs(got - expected).max()) <= RTOL * peak, name


def test_exported_solver_runs_lift_offs_and_landings_as_svbi_run(tmp_path):
    """localized-dynamic keeps the whole active set in C (lift-offs, flights, landings and their
    impact), so the standalone exported loop runs unilateral contact with no Python and writes the
    same numbers as `svbi run`."""
    data = scenario("localized-dynamic", "c", cars=1, spans=4, quake=False, every=5, duration=4.0).to_dict()
    data["title"] = "export with lift-offs: one car under a 3 g vertical record"
    data["train"].update(speed_kmh=120.0, start_position=3.0)
    data["earthquake"] = dict(vertical="synthetic", longitudinal="none", target_pga=29.43, arrival=0.0)
    table, ref, _ = export_and_run(tmp_path, data)
    assert ref.attrs["liftoffs"] >= 5 and ref.attrs["numpy_steps"] == 0
    assert len(table) == ref.sizes["time"]
    cols = [f"contact_force_{c}_{w}" for c in ref.car.values for w in ref.wheel.values]
    got = np.stack([table[c] for c in cols], axis=1)
    expected = ref.contact_force.values.reshape(len(table), -1)
    assert (expected == 0.0).any()  # airborne wheels carry no force
    assert float(np.abs(got - expected).max()) <= RTOL * float(np.abs(expected).max())

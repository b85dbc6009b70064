"""The generated NumPy modules (``svbi.codegen.python_emit``) and the run path that uses them.

* every generated function equals SymPy's evaluation of its kernel spec (30 digits) at random
  points around the spec's sample, to 1e-12 of each output's largest entry;
* the contact-row tables equal the symbolic rows they come from;
* a NumPy-backend run of a built-in vehicle imports neither SymPy, CasADi nor Jinja2 (checked in a
  fresh process); a topology file is derived once into the cache and later only loaded.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from svbi.codegen import kernels, loop_abi
from svbi.codegen.kernels import KernelSpec
from svbi.codegen.vehicle import derive_vehicle
from svbi.runtime.backends.c import build as c_solver_build
from svbi.runtime.model.kernels import load

RTOL = 1e-12
MODELS = ("frame2d", "sprung-mass", "pioneer-2d")


def _specs(model: str) -> list[KernelSpec]:
    if model == kernels.FRAME2D:
        return kernels.frame2d_model_spec().kernels
    vehicle = derive_vehicle(model)
    return [*kernels.model_kernels(vehicle), kernels.vehicle_role_spec(vehicle)]


def _random_inputs(spec: KernelSpec, rng: np.random.Generator) -> list[list[float]]:
    """Around the sample, each value moved by up to 20 % (zero samples get a small random value)."""
    out = []
    for column in spec.sample_inputs():
        values = []
        for x in column:
            values.append(x * (1 + 0.2 * rng.uniform(-1, 1)) if x != 0 else 0.1 * rng.uniform(-1, 1))
        out.append(values)
    return out


def _call(module, spec: KernelSpec, inputs: list[list[float]]) -> list[np.ndarray]:
    args = [v[0] if len(v) == 1 else v for v in inputs]
    result = getattr(module, spec.name)(*args)
    results = result if len(spec.outputs) > 1 else (result,)
    return [
        np.asarray(r, dtype=float).reshape(m.shape) for r, (_, m) in zip(results, spec.outputs, strict=True)
    ]


@pytest.mark.parametrize("model", MODELS)
def test_generated_functions_equal_sympy(model: str) -> None:
    module = load(model)
    rng = np.random.default_rng(20261123)
    specs = _specs(model)
    assert list(module.KERNELS) == [s.name for s in specs]
    for spec in specs:
        for _ in range(3):
            inputs = _random_inputs(spec, rng)
            symbols = [s for _, m in spec.inputs for s in m]
            values = [x for col in inputs for x in col]
            subs = {s: sp.Float(x, 30) for s, x in zip(symbols, values, strict=True)}
            got = _call(module, spec, inputs)
            for (name, m), g in zip(spec.outputs, got, strict=True):
                expected = np.array(m.xreplace(subs).evalf(30).tolist(), dtype=float).reshape(m.shape)
                scale = max(float(np.max(np.abs(expected), initial=0.0)), 1e-300)
                err = float(np.max(np.abs(g - expected), initial=0.0))
                assert err <= RTOL * scale, f"{model}.{spec.name}.{name}: {err:.3g} vs scale {scale:.3g}"


def test_row_tables_equal_the_symbolic_rows() -> None:
    """``c_solver_build.row_coefficients`` (generated tables) against ``c_glue.row_expressions`` (SymPy)."""
    from svbi.codegen import beam, constraints

    rng = np.random.default_rng(7)
    from svbi.codegen import loop_glue as c_glue

    exprs = c_glue.row_expressions()
    degree, nonzero = c_solver_build.row_structure()
    assert nonzero == tuple(sp.expand(e) != 0 for e in exprs)
    assert degree == max(sp.Poly(sp.expand(e), beam.xi).degree() for e in exprs if sp.expand(e) != 0)
    for le, v, dt, kappa, zeta, h in [(2.0, 83.3, 1e-4, 1.0, 1.0, 0.5), (1.3, 0.0, 2e-3, 0.0, 0.0, 0.0)]:
        table = c_solver_build.row_coefficients(le, v, dt, kappa, zeta, h)
        subs = {beam.le: le, constraints.v: v, constraints.dt: dt, constraints.kappa: kappa}
        subs |= {constraints.zeta: zeta, beam.h: h}
        for xi in rng.uniform(0, 1, 3):
            got = (xi ** np.arange(degree + 1)) @ table
            point = {k: sp.Float(x, 30) for k, x in subs.items()} | {beam.xi: sp.Float(xi, 30)}
            expected = np.array([float(e.xreplace(point).evalf(30)) for e in exprs])
            scale = np.maximum(np.abs(expected), np.max(np.abs(expected)) * 1e-8)
            assert np.all(np.abs(got - expected) <= RTOL * scale * 10)


def test_numeric_vehicle_equals_the_symbolic_model() -> None:
    from svbi.runtime.model.train import vehicle_model

    for name in ("sprung-mass", "pioneer-2d"):
        values = {"pioneer-2d": {"wheelset_mass": 2100.0}, "sprung-mass": {}}[name]
        got = vehicle_model(name).numeric(values)
        ref = derive_vehicle(name).numeric(values)
        for field in (
            "M",
            "C",
            "K",
            "F_gravity",
            "W_N",
            "W_T",
            "wheel_offsets",
            "wheel_masses",
            "wheel_radii",
        ):
            a, b = getattr(got, field), getattr(ref, field)
            assert a.shape == b.shape, field
            assert np.allclose(a, b, rtol=RTOL, atol=RTOL * max(float(np.abs(b).max(initial=0.0)), 1.0)), (
                field
            )
        assert (got.car_length, got.carbody_z, got.carbody_theta, got.dof_names) == (
            ref.car_length,
            ref.carbody_z,
            ref.carbody_theta,
            ref.dof_names,
        )


# --------------------------------------------------------------------------------------------------
# what a run imports

PROBE = r"""
import json, sys, traceback

HEAVY = ("sympy", "casadi", "jinja2")
first = {}


class Recorder:
    def find_spec(self, name, path=None, target=None):
        if name in HEAVY and name not in first:
            stack = [f.filename for f in traceback.extract_stack()]
            first[name] = [f for f in stack if "importlib" not in f and not f.startswith("<")][-1]
        return None


sys.meta_path.insert(0, Recorder())
import svbi

scenario = {
    "bridge": dict(spans=2, span_length=20.0, mass_per_length=2e4, youngs_modulus=3e10, area=5.0,
                   second_moment=3.0, damping_ratio=0.02, elements_per_span=4),
    "train": {"vehicle": sys.argv[1], "cars": 2, "speed": 50.0},
    "solver": {"backend": sys.argv[2], "time_step": 1e-3, "duration": 0.01, "method": sys.argv[3]},
    "contact": {"creep": sys.argv[1] == "pioneer-2d"},
}
ds = svbi.simulate(scenario)
assert ds.sizes["time"] > 1
print(json.dumps({name: first[name] for name in HEAVY if name in sys.modules}))
"""


def _run_probe(vehicle: str, backend: str, method: str, env: dict[str, str] | None = None) -> dict[str, str]:
    """Heavy modules imported by a run, each with the file whose import statement pulled it in."""
    proc = subprocess.run(
        [sys.executable, "-c", PROBE, vehicle, backend, method],
        capture_output=True,
        text=True,
        timeout=600,
        env=env,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _svbi_importers(imported: dict[str, str]) -> dict[str, str]:
    """The heavy imports made by svbi itself. Jinja2 may come through third-party code (xarray's
    chunk-manager discovery loads dask, whose widgets import Jinja2): that is not svbi's doing."""
    roots = {
        Path(kernels.__file__).resolve().parent,
        Path(c_solver_build.__file__).resolve().parent,
        Path(loop_abi.__file__).resolve().parent,  # the generator: svbi.codegen.loop_glue
    }
    return {k: v for k, v in imported.items() if Path(v).resolve().parent in roots}


@pytest.mark.parametrize(
    ("vehicle", "method"),
    [
        ("sprung-mass", "localized-dynamic"),
        ("pioneer-2d", "coupled-dynamic"),
        ("moving-load", "localized-dynamic"),
    ],
)
def test_numpy_run_imports_no_sympy_casadi_or_jinja2(vehicle: str, method: str) -> None:
    imported = _run_probe(vehicle, "numpy", method)
    assert "sympy" not in imported and "casadi" not in imported, imported
    assert not _svbi_importers(imported), imported


def test_c_run_imports_no_sympy_casadi_or_jinja2() -> None:
    if shutil.which(os.environ.get("CC", "cc")) is None:
        pytest.skip("no C compiler")
    imported = _run_probe("pioneer-2d", "c", "localized-dynamic")
    assert "sympy" not in imported and "casadi" not in imported, imported
    assert not _svbi_importers(imported), imported


CACHE_PROBE = r"""
import sys
from svbi.runtime.model.train import vehicle_model

v = vehicle_model(sys.argv[1]).numeric({"sprung_mass": 12345.0})
print(repr(float(v.M[0, 0])), "sympy" in sys.modules)
"""


def test_topology_file_is_generated_once_into_the_cache(tmp_path: Path) -> None:
    from svbi.codegen.topology import load_topology

    user = tmp_path / "my-car.toml"
    user.write_text(load_topology("sprung-mass").text, encoding="utf-8")
    env = {**os.environ, "SVBI_CACHE_DIR": str(tmp_path / "cache")}
    runs = []
    for _ in range(2):
        proc = subprocess.run(
            [sys.executable, "-c", CACHE_PROBE, str(user)],
            capture_output=True,
            text=True,
            env=env,
            timeout=300,
        )
        assert proc.returncode == 0, proc.stderr[-3000:]
        runs.append(proc.stdout.split())
    assert runs[0] == ["12345.0", "True"]  # derived and emitted with SymPy the first time
    assert runs[1] == ["12345.0", "False"]  # then only loaded
    modules = list((tmp_path / "cache" / "python").glob("*/numpy_kernels.py"))
    assert len(modules) == 1
    committed = load("sprung-mass")
    assert (
        modules[0].read_text(encoding="utf-8").split("\n", 3)[3]
        == Path(committed.__file__).read_text(encoding="utf-8").split("\n", 3)[3]
    )

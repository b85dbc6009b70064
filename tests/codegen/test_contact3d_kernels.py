"""The generated 3D contact kernels (``generated/contact3d``) and 3D vehicle modules.

* every group of :mod:`svbi.codegen.contact3d_kernels` equals the expressions of
  :mod:`svbi.codegen.contact3d` and :mod:`svbi.codegen.creep3d`, differentiated here, evaluated by
  mpmath at 30 digits, at random points around the sample, with real and with complex inputs, to
  1e-12 of each output's largest entry (the generated code is double precision: its error is a few
  ulps of the largest terms that cancel, the radius in a gap of millimetres; measured at most
  3.3e-14, the normal residuals and gaps, the rest below 1e-15: a margin of 30);
* on complex inputs the functions are analytic: the complex step of the gradient is the Hessian,
  the complex step of the residual along Newmark's direction is the residual Jacobian;
* the committed vehicle modules are what the generator writes, byte for byte (the contact module
  is checked with the whole tree by ``svbi generate --check``, tests/codegen/test_emit_build.py);
* the 3D vehicles' generated matrices equal ``derive_vehicle3d(...).numeric(...)``;
* ``v`` times the creepages' rate gradients is the generalized force of a unit creep force (virtual work);
* the creep law's groups (Kalker's coefficients under a load, the saturated forces of one contact)
  equal the law written out here (Hertz, Kalker, Shen-Hedrick-Elkins) in mpmath at 30 digits, below
  and beyond saturation, to 1e-13 of each output's largest entry (measured 1.1e-15; real inputs:
  the step applies the creep forces explicitly and takes no derivative through them), and are
  zero out of load; the step's creep forces and loads, composed of the generated groups, equal
  the symbolic law over the state;
* the 3D step's model glue imports no SymPy for a built-in car, a step with creep included; a 3D
  topology file is derived once into the cache and later only loaded.
"""

from __future__ import annotations

import os
import subprocess
import sys
from functools import cache
from pathlib import Path

import mpmath
import numpy as np
import pytest
import sympy as sp

from svbi.codegen import contact3d as c3
from svbi.codegen import contact3d_kernels as ck
from svbi.codegen import creep3d
from svbi.codegen.topology3d import builtin_topologies_3d, load_topology3d
from svbi.codegen.vehicle3d import derive_vehicle3d, render_vehicle3d
from svbi.runtime.model.kernels import load

RTOL = 1e-12
ARGS = [s for _, m in ck.INPUTS for s in m]


def _diff(exprs: list[sp.Expr], over) -> sp.Matrix:
    return sp.Matrix([[sp.diff(e, q) for q in over] for e in exprs])


def _newmark(exprs: list[sp.Expr]) -> sp.Matrix:
    return _diff(exprs, ck.Z) + ck.a1 * _diff(exprs, ck.Z_T) + ck.a0 * _diff(exprs, ck.Z_TT)


@cache
def _expected() -> dict[str, list[sp.Matrix]]:
    """Each group's outputs, built here from the contact and creep expressions."""
    c1, c0 = ck.c1, ck.c0
    gaps = [c.gap for c in c3.contacts()]
    normal = [gtt + c1 * gt + c0 * g for (gt, gtt), g in zip(c3.gap_rates(), gaps, strict=True)]
    flanges = [c.flange_gap for c in c3.contacts()]
    dt = c3.time_derivative
    flange = [dt(dt(g)) + c1 * dt(g) + c0 * g for g in flanges]
    creep = [e for cr in creep3d.creepages() for e in (cr.xi_x, cr.xi_y, cr.xi_sp)]
    unit = (creep3d.creep_fx, creep3d.creep_fy, creep3d.creep_spin)
    return {
        "normal_gaps": [sp.Matrix(gaps)],
        "normal_gap_gradients": [_diff(gaps, ck.Z)],
        "normal_gap_hessians": [sp.hessian(g, ck.Z) for g in gaps],
        "normal_residuals": [sp.Matrix(normal)],
        "normal_residual_jacobians": [_newmark(normal)],
        "flange_gaps": [sp.Matrix(flanges)],
        "flange_gap_gradients": [_diff(flanges, ck.Z)],
        "flange_residuals": [sp.Matrix(flange)],
        "flange_residual_jacobians": [_newmark(flange)],
        "creepages": [sp.Matrix(creep)],
        "creepage_gradients": [_diff(creep, ck.Z)],
        "creepage_rate_gradients": [_diff(creep, ck.Z_T)],
        "creep_load_directions": [_diff([*ld.wheelset, *ld.deck], unit) for ld in creep3d.creep_loads()],
    }


@cache
def _mp(group: str):
    return [sp.lambdify(ARGS, m, "mpmath") for m in _expected()[group]]


def _point(rng: np.random.Generator, imaginary: bool) -> list[complex]:
    """Around the sample, each value moved by up to 20 %; with ``imaginary`` each gets an imaginary
    part of up to 10 % of itself."""
    values = []
    for s in ARGS:
        x = ck.SAMPLE[s.name] * (1 + 0.2 * rng.uniform(-1, 1))
        values.append(complex(x, 0.1 * x * rng.uniform(-1, 1)) if imaginary else x)
    return values


def _arguments(values: list) -> list:
    out, k = [], 0
    for _, m in ck.INPUTS:
        part = values[k : k + m.rows]
        out.append(part[0] if m.rows == 1 else np.array(part))
        k += m.rows
    return out


def test_groups_are_the_generated_kernels() -> None:
    module = load(ck.CONTACT3D)
    assert [g.name for g in ck.GROUPS] == list(_expected())
    assert list(module.KERNELS) == [g.name for g in (*ck.GROUPS, *ck.LAW_GROUPS)]
    assert [g.name for g in ck.LAW_GROUPS] == ["kalker_coefficients", "creep_forces"]


@pytest.mark.parametrize("imaginary", [False, True], ids=["real", "complex"])
@pytest.mark.parametrize("group", [g.name for g in ck.GROUPS])
def test_group_equals_sympy(group: str, imaginary: bool) -> None:
    module = load(ck.CONTACT3D)
    rng = np.random.default_rng(20261127 + 7 * imaginary)
    mpmath.mp.dps = 30
    for _ in range(2):
        values = _point(rng, imaginary)
        got = getattr(module, group)(*_arguments(values))
        got = got if isinstance(got, tuple) else (got,)
        for fn, g in zip(_mp(group), got, strict=True):
            expected = np.array(fn(*[mpmath.mpmathify(v) for v in values]).tolist(), dtype=complex)
            g = np.asarray(g)
            assert g.dtype == (np.complex128 if imaginary else np.float64)
            g = g.reshape(expected.shape)
            scale = float(np.max(np.abs(expected)))
            err = float(np.max(np.abs(g - expected)))
            assert err <= RTOL * scale, f"{group}: {err:.3g} vs scale {scale:.3g}"


def test_complex_step_of_the_kernels_gives_their_derivatives() -> None:
    """The Hessian and the residual Jacobians are the complex-step derivatives of the gradient and
    the residuals (exact to round-off: no difference is taken)."""
    module = load(ck.CONTACT3D)
    values = _point(np.random.default_rng(5), False)
    args = _arguments(values)
    a1, a0 = args[-1][2], args[-1][3]
    h = 1e-30
    hess = np.array(module.normal_gap_hessians(*args))
    for pairs in (
        ("normal_residuals", "normal_residual_jacobians"),
        ("flange_residuals", "flange_residual_jacobians"),
    ):
        jac = np.asarray(getattr(module, pairs[1])(*args))
        for k in range(16):
            step = np.zeros(16)
            step[k] = h
            moved = list(args)
            z, zt, ztt = (np.concatenate([args[i], args[i + 3]]).astype(complex) for i in range(3))
            z, zt, ztt = z + 1j * step, zt + 1j * a1 * step, ztt + 1j * a0 * step
            moved[0], moved[1], moved[2], moved[3], moved[4], moved[5] = (
                z[:4],
                zt[:4],
                ztt[:4],
                z[4:],
                zt[4:],
                ztt[4:],
            )
            column = np.asarray(getattr(module, pairs[0])(*moved)).imag / h
            assert np.allclose(column, jac[:, k], rtol=1e-13, atol=1e-13 * np.max(np.abs(jac)))
            if pairs[0] == "normal_residuals":
                grad = np.asarray(module.normal_gap_gradients(*moved)).imag / h
                assert np.allclose(grad, hess[:, k, :], rtol=1e-13, atol=1e-15)


def _law(creepage: list, normal, creep: list) -> tuple[list, list]:
    """Kalker's ``[f11, f22, f23]`` and the saturated ``[F_x, F_y]`` with the spin moment of one
    contact, written out: the Hertz ellipse of two steel bodies (relative curvatures
    ``1/(2 R_wheel)`` along, ``1/(2 R_rail)`` across), ``f11 = G a b C11``, ``f22 = G a b C22``,
    ``f23 = G (a b)^(3/2) C23``, Kalker's linear forces scaled by Shen-Hedrick-Elkins' ``eps``."""
    e, nu, r_wheel, r_rail, m, n, c11, mu, c22, c23 = (mpmath.mpf(x) for x in creep)
    normal = mpmath.mpf(normal)
    g = e / (2 * (1 + nu))
    c = mpmath.cbrt(3 * normal * (1 - nu**2) / (2 * e * (1 / (2 * r_wheel) + 1 / (2 * r_rail))))
    ab = m * c * n * c
    f11, f22, f23 = g * ab * c11, g * ab * c22, g * ab ** mpmath.mpf(1.5) * c23
    x, y, spin = (mpmath.mpf(v) for v in creepage)
    fx, fy = -f11 * x, -f22 * y - f23 * spin
    beta = mpmath.sqrt(fx**2 + fy**2) / (mu * normal)
    eps = 1 - beta / 3 + beta**2 / 27 if beta < 3 else 1 / beta
    return [f11, f22, f23], [eps * fx, eps * fy, f23 * y]


def _close(got, want: list, rtol: float) -> float:
    want = np.array([float(w) for w in want])
    got = np.asarray(got, dtype=float).reshape(-1)
    err = float(np.max(np.abs(got - want)))
    assert err <= rtol * float(np.max(np.abs(want))), (got, want)
    return err


def test_creep_law_groups_equal_the_law() -> None:
    """Below and beyond saturation (the creepages scaled so that ``beta`` spans 0.1 to 10), at
    random points around the sample; zero forces for a contact out of load."""
    module = load(ck.CONTACT3D)
    rng = np.random.default_rng(20261128)
    mpmath.mp.dps = 30
    names = [s.name for _, m in ck.LAW_INPUTS for s in m]
    branches = set()
    for scale in (0.1, 1.0, 10.0):
        for _ in range(3):
            x = {k: ck.LAW_SAMPLE[k] * (1 + 0.2 * rng.uniform(-1, 1)) for k in names}
            creepage = [scale * x[k] for k in ("xi_cx", "xi_cy", "xi_csp")]
            creep = [x[s.name] for s in ck.MATERIAL]
            f, forces = _law(creepage, x["N_c"], creep)
            _close(module.kalker_coefficients(np.array(creepage), x["N_c"], np.array(creep)), f, 1e-13)
            _close(module.creep_forces(np.array(creepage), x["N_c"], np.array(creep)), forces, 1e-13)
            fx, fy = -f[0] * creepage[0], -f[1] * creepage[1] - f[2] * creepage[2]
            branches.add(bool(mpmath.sqrt(fx**2 + fy**2) / (x["mu_f"] * x["N_c"]) < 3))
    assert branches == {True, False}
    creep = np.array([ck.LAW_SAMPLE[s.name] for s in ck.MATERIAL])
    with np.errstate(all="ignore"):
        for normal in (0.0, -1e3):
            got = module.creep_forces(np.array([1e-3, 1e-3, 0.1]), np.float64(normal), creep)
            assert np.array_equal(np.asarray(got, dtype=float), np.zeros(3))


def test_creep_of_the_step_is_the_symbolic_law() -> None:
    """:class:`FlangeCreepKernel3D` (creepages, then the law, then the load directions, all
    generated) equals the creep forces and loads of :mod:`svbi.codegen.creep3d` over the state,
    evaluated by mpmath at 30 digits: each contact's ``[F_x, F_y, M_sp]`` and the load on ``z`` to
    1e-12 of their largest entry (measured 2e-14: the longitudinal creepage is the difference of
    the wheel's forward and rolling speeds, which cancel to 1e-5 of each); a contact out of load
    has none."""
    from svbi.runtime.model.creep_law import CreepParameters
    from svbi.runtime.model.system3d import FlangeCreepKernel3D, Track3D, Wheelset

    x = ck.SAMPLE
    wheelset = Wheelset("ws", np.arange(4), 0.0, x["r0"], x["b"])
    track = Track3D(conicity=x["lam"], eccentricity=x["e_t"], rail_height=x["h_t"], flange_clearance=x["c_f"])
    kernel = FlangeCreepKernel3D(wheelset, track, x["le"], x["v"], 1.0, 1.0, CreepParameters())
    law = dict(zip(ck.MATERIAL, kernel._material, strict=True))
    kalker = creep3d.kalker_coefficients()
    state = [*ck.Z, *ck.Z_T, ck.xi]
    symbols = [*state, *ck.GEOMETRY, creep3d.normal_load]
    forces = [
        sp.Matrix([f.fx, f.fy, f.spin_moment])
        .xreplace(kalker)
        .xreplace(law)
        .xreplace({s: 0 for s in (*ck.IRREGULARITY, *ck.Z_TT)})
        for f in creep3d.creep_forces()
    ]
    force_fns = [sp.lambdify(symbols, f, "mpmath") for f in forces]
    unit = (creep3d.creep_fx, creep3d.creep_fy, creep3d.creep_spin)
    loads = [
        sp.Matrix([*ld.wheelset, *ld.deck]).xreplace({s: 0 for s in ck.IRREGULARITY})
        for ld in creep3d.creep_loads()
    ]
    load_fns = [sp.lambdify([*state, *ck.GEOMETRY, *unit], ld, "mpmath") for ld in loads]
    mpmath.mp.dps = 30
    rng = np.random.default_rng(11)
    geometry = [mpmath.mpf(x[s.name]) for s in ck.GEOMETRY]
    for normal in ([8e4, 6e4], [7e4, 0.0]):
        z = np.array([x[s.name] * (1 + 0.2 * rng.uniform(-1, 1)) for s in ck.Z])
        zd = np.array([x[s.name] * (1 + 0.2 * rng.uniform(-1, 1)) for s in ck.Z_T])
        xi = 0.3 + 0.1 * rng.uniform(-1, 1)
        got, load_got = kernel.creep(z, zd, xi, np.array(normal))
        values = [mpmath.mpf(float(v)) for v in (*z, *zd, xi)]
        want_load = mpmath.matrix(16, 1)
        for k in range(2):
            if normal[k] > 0:
                want = force_fns[k](*values, *geometry, mpmath.mpf(normal[k]))
                _close(got[k], list(want), 1e-12)
            else:
                want = mpmath.matrix([0, 0, 0])
                assert np.array_equal(got[k], np.zeros(3))
            want_load += load_fns[k](*values, *geometry, *want)
        _close(load_got, list(want_load), 1e-12)


# The committed contact module (generated/contact3d/numpy_kernels.py) is compared with what the
# generator writes, byte for byte, by `svbi generate --check` (tests/codegen/test_emit_build.py:
# test_check_passes_on_the_committed_tree and the hash-seed test, the whole tree, the same
# ``python_emit.render_target``): a separate render here repeated that 15 s derivation.


@pytest.mark.parametrize("name", builtin_topologies_3d())
def test_committed_vehicle_module_is_reproduced_byte_for_byte(name: str) -> None:
    _, source = render_vehicle3d(name)
    assert source == Path(load(name).__file__).read_bytes()


@pytest.mark.parametrize("name", builtin_topologies_3d())
def test_vehicle_matrices_equal_the_derivation(name: str) -> None:
    from svbi.runtime.model.system3d import vehicle3d

    topo = load_topology3d(name)
    scalars = sorted(n for n, p in topo.parameters.items() if not isinstance(p.value, tuple))
    override = {scalars[0]: 1.1 * float(topo.parameters[scalars[0]].value) + 1.0}
    module = load(name)
    for values in ({}, override):
        expected = derive_vehicle3d(topo).numeric(values)
        p = [float((topo.defaults() | values)[n]) for n in module.DATA["parameter_vector"]]
        assert module.DATA["dof_names"] == expected.dof_names
        for got, want in (
            (module.mass_matrix(p), expected.M),
            (module.damping_matrix(p), expected.C),
            (module.stiffness_matrix(p), expected.K),
            (module.gravity_load(p), expected.F_gravity),
        ):
            assert np.allclose(got, want, rtol=0, atol=1e-14 * np.max(np.abs(want)))
        # the run-time vehicle: the same matrices less the wheelsets' spin DOFs
        numeric = vehicle3d(name, values)
        keep = [expected.dof_names.index(d) for d in numeric.dof_names]
        assert np.allclose(
            numeric.K, expected.K[np.ix_(keep, keep)], rtol=0, atol=1e-14 * np.max(np.abs(expected.K))
        )
        assert np.allclose(
            numeric.F, expected.F_gravity[keep], rtol=0, atol=1e-14 * np.max(np.abs(expected.F_gravity))
        )
    with pytest.raises(KeyError, match="unknown parameter 'no_such'"):
        vehicle3d(name, {"no_such": 1.0})


NO_SYMPY_PROBE = r"""
import sys
import numpy as np
from svbi.runtime.model.system3d import ContactKernel3D, Track3D, vehicle3d

v = vehicle3d(sys.argv[1])
k = ContactKernel3D(v.wheelsets[0], Track3D(conicity=0.15, rail_height=1.0), 5.0, 50.0, 1.0, 1.0)
z = np.full(16, 1e-3)
k.hessian(z, 0.3); k.residual_jacobian(z, z, z, 0.3, 1.0, 2.0); k.creepage_rate_gradient(z, z, 0.3)
# a step with creep on a span (every wheelset on it)
from svbi.runtime.methods.coupled3d import CoupledDynamic3D, static_state
from svbi.runtime.model.creep_law import CreepParameters
from svbi.runtime.model.span3d import Section3D, simply_supported_span
from svbi.runtime.model.system3d import System3D
section = Section3D(E=3.0e10, A=5.0, I_y=5.0, I_z=20.0, J=8.0, mass_per_length=1.2e4)
span = simply_supported_span(section, 40.0, 8)
start = 5.0 + max(w.offset for w in v.wheelsets)
system = System3D(v, span, Track3D(conicity=0.15), speed=20.0, start=start, creep=CreepParameters())
state = CoupledDynamic3D(system, static_state(system), 1e-4).step(0)
assert np.abs(state.creep).max() > 0.0
plain = {"svbi.codegen", "svbi.codegen.plain_types", "svbi.codegen.c_flags", "svbi.codegen.loop_abi"}
plain |= {"svbi.codegen.vehicles", "svbi.codegen.vehicles3d"}  # data folders (the built-in files)
plain |= {"svbi.codegen.input_files"}  # bounded reading of input files (no SymPy)
symbolic = sorted(m for m in sys.modules if m.startswith("svbi.codegen") and m not in plain)
print(repr(float(v.M[0, 0])), "sympy" in sys.modules, bool(symbolic))
"""


def _probe(target: str, env: dict[str, str] | None = None) -> list[str]:
    proc = subprocess.run(
        [sys.executable, "-c", NO_SYMPY_PROBE, target],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc.stdout.split()


def test_3d_model_glue_imports_no_sympy() -> None:
    mass, sympy_loaded, codegen_loaded = _probe("manchester-3d")
    assert (sympy_loaded, codegen_loaded) == ("False", "False")


def test_3d_topology_file_is_generated_once_into_the_cache(tmp_path: Path) -> None:
    user = tmp_path / "my-3d-car.toml"
    user.write_text(load_topology3d("manchester-3d").text, encoding="utf-8")
    env = {**os.environ, "SVBI_CACHE_DIR": str(tmp_path / "cache")}
    first, second = _probe(str(user), env), _probe(str(user), env)
    builtin = _probe("manchester-3d")
    assert first[1] == "True"  # derived and emitted with SymPy the first time
    assert second[1:] == ["False", "False"]  # then only loaded
    assert first[0] == second[0] == builtin[0]
    modules = list((tmp_path / "cache" / "python").glob("*/numpy_kernels.py"))
    assert len(modules) == 1
    assert modules[0].read_bytes() == Path(load("manchester-3d").__file__).read_bytes()


def test_c_kernels_build_and_equal_the_numpy_module(tmp_path: Path) -> None:
    """The committed C kernels of ``contact3d`` build with the strict flags, and their example
    program prints, at the spec's sample, what the NumPy module (checked above against SymPy)
    returns, to 1e-12 of each output's largest entry (both double precision, CSE'd differently)."""
    import re
    import shutil

    make = shutil.which("make")
    if make is None or shutil.which(os.environ.get("CC", "cc").split()[0]) is None:
        pytest.skip("no make or C compiler")
    committed = Path(load(ck.CONTACT3D).__file__).parent
    for path in committed.iterdir():
        if path.suffix in (".c", ".h") or path.name == "Makefile":
            shutil.copy(path, tmp_path / path.name)
    build = subprocess.run([make, "-C", str(tmp_path)], capture_output=True, text=True, check=False)
    assert build.returncode == 0, build.stdout + build.stderr
    assert "warning" not in (build.stdout + build.stderr).lower()
    run = subprocess.run([str(tmp_path / "contact3d_main")], capture_output=True, text=True, check=True)
    printed: dict[tuple[str, str], dict[tuple[int, int], float]] = {}
    for line in run.stdout.splitlines():
        m = re.fullmatch(r"(\w+)\.(\w+)\[(\d+)\]\[(\d+)\] = (\S+)", line)
        assert m, f"unexpected line {line!r}"
        printed.setdefault((m[1], m[2]), {})[(int(m[3]), int(m[4]))] = float(m[5])
    module = load(ck.CONTACT3D)
    spec = ck.contact3d_model_spec()
    for kernel in spec.kernels:
        args = [v[0] if len(v) == 1 else np.array(v) for v in kernel.sample_inputs()]
        result = getattr(module, kernel.name)(*args)
        results = result if len(kernel.outputs) > 1 else (result,)
        for (name, matrix), want in zip(kernel.outputs, results, strict=True):
            want = np.asarray(want, dtype=float).reshape(matrix.shape)
            got = np.zeros(matrix.shape)
            for (i, j), value in printed[(kernel.name, name)].items():
                got[i, j] = value
            assert len(printed[(kernel.name, name)]) == want.size
            scale = float(np.max(np.abs(want)))
            assert float(np.max(np.abs(got - want))) <= 1e-12 * scale, f"{kernel.name}.{name}"


def test_rate_gradients_of_the_creepages_give_the_forces_generalized_forces() -> None:
    """``v dxi/dz'`` is the generalized force of a unit creep force: in the nominal state, against
    the virtual work of a force along ``t_x`` (``F_x``) and ``t_y`` (``F_y``) on the wheel at its
    contact point ``(0, s b, -r0)`` from the axle centre and its reaction on the rail head, which
    moves by ``(u - h theta - (e + s b) psi, v - h phi, w + (e + s b) phi)`` of the deck section
    (written out here from the contact geometry of docs/three-d.md)."""
    from svbi.codegen import frame3d

    module = load(ck.CONTACT3D)
    values = dict(ck.SAMPLE)
    values.update({s.name: 0.0 for s in (*ck.Z, *ck.Z_T, *ck.Z_TT, *ck.IRREGULARITY)})
    rates = np.asarray(module.creepage_rate_gradients(*_arguments([values[s.name] for s in ARGS])))
    r0, b, lam, e, h, v, le, xi = (values[k] for k in ("r0", "b", "lam", "e_t", "h_t", "v", "le", "xi"))
    n = frame3d.shape_functions()
    at = {frame3d.xi: xi, frame3d.le: le}

    def row(m: sp.Matrix) -> np.ndarray:
        return np.array(m.xreplace(at).evalf(), dtype=float).reshape(-1)

    nu, nv, nw, nphi = (row(n[k]) for k in ("u", "v", "w", "phi"))
    theta, psi = row(sp.diff(n["w"], frame3d.xi) / frame3d.le), row(sp.diff(n["v"], frame3d.xi) / frame3d.le)
    root = np.sqrt(1 + lam**2)
    for k, s in enumerate((1, -1)):
        arm = e + s * b
        # F_x = 1 along t_x = (1, 0, 0): on the wheel a yaw moment -s b; on the deck -(x_rail)
        fx = np.concatenate([[0.0, 0.0, 0.0, -s * b], -(nu - h * theta - arm * psi)])
        # F_y = 1 along t_y = (0, 1, s lam) / sqrt(1 + lam^2)
        fy_lat, fy_vert = 1 / root, s * lam / root
        roll = s * b * fy_vert + r0 * fy_lat  # r_y F_z - r_z F_y
        deck = -(fy_lat * (nv - h * nphi) + fy_vert * (nw + arm * nphi))
        fy = np.concatenate([[fy_lat, fy_vert, roll, 0.0], deck])
        assert np.allclose(v * rates[3 * k], fx, rtol=0, atol=1e-14), k
        assert np.allclose(v * rates[3 * k + 1], fy, rtol=0, atol=1e-14), k

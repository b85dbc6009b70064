"""Kernels of every built-in model: compiled C == CasADi Function == SymPy, at random inputs.

The SymPy oracle evaluates the derived expressions in 30-digit arithmetic (mpmath, via lambdify),
independently of both emitters. The compiled kernels come from the committed ``generated/`` tree,
so these tests also catch committed code that no longer matches the derivation.
"""

from __future__ import annotations

import textwrap
import warnings
from pathlib import Path

import mpmath
import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from svbi.codegen.kernels import KernelSpec, builtin_models, model_spec
from svbi.runtime import toolchain as kernel_cache

RTOL = 1e-12


def random_inputs(spec: KernelSpec, rng: np.random.Generator) -> list[np.ndarray]:
    """Random inputs around the kernel's sample point, respecting the symbols' sign assumptions."""
    out = []
    for _, column in spec.inputs:
        values = []
        for s in column:
            x0 = spec.sample.get(s.name, 0.5)
            if s.is_nonnegative:
                values.append((x0 if x0 > 0 else 1.0) * rng.uniform(0.5, 2.0))
            else:
                values.append((abs(x0) or 1.0) * rng.uniform(-2.0, 2.0))
        out.append(np.array(values))
    return out


_ORACLES: dict[int, object] = {}


def sympy_values(spec: KernelSpec, inputs: list[np.ndarray]) -> list[np.ndarray]:
    """The oracle: the SymPy outputs evaluated in 30-digit arithmetic, independently of both emitters.

    mpmath via lambdify prints Piecewise as lazy conditionals, so a branch that would be complex
    (the cube root of a negative load) is never evaluated, as in SymPy's own semantics.
    """
    if id(spec) not in _ORACLES:
        _ORACLES[id(spec)] = sp.lambdify(spec.input_symbols, [m for _, m in spec.outputs], modules="mpmath")
    with mpmath.workdps(30):
        values = _ORACLES[id(spec)](*[mpmath.mpf(float(v)) for v in np.concatenate(inputs)])
        return [
            np.array(v.tolist(), dtype=float).reshape(m.shape)
            for v, (_, m) in zip(values, spec.outputs, strict=True)
        ]


def assert_close(actual: np.ndarray, expected: np.ndarray, what: str) -> None:
    """Relative 1e-12, measured against the largest entry of the output (a matrix-norm bound)."""
    assert actual.shape == expected.shape, what
    scale = float(np.max(np.abs(expected))) if expected.size else 0.0
    np.testing.assert_allclose(actual, expected, rtol=RTOL, atol=RTOL * scale, err_msg=what)


@pytest.fixture(scope="session")
def emit_cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("svbi-cache")


@pytest.fixture(scope="session")
def builtin(emit_cache: Path) -> dict[str, tuple]:
    """Per built-in model: (spec, C kernels, CasADi kernels); compiled once per session."""
    out = {}
    for name in builtin_models():
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # the C backend must be used here, not the fallback
            c_kernels = kernel_cache.load_kernels(name, "c", cache_dir=emit_cache)
        out[name] = (model_spec(name), c_kernels, kernel_cache.load_kernels(name, "casadi"))
    return out


def test_every_builtin_kernel_is_covered(builtin: dict) -> None:
    """The random test below runs every kernel of every built-in model."""
    names = {(m, k.name) for m, (spec, _, _) in builtin.items() for k in spec.kernels}
    assert {"pioneer-2d", "sprung-mass", "frame2d"} <= set(builtin)
    assert len(names) >= 27


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_c_equals_casadi_equals_sympy(builtin: dict, seed: int) -> None:
    rng = np.random.default_rng(seed)
    for model, (spec, c_kernels, ca_kernels) in builtin.items():
        assert c_kernels.backend == "c" and ca_kernels.backend == "casadi"
        for kernel in spec.kernels:
            inputs = random_inputs(kernel, rng)
            c_out = c_kernels[kernel.name].call_dict(*inputs)
            ca_out = ca_kernels[kernel.name].call_dict(*inputs)
            for (name, _), expected in zip(kernel.outputs, sympy_values(kernel, inputs), strict=True):
                what = f"{model}.{kernel.name}.{name} (seed {seed})"
                assert_close(ca_out[name], expected, "CasADi vs SymPy: " + what)
                assert_close(c_out[name], expected, "C vs SymPy: " + what)
                assert_close(c_out[name], ca_out[name], "C vs CasADi: " + what)


def test_sample_point_and_defaults(builtin: dict) -> None:
    """At the default parameters the C mass matrix is the SymPy one, symmetric positive definite."""
    spec, c_kernels, _ = builtin["pioneer-2d"]
    m = c_kernels.mass_matrix(c_kernels.defaults)
    (expected,) = sympy_values(spec.kernel("mass_matrix"), [c_kernels.defaults])
    assert_close(m, expected, "pioneer-2d mass matrix at the defaults")
    np.testing.assert_array_equal(m, m.T)
    assert np.all(np.linalg.eigvalsh(m) > 0)
    assert c_kernels.parameters == [s.name for s in spec.kernels[0].inputs[0][1]]


def test_structural_zeros_are_not_stored(builtin: dict) -> None:
    """Exact zeros of the SymPy outputs are absent from the generated sparsity."""
    spec, _, ca_kernels = builtin["pioneer-2d"]
    fn = ca_kernels["mass_matrix"].function
    expected_nnz = sum(1 for e in spec.kernel("mass_matrix").outputs[0][1] if e != 0)
    assert fn.sparsity_out(0).nnz() == expected_nnz < 14 * 14


def test_kernel_input_errors(builtin: dict) -> None:
    _, c_kernels, ca_kernels = builtin["sprung-mass"]
    for kernels in (c_kernels, ca_kernels):
        with pytest.raises(ValueError, match="input 'p' needs"):
            kernels.mass_matrix(np.zeros(2))
        with pytest.raises(TypeError, match="takes 1 inputs"):
            kernels.mass_matrix()
        with pytest.raises(AttributeError, match="no kernel"):
            _ = kernels.no_such_kernel


WAGON = textwrap.dedent(
    """
    name = "two-axle-wagon"
    kind = "rigid-body"
    description = "Freight wagon: body on two wheelsets (test topology)."
    source = "test"

    [parameters.body_mass]
    value = 20000.0
    unit = "kg"
    [parameters.body_pitch_inertia]
    value = 1.5e5
    unit = "kg m^2"
    [parameters.wheelset_mass]
    value = 1200.0
    unit = "kg"
    [parameters.k]
    value = 1.2e6
    unit = "N/m"
    [parameters.c]
    value = 2.0e4
    unit = "N s/m"
    [parameters.axle_spacing]
    value = 9.0
    unit = "m"
    [parameters.wheel_radius]
    value = 0.46
    unit = "m"
    [parameters.car_length]
    value = 14.0
    unit = "m"

    [[bodies]]
    name = "carbody"
    dofs = ["z", "theta"]
    mass = "body_mass"
    inertia = "body_pitch_inertia"
    position = "axle_spacing / 2"

    [[bodies]]
    name = "axle_1"
    dofs = ["z"]
    mass = "wheelset_mass"
    position = "0"

    [[bodies]]
    name = "axle_2"
    dofs = ["z"]
    mass = "wheelset_mass"
    position = "axle_spacing"

    [[suspensions]]
    name = "front"
    body_a = "carbody"
    offset_a = "-axle_spacing / 2"
    body_b = "axle_1"
    stiffness = "k"
    damping = "c"

    [[suspensions]]
    name = "rear"
    body_a = "carbody"
    offset_a = "axle_spacing / 2"
    body_b = "axle_2"
    stiffness = "k"
    damping = "c"

    [[wheels]]
    name = "wheel_1"
    body = "axle_1"
    position = "0"
    radius = "wheel_radius"

    [[wheels]]
    name = "wheel_2"
    body = "axle_2"
    position = "axle_spacing"
    radius = "wheel_radius"
    """
)


def test_user_topology_end_to_end(tmp_path: Path, emit_cache: Path) -> None:
    """Topology file -> derive -> generate -> compile -> load -> evaluate, against closed forms."""
    path = tmp_path / "wagon.toml"
    path.write_text(WAGON, encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        kernels = kernel_cache.load_kernels(path, "c", cache_dir=emit_cache)
    assert kernels.backend == "c" and kernels.name == "two-axle-wagon"
    assert kernels.sizes == {"n_dofs": 4, "n_wheels": 2}
    values = dict(zip(kernels.parameters, kernels.defaults, strict=True))
    m, j, mw, k, c, s = (
        values[n] for n in ("body_mass", "body_pitch_inertia", "wheelset_mass", "k", "c", "axle_spacing")
    )
    # Hand-written closed forms for DOFs [z, theta, z_axle_1, z_axle_2]; pitch positive nose up, so
    # the front spring (half a spacing ahead of the body centre) stretches by z + s/2 theta - z_1.
    a = s / 2
    stiffness = k * np.array([[2, 0, -1, -1], [0, 2 * a * a, -a, a], [-1, -a, 1, 0], [-1, a, 0, 1]])
    np.testing.assert_allclose(kernels.mass_matrix(kernels.defaults), np.diag([m, j, mw, mw]), rtol=1e-15)
    np.testing.assert_allclose(kernels.stiffness_matrix(kernels.defaults), stiffness, rtol=1e-14)
    np.testing.assert_allclose(kernels.damping_matrix(kernels.defaults), stiffness * c / k, rtol=1e-14)
    np.testing.assert_allclose(
        kernels.gravity_load(kernels.defaults).ravel(), -9.81 * np.array([m, 0, mw, mw]), rtol=1e-15
    )
    w_n, w_t = kernels.contact_directions(kernels.defaults)
    np.testing.assert_array_equal(w_n, [[0, 0], [0, 0], [1, 0], [0, 1]])
    np.testing.assert_array_equal(w_t, np.zeros((4, 2)))  # axles without a spin DOF
    casadi_kernels = kernel_cache.load_kernels(path, "casadi", cache_dir=emit_cache)
    p = kernels.parameter_vector({"k": 2.0e6})
    np.testing.assert_allclose(kernels.stiffness_matrix(p), casadi_kernels.stiffness_matrix(p), rtol=1e-15)

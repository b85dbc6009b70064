"""SymPy -> CasADi conversion on toy kernels written here, then through C.

Every mapped SymPy node type is exercised against SymPy's own 30-digit evaluation; unmapped nodes
and malformed specs fail with messages that name the problem.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from svbi.codegen.casadi_emit import SympyToCasadi, UnsupportedExpression, build_function, load_function
from svbi.codegen.kernels import KernelError, KernelSpec, ModelSpec
from svbi.runtime import toolchain as kernel_cache

x, y = sp.symbols("x y", real=True)
p = sp.Symbol("p", positive=True)

# Every construct the emitter maps, each in its own output entry so a wrong mapping is pinpointed.
TOY_EXPRESSIONS = {
    "poly": 3 * x**2 - x * y / 7 + sp.Rational(1, 3) * y - sp.Rational(5, 4),
    "int_powers": x**5 - (y**2 + 1) ** -3 + p**70 - 1 / x**2,
    "half_powers": sp.sqrt(p) + p ** sp.Rational(3, 2) + 1 / sp.sqrt(p) + p ** sp.Rational(-5, 2),
    "real_power": p**0.37 + p ** sp.Rational(1, 3),
    "symbolic_power": p**x,
    "trig": sp.sin(x) * sp.cos(y) + sp.tan(x / 3) + sp.atan(y) + sp.atan2(y, x),
    "inverse_trig": sp.asin(x / 4) + sp.acos(y / 4),
    "hyperbolic": sp.sinh(x) + sp.cosh(y) + sp.tanh(x * y) + sp.asinh(x) + sp.acosh(p + 1) + sp.atanh(y / 4),
    "exp_log": sp.exp(x / 2) * sp.log(p) - sp.exp(-(y**2)),
    "abs_sign": sp.Abs(x - y) * sp.sign(y) + sp.floor(x) + sp.ceiling(y),
    "min_max": sp.Min(x, y, p) + sp.Max(x, y, 2 * p) + sp.Min(x, 1),
    "piecewise": sp.Piecewise(
        (x**2, x < -1), (y, sp.And(x >= -1, y > 0)), (-p, sp.Or(x > 2, sp.Eq(y, 0))), (0, True)
    ),
    "heaviside": sp.Heaviside(x) * y + sp.Heaviside(y, 1) * x,
    "constants": sp.pi * x + sp.E * y + sp.Float("0.1", 30),
    "erf": sp.erf(x / 2),
}


def toy_spec() -> KernelSpec:
    names = list(TOY_EXPRESSIONS)
    column = sp.Matrix([TOY_EXPRESSIONS[n] for n in names])
    matrix = sp.Matrix([[x * p, 0, 0], [0, 0, sp.sin(y)], [0, 0, 0]])  # 2 structural nonzeros
    return KernelSpec(
        "toy",
        "Every mapped SymPy construct.",
        [("state", sp.Matrix([x, y])), ("param", sp.Matrix([p]))],
        [("values", column), ("sparse", matrix)],
        sample={"x": 0.3, "y": -0.7, "p": 1.7},
    )


def sympy_values(spec: KernelSpec, inputs: list[np.ndarray]) -> list[np.ndarray]:
    flat = np.concatenate(inputs)
    subs = {s: sp.Float(float(v), 30) for s, v in zip(spec.input_symbols, flat, strict=True)}
    return [
        np.array(m.xreplace(subs).evalf(30).tolist(), dtype=float).reshape(m.shape) for _, m in spec.outputs
    ]


@pytest.fixture(scope="module")
def toy_kernels(tmp_path_factory: pytest.TempPathFactory) -> tuple:
    spec = toy_spec()
    model = ModelSpec("toy-model", "Toy model for the emitter tests.", [spec], [("p", 1.7)], {"n_dofs": 2})
    cache = tmp_path_factory.mktemp("toy-cache")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        c_kernels = kernel_cache.load_kernels(model, "c", cache_dir=cache)
    return spec, c_kernels, kernel_cache.load_kernels(model, "casadi", cache_dir=cache)


def _check(spec: KernelSpec, outputs: list[np.ndarray], inputs: list[np.ndarray], what: str) -> None:
    names = list(TOY_EXPRESSIONS)
    for (out_name, _), got, expected in zip(spec.outputs, outputs, sympy_values(spec, inputs), strict=True):
        for index in np.ndindex(expected.shape):
            label = names[index[0]] if out_name == "values" else f"sparse{index}"
            e, g = expected[index], got[index]
            if math.isnan(e):
                assert math.isnan(g), f"{what} {label}"
            else:
                assert g == pytest.approx(e, rel=1e-12, abs=1e-14), f"{what} {label}"


@settings(max_examples=40, deadline=None)
@given(
    xv=st.floats(-3.0, 3.0).filter(lambda v: abs(v) > 1e-3),
    yv=st.floats(-3.5, 3.5).filter(lambda v: abs(v) > 1e-3),
    pv=st.floats(0.1, 5.0),
)
def test_every_construct_c_casadi_sympy(toy_kernels: tuple, xv: float, yv: float, pv: float) -> None:
    spec, c_kernels, ca_kernels = toy_kernels
    inputs = [np.array([xv, yv]), np.array([pv])]
    _check(spec, list(ca_kernels.toy(*inputs)), inputs, "CasADi")
    _check(spec, list(c_kernels.toy(*inputs)), inputs, "C")


def test_branch_points(toy_kernels: tuple) -> None:
    """Relational edges (x = -1, x = 2, y = 0) take the same branch as SymPy."""
    spec, c_kernels, ca_kernels = toy_kernels
    for xv, yv in [(-1.0, 0.5), (-1.0, 0.0), (1.0, 0.0), (2.0, 1.0), (2.5, 0.0), (3.0, -1.0)]:
        inputs = [np.array([xv, yv]), np.array([1.3])]
        _check(spec, list(c_kernels.toy(*inputs)), inputs, f"C at x={xv}, y={yv}")
        _check(spec, list(ca_kernels.toy(*inputs)), inputs, f"CasADi at x={xv}, y={yv}")


def test_structural_zeros_and_sparsity() -> None:
    fn = build_function(toy_spec())
    assert fn.sparsity_out(1).nnz() == 2
    assert fn.sparsity_out(1).get_triplet() == ([0, 1], [0, 2])
    assert fn.name_in() == ["state", "param"] and fn.name_out() == ["values", "sparse"]


def test_all_zero_output_is_empty() -> None:
    spec = KernelSpec("z", "", [("state", sp.Matrix([x]))], [("zero", sp.zeros(2, 3))])
    fn = build_function(spec)
    assert fn.sparsity_out(0).nnz() == 0 and fn.size_out(0) == (2, 3)


def test_memoised_walk_shares_subexpressions() -> None:
    """A repeated SymPy subtree is converted once and is one node in the CasADi graph."""
    symbols = {x: ca.SX.sym("x"), y: ca.SX.sym("y")}
    convert = SympyToCasadi(symbols)
    shared = sp.sin(x * y + 1)
    first = convert(shared)
    assert convert(shared) is first
    expr = convert(shared**2 + 3 * shared + sp.cos(shared))
    f = ca.Function("f", [symbols[x], symbols[y]], [expr])
    assert sum(1 for i in range(f.n_instructions()) if f.instruction_id(i) == ca.OP_SIN) == 1


def test_integer_powers_are_multiplications() -> None:
    symbols = {x: ca.SX.sym("x")}
    f = ca.Function("f", [symbols[x]], [SympyToCasadi(symbols)(x**6)])
    ops = {f.instruction_id(i) for i in range(f.n_instructions())}
    assert ca.OP_POW not in ops and ca.OP_CONSTPOW not in ops
    assert float(f(1.1)) == pytest.approx(1.1**6, rel=1e-15)


def test_unsupported_node_names_its_type() -> None:
    spec = KernelSpec("bad", "", [("state", sp.Matrix([x]))], [("out", sp.Matrix([sp.gamma(x)]))])
    with pytest.raises(UnsupportedExpression, match="'gamma'"):
        build_function(spec)
    spec = KernelSpec("bad", "", [("state", sp.Matrix([x]))], [("out", sp.Matrix([sp.I * x]))])
    with pytest.raises(UnsupportedExpression, match="complex|ImaginaryUnit"):
        build_function(spec)


@pytest.mark.parametrize(
    ("inputs", "outputs", "message"),
    [
        ([("state", sp.Matrix([x]))], [("out", sp.Matrix([x * y]))], r"not inputs: \['y'\]"),
        ([("state", sp.Matrix([x, x + 1]))], [("out", sp.Matrix([x]))], "not a plain Symbol"),
        ([("a", sp.Matrix([x])), ("b", sp.Matrix([x]))], [("out", sp.Matrix([x]))], "appears in input"),
        ([("state", sp.Matrix([[x, y]]))], [("out", sp.Matrix([x]))], "must be a non-empty column"),
        ([("state", sp.Matrix([x]))], [("state", sp.Matrix([x]))], "unique"),
        ([("bad-name", sp.Matrix([x]))], [("out", sp.Matrix([x]))], "C identifier"),
    ],
)
def test_malformed_specs(inputs: list, outputs: list, message: str) -> None:
    with pytest.raises(KernelError, match=message):
        KernelSpec("k", "", inputs, outputs)


def test_casadi_file_round_trip(tmp_path: Path) -> None:
    from svbi.codegen.casadi_emit import save_model

    model = ModelSpec("toy-model", "", [toy_spec()])
    (path,) = save_model(model, tmp_path)
    assert path.name == "toy.casadi"
    f = load_function(path)
    assert f.name() == "svbi_toy_model_toy"
    np.testing.assert_array_equal(
        np.array(f(np.array([0.3, -0.7]), 1.7)[1].full()),
        np.array(build_function(toy_spec(), "toy-model")(np.array([0.3, -0.7]), 1.7)[1].full()),
    )


def test_edge_values_match_sympy() -> None:
    """Heaviside at 0 (default 1/2) and a Piecewise with no matching branch (nan), as in SymPy."""
    exprs = [sp.Heaviside(x), sp.Piecewise((1, x > 0)), sp.sign(x), sp.Min(x, 0) + sp.Max(x, 0)]
    spec = KernelSpec("edge", "", [("state", sp.Matrix([x]))], [("out", sp.Matrix(exprs))])
    got = np.array(build_function(spec)(0.0).full()).ravel()
    expected = [sp.Heaviside(0), sp.nan, sp.sign(0), 0]
    assert got[0] == float(expected[0]) == 0.5
    assert math.isnan(got[1])
    assert got[2] == 0.0 and got[3] == 0.0

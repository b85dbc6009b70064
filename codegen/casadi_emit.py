"""SymPy -> CasADi: kernels become ``casadi.Function`` objects and ``.casadi`` files.

The conversion is an explicit, memoised walk of the SymPy expression tree (a dict keyed by the
SymPy node, so a shared subexpression is converted once and stays shared in the CasADi graph).
Nothing goes through ``lambdify`` or string printing: every SymPy node type that the models use
maps to one CasADi operation, and anything else raises :class:`UnsupportedExpression` naming the
node type. Exact zeros of an output matrix stay *structural* zeros (CasADi sparsity), so the
generated C neither stores nor computes them.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping
from pathlib import Path

import casadi as ca
import sympy as sp

from svbi.codegen.kernels import KernelSpec, ModelSpec

FUNCTION_OPTIONS = {"cse": True}
"""Options of every generated ``casadi.Function``: common subexpressions are shared."""

MAX_UNROLLED_POWER = 64
"""Integer powers up to this exponent are emitted as multiplications (exact and fast)."""


class UnsupportedExpression(TypeError):
    """A SymPy node has no CasADi counterpart in this emitter."""


def _fold(op: Callable[[ca.SX, ca.SX], ca.SX], items: list[ca.SX]) -> ca.SX:
    acc = items[0]
    for item in items[1:]:
        acc = op(acc, item)
    return acc


def _int_power(base: ca.SX, n: int) -> ca.SX:
    """``base**n`` for n >= 1 by binary exponentiation (multiplications only)."""
    result = None
    square = base
    while n:
        if n & 1:
            result = square if result is None else result * square
        n >>= 1
        if n:
            square = square * square
    return result


_UNARY: dict[type, Callable[[ca.SX], ca.SX]] = {
    sp.sin: ca.sin,
    sp.cos: ca.cos,
    sp.tan: ca.tan,
    sp.asin: ca.asin,
    sp.acos: ca.acos,
    sp.atan: ca.atan,
    sp.sinh: ca.sinh,
    sp.cosh: ca.cosh,
    sp.tanh: ca.tanh,
    sp.asinh: ca.asinh,
    sp.acosh: ca.acosh,
    sp.atanh: ca.atanh,
    sp.exp: ca.exp,
    sp.Abs: ca.fabs,
    sp.sign: ca.sign,
    sp.floor: ca.floor,
    sp.ceiling: ca.ceil,
    sp.erf: ca.erf,
}

_RELATIONAL: dict[type, Callable[[ca.SX, ca.SX], ca.SX]] = {
    sp.StrictLessThan: lambda a, b: a < b,
    sp.LessThan: lambda a, b: a <= b,
    sp.StrictGreaterThan: lambda a, b: a > b,
    sp.GreaterThan: lambda a, b: a >= b,
    sp.Equality: lambda a, b: a == b,
    sp.Unequality: lambda a, b: a != b,
}


class SympyToCasadi:
    """Memoised converter from SymPy expressions to CasADi ``SX`` for a fixed symbol map."""

    def __init__(self, symbols: Mapping[sp.Symbol, ca.SX]) -> None:
        self._symbols = dict(symbols)
        self._memo: dict[sp.Basic, ca.SX] = {}

    def __call__(self, expr: sp.Basic) -> ca.SX:
        expr = sp.sympify(expr)
        cached = self._memo.get(expr)
        if cached is None:
            cached = self._convert(expr)
            self._memo[expr] = cached
        return cached

    def matrix(self, mat: sp.MatrixBase) -> ca.SX:
        """A SymPy matrix as an ``SX`` matrix whose sparsity omits the exact zeros."""
        rows: list[int] = []
        cols: list[int] = []
        values: list[ca.SX] = []
        for j in range(mat.cols):  # column-major: CasADi's compressed-column order
            for i in range(mat.rows):
                entry = mat[i, j]
                if entry == 0:
                    continue
                rows.append(i)
                cols.append(j)
                values.append(self(entry))
        sparsity = ca.Sparsity.triplet(mat.rows, mat.cols, rows, cols)
        if not values:
            return ca.SX(sparsity)
        return ca.SX(sparsity, ca.vertcat(*values))

    def _convert(self, expr: sp.Basic) -> ca.SX:
        if isinstance(expr, sp.Symbol):
            try:
                return self._symbols[expr]
            except KeyError:
                raise UnsupportedExpression(
                    f"free symbol {expr.name!r} is not among the kernel inputs"
                ) from None
        if expr.is_Number or isinstance(expr, sp.NumberSymbol):
            if expr.is_extended_real is False:
                raise UnsupportedExpression(f"complex number {expr} ({type(expr).__name__})")
            return ca.SX(float(expr))
        if expr is sp.true:
            return ca.SX(1.0)
        if expr is sp.false:
            return ca.SX(0.0)
        kind = type(expr)
        if isinstance(expr, sp.Add):
            return _fold(lambda a, b: a + b, [self(a) for a in expr.args])
        if isinstance(expr, sp.Mul):
            return self._mul(expr)
        if isinstance(expr, sp.Pow):
            return self._pow(expr.base, expr.exp)
        if kind in _UNARY:
            return _UNARY[kind](self(expr.args[0]))
        if kind is sp.log:
            return ca.log(self(expr.args[0]))
        if kind is sp.atan2:
            return ca.atan2(self(expr.args[0]), self(expr.args[1]))
        if kind is sp.Min:
            return _fold(ca.fmin, [self(a) for a in expr.args])
        if kind is sp.Max:
            return _fold(ca.fmax, [self(a) for a in expr.args])
        if kind is sp.Heaviside:
            x = self(expr.args[0])
            at_zero = self(expr.args[1]) if len(expr.args) > 1 else ca.SX(0.5)
            return ca.if_else(x > 0, 1.0, ca.if_else(x == 0, at_zero, 0.0))
        if kind is sp.Piecewise:
            return self._piecewise(expr)
        if kind in _RELATIONAL:
            return _RELATIONAL[kind](self(expr.lhs), self(expr.rhs))
        if kind is sp.And:
            return _fold(ca.logic_and, [self(a) for a in expr.args])
        if kind is sp.Or:
            return _fold(ca.logic_or, [self(a) for a in expr.args])
        if kind is sp.Not:
            return ca.logic_not(self(expr.args[0]))
        raise UnsupportedExpression(
            f"SymPy node type {kind.__name__!r} has no CasADi mapping (in expression {sp.sstr(expr)[:120]})"
        )

    def _mul(self, expr: sp.Mul) -> ca.SX:
        # a / b is Mul(a, Pow(b, -1)) in SymPy: emit one division instead of a reciprocal and a
        # product, which is both cheaper and better rounded.
        num: list[ca.SX] = []
        den: list[ca.SX] = []
        sign = 1
        for factor in expr.args:
            if factor == -1:
                sign = -sign
            elif isinstance(factor, sp.Pow) and factor.exp.is_Number and factor.exp.is_negative:
                den.append(self._pow(factor.base, -factor.exp))
            elif (
                isinstance(factor, sp.Rational) and not isinstance(factor, sp.Integer) and factor.p in (1, -1)
            ):
                # Rational(1, q) * x is emitted as x / q: exact for q a power of two, and the
                # correctly rounded quotient otherwise.
                if factor.p < 0:
                    sign = -sign
                den.append(ca.SX(float(factor.q)))
            else:
                num.append(self(factor))
        result = _fold(lambda a, b: a * b, num) if num else ca.SX(1.0)
        if den:
            result = result / _fold(lambda a, b: a * b, den)
        return -result if sign < 0 else result

    def _pow(self, base: sp.Basic, exponent: sp.Basic) -> ca.SX:
        if base.is_Number and exponent.is_Number:
            # A constant such as 2**(1/3): SymPy rounds it correctly, pow() might not.
            value = sp.Pow(base, exponent).evalf(30)
            if value.is_extended_real is False:
                raise UnsupportedExpression(f"complex constant {base}**{exponent}")
            return ca.SX(float(value))
        b = self(base)
        if exponent.is_Integer:
            n = int(exponent)
            if n == 0:
                return ca.SX(1.0)
            if abs(n) <= MAX_UNROLLED_POWER:
                p = _int_power(b, abs(n))
            else:
                p = ca.constpow(b, float(abs(n)))
            return 1.0 / p if n < 0 else p
        if exponent.is_Rational and exponent.q == 2:
            # Half-integer powers: sqrt(b) times an integer power.
            root = ca.sqrt(b)
            n = abs(exponent.p)
            p = root if n == 1 else _int_power(b, n // 2) * root
            return 1.0 / p if exponent.p < 0 else p
        if exponent.is_Number:
            return ca.constpow(b, float(exponent))
        return ca.power(b, self(exponent))

    def _piecewise(self, expr: sp.Piecewise) -> ca.SX:
        # SymPy evaluates to nan when no condition holds; so does the emitted code.
        result: ca.SX = ca.SX(math.nan)
        for value, cond in reversed(expr.args):
            if cond is sp.true:
                result = self(value)
            else:
                result = ca.if_else(self(cond), self(value), result)
        return result


def casadi_name(model: str | None, kernel: str) -> str:
    """Name of the Function (and of its C symbol): ``svbi_<model>_<kernel>``."""
    from svbi.codegen.kernels import c_identifier

    return f"svbi_{c_identifier(model)}_{kernel}" if model else kernel


def build_function(spec: KernelSpec, model: str | None = None) -> ca.Function:
    """The ``casadi.Function`` of a kernel: named inputs and outputs, ``cse`` on."""
    sx_inputs = []
    symbols: dict[sp.Symbol, ca.SX] = {}
    for _, column in spec.inputs:
        elements = [ca.SX.sym(s.name) for s in column]
        symbols.update(zip(column, elements, strict=True))
        sx_inputs.append(ca.vertcat(*elements))
    convert = SympyToCasadi(symbols)
    sx_outputs = [convert.matrix(m) for _, m in spec.outputs]
    return ca.Function(
        casadi_name(model, spec.name),
        sx_inputs,
        sx_outputs,
        [n for n, _ in spec.inputs],
        [n for n, _ in spec.outputs],
        dict(FUNCTION_OPTIONS),
    )


def build_functions(model: ModelSpec) -> list[ca.Function]:
    return [build_function(k, model.name) for k in model.kernels]


def serialize(function: ca.Function) -> bytes:
    """The serialized Function (what ``Function.save`` writes), as bytes."""
    return function.serialize().encode("ascii")


def casadi_files(model: ModelSpec, functions: list[ca.Function] | None = None) -> dict[str, bytes]:
    """``{"<kernel>.casadi": bytes}`` for every kernel of a model."""
    functions = functions if functions is not None else build_functions(model)
    return {f"{k.name}.casadi": serialize(f) for k, f in zip(model.kernels, functions, strict=True)}


def save_model(model: ModelSpec, out_dir: str | os.PathLike[str]) -> list[Path]:
    """Write ``<out_dir>/<kernel>.casadi`` for every kernel; returns the paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, data in casadi_files(model).items():
        path = out / name
        path.write_bytes(data)
        paths.append(path)
    return paths


def load_function(path: str | os.PathLike[str]) -> ca.Function:
    """Read a ``.casadi`` file written by :func:`save_model`."""
    return ca.Function.deserialize(Path(path).read_text(encoding="ascii"))

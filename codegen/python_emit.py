"""Python emitter: every kernel of a model as a plain NumPy function, in one module per model.

The runtime of the NumPy backend (and the set-up of the C backend) evaluates these modules instead
of deriving the model again: a run imports neither SymPy nor CasADi (SymForce's Python backend
pattern). One model becomes ``<model>/numpy_kernels.py``::

    MODEL, INPUTS_SHA256, DATA          plain data: names, defaults, sizes (no SymPy objects)
    def <kernel>(<inputs>): ...         one function per KernelSpec, common subexpressions shared

Calling convention, from the :class:`~svbi.codegen.kernels.KernelSpec`: the arguments are the
spec's inputs in ABI order; a one-symbol input is a scalar (or a NumPy array, broadcast), a longer
one a sequence that the function unpacks. Each output is returned as a scalar expression when it is
1x1, as a 1-D array when it is a row or a column, else as a 2-D array of its shape; several outputs
come back as a tuple in spec order.

Determinism: the module depends only on the spec, the extra data and the SymPy version; it starts
with a banner naming this module and the sha256 of those inputs, no timestamps.
"""

from __future__ import annotations

import hashlib
import keyword
from collections.abc import Mapping
from typing import Any

import sympy as sp
from sympy.printing.numpy import NumPyPrinter

from svbi.codegen.kernels import KernelSpec, ModelSpec
from svbi.codegen.plain_types import PYTHON_KERNELS_FILE

GENERATOR = "svbi.codegen.python_emit"
FILENAME = PYTHON_KERNELS_FILE
_RESERVED = {"numpy", "math", "DATA", "MODEL", "INPUTS_SHA256"}


class _Printer(NumPyPrinter):
    """NumPy printer that spells every input symbol by its local (argument) name."""

    def __init__(self, names: Mapping[sp.Symbol, str]) -> None:
        super().__init__({"fully_qualified_modules": True, "allow_unknown_functions": False})
        self._names = dict(names)

    def _print_Symbol(self, expr: sp.Symbol) -> str:  # noqa: N802 - SymPy's printer protocol
        return self._names.get(expr, expr.name)


def _safe(name: str, taken: set[str]) -> bool:
    return (
        name.isidentifier() and not keyword.iskeyword(name) and name not in taken and not name.startswith("_")
    )


def function_source(spec: KernelSpec, complex_safe: bool = False) -> str:
    """Python source of one kernel (see the module docstring for the calling convention).

    ``complex_safe``: arrays take the type of their entries (``float64`` for real inputs,
    ``complex128`` for complex ones, so the function works on the complex step) instead of being
    cast to ``float64``; an array of constants only stays ``float64``."""
    taken = set(_RESERVED) | {n for n, _ in spec.inputs}
    names: dict[sp.Symbol, str] = {}
    args: list[str] = []
    unpack: list[str] = []
    for arg, column in spec.inputs:
        args.append(arg)
        symbols = list(column)
        if len(symbols) == 1:
            names[symbols[0]] = arg
            continue
        local = []
        for k, s in enumerate(symbols):
            candidate = s.name if _safe(s.name, taken) else f"{arg}_{k}"
            taken.add(candidate)
            names[s] = candidate
            local.append(candidate)
        unpack.append(f"    {', '.join(local)} = {arg}")
    entries: list[sp.Expr] = []
    for _, m in spec.outputs:
        entries += [e for e in m if e != 0]
    replacements, reduced = sp.cse(entries, symbols=sp.numbered_symbols("_t"), order="canonical")
    printer = _Printer(names)
    lines = [f"def {spec.name}({', '.join(args)}):", f'    """{_docstring(spec)}"""']
    lines += unpack
    for sym, expr in replacements:
        lines.append(f"    {sym.name} = {printer.doprint(expr)}")
    values = iter(reduced)
    results = []
    for _, m in spec.outputs:
        printed = [printer.doprint(next(values)) if e != 0 else "0.0" for e in m]
        results.append(_shaped(printed, m.shape, complex_safe and bool(m.free_symbols)))
    if len(results) == 1:
        lines.append(f"    return {results[0]}")
    else:
        lines.append("    return (")
        lines += [f"        {r}," for r in results]
        lines.append("    )")
    return "\n".join(lines) + "\n"


def _docstring(spec: KernelSpec) -> str:
    ins = ", ".join(f"{n}[{m.rows}]" if m.rows > 1 else n for n, m in spec.inputs)
    outs = ", ".join(f"{n} {m.rows}x{m.cols}" for n, m in spec.outputs)
    return f"{spec.doc} ({ins}) -> {outs}".replace('"""', "'''").replace("\\", "\\\\")


def _shaped(printed: list[str], shape: tuple[int, int], inferred: bool = False) -> str:
    rows, cols = shape
    dtype = "" if inferred else ", dtype=numpy.float64"
    if rows * cols == 0:
        return f"numpy.zeros(({rows}, {cols}))"
    if rows == 1 and cols == 1:
        return printed[0]
    if rows == 1 or cols == 1:
        return f"numpy.array([{', '.join(printed)}]{dtype})"
    body = ", ".join("[" + ", ".join(printed[r * cols : (r + 1) * cols]) + "]" for r in range(rows))
    return f"numpy.array([{body}]{dtype})"


def input_hash(model: ModelSpec, data: Mapping[str, Any], complex_safe: bool = False) -> str:
    """sha256 of the spec text, the plain data, the generator, the SymPy version and the
    ``complex_safe`` option."""
    h = hashlib.sha256()
    for text in (f"sympy {sp.__version__}", GENERATOR, repr(sorted(data.items()))):
        h.update(text.encode() + b"\n")
    if complex_safe:
        h.update(b"complex_safe\n")
    h.update(model.fingerprint_text().encode())
    return h.hexdigest()


def render_module(
    model: ModelSpec, data: Mapping[str, Any] | None = None, complex_safe: bool = False
) -> bytes:
    """The generated module of ``model``: plain ``data`` (a dict of Python literals) plus one
    function per kernel (``complex_safe``: see :func:`function_source`)."""
    data = dict(data or {})
    digest = input_hash(model, data, complex_safe)
    head = [
        f"# Generated by {GENERATOR} from the kernel specs of model {model.name!r}",
        f"# (inputs sha256 {digest}, SymPy {sp.__version__}).",
        "# Do not edit: regenerate with `svbi generate --all` (or `make generate`).",
        f'"""{model.doc}"""'.replace("\\", "\\\\"),
        "",
        "import numpy",
        "",
        f"MODEL = {model.name!r}",
        f"INPUTS_SHA256 = {digest!r}",
        "DATA = {",
    ]
    head += [f"    {k!r}: {v!r}," for k, v in data.items()]
    head += ["}", f"KERNELS = {tuple(k.name for k in model.kernels)!r}"]
    parts = ["\n".join(head) + "\n"]
    parts += [function_source(k, complex_safe) for k in model.kernels]
    return ("\n\n".join(parts)).encode()


# ---------------------------------------------------------------------------------------------
# models


def topology_data(topology: Any) -> dict[str, Any]:
    """Plain data of a topology: what parameter validation and the runtime need without SymPy."""
    bodies = list(topology.bodies)
    carbody = bodies[0] if bodies else None

    def dof(body: Any, name: str) -> int | None:
        index = 0
        for b in bodies:
            for d in b.dofs:
                if b is body and d == name:
                    return index
                index += 1
        return None

    return {
        "name": topology.name,
        "kind": topology.kind,
        "description": topology.description,
        "parameters": tuple(
            (p.name, p.value, p.unit, p.description, p.assumed, p.signed)
            for p in topology.parameters.values()
        ),
        "parameter_vector": tuple(s.name for s in topology.symbols),
        "body_names": tuple(b.name for b in bodies),
        "wheel_names": tuple(w.name for w in topology.wheels),
        "carbody_z": dof(carbody, "z") if carbody else None,
        "carbody_theta": dof(carbody, "theta") if carbody else None,
    }


def render_target(target: str) -> tuple[str, bytes]:
    """The generated module of a built-in model name (``frame2d``, ``frame3d`` or a vehicle) or a
    topology file: ``(model name, module source)``. A moving-load vehicle has no kernels, only its
    data."""
    from svbi.codegen import contact3d_kernels, frame3d, kernels
    from svbi.codegen.topology import load_topology
    from svbi.codegen.vehicle import derive_vehicle

    if target == kernels.FRAME2D:
        return target, render_module(kernels.frame2d_model_spec(), frame2d_data())
    if target == frame3d.FRAME3D:
        return target, render_module(frame3d.frame3d_model_spec(), frame3d_data())
    if target == contact3d_kernels.CONTACT3D:
        spec = contact3d_kernels.contact3d_model_spec()
        return target, render_module(spec, contact3d_kernels.contact3d_data(), complex_safe=True)
    topology = load_topology(target)
    if kernels.skip_reason(target) is not None:
        spec = ModelSpec(topology.name, f"Vehicle model {topology.name}: {topology.description}", [])
        return topology.name, render_module(spec, topology_data(topology))
    return topology.name, render_vehicle(derive_vehicle(topology))


def render_vehicle(model: Any, spec: ModelSpec | None = None) -> bytes:
    """The generated module of a derived vehicle model (``VehicleModel``); ``spec`` is its
    ``vehicle_model_spec`` when the caller has it already."""
    from svbi.codegen import kernels

    spec = spec or kernels.vehicle_model_spec(model)
    data = topology_data(model.topology)
    data["dof_names"] = tuple(q.name for q in model.dofs)
    data["roles"] = tuple(
        (key, check, message, tuple(sorted(str(s) for s in e.free_symbols)))
        for key, check, message, e in kernels.vehicle_roles(model.topology)
    )
    kernel_list = [*spec.kernels, kernels.vehicle_role_spec(model)]
    return render_module(ModelSpec(spec.name, spec.doc, kernel_list, spec.parameters, spec.sizes), data)


def frame3d_data() -> dict[str, Any]:
    """Plain data of the 3D element: its DOF names and the default Poisson's ratio."""
    from svbi.codegen import frame3d

    return {"dof_names": frame3d.DOF_NAMES, "poisson_default": frame3d.POISSON_DEFAULT}


def frame2d_data() -> dict[str, Any]:
    """Structure of the bridge tables: degree and structurally non-zero columns of every block."""
    from svbi.codegen import creep, kernels

    spec = kernels.frame2d_model_spec()
    nonzero = {}
    for name in ("shape_coefficients", "bridge_row_coefficients"):
        for out, m in spec.kernel(name).outputs:
            if m.rows > 1:
                nonzero[out] = tuple(any(m[r, c] != 0 for r in range(m.rows)) for c in range(m.cols))
    return {
        "xi_degree": kernels.XI_DEGREE,
        "bridge_history": kernels.BRIDGE_HISTORY,
        "nonzero_columns": nonzero,
        "creep_split_count": spec.kernel("creep_split_coefficients").outputs[0][1].rows,
        "creep_parameters": tuple(s.name for s in creep.PARAMETERS),
    }

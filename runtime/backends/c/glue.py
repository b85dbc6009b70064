"""The generated glue of the C time loop: thin headers rendered at generation time.

The loop itself is static C in ``runtime/csrc/`` (docs/c-backend.md). What depends on the symbolic
pipeline or on a vehicle topology is rendered here, by ``svbi generate`` (Jinja2 templates in
``templates/solver/``, the creep law through the CasADi emitter), and committed under
``generated/`` for the built-in models:

* ``generated/solver/svbi_solver_types.h``: the structs and status codes, from the field lists of
  :mod:`svbi.runtime.backends.c.build` (which also build the ctypes mirrors: one definition);
* ``generated/frame2d/svbi_contact_rows.h``: the contact-row table of the bridge element (degree,
  columns, structural non-zeros, the unrolled evaluation) from ``c_solver_build.row_structure``;
  ``generated/frame2d/creep_split*``: the creep law split into per-run coefficients and a per-step
  force (``svbi.codegen.creep.split_creep_force``), C from the CasADi emitter;
* ``generated/<model>/svbi_topology.h``: the sizes of one vehicle topology (``moving-load`` too).

At run time a built-in model reads these files (no Jinja2, no CasADi); a topology file has its
``svbi_topology.h`` rendered here when its loop is first built. This module imports Jinja2, SymPy
and CasADi: only generation and exports use it.
"""

from __future__ import annotations

from functools import cache
from typing import Any

import jinja2
import sympy as sp

from . import build as c_solver_build
from .build import (
    BRIDGE_FOLDER,
    CREEP_FILES,
    GLUE_NAMES,
    MOVING_LOAD_FOLDER,
    ROWS_HEADER,
    SOLVER_FOLDER,
    TOPOLOGY_HEADER,
    TYPES_HEADER,
)

GENERATOR = "svbi.runtime.backends.c.glue"
__all__ = [
    "BRIDGE_FOLDER",
    "CREEP_FILES",
    "GLUE_NAMES",
    "MOVING_LOAD_FOLDER",
    "ROWS_HEADER",
    "SOLVER_FOLDER",
    "TOPOLOGY_HEADER",
    "TYPES_HEADER",
    "bridge_glue",
    "contact_rows",
    "creep_split_sources",
    "environment",
    "model_glue",
    "solver_types",
    "topology",
]


@cache
def row_expressions() -> tuple[sp.Expr, ...]:
    """The contact-row columns of the C table, in ``ROW_BLOCKS`` then ``ROW_SCALARS`` order.

    The symbolic rows behind the generated tables of :func:`row_coefficients` (SymPy; for tests and
    derivations, not for a run): ``W_N^B`` and the discrete aux-bridge row of
    ``svbi.codegen.constraints`` split into ``W_hat`` and the coefficients of ``h_B`` in the
    histories and the irregularity (``svbi.codegen.kernels.discrete_bridge_row_parts``).
    """
    from svbi.codegen import beam
    from svbi.codegen.kernels import BRIDGE_HISTORY, discrete_bridge_row_parts

    _, w_hat, coefs = discrete_bridge_row_parts()
    exprs: list[sp.Expr] = list(beam.normal_row(0)) + list(w_hat) + coefs["P_ue"] + coefs["Q_ue"]
    exprs += list(beam.tangential_row(0)) + list(beam.tangential_row(1))
    exprs += [coefs[k][0] for k in BRIDGE_HISTORY]
    return tuple(exprs)


@cache
def row_powers() -> tuple[tuple[int, ...], ...]:
    """For every column of the row table, the powers of xi whose coefficient is structurally
    non-zero (an empty tuple for a zero column): the rest of the table is exactly 0 for every
    parameter value, so the generated evaluation leaves it out (the same sums)."""
    from svbi.codegen import beam

    out = []
    for e in row_expressions():
        value = sp.expand(e)
        if value == 0:
            out.append(())
            continue
        coeffs = sp.Poly(value, beam.xi).all_coeffs()[::-1]
        out.append(tuple(p for p, c in enumerate(coeffs) if sp.expand(c) != 0))
    return tuple(out)


def environment() -> jinja2.Environment:
    """The Jinja2 environment of the templates in ``templates/`` (strict, no autoescape)."""
    return jinja2.Environment(
        loader=jinja2.PackageLoader("svbi.templates", "."),
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
        trim_blocks=True,
        lstrip_blocks=True,
        autoescape=False,
    )


def _render(template: str, context: dict[str, Any]) -> bytes:
    full = f"solver/{template}"
    return (
        environment()
        .get_template(full)
        .render({"generator": GENERATOR, "template": f"templates/{full}", **context})
        .encode()
    )


def solver_types() -> dict[str, bytes]:
    """``svbi_solver_types.h``: the structs (``c_solver_build.STRUCTS``) and status codes."""
    structs = {
        k: [{"name": f.name, "ctype": c_solver_build.C_TYPES[f.kind], "doc": f.doc} for f in v]
        for k, v in c_solver_build.STRUCTS.items()
    }
    return {TYPES_HEADER: _render("types.h.j2", {"structs": structs, "status": c_solver_build.STATUS_CODES})}


def contact_rows() -> dict[str, bytes]:
    """``svbi_contact_rows.h``: the contact-row table of the bridge element."""
    degree, nonzero = c_solver_build.row_structure()
    powers = row_powers()
    blocks = c_solver_build.ROW_BLOCKS
    context = {
        "row_powers": [list(p) for p in powers],
        "row_degree": degree,
        "row_cols": c_solver_build.ROW_COLUMNS,
        "row_blocks": [
            {"name": n, "first": 6 * i, "nonzero": [j for j in range(6) if nonzero[6 * i + j]]}
            for i, n in enumerate(blocks)
        ],
        "row_scalars": [
            {"name": n, "col": 6 * len(blocks) + i} for i, n in enumerate(c_solver_build.ROW_SCALARS)
        ],
    }
    return {ROWS_HEADER: _render("contact_rows.h.j2", context)}


def creep_split_sources(embedded: bool = False) -> dict[str, bytes]:
    """C sources of the split creep law (``svbi.codegen.creep.split_creep_force``), from the CasADi
    emitter: the functions ``svbi_creep_split_coefficients(creep[8]) -> c`` and
    ``svbi_creep_split_force(creepage, N, c, N_cbrt) -> F_x`` (``N_cbrt``: the cube root of N)."""
    from svbi.codegen import c_emit
    from svbi.codegen import creep as law
    from svbi.codegen.kernels import CREEP_SAMPLE, KernelSpec, ModelSpec, column

    coefs, reduced, symbols = law.split_creep_force()
    sample = {k: v for k, v in CREEP_SAMPLE.items() if k not in ("xi_x", "N_c")}
    kernels = [
        KernelSpec(
            "coefficients",
            "Parameter-only subexpressions of the creep law (Eqs. 15-16).",
            [("creep", column(law.PARAMETERS))],
            [("c", sp.Matrix(list(coefs)))],
            sample,
        ),
        KernelSpec(
            "force",
            "Creep force F_x(creepage, N) from the coefficients of `coefficients`.",
            [
                ("creepage", column([law.xi])),
                ("N", column([law.normal_load])),
                ("c", column(symbols)),
                ("N_cbrt", column([law.N_CBRT])),
            ],
            [("F_x", sp.Matrix([[reduced]]))],
            {"xi_x": 5e-3, "N_c": 8.5e4, "N_cbrt": 8.5e4 ** (1 / 3)},
        ),
    ]
    model = ModelSpec(
        c_solver_build.CREEP_MODEL,
        "The creep law split into per-run coefficients and a per-step force.",
        kernels,
    )
    files = c_emit.render_model(model, c_emit.EmitOptions.embedded() if embedded else c_emit.EmitOptions())
    return {n: files[n] for n in CREEP_FILES}


def bridge_glue(embedded: bool = False) -> dict[str, bytes]:
    """The loop's files in ``generated/frame2d/``: contact rows and the split creep law."""
    return {**contact_rows(), **creep_split_sources(embedded)}


def topology(model: str, nv: int, nw: int) -> dict[str, bytes]:
    """``svbi_topology.h`` of one vehicle topology (``nv = 0``: moving loads)."""
    context = {"model": model, "nv": nv, "nw": nw, "moving_load": nv == 0}
    return {TOPOLOGY_HEADER: _render("topology.h.j2", context)}


def model_glue(spec: Any) -> dict[str, bytes]:
    """The loop's files inside the generated folder of a :class:`svbi.codegen.kernels.ModelSpec`."""
    from svbi.codegen.kernels import FRAME2D

    if spec.name == FRAME2D:
        return bridge_glue()
    return topology(spec.name, int(spec.sizes["n_dofs"]), int(spec.sizes["n_wheels"]))

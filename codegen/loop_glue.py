"""The generated glue of the C time loop: thin headers rendered at generation time.

The loop itself is static C in ``runtime/csrc/`` (docs/c-backend.md). What depends on the symbolic
pipeline or on a vehicle topology is rendered here, by ``svbi generate`` (Jinja2 templates in
``templates/solver/``, the creep law through the CasADi emitter), and committed under
``generated/`` for the built-in models:

* ``generated/solver/svbi_solver_types.h``: the structs and status codes, from the field lists of
  :mod:`svbi.codegen.loop_abi` (from which the runtime also builds its ctypes mirrors: one
  definition);
* ``generated/frame2d/svbi_contact_rows.h``: the contact-row table of the bridge element (degree,
  columns, structural non-zeros, the unrolled evaluation) from the bridge element's kernels
  (:func:`svbi.codegen.python_emit.frame2d_data`, the plain data of the generated bridge module);
  ``generated/frame2d/creep_split*``: the creep law split into per-run coefficients and a per-step
  force (``svbi.codegen.creep.split_creep_force``), C from the CasADi emitter;
* ``generated/<model>/svbi_topology.h``: the sizes of one vehicle topology (``moving-load`` too);
* ``generated/solver3d/svbi_loop3d_types.h``: the structs and status codes of the compiled 3D loop,
  from the field lists of :mod:`svbi.codegen.loop3d_abi` (from which the runtime builds that loop's
  ctypes mirrors).

At run time a built-in model reads these files (no Jinja2, no CasADi); a topology file has its
``svbi_topology.h`` rendered here when its loop is first built (``svbi.runtime.backends.c.build``).
This module imports Jinja2 and SymPy (and, for the creep law, CasADi): only generation, exports and
that first build of a topology file's loop use it. It never imports the runtime.
"""

from __future__ import annotations

from functools import cache
from typing import Any

import jinja2
import sympy as sp

from svbi.codegen import loop3d_abi
from svbi.codegen import loop_abi as abi
from svbi.codegen.loop3d_abi import SOLVER3D_FOLDER, TYPES3D_HEADER
from svbi.codegen.loop_abi import (
    BRIDGE_FOLDER,
    CREEP_FILES,
    GLUE_NAMES,
    MOVING_LOAD_FOLDER,
    ROWS_HEADER,
    SOLVER_FOLDER,
    TOPOLOGY_HEADER,
    TYPES_HEADER,
)

GENERATOR = "svbi.codegen.loop_glue"
__all__ = [
    "BRIDGE_FOLDER",
    "CREEP_FILES",
    "GLUE_NAMES",
    "MOVING_LOAD_FOLDER",
    "ROWS_HEADER",
    "SOLVER3D_FOLDER",
    "SOLVER_FOLDER",
    "TOPOLOGY_HEADER",
    "TYPES3D_HEADER",
    "TYPES_HEADER",
    "bridge_glue",
    "contact_rows",
    "creep_split_sources",
    "environment",
    "loop3d_types",
    "model_glue",
    "solver_types",
    "topology",
]


@cache
def row_expressions() -> tuple[sp.Expr, ...]:
    """The contact-row columns of the C table, in ``ROW_BLOCKS`` then ``ROW_SCALARS`` order.

    The symbolic rows behind the generated tables of
    ``svbi.runtime.backends.c.build.row_coefficients`` (SymPy; for tests and derivations, not for a
    run): ``W_N^B`` and the discrete aux-bridge row of
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
    """``svbi_solver_types.h``: the structs (``loop_abi.STRUCTS``) and status codes."""
    structs = {
        k: [{"name": f.name, "ctype": abi.C_TYPES[f.kind], "doc": f.doc} for f in v]
        for k, v in abi.STRUCTS.items()
    }
    return {TYPES_HEADER: _render("types.h.j2", {"structs": structs, "status": abi.STATUS_CODES})}


def loop3d_types() -> dict[str, bytes]:
    """``svbi_loop3d_types.h``: the structs (``loop3d_abi.STRUCTS3D``) and status codes of the 3D loop."""
    structs = {
        k: [{"name": f.name, "ctype": abi.C_TYPES[f.kind], "doc": f.doc} for f in v]
        for k, v in loop3d_abi.STRUCTS3D.items()
    }
    context = {"structs": structs, "status": loop3d_abi.STATUS3D_CODES}
    return {TYPES3D_HEADER: _render("loop3d_types.h.j2", context)}


def row_structure() -> tuple[int, tuple[bool, ...]]:
    """Polynomial degree in xi and the structurally non-zero columns of the row table, from the
    bridge element's kernels (the plain data that ``svbi generate`` writes into the generated bridge
    module, which the runtime reads: ``svbi.runtime.backends.c.build.row_structure``)."""
    from svbi.codegen.python_emit import frame2d_data

    data = frame2d_data()
    nonzero = tuple(flag for name in abi.ROW_TABLES for flag in data["nonzero_columns"][name])
    return int(data["xi_degree"]), nonzero


def contact_rows() -> dict[str, bytes]:
    """``svbi_contact_rows.h``: the contact-row table of the bridge element."""
    degree, nonzero = row_structure()
    powers = row_powers()
    blocks = abi.ROW_BLOCKS
    context = {
        "row_powers": [list(p) for p in powers],
        "row_degree": degree,
        "row_cols": abi.ROW_COLUMNS,
        "row_blocks": [
            {"name": n, "first": 6 * i, "nonzero": [j for j in range(6) if nonzero[6 * i + j]]}
            for i, n in enumerate(blocks)
        ],
        "row_scalars": [{"name": n, "col": 6 * len(blocks) + i} for i, n in enumerate(abi.ROW_SCALARS)],
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
        abi.CREEP_MODEL,
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

"""Kernel specifications: what the emitters turn into CasADi Functions and C code.

A :class:`KernelSpec` is a named set of SymPy outputs of ordered, named input vectors. The input
order is the C ABI of the generated function, so it never changes silently. Physical parameters stay
symbolic inputs (the vehicle parameter vector, or ``E, A, I, mu, le`` of a beam element), so that one
compiled kernel serves every parameter set; only sizes (DOFs, wheels) are baked in.

A :class:`ModelSpec` groups the kernels of one model (a vehicle topology, or the bridge element
``frame2d``) with its parameter defaults and sizes, which the C header exposes as constants.

The model-specific lists (:func:`model_kernels`, :func:`beam_kernels`) are built from the symbolic
core (``vehicle.py``, ``beam.py``, ``constraints.py``, ``creep.py``); each kernel is one small
function in a registry, so adding a kernel is adding one entry.
"""

from __future__ import annotations

import hashlib
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cache
from typing import Any

import sympy as sp

from svbi.codegen.plain_types import c_identifier

_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")

FRAME2D = "frame2d"
"""Model name of the bridge frame element kernels (:func:`beam_kernels`)."""
FRAME3D = "frame3d"
"""Model name of the 3D frame element kernels (:func:`svbi.codegen.frame3d.frame3d_model_spec`)."""
CONTACT3D = "contact3d"
"""Model name of the 3D contact kernels (:func:`svbi.codegen.contact3d_kernels.contact3d_model_spec`)."""


class KernelError(ValueError):
    """A kernel specification is malformed; the message names the kernel and the problem."""


def _as_matrix(value: Any) -> sp.ImmutableMatrix:
    if isinstance(value, sp.MatrixBase):
        return sp.ImmutableMatrix(value)
    if isinstance(value, (list, tuple)):
        return sp.ImmutableMatrix(value)
    return sp.ImmutableMatrix([[sp.sympify(value)]])


@dataclass(frozen=True)
class KernelSpec:
    """One generated function: ``outputs = f(inputs)``.

    ``inputs`` is an ordered list of ``(name, column of distinct Symbols)``; the order is the C ABI.
    ``outputs`` is an ordered list of ``(name, Matrix)``; exact zeros stay structural zeros in the
    generated code. ``sample`` gives a typical value for every input symbol, by symbol name: the
    example program and the tests evaluate kernels there (and at random points around it).
    """

    name: str
    doc: str
    inputs: list[tuple[str, sp.ImmutableMatrix]]
    outputs: list[tuple[str, sp.ImmutableMatrix]]
    sample: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        where = f"kernel {self.name!r}"
        if not _IDENT.match(self.name):
            raise KernelError(f"{where}: name must be a C identifier")
        inputs = [(n, _as_matrix(m)) for n, m in self.inputs]
        outputs = [(n, _as_matrix(m)) for n, m in self.outputs]
        object.__setattr__(self, "inputs", inputs)
        object.__setattr__(self, "outputs", outputs)
        object.__setattr__(self, "sample", {str(k): float(v) for k, v in self.sample.items()})
        names = [n for n, _ in inputs] + [n for n, _ in outputs]
        for n in names:
            if not _IDENT.match(n):
                raise KernelError(f"{where}: input/output name {n!r} is not a C identifier")
        if len(set(names)) != len(names):
            raise KernelError(f"{where}: input and output names must be unique, got {names}")
        if not outputs:
            raise KernelError(f"{where}: no outputs")
        seen: dict[str, str] = {}
        for n, m in inputs:
            if m.cols != 1 or m.rows == 0:
                raise KernelError(f"{where}: input {n!r} must be a non-empty column, got {m.shape}")
            for s in m:
                if not isinstance(s, sp.Symbol):
                    raise KernelError(f"{where}: input {n!r} holds {s!r}, which is not a plain Symbol")
                if s.name in seen:
                    raise KernelError(
                        f"{where}: symbol {s.name!r} appears in input {seen[s.name]!r} and input {n!r}"
                    )
                seen[s.name] = n
        known = set(self.input_symbols)
        for n, m in outputs:
            free = {s for s in m.free_symbols if s not in known}
            if free:
                missing = sorted(str(s) for s in free)
                raise KernelError(f"{where}: output {n!r} depends on symbols that are not inputs: {missing}")
        unknown = sorted(set(self.sample) - set(seen))
        if unknown:
            raise KernelError(f"{where}: sample values for unknown symbols {unknown}")

    @property
    def input_symbols(self) -> list[sp.Symbol]:
        """All input symbols, flattened in ABI order."""
        return [s for _, m in self.inputs for s in m]

    def sample_inputs(self) -> list[list[float]]:
        """The sample point as one list of floats per input (missing symbols default to 0.5)."""
        return [[self.sample.get(s.name, 0.5) for s in m] for _, m in self.inputs]

    def fingerprint_text(self) -> str:
        """Canonical text of the spec (``srepr`` of every matrix): the input of the emitters' hash."""
        parts = [f"kernel {self.name}", self.doc]
        parts += [f"in {n} {sp.srepr(m)}" for n, m in self.inputs]
        parts += [f"out {n} {sp.srepr(m)}" for n, m in self.outputs]
        parts += [f"sample {k} {v!r}" for k, v in sorted(self.sample.items())]
        return "\n".join(parts)


@dataclass(frozen=True)
class ModelSpec:
    """The kernels of one model plus what the C header exposes about it.

    ``parameters`` lists ``(name, default)`` in the order of the parameter input vector; ``sizes``
    are integer constants (``n_dofs``, ``n_wheels``...) written as ``#define`` in the header.
    """

    name: str
    doc: str
    kernels: list[KernelSpec]
    parameters: list[tuple[str, float]] = field(default_factory=list)
    sizes: dict[str, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        names = [k.name for k in self.kernels]
        if len(set(names)) != len(names):
            raise KernelError(f"model {self.name!r}: duplicate kernel names in {names}")
        for key in self.sizes:
            if not _IDENT.match(key):
                raise KernelError(f"model {self.name!r}: size name {key!r} is not a C identifier")

    @property
    def c_name(self) -> str:
        return c_identifier(self.name)

    def kernel(self, name: str) -> KernelSpec:
        for k in self.kernels:
            if k.name == name:
                return k
        raise KeyError(f"model {self.name!r} has no kernel {name!r}; it has {[k.name for k in self.kernels]}")

    def fingerprint_text(self) -> str:
        parts = [f"model {self.name}", self.doc]
        parts += [f"param {n} {v!r}" for n, v in self.parameters]
        parts += [f"size {k} {v}" for k, v in sorted(self.sizes.items())]
        parts += [k.fingerprint_text() for k in self.kernels]
        return "\n\n".join(parts)

    def fingerprint(self, extra: Sequence[str] = ()) -> str:
        """sha256 of the spec text plus the SymPy and CasADi versions (and ``extra`` strings)."""
        import casadi

        h = hashlib.sha256()
        for text in (f"sympy {sp.__version__}", f"casadi {casadi.__version__}", *extra):
            h.update(text.encode() + b"\n")
        h.update(self.fingerprint_text().encode())
        return h.hexdigest()


# ---------------------------------------------------------------------------------------------
# Kernel lists of the built-in models
# ---------------------------------------------------------------------------------------------

GRAVITY = sp.Rational(981, 100)
"""g = 9.81 m/s^2 (docs/design.md section 2), substituted exactly into the gravity load."""

BEAM_SAMPLE: dict[str, float] = {
    # Scenario defaults of docs/scenario.md (32 m span, 16 elements), with a nonzero rail height
    # and contact position so that the sample exercises every term.
    "E": 35.5e9,
    "A": 8.63,
    "I": 6.58,
    "mu": 22.4e3,
    "le": 2.0,
    "h": 0.5,
    "xi": 0.3,
    "v": 83.33,
    "dt": 1.0e-4,
    "kappa": 1.0,
    "zeta": 1.0,
}


def _state_sample(symbols: Sequence[sp.Symbol], scale: float) -> dict[str, float]:
    """Distinct, nonzero sample values for state vectors (every entry contributes)."""
    return {s.name: scale * (1.0 + 0.25 * i) * (-1) ** i for i, s in enumerate(symbols)}


def column(symbols: Sequence[sp.Symbol]) -> sp.ImmutableMatrix:
    return sp.ImmutableMatrix(list(symbols))


def _row_matrix(values: Sequence[sp.Expr]) -> sp.Matrix:
    return sp.Matrix(len(values), 1, list(values))


VehicleFactory = Callable[[Any], "KernelSpec | None"]
"""Builds one kernel of a vehicle model (a ``VehicleModel``), or None when it does not apply."""

VEHICLE_KERNELS: dict[str, VehicleFactory] = {}
"""Vehicle kernels in emission order. Registering a function here adds a kernel to every vehicle."""

BEAM_KERNELS: dict[str, Callable[[], KernelSpec | None]] = {}
"""Bridge-element (``frame2d``) kernels in emission order."""


def vehicle_kernel(fn: VehicleFactory) -> VehicleFactory:
    VEHICLE_KERNELS[fn.__name__.removeprefix("_k_")] = fn
    return fn


def beam_kernel(fn: Callable[[], KernelSpec | None]) -> Callable[[], KernelSpec | None]:
    BEAM_KERNELS[fn.__name__.removeprefix("_k_")] = fn
    return fn


def _vehicle_inputs(model: Any) -> tuple[list[tuple[str, sp.ImmutableMatrix]], dict[str, float]]:
    params = list(model.parameters)
    defaults = model.topology.defaults()
    return [("p", column(params))], {s.name: float(defaults[s.name]) for s in params}


def _vehicle_spec(
    model: Any, name: str, doc: str, outputs: list, extra_inputs=(), extra_sample=None
) -> KernelSpec:
    inputs, sample = _vehicle_inputs(model)
    return KernelSpec(name, doc, inputs + list(extra_inputs), outputs, {**sample, **(extra_sample or {})})


@vehicle_kernel
def _k_mass_matrix(model: Any) -> KernelSpec:
    return _vehicle_spec(
        model, "mass_matrix", "Vehicle mass matrix m^V of Eq. (4).", [("M", model.mass_matrix)]
    )


@vehicle_kernel
def _k_damping_matrix(model: Any) -> KernelSpec:
    return _vehicle_spec(
        model, "damping_matrix", "Vehicle damping matrix c^V of Eq. (4).", [("C", model.damping_matrix)]
    )


@vehicle_kernel
def _k_stiffness_matrix(model: Any) -> KernelSpec:
    return _vehicle_spec(
        model, "stiffness_matrix", "Vehicle stiffness matrix k^V of Eq. (4).", [("K", model.stiffness_matrix)]
    )


@vehicle_kernel
def _k_gravity_load(model: Any) -> KernelSpec:
    from svbi.codegen.vehicle import g

    return _vehicle_spec(
        model,
        "gravity_load",
        "Generalized gravity forces on the vehicle DOFs (g = 9.81 m/s^2), right-hand side of Eq. (4).",
        [("F", model.gravity_load.xreplace({g: GRAVITY}))],
    )


@vehicle_kernel
def _k_contact_directions(model: Any) -> KernelSpec:
    return _vehicle_spec(
        model,
        "contact_directions",
        "Contact direction matrices W_N^V (normal) and W_T^V (tangential), one column per wheel (Eq. 4).",
        [("W_N", model.contact_normal), ("W_T", model.contact_tangential)],
    )


@vehicle_kernel
def _k_wheel_geometry(model: Any) -> KernelSpec:
    return _vehicle_spec(
        model,
        "wheel_geometry",
        "Per wheel: offset behind the car's leading axle, rolling radius, and mass W_i^T m^V W_i.",
        [
            ("offsets", _row_matrix(model.wheel_offsets)),
            ("radii", _row_matrix(model.wheel_radii)),
            ("masses", _row_matrix(model.wheel_masses)),
        ],
    )


def _split_input() -> tuple[list[tuple[str, sp.ImmutableMatrix]], dict[str, float]]:
    from svbi.codegen.vehicle import a_split

    return [("split", column([a_split]))], {a_split.name: 0.5}


@vehicle_kernel
def _k_aux_masses(model: Any) -> KernelSpec:
    inputs, sample = _split_input()
    return _vehicle_spec(
        model,
        "aux_masses",
        "Auxiliary contact point masses m^g = a W^T m^V W (diagonal, as a column) and the active "
        "vehicle mass m~^V = m^V - W m^g W^T (Section 2.3).",
        [
            ("m_aux", _row_matrix(list(model.aux_masses().diagonal()))),
            ("M_active", model.active_mass_matrix()),
        ],
        inputs,
        sample,
    )


@vehicle_kernel
def _k_vehicle_constraint(model: Any) -> KernelSpec:
    from svbi.codegen import constraints

    inputs, sample = _split_input()
    n, nw = model.contact_normal.shape
    active, aux = model.active_mass_matrix(), model.aux_masses()
    b_columns, masses = [], []
    for i in range(nw):
        e = sp.zeros(nw, 1)
        e[i, 0] = 1
        b = constraints.b_vehicle(model.contact_normal[:, i], e)
        b_columns.append(b)
        masses.append(constraints.mass_vehicle_constraint(b, active, aux))
    return _vehicle_spec(
        model,
        "vehicle_constraint",
        "Wheel-aux constraints: b-vectors b_i^V over [u^V; u^g] (Eq. 25, one column per wheel) and "
        "constraint masses m_N,ii^V (Eq. 27).",
        [
            ("b", sp.Matrix.hstack(*b_columns) if b_columns else sp.zeros(n + nw, 0)),
            ("m_bar", _row_matrix(masses)),
        ],
        inputs,
        sample,
    )


@vehicle_kernel
def _k_gap_vehicle(model: Any) -> KernelSpec:
    from svbi.codegen import constraints

    n, nw = model.contact_normal.shape
    u_v = [sp.Symbol(f"u_{q.name}", real=True) for q in model.dofs]
    u_g = [sp.Symbol(f"ug_{i + 1}", real=True) for i in range(nw)]
    gaps = [constraints.gap_vehicle(model.contact_normal[:, i], sp.Matrix(u_v), u_g[i]) for i in range(nw)]
    return _vehicle_spec(
        model,
        "gap_vehicle",
        "Wheel-aux gaps g_V,i = W_i^T u^V - u^g_i (Eq. 18), one per wheel.",
        [("g_V", _row_matrix(gaps))],
        [("u_V", column(u_v)), ("u_g", column(u_g))],
        {**_state_sample(u_v, 1e-3), **_state_sample(u_g, 2e-3)},
    )


CREEP_SAMPLE: dict[str, float] = {
    # Steel wheel on a UIC60-like rail head; creepage and load chosen so that random points around
    # the sample reach the saturated branch (beta > 3) and the out-of-contact branch (N <= 0).
    "E_wr": 2.1e11,
    "nu_wr": 0.3,
    "R_wheel": 0.4575,
    "R_rail": 0.3,
    "hertz_m": 1.2,
    "hertz_n": 0.8,
    "kalker_c11": 4.0,
    "mu_f": 0.3,
    "xi_x": 5.0e-3,
    "N_c": 8.5e4,
}


@vehicle_kernel
def _k_creepage(model: Any) -> KernelSpec:
    from svbi.codegen import beam, creep

    n, nw = model.contact_tangential.shape
    ud_v = [sp.Symbol(f"ud_{q.name}", real=True) for q in model.dofs]
    xis = [sp.Symbol(f"xi_{i + 1}", real=True) for i in range(nw)]
    u_e = [sp.Symbol(f"ue{i + 1}_{d}", real=True) for i in range(nw) for d in beam.DOF_NAMES]
    ud_e = [sp.Symbol(f"ude{i + 1}_{d}", real=True) for i in range(nw) for d in beam.DOF_NAMES]
    rt_x = [sp.Symbol(f"rt_x_{i + 1}", real=True) for i in range(nw)]
    w_b = sp.zeros(beam.NDOF * nw, nw)
    w_bx = sp.zeros(beam.NDOF * nw, nw)
    for i in range(nw):
        rows = slice(beam.NDOF * i, beam.NDOF * (i + 1))
        w_b[rows, i] = beam.tangential_row(0).T.xreplace({beam.xi: xis[i]})
        w_bx[rows, i] = beam.tangential_row(1).T.xreplace({beam.xi: xis[i]})
    creepages = creep.creepage(
        model.contact_tangential, sp.Matrix(ud_v), w_b, sp.Matrix(ud_e), w_bx, sp.Matrix(u_e), sp.Matrix(rt_x)
    )
    sample = {
        "v": BEAM_SAMPLE["v"],
        "le": BEAM_SAMPLE["le"],
        "h": BEAM_SAMPLE["h"],
        **{s.name: 0.1 + 0.6 * i / max(nw - 1, 1) for i, s in enumerate(xis)},
        **_state_sample(ud_v, 1e-2),
        **_state_sample(u_e, 1e-3),
        **_state_sample(ud_e, 1e-2),
        **_state_sample(rt_x, 1e-4),
    }
    return _vehicle_spec(
        model,
        "creepage",
        "Longitudinal creepage of every wheel, Eq. (16) with the rolling part removed: "
        "(W_T^V' ud_V - W_T^B' ud_e - v W_T^B'' u_e - v r_T') / v. Wheel i sits at xi_i of an element "
        "(element = [le, h]) whose DOFs are u_e[6i:6i+6].",
        [("creepage", creepages)],
        [
            ("ud_V", column(ud_v)),
            ("v", column([creep.v])),
            ("element", column([beam.le, beam.h])),
            ("xi", column(xis)),
            ("u_e", column(u_e)),
            ("ud_e", column(ud_e)),
            ("rt_x", column(rt_x)),
        ],
        sample,
    )


def _beam_spec(name: str, doc: str, inputs: list, outputs: list, extra_sample=None) -> KernelSpec:
    symbols = [s for _, m in inputs for s in m]
    sample = {s.name: BEAM_SAMPLE[s.name] for s in symbols if s.name in BEAM_SAMPLE}
    return KernelSpec(name, doc, inputs, outputs, {**sample, **(extra_sample or {})})


def _section() -> list[tuple[str, sp.ImmutableMatrix]]:
    from svbi.codegen import beam

    return [("section", column([beam.E, beam.A, beam.I, beam.mu])), ("le", column([beam.le]))]


@beam_kernel
def _k_element_mass() -> KernelSpec:
    from svbi.codegen import beam

    return _beam_spec(
        "element_mass",
        "Consistent mass matrix of the 2D frame element, DOFs [u1, w1, theta1, u2, w2, theta2].",
        _section(),
        [("M_e", beam.element_mass())],
    )


@beam_kernel
def _k_element_stiffness() -> KernelSpec:
    from svbi.codegen import beam

    return _beam_spec(
        "element_stiffness",
        "Stiffness matrix of the 2D frame element (axial EA and bending EI).",
        _section(),
        [("K_e", beam.element_stiffness())],
    )


@beam_kernel
def _k_column_mass() -> KernelSpec:
    from svbi.codegen import beam

    return _beam_spec(
        "column_mass",
        "Consistent mass of a vertical (pier) column element in global DOFs [u1, w1, theta1, u2, w2, "
        "theta2], node 1 at the bottom: the frame element turned a quarter turn.",
        _section(),
        [("M_c", beam.column_mass())],
    )


@beam_kernel
def _k_column_stiffness() -> KernelSpec:
    from svbi.codegen import beam

    return _beam_spec(
        "column_stiffness",
        "Stiffness of a vertical (pier) column element in global DOFs, node 1 at the bottom.",
        _section(),
        [("K_c", beam.column_stiffness())],
    )


@beam_kernel
def _k_contact_rows() -> KernelSpec:
    from svbi.codegen import beam

    return _beam_spec(
        "contact_rows",
        "Contact rows at xi: W_N^B and its x-derivatives (Eq. 10), W_T^B = u - h dw/dx and its "
        "x-derivative (Eqs. 10, 16); each 1x6 over the element DOFs.",
        [("xi", column([beam.xi])), ("le", column([beam.le])), ("h", column([beam.h]))],
        [
            ("N", beam.normal_row(0)),
            ("N_x", beam.normal_row(1)),
            ("N_xx", beam.normal_row(2)),
            ("T", beam.tangential_row(0)),
            ("T_x", beam.tangential_row(1)),
        ],
    )


@beam_kernel
def _k_gap_bridge() -> KernelSpec:
    from svbi.codegen import beam, constraints

    gap = constraints.gap_bridge()
    ue, ue1, ue2 = gap.u_elem
    track = column([constraints.r, constraints.r1, constraints.r2])
    inputs = [
        ("xi", column([beam.xi])),
        ("le", column([beam.le])),
        ("v", column([constraints.v])),
        ("u_g", column(gap.u_aux)),
        ("u_e", column(ue)),
        ("u_e_t", column(ue1)),
        ("u_e_tt", column(ue2)),
        ("track", track),
    ]
    states = [*gap.u_aux, *ue, *ue1, *ue2, *track]
    return _beam_spec(
        "gap_bridge",
        "Aux-bridge gap g_B and its exact time derivatives with the convective terms of a contact "
        "moving at speed v (Eqs. 20-21). u_g = [u^g, u^g', u^g''], track = [r, r', r''].",
        inputs,
        [("g", sp.Matrix([[gap.g]])), ("g_t", sp.Matrix([[gap.g_t]])), ("g_tt", sp.Matrix([[gap.g_tt]]))],
        _state_sample(states, 1e-3),
    )


@beam_kernel
def _k_gap_support() -> KernelSpec:
    from svbi.codegen import constraints

    u = sp.Symbol("u_support", real=True)
    return _beam_spec(
        "gap_support",
        "Support gap g_G = q - E^T u^B (Eq. 23) for one support DOF.",
        [("q", column([constraints.q])), ("u", column([u]))],
        [("g_G", sp.Matrix([[constraints.gap_support(u)]]))],
        {"q": 2e-3, "u_support": -1e-3},
    )


@beam_kernel
def _k_bridge_constraint() -> KernelSpec:
    from svbi.codegen import beam, constraints

    m_aux = sp.Symbol("m_aux", positive=True)
    return _beam_spec(
        "bridge_constraint",
        "Aux-bridge constraint at xi: b-vector b_i^B over [u^g_i; u_e] (Eq. 29) and constraint mass "
        "m_N,ii^B with the element's consistent mass (Eq. 31).",
        [
            ("xi", column([beam.xi])),
            ("le", column([beam.le])),
            ("mu", column([beam.mu])),
            ("m_aux", column([m_aux])),
        ],
        [("b", constraints.b_bridge()), ("m_bar", sp.Matrix([[constraints.mass_bridge_constraint(m_aux)]]))],
        {"m_aux": 950.0},
    )


@beam_kernel
def _k_support_constraint() -> KernelSpec:
    from svbi.codegen import beam, constraints

    masses = [constraints.mass_support_constraint(dof) for dof in range(beam.NDOF)]
    return _beam_spec(
        "support_constraint",
        "Support constraint masses b^T m^B b (Eq. 34) for a support on each element DOF; the "
        "b-vectors themselves are unit vectors (Eq. 33).",
        [("mu", column([beam.mu])), ("le", column([beam.le]))],
        [("m_bar", _row_matrix(masses))],
    )


def _newmark_input() -> tuple[str, sp.ImmutableMatrix]:
    from svbi.codegen import constraints

    return ("newmark", column([constraints.dt, constraints.kappa, constraints.zeta]))


@beam_kernel
def _k_discrete_bridge_row() -> KernelSpec:
    from svbi.codegen import beam, constraints

    row, names = constraints.discrete_bridge_row()
    history = [names["P_ug"], names["Q_ug"]]
    track = [constraints.r, constraints.r1, constraints.r2]
    return _beam_spec(
        "discrete_bridge_row",
        "Aux-bridge constraint at t_{n+1} with Newmark: u^g - W_hat u_e = h_B (method notes section 2b). "
        "newmark = [dt, kappa, zeta]; history = [P_ug, Q_ug]; track = [r, r', r''].",
        [
            ("xi", column([beam.xi])),
            ("le", column([beam.le])),
            ("v", column([constraints.v])),
            _newmark_input(),
            ("history", column(history)),
            ("P_ue", column(names["P_ue"])),
            ("Q_ue", column(names["Q_ue"])),
            ("track", column(track)),
        ],
        [("W_hat", row.row), ("h_B", sp.Matrix([[row.rhs]])), ("d", sp.Matrix([[row.d]]))],
        _state_sample([*history, *names["P_ue"], *names["Q_ue"], *track], 1e-3),
    )


@beam_kernel
def _k_discrete_point_row() -> KernelSpec:
    from svbi.codegen import constraints

    row, names = constraints.discrete_point_row()
    ground = [constraints.q, constraints.q1, constraints.q2]
    history = [names["P_y"], names["Q_y"]]
    return _beam_spec(
        "discrete_point_row",
        "Prescribed-motion constraint (supports, wheels off the bridge) at t_{n+1}: y = rhs. "
        "newmark = [dt, kappa, zeta]; ground = [q, q', q'']; history = [P_y, Q_y].",
        [_newmark_input(), ("ground", column(ground)), ("history", column(history))],
        [("rhs", sp.Matrix([[row.rhs]])), ("d", sp.Matrix([[row.d]]))],
        _state_sample([*ground, *history], 1e-3),
    )


@beam_kernel
def _k_creep_force() -> KernelSpec:
    from svbi.codegen import creep

    return KernelSpec(
        "creep_force",
        "Longitudinal creep force F_x(xi, N) of one wheel, Eq. (15) with Kalker's linear coefficient and "
        "Shen-Hedrick-Elkins saturation, and its slope dF_x/dxi. creep = [E_wr, nu_wr, R_wheel, "
        "R_rail, hertz_m, hertz_n, kalker_c11, mu_f].",
        [
            ("creepage", column([creep.xi])),
            ("N", column([creep.normal_load])),
            ("creep", column(creep.PARAMETERS)),
        ],
        [
            ("F_x", sp.Matrix([[creep.creep_force()]])),
            ("dF_dxi", sp.Matrix([[creep.creep_force_derivative()]])),
        ],
        CREEP_SAMPLE,
    )


# Per-run tables: coefficients of the polynomials in xi, as functions of the run constants. Within
# one run the element length, speed, time step and constraint coefficients are fixed, so every
# contact row is a polynomial in the local coordinate xi of the contact; the runtime evaluates
# ``[1, xi, xi^2, ...] @ coefficients`` for all contacts at once.

XI_DEGREE = 3
"""Degree in xi of every contact row (Hermite cubics); the coefficient tables have 4 rows."""

BRIDGE_HISTORY = ("P_ug", "Q_ug", "r", "r_x", "r_xx")
"""Scalar histories of ``h_B`` (columns of ``c_scalars`` of ``bridge_row_coefficients``)."""


def xi_coefficients(exprs: Sequence[sp.Expr], degree: int | None = XI_DEGREE) -> sp.Matrix:
    """``(degree + 1, len(exprs))`` matrix: entry (k, j) is the coefficient of xi^k in exprs[j]
    (``degree`` None: the highest degree of the expressions)."""
    from svbi.codegen import beam

    values = [sp.expand(sp.sympify(e)) for e in exprs]
    polys = [sp.Poly(v, beam.xi) if v != 0 else None for v in values]
    if degree is None:
        degree = max((p.degree() for p in polys if p is not None), default=0)
    out = sp.zeros(degree + 1, len(exprs))
    for j, poly in enumerate(polys):
        if poly is None:
            continue
        if poly.degree() > degree:
            raise KernelError(f"expression {j} has degree {poly.degree()} in xi > {degree}")
        for (power,), c in poly.terms():
            out[power, j] = sp.factor_terms(sp.cancel(c))
    return out


@cache
def discrete_bridge_row_parts(
    accelerating: bool = False,
) -> tuple[sp.Expr, list[sp.Expr], dict[str, list[sp.Expr]]]:
    """The discrete aux-bridge row (``constraints.discrete_bridge_row``) split into ``d``, ``W_hat``
    and the coefficients of ``h_B`` in each history and the irregularity (``P_ue``, ``Q_ue``: six
    each; ``BRIDGE_HISTORY``: one each).

    ``h_B`` is linear in those; the coefficients are taken by differentiation and the remainder is
    checked to vanish.
    """
    from svbi.codegen import beam, constraints

    row, names = constraints.discrete_bridge_row(accelerating)
    rhs = row.rhs
    scalars = dict(zip(BRIDGE_HISTORY, (names["P_ug"], names["Q_ug"], *constraints_track()), strict=True))
    coefs: dict[str, list[sp.Expr]] = {}
    rest = rhs
    for key, sym in scalars.items():
        c = sp.diff(rhs, sym)
        coefs[key] = [c]
        rest = rest - c * sym
    for key in ("P_ue", "Q_ue"):
        vec = names[key]
        cs = [sp.diff(rhs, vec[i]) for i in range(beam.NDOF)]
        coefs[key] = cs
        rest = rest - sum(c * vec[i] for i, c in enumerate(cs))
    if sp.simplify(sp.expand(rest)) != 0:
        raise AssertionError("h_B of the discrete bridge row is not linear in its histories")
    return row.d, list(row.row), coefs


def constraints_track() -> tuple[sp.Symbol, sp.Symbol, sp.Symbol]:
    """Irregularity r and its x-derivatives (symbols of ``constraints``)."""
    from svbi.codegen import constraints

    return constraints.r, constraints.r1, constraints.r2


@beam_kernel
def _k_shape_coefficients() -> KernelSpec:
    from svbi.codegen import beam

    return _beam_spec(
        "shape_coefficients",
        "Coefficients in ascending powers of xi of the contact rows of one element: W_N^B and its "
        "x-derivatives N0, N1, N2 (Eq. 10), W_T^B = u - h dw/dx and its x-derivative T0, T1 "
        "(Eqs. 10, 16), and the axial shape functions; each (4 x 6) over the element DOFs.",
        [("le", column([beam.le])), ("h", column([beam.h]))],
        [
            ("N0", xi_coefficients(list(beam.normal_row(0)))),
            ("N1", xi_coefficients(list(beam.normal_row(1)))),
            ("N2", xi_coefficients(list(beam.normal_row(2)))),
            ("T0", xi_coefficients(list(beam.tangential_row(0)))),
            ("T1", xi_coefficients(list(beam.tangential_row(1)))),
            ("axial", xi_coefficients(list(beam.axial_shape()))),
        ],
    )


@beam_kernel
def _k_bridge_row_coefficients() -> KernelSpec:
    from svbi.codegen import beam, constraints

    d, w_hat, coefs = discrete_bridge_row_parts()
    return _beam_spec(
        "bridge_row_coefficients",
        "The discrete aux-bridge row u^g - W_hat u_e = h_B at t_{n+1} (method notes section 2b) as "
        "coefficients in ascending powers of xi: W_hat, and h_B = c_P_ue.P_ue + c_Q_ue.Q_ue + "
        "c_scalars.[P_ug, Q_ug, r, r', r''] (each 4 x 6, c_scalars 4 x 5); d is the position "
        "coefficient of the discrete constraint ODE. newmark = [dt, kappa, zeta].",
        [("le", column([beam.le])), ("v", column([constraints.v])), _newmark_input()],
        [
            ("W_hat", xi_coefficients(w_hat)),
            ("c_P_ue", xi_coefficients(coefs["P_ue"])),
            ("c_Q_ue", xi_coefficients(coefs["Q_ue"])),
            ("c_scalars", xi_coefficients([coefs[k][0] for k in BRIDGE_HISTORY])),
            ("d", sp.Matrix([[d]])),
        ],
    )


@beam_kernel
def _k_bridge_row_acceleration_coefficients() -> KernelSpec:
    from svbi.codegen import beam, constraints

    _, w_hat, coefs = discrete_bridge_row_parts(accelerating=True)
    a = constraints.a_x
    by_a = lambda exprs: [sp.diff(e, a) for e in exprs]  # noqa: E731 - the row is linear in a_x
    return _beam_spec(
        "bridge_row_acceleration_coefficients",
        "What the train's acceleration a_x (x'' along the track) adds to the discrete aux-bridge row "
        "per unit a_x: W_hat and c_scalars of bridge_row_coefficients gain a_x times these "
        "(ascending powers of xi, 4 x 6 and 4 x 5); the histories' coefficients do not change. "
        "newmark = [dt, kappa, zeta].",
        [("le", column([beam.le])), _newmark_input()],
        [
            ("W_hat_a", xi_coefficients(by_a(w_hat))),
            ("c_scalars_a", xi_coefficients(by_a([coefs[k][0] for k in BRIDGE_HISTORY]))),
        ],
    )


@beam_kernel
def _k_point_row_coefficients() -> KernelSpec:
    from svbi.codegen import constraints

    row, names = constraints.discrete_point_row()
    syms = (names["P_y"], names["Q_y"], constraints.q2, constraints.q1, constraints.q)
    return _beam_spec(
        "point_row_coefficients",
        "Prescribed-motion row y_{n+1} = c.[P_y, Q_y, q'', q', q] (supports, Eqs. 22-24; wheels off "
        "the bridge; method notes section 2c) and its position coefficient d. newmark = [dt, kappa, "
        "zeta].",
        [_newmark_input()],
        [("d", sp.Matrix([[row.d]])), ("c", _row_matrix([sp.diff(row.rhs, s) for s in syms]))],
    )


@beam_kernel
def _k_bridge_constraint_mass_coefficients() -> KernelSpec:
    from svbi.codegen import beam, constraints

    m_aux = sp.Symbol("m_aux", positive=True)
    num, den = sp.fraction(sp.together(constraints.mass_bridge_constraint(m_aux)))
    degree = max(sp.Poly(sp.expand(e), beam.xi).degree() for e in (num, den))
    return _beam_spec(
        "bridge_constraint_mass_coefficients",
        "Constraint mass m_N,ii^B(xi) of Eq. (31) as the ratio of two polynomials in xi: "
        "coefficients in ascending powers of the numerator and the denominator.",
        [("le", column([beam.le])), ("mu", column([beam.mu])), ("m_aux", column([m_aux]))],
        [("num", xi_coefficients([num], degree)), ("den", xi_coefficients([den], degree))],
        {"m_aux": 950.0},
    )


@beam_kernel
def _k_kalker_f33() -> KernelSpec:
    from svbi.codegen import creep

    return KernelSpec(
        "kalker_f33",
        "Kalker's longitudinal creep coefficient f33 = G a b C11 under the normal load N (Section 2.4); "
        "0 out of contact (N <= 0).",
        [("N", column([creep.normal_load])), ("creep", column(creep.PARAMETERS))],
        [
            (
                "f33",
                sp.Matrix([[sp.Piecewise((sp.S.Zero, creep.normal_load <= 0), (creep.kalker_f33(), True))]]),
            )
        ],
        {k: v for k, v in CREEP_SAMPLE.items() if k != "xi_x"},
    )


@beam_kernel
def _k_creep_split_coefficients() -> KernelSpec:
    from svbi.codegen import creep

    coefs, _, _ = creep.split_creep_force()
    return KernelSpec(
        "creep_split_coefficients",
        "Parameter-only subexpressions c of the creep law (Eqs. 15-16), computed once per run.",
        [("creep", column(creep.PARAMETERS))],
        [("c", _row_matrix(list(coefs)))],
        {k: v for k, v in CREEP_SAMPLE.items() if k not in ("xi_x", "N_c")},
    )


@beam_kernel
def _k_creep_split_force() -> KernelSpec:
    from svbi.codegen import creep

    coefs, reduced, symbols = creep.split_creep_force()
    return KernelSpec(
        "creep_split_force",
        "Creep force F_x(creepage, N) (Eq. 15 with saturation) from the coefficients c of "
        "creep_split_coefficients; N_cbrt is the cube root of N.",
        [
            ("creepage", column([creep.xi])),
            ("N", column([creep.normal_load])),
            ("c", column(symbols)),
            ("N_cbrt", column([creep.N_CBRT])),
        ],
        [("F_x", sp.Matrix([[reduced]]))],
        {"xi_x": 5e-3, "N_c": 8.5e4, "N_cbrt": 8.5e4 ** (1 / 3)},
    )


def vehicle_role_spec(model: Any) -> KernelSpec:
    """Masses and inertias of the bodies and the wheel radii (the values that parameter validation
    checks, ``topology._check_positive_roles``), in :func:`vehicle_roles` order."""
    return _vehicle_spec(
        model,
        "roles",
        "Body masses and pitch inertias, then wheel radii, at the parameter vector p.",
        [("values", _row_matrix([e for _, _, _, e in vehicle_roles(model.topology)] or [sp.S.Zero]))],
    )


def vehicle_roles(topology: Any) -> list[tuple[str, str, str, sp.Expr]]:
    """``(key, check, message, expression)`` of every value checked on a parameter set: body masses
    and inertias must be positive, wheel radii not negative (same keys and messages as
    ``topology._check_positive_roles``)."""
    out = []
    for i, body in enumerate(topology.bodies):
        for role, e in (("mass", body.mass), ("inertia", body.inertia)):
            if e is not None:
                out.append(
                    (f"bodies[{i}].{role}", "positive", f"{role} of body {body.name!r} must be positive", e)
                )
    for i, wheel in enumerate(topology.wheels):
        out.append((f"wheels[{i}].radius", "nonnegative", "radius must not be negative", wheel.radius))
    return out


# ---------------------------------------------------------------------------------------------
# Models
# ---------------------------------------------------------------------------------------------


def model_kernels(model: Any) -> list[KernelSpec]:
    """Every kernel of a vehicle model (a ``VehicleModel``), in emission order."""
    if model.kind != "rigid-body" or not model.dofs:
        raise KernelError(
            f"vehicle {model.name!r} ({model.kind}) has no vehicle dynamics: there is nothing to generate "
            "(moving loads are prescribed forces, evaluated directly by the runtime)"
        )
    specs = (factory(model) for factory in VEHICLE_KERNELS.values())
    return [s for s in specs if s is not None]


def beam_kernels() -> list[KernelSpec]:
    """Every kernel of the bridge frame element and its contact constraints (model ``frame2d``)."""
    specs = (factory() for factory in BEAM_KERNELS.values())
    return [s for s in specs if s is not None]


def vehicle_model_spec(model: Any) -> ModelSpec:
    """The :class:`ModelSpec` of a derived vehicle model."""
    defaults = model.topology.defaults()
    return ModelSpec(
        name=model.name,
        doc=f"Vehicle model {model.name}: {model.topology.description}",
        kernels=model_kernels(model),
        parameters=[(s.name, float(defaults[s.name])) for s in model.parameters],
        sizes={"n_dofs": len(model.dofs), "n_wheels": int(model.contact_normal.shape[1])},
    )


@cache
def frame2d_model_spec() -> ModelSpec:
    """The :class:`ModelSpec` of the bridge element (``frame2d``)."""
    from svbi.codegen import beam

    return ModelSpec(
        name=FRAME2D,
        doc="2D Euler-Bernoulli frame element of the bridge, its contact rows and constraints.",
        kernels=beam_kernels(),
        parameters=[(s.name, BEAM_SAMPLE[s.name]) for s in (beam.E, beam.A, beam.I, beam.mu)],
        sizes={"n_dofs": beam.NDOF, "n_nodes": 2},
    )


def skip_reason(name_or_path: str) -> str | None:
    """Why a model has nothing to generate (moving loads), or None."""
    if name_or_path in (FRAME2D, FRAME3D, CONTACT3D):
        return None
    from svbi.codegen.topology import load_topology
    from svbi.codegen.topology3d import builtin_topologies_3d

    if name_or_path in builtin_topologies_3d():
        return None

    topology = load_topology(name_or_path)
    if topology.kind != "rigid-body" or not topology.bodies:
        return (
            f"{topology.name}: a {topology.kind} vehicle has no dynamics; its prescribed axle forces need "
            "no generated code"
        )
    return None


def model_spec(name_or_path: Any) -> ModelSpec:
    """The :class:`ModelSpec` of ``frame2d``, a built-in vehicle name or a topology file path."""
    if isinstance(name_or_path, ModelSpec):
        return name_or_path
    if str(name_or_path) == FRAME2D:
        return frame2d_model_spec()
    from svbi.codegen.vehicle import derive_vehicle

    return vehicle_model_spec(derive_vehicle(str(name_or_path)))


def builtin_models() -> list[str]:
    """Models whose generated code is committed: every rigid-body built-in vehicle, and ``frame2d``."""
    from svbi.codegen.topology import builtin_topologies

    return [n for n in builtin_topologies() if skip_reason(n) is None] + [FRAME2D]

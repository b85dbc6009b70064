"""The compiled Newmark loop: static C in ``runtime/csrc/`` plus thin generated glue, built and loaded.

The loop is ordinary C (``runtime/csrc/*.c``, docs/c-backend.md). One loop library is built per
vehicle topology: the sizes fixed by the topology (vehicle DOFs ``NV``, wheels per car ``NW``, moving
loads or not) come from the generated header ``svbi_topology.h``; the contact-row table (degree and
non-zero pattern of the polynomials in ``xi``) from ``svbi_contact_rows.h``; the creep law from the
CasADi-emitted ``creep_split`` kernels; the structs from ``svbi_solver_types.h``. Those are rendered
by ``svbi generate`` (:mod:`svbi.codegen.loop_glue`) and committed under ``generated/`` for the
built-in models, so that running a built-in model imports neither Jinja2 nor CasADi. Everything that
depends on the run (cars, spans, elements, the numbers of every matrix) travels in a setup struct.
The structs are written once, as lists of fields in :mod:`svbi.codegen.loop_abi` (plain data, no
SymPy or Jinja2); the C header (generated) and the ctypes mirrors here are both built from those
lists, so they cannot disagree.

Every formula the C loop evaluates comes from the symbolic pipeline: the contact rows (``W_N^B``
and the discrete aux-bridge row of ``svbi.codegen.constraints``) are passed as the coefficients of
their polynomials in the local coordinate ``xi`` (as ``svbi.runtime.model.contact_rows`` evaluates them), the
point rows (supports, off-bridge contacts) as their coefficients, the constraint mass of Eq. (31) as
the two polynomials of its ratio. The loop itself is Newmark's average-acceleration scheme and
linear algebra.

The library is compiled through :mod:`svbi.runtime.toolchain` (per-user cache keyed by the content
hash of every source and the flags, ``-O3``), with the strict warning set of the kernels
(``-std=c99 -Wall -Wextra -Werror``). On an x86-64 CPU with AVX2 the loop is built with ``-mavx2``
(its lanes of four doubles fill one register; :func:`simd_flags`) and ``-ffp-contract=off``, so that
its results are bit for bit those of a plain build (no fused multiply-adds). ``$SVBI_CFLAGS`` appends
flags, e.g. ``-march=native`` for a machine-specific build; ``SVBI_SIMD=0`` turns AVX2 off.
"""

from __future__ import annotations

import ctypes
import os
import shlex
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Any

import numpy as np

from ....codegen.c_flags import CASADI_WARNING_EXCEPTION, STRICT_FLAGS
from ....codegen.loop_abi import (
    BRIDGE_FOLDER,
    CREEP_FILES,
    EXCITATION_FIELDS,
    INFO_FIELDS,
    MOVING_LOAD_FOLDER,
    OUTPUT_FIELDS,
    PPOLY_FIELDS,
    ROW_COLUMNS,
    ROW_TABLES,
    ROWS_HEADER,
    SETUP_FIELDS,
    SOLVER_FOLDER,
    STATE_FIELDS,
    TOPOLOGY_HEADER,
    TYPES_HEADER,
    Field,
)
from ....codegen.plain_types import c_identifier
from ... import toolchain as kernel_cache
from ...model.contact_rows import bridge_row_tables, bridge_row_tables_changing_speed, shape_tables
from ...model.kernels import frame2d
from ...toolchain import generated_root

_CTYPES: dict[str, Any] = {
    # the ctypes mirror of every Field kind (loop_abi.C_TYPES spells them in C)
    "int": ctypes.c_int,
    "long": ctypes.c_long,
    "double": ctypes.c_double,
    "int*": ctypes.c_void_p,
    "long*": ctypes.c_void_p,
    "double*": ctypes.c_void_p,
    "mint*": ctypes.c_void_p,
    "mdouble*": ctypes.c_void_p,
    "mchar*": ctypes.c_void_p,
    "ppoly*": ctypes.c_void_p,
}


class PPoly(ctypes.Structure):
    _fields_ = [(f.name, _CTYPES[f.kind]) for f in PPOLY_FIELDS]


_CTYPES["ppoly"] = PPoly


def structure(name: str, fields: list[Field], doc: str = "") -> type[ctypes.Structure]:
    """The ctypes mirror of a struct of the loop's ABI: its members in the order of ``fields``
    (also the 3D loop's, :mod:`svbi.runtime.backends.c.stepper3d`)."""
    members: dict[str, Any] = {"_fields_": [(f.name, _CTYPES[f.kind]) for f in fields]}
    if doc:
        members["__doc__"] = doc
    return type(name, (ctypes.Structure,), members)


Setup = structure("Setup", SETUP_FIELDS)
State = structure("State", STATE_FIELDS)
Excitation = structure("Excitation", EXCITATION_FIELDS)
Outputs = structure("Outputs", OUTPUT_FIELDS)
Info = structure("Info", INFO_FIELDS)


# --------------------------------------------------------------------------------------------------
# the contact-row table (symbolic -> polynomial coefficients in xi)


@cache
def row_structure() -> tuple[int, tuple[bool, ...]]:
    """Polynomial degree in xi and the structurally non-zero columns of the row table (plain data
    of the generated bridge module)."""
    data = frame2d().DATA
    nonzero = tuple(flag for name in ROW_TABLES for flag in data["nonzero_columns"][name])
    return int(data["xi_degree"]), nonzero


def row_coefficients(
    le: float, speed: float, dt: float, kappa: float, zeta: float, rail_height: float = 0.0
) -> np.ndarray:
    """``(degree + 1, ROW_COLUMNS)`` coefficients of every column in ascending powers of xi, from
    the generated tables of the bridge element (``svbi.runtime.model.contact_rows``)."""
    return _row_table(bridge_row_tables(le, speed, dt, kappa, zeta)[1], shape_tables(le, rail_height))


def _row_table(rows: dict[str, np.ndarray], shapes: dict[str, np.ndarray] | None) -> np.ndarray:
    """The C loop's row table from the discrete row's tables and the shape tables (zeros without)."""
    tables = {**(shapes or {k: np.zeros((4, 6)) for k in ("N0", "T0", "T1")}), **rows}
    out = np.hstack([tables[name] for name in ROW_TABLES])
    assert out.shape == (row_structure()[0] + 1, ROW_COLUMNS)
    return out


def row_coefficients_changing_speed(
    le: float, dt: float, kappa: float, zeta: float, rail_height: float = 0.0
) -> np.ndarray:
    """``(4, degree + 1, ROW_COLUMNS)``: the tables ``T0, T1, T2, Ta`` with which the contact rows of
    a train at speed v and acceleration a are ``T0 + v T1 + v^2 T2 + a Ta``
    (``contact_rows.bridge_row_tables_changing_speed``; the shape rows are in ``T0`` alone)."""
    parts = bridge_row_tables_changing_speed(le, dt, kappa, zeta)
    return np.stack(
        [_row_table(p, shape_tables(le, rail_height) if k == 0 else None) for k, p in enumerate(parts)]
    )


# --------------------------------------------------------------------------------------------------
# sources: static C plus the generated glue


CSRC = "csrc"
"""Package-data folder of :mod:`svbi.runtime` holding the static C of the loop."""


@dataclass(frozen=True)
class LoopSpec:
    """What one loop library is specialised for."""

    model: str
    """Vehicle topology name (built-in) or path; "moving-load" for prescribed axle forces."""
    nv: int
    """Vehicle DOFs per car (0 for moving loads)."""
    nw: int
    """Wheels per car (0: runtime, moving loads)."""

    @property
    def c_name(self) -> str:
        return c_identifier(self.model.rsplit("/", 1)[-1].removesuffix(".toml"))

    @property
    def moving_load(self) -> bool:
        return self.nv == 0


def loop_spec(train: Any) -> LoopSpec:
    """The :class:`LoopSpec` of a :class:`svbi.runtime.model.train.Train`."""
    name = train.topology_name or ("moving-load" if train.moving_load else "vehicle")
    if train.moving_load:
        return LoopSpec(name, 0, 0)
    return LoopSpec(name, int(train.ndof), int(train.wheels))


CSRC_3D = "loop3d"
"""Subfolder of ``runtime/csrc/`` holding the 3D loop (its own library, beside the 2D loop's layers:
:mod:`svbi.runtime.backends.c.stepper3d`)."""
CSRC_LAYERS = ("core", "step", "methods", "loop")
"""Subfolders of ``runtime/csrc/``, bottom to top: a file calls only files of its own layer or below
(docs/c-backend.md; tests/architecture/test_c_layers.py)."""


def static_sources() -> dict[str, bytes]:
    """``{file name: bytes}`` of the static C of the loop (``runtime/csrc/<layer>/*.c, *.h``), flat:
    the layers are folders of the package, their file names unique, and the library (and an
    export) is built from one flat folder."""
    folder = resources.files("svbi.runtime").joinpath(CSRC)
    files: dict[str, bytes] = {}
    for layer in CSRC_LAYERS:
        for p in sorted(folder.joinpath(layer).iterdir(), key=lambda p: p.name):
            if p.name.endswith((".c", ".h")):
                if p.name in files:
                    raise RuntimeError(f"runtime/csrc: {p.name} in two layers")
                files[p.name] = p.read_bytes()
    return dict(sorted(files.items()))


def _committed(folder: str, names: tuple[str, ...]) -> dict[str, bytes] | None:
    """Files of ``generated/<folder>/``, or None when one is missing."""
    root = generated_root() / folder
    paths = [root / n for n in names]
    if not all(p.is_file() for p in paths):
        return None
    return {p.name: p.read_bytes() for p in paths}


def _topology_matches(header: bytes, spec: LoopSpec) -> bool:
    text = header.decode()
    return f"#define SVBI_NV {spec.nv} " in text and f"#define SVBI_NW {spec.nw} " in text


def glue_sources(spec: LoopSpec, embedded: bool = False) -> dict[str, bytes]:
    """The generated glue of one topology: the committed files for built-in models (no Jinja2 or
    CasADi import); for a topology file, its ``svbi_topology.h`` rendered now by
    :mod:`svbi.codegen.loop_glue`. ``embedded``: the embedded-target variant of the CasADi creep law
    (rendered now)."""
    files = _committed(SOLVER_FOLDER, (TYPES_HEADER,))
    if files is None:
        from ....codegen import loop_glue  # generation: Jinja2 (a source tree without generated/)

        files = loop_glue.solver_types()
    bridge_names = (ROWS_HEADER,) if spec.moving_load else (ROWS_HEADER, *CREEP_FILES)
    bridge = None if embedded and not spec.moving_load else _committed(BRIDGE_FOLDER, bridge_names)
    if bridge is None:
        from ....codegen import loop_glue  # generation: Jinja2, SymPy, CasADi (the embedded creep law)

        bridge = loop_glue.contact_rows()
        if not spec.moving_load:
            bridge.update(loop_glue.creep_split_sources(embedded))
    files.update(bridge)
    folder = MOVING_LOAD_FOLDER if spec.moving_load else spec.model
    topology = _committed(folder, (TOPOLOGY_HEADER,)) if "/" not in folder else None
    if topology is None or not _topology_matches(topology[TOPOLOGY_HEADER], spec):
        from ....codegen import loop_glue  # generation: Jinja2 (a topology file's sizes)

        topology = loop_glue.topology(spec.model, spec.nv, spec.nw)
    files.update(topology)
    return files


def render_sources(spec: LoopSpec, embedded: bool = False) -> dict[str, bytes]:
    """``{file name: bytes}`` of the loop library of one vehicle topology: the static C of
    ``runtime/csrc`` and the generated glue (:func:`glue_sources`), one flat folder."""
    return {**static_sources(), **glue_sources(spec, embedded)}


class LoopLibrary:
    """The compiled loop of one topology, with typed entry points."""

    def __init__(self, spec: LoopSpec, library: ctypes.CDLL) -> None:
        self.spec = spec
        self._library = library
        self.workspace = library.svbi_solver_workspace
        self.workspace.argtypes = [
            ctypes.POINTER(Setup),
            ctypes.POINTER(ctypes.c_long),
            ctypes.POINTER(ctypes.c_long),
        ]
        self.workspace.restype = ctypes.c_int
        self.init = library.svbi_solver_init
        self.init.argtypes = [ctypes.POINTER(Setup), ctypes.c_void_p, ctypes.c_void_p]
        self.init.restype = ctypes.c_int
        self.run = library.svbi_solver_run
        self.run.argtypes = [
            ctypes.POINTER(Setup),
            ctypes.POINTER(State),
            ctypes.POINTER(Excitation),
            ctypes.POINTER(Outputs),
            ctypes.c_void_p,
            ctypes.c_void_p,
            ctypes.c_long,
            ctypes.c_long,
            ctypes.POINTER(Info),
        ]
        self.run.restype = ctypes.c_int


_LIBRARIES: dict[LoopSpec, LoopLibrary] = {}

LOOP_FLAGS = (*STRICT_FLAGS, CASADI_WARNING_EXCEPTION, "-O3", "-fPIC", "-shared")
"""Flags of the loop library (then ``$SVBI_CFLAGS``). The CasADi kernels linked in (creep law) need
their one exception (svbi.codegen.c_flags)."""


@cache
def simd_flags() -> tuple[str, ...]:
    """``-mavx2 -ffp-contract=off`` when this is an x86-64 Linux machine whose CPU has AVX2 (and
    ``SVBI_SIMD`` is not ``0``); else nothing.

    The loop is compiled on the machine that runs it, so it may use what the CPU has. Its lane loops
    (four spans, four cars) then take one AVX2 instruction where SSE2 takes two: about 9 % off the
    paper step (benchmarks/bench_solver.py). Contraction stays off, so the results do not depend on
    the instruction set: a plain SSE2 build and the exported solver give the same bits here.
    """
    import platform

    if os.environ.get("SVBI_SIMD", "1") == "0" or platform.machine().lower() not in ("x86_64", "amd64"):
        return ()
    try:
        with open("/proc/cpuinfo", encoding="ascii", errors="replace") as f:
            flags = next((line.split(":", 1)[1].split() for line in f if line.startswith("flags")), [])
    except OSError:
        return ()
    return ("-mavx2", "-ffp-contract=off") if "avx2" in flags else ()


def load_loop(spec: LoopSpec) -> LoopLibrary:
    """Collect the sources, compile them (cached) and load the loop library of a topology.

    Raises :class:`svbi.runtime.toolchain.CompilerError` when no C compiler works.
    """
    if spec not in _LIBRARIES:
        flags = (*LOOP_FLAGS, *simd_flags(), *shlex.split(os.environ.get("SVBI_CFLAGS", "")))
        library = kernel_cache.load_library(render_sources(spec), f"svbi_{spec.c_name}_solver", flags=flags)
        _LIBRARIES[spec] = LoopLibrary(spec, library)
    return _LIBRARIES[spec]


def pointer(array: np.ndarray | None) -> int | None:
    """Address of a C-contiguous array's data (None for an absent array)."""
    if array is None:
        return None
    if not array.flags.c_contiguous:
        raise ValueError("the C loop needs C-contiguous arrays")
    return array.ctypes.data

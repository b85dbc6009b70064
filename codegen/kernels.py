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
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cache
from typing import Any

import sympy as sp

_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")

FRAME2D = "frame2d"
"""Model name of the bridge frame element kernels (:func:`beam_kernels`)."""


class KernelError(ValueError):
    """A kernel specification is malformed; the message names the kernel and the problem."""


def c_identifier(name: str) -> str:
    """C-safe spelling of a model name: ``pioneer-2d`` -> ``pioneer_2d``."""
    ident = re.sub(r"[^A-Za-z0-9_]", "_", name)
    if not ident or ident[0].isdigit():
        ident = "m_" + ident
    return ident


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
# Built-in models
# ---------------------------------------------------------------------------------------------

KernelFactory = Callable[[Any], "KernelSpec | None"]
"""Builds one kernel of a vehicle model, or returns None when it does not apply to that model."""

VEHICLE_KERNELS: dict[str, KernelFactory] = {}
"""Registry of vehicle kernels, in emission order. Add an entry to add a kernel to every vehicle."""

BEAM_KERNELS: dict[str, Callable[[], KernelSpec | None]] = {}
"""Registry of bridge-element (``frame2d``) kernels, in emission order."""


def vehicle_kernel(name: str) -> Callable[[KernelFactory], KernelFactory]:
    def register(fn: KernelFactory) -> KernelFactory:
        VEHICLE_KERNELS[name] = fn
        return fn

    return register


def beam_kernel(name: str) -> Callable[[Callable[[], KernelSpec | None]], Callable[[], KernelSpec | None]]:
    def register(fn: Callable[[], KernelSpec | None]) -> Callable[[], KernelSpec | None]:
        BEAM_KERNELS[name] = fn
        return fn

    return register


def column(symbols: Sequence[sp.Symbol]) -> sp.ImmutableMatrix:
    return sp.ImmutableMatrix(list(symbols))


def sample_of(values: Mapping[str, Any]) -> dict[str, float]:
    return {k: float(v) for k, v in values.items() if isinstance(v, (int, float))}

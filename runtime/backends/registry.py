"""Which stepper runs a method on a backend: ``"numpy"`` (the reference, ``svbi.runtime.methods``),
``"c"`` (the whole loop in C, :mod:`.c.stepper`) and ``"casadi"`` (:mod:`.casadi`). Each backend
module offers ``steppers()``, ``{method: stepper class}``; a stepper has ``__init__(model, state)``,
``step(n) -> State`` and a ``contacts`` attribute (the geometry of the last step). A stepper that
also has ``run_loop(recorder, guard, bar)`` runs the whole loop itself (the C loop, in chunks of
steps); a ``backend`` attribute on the stepper overrides the name recorded in the results (a
fallback says so). :func:`register_backend` adds or replaces a backend (tests, plugins)."""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping
from typing import Any

from ..methods.steppers import numpy_steppers
from . import casadi
from .base import BackendFallback
from .c import stepper as c_stepper

_BACKENDS: dict[str, dict[str, Callable[..., Any]]] = {}
_WARNED: set[str] = set()


def register_backend(name: str, steppers: Mapping[str, Callable[..., Any]]) -> None:
    """Register a backend: ``steppers`` maps each method name to a stepper class."""
    _BACKENDS[name] = dict(steppers)


def unregister_backend(name: str) -> None:
    """Forget a backend registered with :func:`register_backend` (a built-in one comes back on its
    next use)."""
    _BACKENDS.pop(name, None)


def stepper_class(backend: str, method: str) -> tuple[str, Callable[..., Any]]:
    """The stepper for ``method`` on ``backend``, or the NumPy one (warning once)."""
    if "numpy" not in _BACKENDS:
        register_backend("numpy", numpy_steppers())
    if backend == "c" and "c" not in _BACKENDS:
        register_backend("c", c_stepper.steppers())  # the whole loop in C (docs/c-backend.md)
    if backend == "casadi" and "casadi" not in _BACKENDS:
        register_backend("casadi", casadi.steppers())
    if backend not in _BACKENDS or method not in _BACKENDS[backend]:
        if backend not in _WARNED:
            _WARNED.add(backend)
            warnings.warn(
                f"solver.backend = {backend!r} is not available in this version; running the NumPy "
                "backend (same results, slower)",
                BackendFallback,
                stacklevel=3,
            )
        backend = "numpy"
    return backend, _BACKENDS[backend][method]

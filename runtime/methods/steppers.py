"""The NumPy reference steppers by method name: the ``"numpy"`` backend, and the steppers the
compiled backends hand their event steps to."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from .coupled_classic import CoupledClassic
from .coupled_dynamic import CoupledDynamic
from .localized import LocalizedDynamic


def numpy_steppers() -> dict[str, Callable[..., Any]]:
    """``{method: stepper class}``: each takes ``(model, state)`` and has ``step(n) -> State``."""
    return {
        "localized-dynamic": LocalizedDynamic,
        "coupled-dynamic": CoupledDynamic,
        "coupled-classic": CoupledClassic,
    }

"""The ``"casadi"`` backend: the NumPy loop with the contact rows evaluated by CasADi.

The per-step symbolic content of every method is the contact rows: ``W_N^B`` and its
x-derivatives, and the discrete aux-bridge row ``(W_hat, h_B)`` of ``svbi.codegen.constraints``.
This backend evaluates them with the serialized CasADi Functions of the ``frame2d`` model
(``load_kernels("frame2d", backend="casadi")``: ``contact_rows`` and ``discrete_bridge_row``),
mapped over all contacts in one call per step, instead of the polynomial tables of
``svbi.runtime.model.contact_rows``; everything else is the NumPy stepper. ``h_B`` is linear in the histories
and the irregularity, so its coefficients are the row evaluated at unit inputs (one mapped call).
It exists to cross-check the CasADi Functions inside the loop; it is slow.
"""

from __future__ import annotations

from functools import cache
from typing import Any

import numpy as np

from ...codegen.loop_abi import METHOD_CODES
from ..methods.steppers import numpy_steppers
from ..model.contact_rows import ContactRows
from ..model.system import Model, State
from ..toolchain import load_kernels

UNIT_INPUTS = 2 + 6 + 6 + 3
"""history (P_ug, Q_ug), P_ue, Q_ue, track (r, r', r''): the inputs ``h_B`` is linear in."""


@cache
def _functions() -> tuple[Any, Any]:
    k = load_kernels("frame2d", backend="casadi")
    return k["contact_rows"].function, k["discrete_bridge_row"].function


class CasadiContactRows:
    """Drop-in for :class:`svbi.runtime.model.contact_rows.ContactRowKernel`, evaluated by CasADi."""

    def __init__(self, le: float | np.ndarray, speed: float, dt: float, kappa: float, zeta: float) -> None:
        """``le``: the element length, or one per span (a bridge of unequal spans)."""
        self.le, self.speed = np.asarray(le, dtype=float), speed
        self.newmark = np.array([dt, kappa, zeta])
        self._maps: dict[int, tuple[Any, Any]] = {}
        self._units = np.vstack([np.zeros((1, UNIT_INPUTS)), np.eye(UNIT_INPUTS)]).T  # 17 x 18

    def _mapped(self, n: int) -> tuple[Any, Any]:
        if n not in self._maps:
            rows, discrete = _functions()
            self._maps[n] = (rows.map(n), discrete.map(n * (UNIT_INPUTS + 1)))
        return self._maps[n]

    def __call__(
        self, xi: np.ndarray, span: np.ndarray | None = None, v: float | None = None, a: float = 0.0
    ) -> ContactRows:
        """Rows at ``xi`` of the spans ``span`` (each with its element length); the CasADi backend
        runs trains at constant speed, so ``v`` and ``a`` are not needed."""
        xi = np.asarray(xi, dtype=float)
        n = xi.size
        rows, discrete = self._mapped(n)
        m = UNIT_INPUTS + 1
        if self.le.ndim == 0:
            le, les = float(self.le), float(self.le)
        else:  # one element length per contact, as the mapped calls take their arguments
            le = self.le[np.asarray(span)][None, :]
            les = np.repeat(le, m, axis=1)
        N, N_x, N_xx, _, _ = (np.array(v.full()).reshape(n, 6) for v in rows(xi[None, :], le, 0.0))
        units = np.tile(self._units, (1, n))
        xis = np.repeat(xi, m)[None, :]
        out = discrete(xis, les, self.speed, self.newmark, units[0:2], units[2:8], units[8:14], units[14:17])
        W_hat = np.array(out[0].full()).reshape(n, m, 6)[:, 0, :]  # mapped 1x6 rows, side by side
        h = np.array(out[1].full()).reshape(n, m)
        coef = h[:, 1:] - h[:, :1]  # h_B is linear and homogeneous: the unit responses
        return ContactRows(
            N,
            N_x,
            N_xx,
            W_hat.copy(),
            coef[:, 2:8],
            coef[:, 8:14],
            coef[:, 0],
            coef[:, 1],
            coef[:, 14],
            coef[:, 15],
            coef[:, 16],
        )


def casadi_stepper(method: str) -> Any:
    """Stepper factory: the NumPy stepper of ``method`` with CasADi-evaluated contact rows."""

    def make(model: Model, state: State) -> Any:
        stepper = numpy_steppers()[method](model, state)
        old = stepper.rows
        kappa, zeta = (
            (0.0, 0.0) if method == "coupled-classic" else (model.settings.kappa, model.settings.zeta)
        )
        stepper.rows = CasadiContactRows(
            model.bridge.contact_element_length, model.speed, model.dt, kappa, zeta
        )
        assert old.d == stepper.point.d or method == "coupled-classic"
        stepper.backend = "casadi"
        return stepper

    make.__name__ = f"casadi_{method.replace('-', '_')}"
    return make


def steppers() -> dict[str, Any]:
    """The ``"casadi"`` backend's steppers by method (``svbi.runtime.backends.registry``)."""
    return {m: casadi_stepper(m) for m in METHOD_CODES}

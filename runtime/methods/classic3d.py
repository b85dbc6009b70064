"""coupled-classic in 3D (docs/three-d.md, "The 3D time step").

The classic Lagrange-multiplier step of :mod:`svbi.runtime.methods.coupled_classic` for the 3D
system of :mod:`svbi.runtime.methods.coupled3d`: every contact (the two normal gaps and the two
flange gaps of each wheelset) is imposed at the acceleration level, ``g'' = 0`` at t_{n+1}, with the
exact rates of the moving contact (the convective terms included: the 2D classic row, the b-vector
of the paper). The multipliers are the contact forces, the wheel's whole mass rides on the rail (no
auxiliary point), the unknowns are those of the coupled-dynamic step, ``[du_V, u_B, forces]``, solved
by the same Newton iteration (the 3D gap is nonlinear in the roll).

The row is the generated residual kernel with ``c1 = c0 = 0`` (``E = g''``): the coupled-dynamic
step with ``kappa = 0``, so everything else is that step's (creep forces, the contact state with
lift-off, landing and flange contact, the plastic impact of a closing contact, support motion and
the approach track). Nothing pulls a gap back once it has opened, so the gaps drift: Newmark's
truncation of the moving contact, of the irregularities under it and of the rolled cones' nonlinear
gap accumulates without feedback, and a slope kink under a wheel (a span end) leaves a gap rate
that grows the gap linearly. That drift is the point of offering the method (docs/method.md
section 6). A closing contact (a landing, a flange strike) is put back on its rail at the position
level (``g_{n+1} = 0``), as in 2D; a contact held over a step keeps its acceleration-level row.
"""

from __future__ import annotations

from ..model.system3d import System3D
from .coupled3d import CoupledDynamic3D, State3D


class CoupledClassic3D(CoupledDynamic3D):
    """The classic (index-1) monolithic 3D step; see the module docstring."""

    name = "coupled-classic-3d"

    def __init__(
        self,
        system: System3D,
        state: State3D,
        time_step: float,
        kappa: float = 0.0,
        zeta: float = 0.0,
        normal: str = "unilateral",
    ) -> None:
        """``kappa`` and ``zeta`` are accepted for the steps' common signature and not used: the
        classic rows are ``g'' = 0`` (``kappa = 0``), as 2D coupled-classic ignores
        ``solver.constraint_kappa``."""
        del kappa, zeta
        super().__init__(system, state, time_step, 0.0, 0.0, normal)

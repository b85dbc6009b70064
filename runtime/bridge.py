"""The bridge: a chain of identical simply supported spans (paper Section 2.2).

Each span has its own nodes (no node is shared at a joint), 3 DOFs per node ``(u, w, theta)`` and
``elements_per_span`` Euler-Bernoulli frame elements from ``svbi.codegen.beam``. The support DOFs are
kept: the fixed bearing (``u`` and ``w``) at the left end and the sliding bearing (``w``) at the right
end of every span are tied to the ground by constraints (Eqs. 22-24), so an earthquake enters the
bridge as prescribed support motion, synchronous or not.

Rayleigh damping ``C = alpha M + beta K`` is fitted to the first two vertical modes of a span with its
supports held. It acts on the motion *relative to the ground*: the damping force is
``C (u' - T q')``, where ``T q`` is the quasi-static (rigid-body) displacement field that the support
motion ``q`` imposes on a simply supported span. ``K T = 0``, so only ``C T q'`` (in practice
``alpha M T q'``) appears as a known load. Damping in absolute coordinates would resist the
earthquake itself (method-notes pitfall 9).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from svbi.codegen.plain_types import GRAVITY
from svbi.runtime.modes import span_matrices, span_support_dofs

SUPPORT_COMPONENTS = ("longitudinal", "vertical", "vertical")
"""Component of each support constraint of a span, in the order of ``span_support_dofs``."""


@dataclass(frozen=True)
class Location:
    """Where the contact points are: span and element index, local coordinate, on/off the bridge."""

    x: np.ndarray
    on: np.ndarray
    span: np.ndarray
    element: np.ndarray
    xi: np.ndarray

    @property
    def first_dof(self) -> np.ndarray:
        """Span-local index of the first DOF of the element (its 6 DOFs are contiguous)."""
        return 3 * self.element


class Bridge:
    """Numeric matrices of one span (all spans are equal) and the geometry of the span chain."""

    def __init__(
        self,
        spans: int,
        span_length: float,
        mass_per_length: float,
        youngs_modulus: float,
        area: float,
        second_moment: float,
        damping_ratio: float,
        elements_per_span: int,
        rail_height: float = 0.0,
    ) -> None:
        self.spans = int(spans)
        self.span_length = float(span_length)
        self.elements = int(elements_per_span)
        self.element_length = self.span_length / self.elements
        self.mass_per_length = float(mass_per_length)
        self.youngs_modulus = float(youngs_modulus)
        self.area = float(area)
        self.second_moment = float(second_moment)
        self.damping_ratio = float(damping_ratio)
        self.rail_height = float(rail_height)
        self.ndof = 3 * (self.elements + 1)
        self.M, self.K = span_matrices(
            self.span_length, self.elements, youngs_modulus, area, second_moment, mass_per_length
        )
        self.support_dofs = np.array(span_support_dofs(self.elements))
        self.nsupport = len(self.support_dofs)
        self.E = np.zeros((self.ndof, self.nsupport))
        self.E[self.support_dofs, np.arange(self.nsupport)] = 1.0
        self.vertical_frequencies = self._vertical_frequencies()
        self.alpha, self.beta = self._rayleigh(self.damping_ratio)
        self.C = self.alpha * self.M + self.beta * self.K
        self.T = self._quasi_static_field()
        self.CT = self.C @ self.T
        ends = np.where(self.support_dofs == 3 * self.elements + 1, self.span_length, 0.0)
        self.support_x = np.arange(self.spans)[:, None] * self.span_length + ends[None, :]
        """Position of every support constraint, shape ``(spans, nsupport)``."""
        self.dead_load_reactions = self._dead_load_reactions()
        """Support forces carrying the span's own weight, shape ``(nsupport,)`` (results
        ``support_reaction``: the bridge DOFs are measured from this dead-load state)."""

    # ----------------------------------------------------------------------------------------------
    def _vertical_frequencies(self) -> np.ndarray:
        """Circular frequencies (rad/s) of the vertical modes of one span, supports held."""
        free = np.setdiff1d(np.arange(self.ndof), self.support_dofs)
        bending = np.array([i for i in free if i % 3 != 0])
        sub = np.ix_(bending, bending)
        eig = sla.eigh(self.K[sub], self.M[sub], eigvals_only=True)
        return np.sqrt(np.clip(eig, 0.0, None))

    def _rayleigh(self, ratio: float) -> tuple[float, float]:
        """``alpha, beta`` giving the damping ratio on the first two vertical modes."""
        if ratio == 0.0:
            return 0.0, 0.0
        if len(self.vertical_frequencies) < 2:
            w1 = self.vertical_frequencies[0]
            return 0.0, 2 * ratio / w1
        w1, w2 = self.vertical_frequencies[:2]
        return 2 * ratio * w1 * w2 / (w1 + w2), 2 * ratio / (w1 + w2)

    def _dead_load_reactions(self) -> np.ndarray:
        """The consistent gravity load ``-g M e_z`` (``e_z``: unit vertical translation of every
        node) on the span with its supports held: ``R = (K u - f)`` at the support DOFs."""
        ez = np.zeros(self.ndof)
        ez[1::3] = 1.0
        f = -GRAVITY * (self.M @ ez)
        free = np.setdiff1d(np.arange(self.ndof), self.support_dofs)
        u = np.zeros(self.ndof)
        u[free] = sla.solve(self.K[np.ix_(free, free)], f[free], assume_a="sym")
        return (self.K @ u - f)[self.support_dofs]

    def _quasi_static_field(self) -> np.ndarray:
        """``T`` (ndof x nsupport): the rigid-body field of a span for unit support motions."""
        x = np.arange(self.elements + 1) * self.element_length
        L = self.span_length
        T = np.zeros((self.ndof, self.nsupport))
        for col, (dof, comp) in enumerate(zip(self.support_dofs, SUPPORT_COMPONENTS, strict=True)):
            if comp == "longitudinal":
                T[0::3, col] = 1.0
            elif dof == 1:  # left vertical support
                T[1::3, col] = 1.0 - x / L
                T[2::3, col] = -1.0 / L
            else:  # right vertical support
                T[1::3, col] = x / L
                T[2::3, col] = 1.0 / L
        return T

    # ----------------------------------------------------------------------------------------------
    @property
    def length(self) -> float:
        return self.spans * self.span_length

    @property
    def support_vertical(self) -> np.ndarray:
        """Mask of the vertical support constraints, shape ``(nsupport,)``."""
        return np.array([c == "vertical" for c in SUPPORT_COMPONENTS])

    def locate(self, x: np.ndarray) -> Location:
        """Span (``floor(x / L)``, so a point on a joint belongs to the span ahead), element
        (clamped to the span) and local coordinate of the points ``x``. Off the bridge, span,
        element and ``xi`` are clamped placeholders: always use them together with ``on``."""
        x = np.asarray(x, dtype=float)
        span_f = np.floor(x * (1.0 / self.span_length))
        on = (span_f >= 0) & (span_f < self.spans)
        span = np.clip(span_f, 0, self.spans - 1)
        local = (x - span * self.span_length) * (1.0 / self.element_length)
        element = np.clip(np.floor(local), 0, self.elements - 1)
        xi = np.clip(local - element, 0.0, 1.0)
        return Location(x, on, span.astype(np.intp), element.astype(np.intp), xi)

    def midspan_location(self) -> tuple[int, float]:
        """Element and local coordinate of the midspan point (same for every span)."""
        local = 0.5 * self.span_length
        element = min(int(np.floor(local / self.element_length)), self.elements - 1)
        return element, local / self.element_length - element

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
earthquake itself (docs/design.md pitfall 9).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
import scipy.linalg as sla

from ...codegen.plain_types import GRAVITY
from .modes import member_sparse

DENSE_LIMIT = 600
"""Set-up problems (eigenvalues, static solves) on at most this many DOFs use dense LAPACK; larger
ones sparse factorizations and shift-invert Lanczos, whose cost grows linearly with the size."""
TRIM = 1e-14
"""Entries of the quasi-static field below this (per unit support motion) are dropped."""
EDGE_TOL = 1e-17
"""A window of the quasi-static solve is wide enough once the field on its outer substructures is
below this (per unit support motion): three orders below :data:`TRIM`."""
DIRECT_LIMIT = 3000
"""A bridge of at most this many DOFs solves its quasi-static field in one piece (one sparse
factorization of the whole bridge, a dense block of supports at a time); a longer one window by
window (``Bridge._quasi_static_global``)."""
WINDOW_LINES = 8
"""Support lines whose supports share one window (one sparse factorization) of the quasi-static
solve."""

VERTICAL_MODES = 10
"""How many vertical frequencies of a span the paper's bridge keeps (``vertical_frequencies``)."""

SUPPORT_COMPONENTS = ("longitudinal", "vertical", "vertical")
"""Component of each support constraint of a span of the shorthand bridge, in the order of
``span_support_dofs``."""

LONGITUDINAL, VERTICAL, ROTATION = 0, 1, 2
"""Component codes of a support constraint (``Bridge.support_component``)."""
COMPONENT_NAMES = ("longitudinal", "vertical", "rotation")


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


@dataclass(frozen=True)
class Section:
    """A cross-section: mass per length (kg/m), E (Pa), A (m^2), I (m^4) and the damping ratio."""

    mass_per_length: float
    youngs_modulus: float
    area: float
    second_moment: float
    damping_ratio: float


@dataclass(frozen=True)
class Girder:
    """A deck continuous over ``len(spans)`` spans (one span: simply supported)."""

    spans: tuple[float, ...]
    section: Section
    fixed_support: int = 0
    """Which of its support lines (0 = its first) carries the fixed (longitudinal) bearing."""


@dataclass(frozen=True)
class Pier:
    """A pier column under support line ``support`` (0 = first abutment), fixed at its base."""

    support: int
    height: float
    section: Section
    bearing_vertical: float | None = None
    """Stiffness (N/m) of the bearings between the girders and the pier top, vertically; None: rigid."""
    bearing_longitudinal: float | None = None
    """... and longitudinally (the fixed bearing); None: rigid."""


@dataclass(frozen=True)
class SupportTable:
    """The active support constraints as the results list them (dimension ``support``)."""

    flat: np.ndarray
    """Index of each into the ``(nsub, 3)`` support slots, row-major."""
    x: np.ndarray
    sub: np.ndarray
    component: np.ndarray
    dead_load: np.ndarray
    """Reaction carrying the bridge's own weight, N."""


@dataclass
class SubKind:
    """Matrices shared by every substructure (span or pier) with the same geometry, section,
    damping and support layout: sparse (``Ms``, ``Ks``, ``Cs``, what the set-up uses) and dense
    (``M``, ``K``, ``C``, formed on first use by the steppers)."""

    Ms: Any
    Ks: Any
    length: float
    element_length: float
    section: Section
    pier: bool
    support_dofs: np.ndarray
    """Three support slots (DOF of each; meaningful where ``support_active``)."""
    support_active: np.ndarray
    alpha: float
    beta: float

    @cached_property
    def Cs(self) -> Any:
        """Rayleigh damping ``alpha M + beta K``, sparse."""
        return (self.alpha * self.Ms + self.beta * self.Ks).tocsr()

    @cached_property
    def M(self) -> np.ndarray:
        return self.Ms.toarray()

    @cached_property
    def K(self) -> np.ndarray:
        return self.Ks.toarray()

    @cached_property
    def C(self) -> np.ndarray:
        return self.alpha * self.M + self.beta * self.K


@dataclass(frozen=True)
class Links:
    """Constraints ``u[a_sub, a_dof] - u[b_sub, b_dof] = 0`` between substructures: a girder's
    continuity over an interior support (u, w, theta) and the bearings on pier tops (w, and u
    at the fixed bearing). Imposed like the supports, as stabilised gaps (Eq. 22 with no ground)."""

    a_sub: np.ndarray
    a_dof: np.ndarray
    b_sub: np.ndarray
    b_dof: np.ndarray
    kind: tuple[str, ...]
    compliance: np.ndarray
    """0 for a rigid link; ``1 / k`` for a bearing spring of stiffness ``k`` (the link force is then
    ``k (u_b - u_a)`` on end a: the spring, exact and implicit, not a stabilised constraint)."""

    @property
    def spring(self) -> np.ndarray:
        return self.compliance > 0.0

    def __len__(self) -> int:
        return len(self.a_sub)

    def subset(self, keep: np.ndarray) -> Links:
        return Links(
            self.a_sub[keep],
            self.a_dof[keep],
            self.b_sub[keep],
            self.b_dof[keep],
            tuple(k for k, used in zip(self.kind, keep, strict=True) if used),
            self.compliance[keep],
        )

    def flat_dofs(self, ndof: int) -> tuple[np.ndarray, np.ndarray]:
        """Both ends as indices into the substructures' DOFs laid out one after the other."""
        return ndof * self.a_sub + self.a_dof, ndof * self.b_sub + self.b_dof

    def gap(self, X: np.ndarray) -> np.ndarray:
        """``L x``: end a less end b of every link, for ``X`` of shape ``(nsub, ndof)``."""
        return X[self.a_sub, self.a_dof] - X[self.b_sub, self.b_dof]

    def load(self, force: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
        """``L^T force`` (``+force`` on end a, ``-force`` on end b) as ``(nsub, ndof)`` loads."""
        out = np.zeros(shape)
        np.add.at(out, (self.a_sub, self.a_dof), force)
        np.add.at(out, (self.b_sub, self.b_dof), -force)
        return out

    def targets(self, point: Any, P: np.ndarray, Q: np.ndarray) -> np.ndarray:
        """The gap every link must have at t_{n+1}: a rigid link's stabilised row (the point row of
        Eq. 22 with no ground: target 0, histories ``L P``, ``L Q``); 0 for a bearing spring,
        whose force is elastic, not a constraint's."""
        return np.where(self.spring, 0.0, point.target(self.gap(P), self.gap(Q), 0.0, 0.0, 0.0))


def lowest_eigenvalues(K: Any, M: Any, count: int) -> np.ndarray:
    """The ``count`` lowest eigenvalues (ascending) of ``K x = lambda M x``, ``K`` and ``M``
    sparse symmetric, ``K`` positive definite: shift-invert Lanczos (one sparse factorization)
    from a fixed start vector, so that the result is reproducible, then Rayleigh-Ritz on its
    vectors. The shift sits just below the lowest eigenvalue (:func:`_below_lowest`): a long
    continuous girder has hundreds of modes within a few per cent of its first, which Lanczos
    about 0 separates only after thousands of steps."""
    import scipy.sparse.linalg as spla

    n = K.shape[0]
    K, M = K.tocsc(), M.tocsc()
    _, X = spla.eigsh(K, k=count, M=M, sigma=_below_lowest(K, M), which="LM", v0=np.ones(n))
    # Rayleigh-Ritz on the converged vectors: Lanczos's tolerance is relative to the largest
    # shift-inverted value, which leaves the modes far from the shift less accurate than their
    # vectors; the Ritz values of the vectors are accurate to the square of the vectors' error
    a, b = X.T @ (K @ X), X.T @ (M @ X)
    return sla.eigh(0.5 * (a + a.T), 0.5 * (b + b.T), eigvals_only=True)


BAND_LIMIT = 64
"""Widest band (in DOFs) for which :func:`_below_lowest` brackets the lowest eigenvalue."""


def _below_lowest(K: Any, M: Any, rtol: float = 1e-7) -> float:
    """A shift a little below the lowest eigenvalue of ``K x = lambda M x``: bisection on whether
    ``K - sigma M`` is positive definite (a banded Cholesky factorization, linear in the size),
    from an upper bound (the Rayleigh quotient after a few inverse iterations) down to a bracket
    of ``rtol``; the shift is the bracket's lower end less ``rtol`` of the bound. 0 where the
    matrices are not banded in their order."""
    import scipy.sparse.linalg as spla

    pattern = (abs(K) + abs(M)).tocoo()  # the sum drops stored zeros
    width = int(np.max(pattern.col - pattern.row, initial=0))
    if width > BAND_LIMIT:
        return 0.0
    n = K.shape[0]

    def band(a: Any) -> np.ndarray:
        a = a.tocoo()
        upper = (a.col >= a.row) & (a.data != 0.0)
        out = np.zeros((width + 1, n))
        out[width + a.row[upper] - a.col[upper], a.col[upper]] = a.data[upper]
        return out

    k_band, m_band = band(K), band(M)
    lu = spla.splu(K.tocsc())
    x = np.ones(n)
    for _ in range(5):
        x = lu.solve(M @ x)
        x /= np.abs(x).max()
    hi, lo = float(x @ (K @ x)) / float(x @ (M @ x)), 0.0
    while hi - lo > rtol * hi:
        mid = 0.5 * (lo + hi)
        try:
            sla.cholesky_banded(k_band - mid * m_band)
            lo = mid
        except np.linalg.LinAlgError:
            hi = mid
    return lo - rtol * hi


def _circular_frequencies(M: Any, K: Any, dofs: np.ndarray, count: int | None = None) -> np.ndarray:
    """Circular frequencies (rad/s, ascending) of ``K x = w^2 M x`` on the DOFs ``dofs``: all of
    them (``count`` None), or the lowest ``count``. ``M``, ``K`` sparse or dense; a problem above
    :data:`DENSE_LIMIT` DOFs asked for a few modes goes to :func:`lowest_eigenvalues`."""
    n = len(dofs)
    if count is not None and n > DENSE_LIMIT and count < n - 1:
        k = K.tocsr()[dofs][:, dofs]
        m = M.tocsr()[dofs][:, dofs]
        lam = lowest_eigenvalues(k, m, count)
    else:
        dense_k = K.toarray() if hasattr(K, "toarray") else K
        dense_m = M.toarray() if hasattr(M, "toarray") else M
        sub = np.ix_(dofs, dofs)
        lam = sla.eigh(dense_k[sub], dense_m[sub], eigvals_only=True)
        lam = lam if count is None else lam[:count]
    return np.sqrt(np.clip(lam, 0.0, None))


def _columns(rows: Any, columns: tuple[np.ndarray, ...], position: np.ndarray) -> list[Any]:
    """The columns ``columns[i]`` of the COO matrix ``rows``, one CSR matrix for each, in time
    linear in their entries (``rows[:, cols]`` of SciPy costs a pass over every column of the
    matrix). ``position``: -1 for every column of ``rows``, left so."""
    import scipy.sparse as sps

    out = []
    for cols in columns:
        position[cols] = np.arange(len(cols))
        at = position[rows.col]
        keep = at >= 0
        out.append(
            sps.csr_matrix((rows.data[keep], (rows.row[keep], at[keep])), shape=(rows.shape[0], len(cols)))
        )
        position[cols] = -1
    return out


def _all_entries(a: np.ndarray) -> Any:
    """Every entry of the dense matrix ``a``, zeros included, row by row, as COO."""
    import scipy.sparse as sps

    n, m = a.shape
    rows, cols = np.divmod(np.arange(n * m), m)
    return sps.coo_matrix((a.ravel(), (rows, cols)), shape=(n, m))


def _section_args(section: Section) -> tuple[float, float, float, float]:
    """A section as the generated element kernels take it."""
    return (section.youngs_modulus, section.area, section.second_moment, section.mass_per_length)


def _gravity_reactions(
    M: Any, K: Any, vertical: np.ndarray, held: np.ndarray, free: np.ndarray, solve_free: Any
) -> np.ndarray:
    """The consistent gravity load ``f = -g M e_z`` (``vertical``: unit vertical translation of
    every node) with the ``held`` DOFs fixed: ``R = (K u - f)`` there, ``u_f = solve_free(f_f)``
    (``K_ff`` factored by the caller)."""
    f = -GRAVITY * (M @ vertical)
    u = np.zeros(len(vertical))
    u[free] = solve_free(f[free])
    return (K @ u - f)[held]


class Bridge:
    """The bridge as substructures: its spans (each with its own nodes, ``elements_per_span``
    frame elements) and its pier columns (as many column elements), joined by :class:`Links` and
    tied to the ground by support constraints (Eqs. 22-24).

    ``Bridge(spans, span_length, ...)`` is the shorthand chain of identical simply supported spans
    (the paper's bridge). ``girders``/``piers`` give the long form (``docs/scenario.md``); a long
    form without piers whose girders are single equal spans of the default section builds the
    same arrays as the shorthand. Substructure ``s < spans`` is span ``s``; then the piers in
    their given order.

    ``matrices=False`` stops after the layout (sizes, supports, links, positions): what sizes a
    run (``svbi.runtime.run.memory``) without building any matrix. Everything that set-up builds is
    sparse or banded, its cost linear in the spans, piers and elements (``docs/performance.md``).
    """

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
        girders: list[Girder] | None = None,
        piers: list[Pier] | None = None,
        matrices: bool = True,
    ) -> None:
        default = Section(
            float(mass_per_length),
            float(youngs_modulus),
            float(area),
            float(second_moment),
            float(damping_ratio),
        )
        if girders is None:
            girders = [Girder((float(span_length),), default)] * int(spans)
        self.girders = list(girders)
        self.piers = list(piers or [])
        self.elements = int(elements_per_span)
        self._frequency_cache: dict[tuple, np.ndarray] = {}
        self.rail_height = float(rail_height)
        self.ndof = 3 * (self.elements + 1)
        self.span_lengths = np.array([length for g in self.girders for length in g.spans], dtype=float)
        self.spans = len(self.span_lengths)
        self.nsub = self.spans + len(self.piers)
        self.span_starts = np.concatenate([[0.0], np.cumsum(self.span_lengths)[:-1]])
        self.line_x = np.concatenate([[0.0], np.cumsum(self.span_lengths)])
        """Position of every support line (abutments and piers), ``spans + 1`` entries."""
        self.span_girder = np.repeat(np.arange(len(self.girders)), [len(g.spans) for g in self.girders])
        self.uniform = (
            not self.piers
            and all(len(g.spans) == 1 and g.fixed_support == 0 for g in self.girders)
            and len({(g.spans, g.section) for g in self.girders}) == 1
        )
        """The paper's bridge: identical simply supported spans on rigid supports, fixed bearing
        on the left (what the C backend runs)."""
        self._build(matrices)

    # ----------------------------------------------------------------------------------------------
    def _build(self, matrices: bool = True) -> None:
        ne, nd = self.elements, self.ndof
        pier_at = {p.support: i for i, p in enumerate(self.piers)}
        for p in self.piers:
            if not 0 <= p.support <= self.spans:
                raise ValueError(f"pier support line {p.support} is not one of 0..{self.spans}")
        sup_dof = np.zeros((self.nsub, 3), dtype=np.intp)
        sup_dof[:] = [0, 1, 3 * ne + 1]
        sup_comp = np.tile([LONGITUDINAL, VERTICAL, VERTICAL], (self.nsub, 1))
        sup_active = np.zeros((self.nsub, 3), dtype=bool)
        sup_x = np.zeros((self.nsub, 3))
        links: list[tuple[int, int, int, int, str, float]] = []
        top = 3 * ne  # a pier's top node: u at 3 ne, w at 3 ne + 1

        def hold(span: int, slot: int, dof: int, line: int, what: str) -> None:
            """A bearing of ``span`` on support line ``line``: to the ground, or to a pier top."""
            sup_dof[span, slot] = dof
            sup_x[span, slot] = self.line_x[line]
            if line in pier_at:
                p = self.piers[pier_at[line]]
                k = p.bearing_longitudinal if what == "u" else p.bearing_vertical
                pier = self.spans + pier_at[line]
                links.append(
                    (
                        span,
                        dof,
                        pier,
                        top + (0 if what == "u" else 1),
                        f"bearing-{what}",
                        1.0 / k if k else 0.0,
                    )
                )
            else:
                sup_active[span, slot] = True

        s0 = 0
        for g in self.girders:
            k = len(g.spans)
            if not 0 <= g.fixed_support <= k:
                raise ValueError(f"fixed_support {g.fixed_support} is not one of the girder's lines 0..{k}")
            for j in range(k):
                s = s0 + j
                if j == 0:
                    hold(s, 1, 1, s, "w")
                else:  # continuous over the interior support: the start node follows the span behind
                    links += [(s - 1, 3 * ne + d, s, d, f"continuity-{n}", 0.0) for d, n in enumerate("uwt")]
                hold(s, 2, 3 * ne + 1, s + 1, "w")
                if g.fixed_support == 0 and j == 0:
                    hold(s, 0, 0, s, "u")
                elif g.fixed_support == j + 1:  # an interior line: on the span behind (continuity)
                    hold(s, 0, 3 * ne, s + 1, "u")
            s0 += k
        for i, p in enumerate(self.piers):
            sub = self.spans + i
            sup_dof[sub] = [0, 1, 2]
            sup_comp[sub] = [LONGITUDINAL, VERTICAL, ROTATION]
            sup_active[sub] = True
            sup_x[sub] = self.line_x[p.support]
        self.support_dof = sup_dof
        self.support_component = sup_comp
        self.support_active = sup_active
        self.support_x_all = sup_x
        """Position of every support slot, ``(nsub, 3)`` (see ``support_active``)."""
        la = np.array(links, dtype=object).reshape(-1, 6)
        self.links = Links(
            la[:, 0].astype(np.intp),
            la[:, 1].astype(np.intp),
            la[:, 2].astype(np.intp),
            la[:, 3].astype(np.intp),
            tuple(la[:, 4]),
            la[:, 5].astype(float),
        )
        self.span_length = float(self.span_lengths[0])
        """The spans' length (the paper's bridge); the first span's otherwise."""
        if not matrices:
            return
        self._kinds()
        if self.uniform:
            k0 = self.kinds[0]
            self.element_length = k0.element_length
            self.mass_per_length = k0.section.mass_per_length
            self.youngs_modulus = k0.section.youngs_modulus
            self.area = k0.section.area
            self.second_moment = k0.section.second_moment
            self.damping_ratio = k0.section.damping_ratio
            self.alpha, self.beta = k0.alpha, k0.beta
            self.support_dofs = k0.support_dofs
            self.nsupport = 3
            self.E = np.zeros((nd, 3))
            self.E[self.support_dofs, np.arange(3)] = 1.0
            self.vertical_frequencies = self.girder_frequencies(self.girders[0], VERTICAL_MODES)
            """The lowest vertical circular frequencies (rad/s) of a span on its supports."""
            self.T = self._quasi_static_field()
            self.CT = self.C @ self.T if nd <= DENSE_LIMIT else k0.Cs @ self.T
            self.support_x = sup_x
            """Position of every support constraint, shape ``(spans, nsupport)``."""
            self.dead_load_reactions = self._dead_load_reactions()
            """Support forces carrying the span's own weight, shape ``(nsupport,)`` (results
            ``support_reaction``: the bridge DOFs are measured from this dead-load state)."""
        else:
            self._global()

    # the paper's bridge: the matrices of its one span kind (dense, formed on first use)
    @property
    def M(self) -> np.ndarray:
        return self._span_kind().M

    @property
    def K(self) -> np.ndarray:
        return self._span_kind().K

    @property
    def C(self) -> np.ndarray:
        return self._span_kind().C

    def _span_kind(self) -> SubKind:
        if not self.uniform:
            raise AttributeError("only the paper's bridge (one span kind) has Bridge.M, K, C; use kinds")
        return self.kinds[0]

    def _kinds(self) -> None:
        """Group the substructures by everything their matrices depend on."""
        ne = self.elements
        keys: dict[tuple, int] = {}
        self.kinds: list[SubKind] = []
        kind = np.zeros(self.nsub, dtype=np.intp)
        girder_damping = [
            self._rayleigh(self.girder_frequencies(g, 2), g.section.damping_ratio) for g in self.girders
        ]
        for s in range(self.nsub):
            if s < self.spans:
                g = self.girders[self.span_girder[s]]
                length, section, pier = float(self.span_lengths[s]), g.section, False
                alpha, beta = girder_damping[self.span_girder[s]]
            else:
                p = self.piers[s - self.spans]
                length, section, pier = p.height, p.section, True
                alpha, beta = self._rayleigh(self._pier_frequencies(p, 2), section.damping_ratio)
            key = (
                pier,
                length,
                section,
                tuple(self.support_dof[s]),
                tuple(self.support_active[s]),
                alpha,
                beta,
            )
            if key not in keys:
                names = ("column_mass", "column_stiffness") if pier else ("element_mass", "element_stiffness")
                M, K = member_sparse(names, length, ne, _section_args(section))
                keys[key] = len(self.kinds)
                self.kinds.append(
                    SubKind(
                        M,
                        K,
                        length,
                        length / ne,
                        section,
                        pier,
                        self.support_dof[s].copy(),
                        self.support_active[s].copy(),
                        alpha,
                        beta,
                    )
                )
            kind[s] = keys[key]
        self.kind = kind
        self.kind_members = [np.flatnonzero(kind == k) for k in range(len(self.kinds))]
        self.span_element_length = self.span_lengths / ne
        self.span_mass_per_length = np.array(
            [self.girders[g].section.mass_per_length for g in self.span_girder], dtype=float
        )

    # ----------------------------------------------------------------------------------------------
    def _girder_matrices(self, g: Girder) -> tuple[Any, Any, list[int]]:
        """A girder alone as one continuous beam (shared nodes): sparse M, K and the DOFs its
        bearings hold on rigid supports (w at every line, u at the fixed line)."""
        import scipy.sparse as sps

        ne = self.elements
        n = 3 * (ne * len(g.spans) + 1)
        parts: tuple[list, list] = ([], [])
        for j, length in enumerate(g.spans):
            pair = member_sparse(("element_mass", "element_stiffness"), length, ne, _section_args(g.section))
            for part, a in zip(parts, pair, strict=True):
                a = a.tocoo()
                part.append((a.data, a.row + 3 * ne * j, a.col + 3 * ne * j))

        def stacked(part: list) -> Any:
            data, r, c = (np.concatenate(x) for x in zip(*part, strict=True))
            return sps.csr_matrix((data, (r, c)), shape=(n, n))

        M, K = stacked(parts[0]), stacked(parts[1])
        held = [3 * ne * j + 1 for j in range(len(g.spans) + 1)] + [3 * ne * g.fixed_support]
        return M, K, held

    def girder_frequencies(self, g: Girder, count: int | None = None) -> np.ndarray:
        """Circular frequencies (rad/s) of the vertical modes of a girder alone on rigid supports:
        all of them, or the lowest ``count`` (its Rayleigh damping is fitted to the first two;
        ``svbi metrics`` filters with the first three). Kept per girder and count."""
        key = (g, count)
        if key not in self._frequency_cache:
            M, K, held = self._girder_matrices(g)
            free = np.setdiff1d(np.arange(M.shape[0]), held)
            self._frequency_cache[key] = _circular_frequencies(M, K, free[free % 3 != 0], count)
        return self._frequency_cache[key]

    def _pier_frequencies(self, p: Pier, count: int | None = None) -> np.ndarray:
        """Circular frequencies (rad/s) of the sway modes of a pier alone, a fixed-base cantilever
        (all, or the lowest ``count``). Kept per height, section and count."""
        key = (p.height, p.section, count)
        if key not in self._frequency_cache:
            M, K = member_sparse(
                ("column_mass", "column_stiffness"), p.height, self.elements, _section_args(p.section)
            )
            dofs = np.arange(3, M.shape[0])
            self._frequency_cache[key] = _circular_frequencies(M, K, dofs[dofs % 3 != 1], count)
        return self._frequency_cache[key]

    @staticmethod
    def _rayleigh(frequencies: np.ndarray, ratio: float) -> tuple[float, float]:
        """``alpha, beta`` giving the damping ratio at the first two circular frequencies."""
        if ratio == 0.0:
            return 0.0, 0.0
        if len(frequencies) < 2:
            w1 = frequencies[0]
            return 0.0, 2 * ratio / w1
        w1, w2 = frequencies[:2]
        return 2 * ratio * w1 * w2 / (w1 + w2), 2 * ratio / (w1 + w2)

    def _dead_load_reactions(self) -> np.ndarray:
        """Support forces carrying one span's own weight (:func:`_gravity_reactions`)."""
        ez = np.zeros(self.ndof)
        ez[1::3] = 1.0
        free = np.setdiff1d(np.arange(self.ndof), self.support_dofs)
        if self.ndof <= DENSE_LIMIT:
            k_ff = self.K[np.ix_(free, free)]
            return _gravity_reactions(
                self.M, self.K, ez, self.support_dofs, free, lambda f: sla.solve(k_ff, f, assume_a="sym")
            )
        import scipy.sparse.linalg as spla

        k0 = self.kinds[0]
        lu = spla.splu(k0.Ks.tocsr()[free][:, free].tocsc())
        return _gravity_reactions(k0.Ms, k0.Ks, ez, self.support_dofs, free, lu.solve)

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
    # the whole bridge as one structure (links merge DOFs): modes, quasi-static field, dead load
    def _global(self) -> None:
        """Global numbering (every link merges two DOFs), the quasi-static field ``T`` of the
        active supports as a sparse map to every substructure DOF, ``C T`` for the damping load
        on the motion relative to the ground, and the dead-load reactions."""
        import scipy.sparse as sps
        import scipy.sparse.linalg as spla

        nd, nsub = self.ndof, self.nsub
        parent = np.arange(nsub * nd)

        def find(i: int) -> int:
            while parent[i] != i:
                parent[i] = parent[parent[i]]
                i = parent[i]
            return i

        L = self.links
        rigid = ~L.spring
        for a_s, a_d, b_s, b_d in zip(
            L.a_sub[rigid], L.a_dof[rigid], L.b_sub[rigid], L.b_dof[rigid], strict=True
        ):
            ra, rb = find(a_s * nd + a_d), find(b_s * nd + b_d)
            if ra != rb:
                parent[max(ra, rb)] = min(ra, rb)
        roots = np.array([find(i) for i in range(nsub * nd)])
        uniq, gmap = np.unique(roots, return_inverse=True)
        self.global_dof = gmap.reshape(nsub, nd)
        """Global DOF of every substructure DOF (links merged), ``(nsub, ndof)``."""
        self.nglobal = len(uniq)
        # the kinds' entries, substructure by substructure (entries a link merges are summed in the
        # order of the substructures); a short bridge takes every entry of its kinds' dense blocks,
        # zeros included, so that SciPy orders its one factorization as it always has
        direct = self.nglobal <= DIRECT_LIMIT
        entries = [
            (_all_entries(kd.M), _all_entries(kd.K)) if direct else (kd.Ms.tocoo(), kd.Ks.tocoo())
            for kd in self.kinds
        ]
        m_parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        k_parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        for s in range(nsub):
            g = self.global_dof[s]
            for parts, a in zip((m_parts, k_parts), entries[self.kind[s]], strict=True):
                parts.append((g[a.row], g[a.col], a.data))
        spring = L.spring
        if spring.any():  # bearing springs join their two DOFs elastically
            ga = self.global_dof[L.a_sub[spring], L.a_dof[spring]]
            gb = self.global_dof[L.b_sub[spring], L.b_dof[spring]]
            k = 1.0 / L.compliance[spring]
            for r, c, v in ((ga, ga, k), (gb, gb, k), (ga, gb, -k), (gb, ga, -k)):
                k_parts.append((r, c, v))
        shape = (self.nglobal, self.nglobal)

        def assembled(parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]]) -> Any:
            r, c, v = (np.concatenate(x) for x in zip(*parts, strict=True))
            return sps.csc_matrix((v, (r, c)), shape=shape)

        self.M_global = assembled(m_parts)
        self.K_global = assembled(k_parts)
        act = self.support_active
        self.support_global = self.global_dof[np.nonzero(act)[0], self.support_dof[act]]
        """Global DOF of every active support constraint (row-major over ``(nsub, 3)``)."""
        if len(np.unique(self.support_global)) != len(self.support_global):
            raise ValueError("two support constraints hold the same DOF (check the piers' support lines)")
        free = np.setdiff1d(np.arange(self.nglobal), self.support_global)
        self.free_global = free
        K = self.K_global
        lu = spla.splu(K[free][:, free].tocsc())
        Tg = self._quasi_static_direct(K, free, lu) if direct else self._quasi_static_global(K.tocsr())
        # per substructure: T_s = Tg[global_dof[s]]; C T as one sparse map (nsub*ndof x nsup)
        self.T_map = Tg[self.global_dof.ravel()].tocsr()
        if direct:  # the block diagonal of every C_s, from the dense blocks (the order of the
            # product's entries, which the C loop sums in, is then that of earlier versions)
            C_blocks = sps.block_diag([self.kinds[self.kind[s]].C for s in range(nsub)], format="csr")
        else:
            c_parts = []
            for k, members in enumerate(self.kind_members):
                c = self.kinds[k].Cs.tocoo()
                at = nd * members[:, None]
                c_parts.append(((at + c.row).ravel(), (at + c.col).ravel(), np.tile(c.data, len(members))))
            r, c, v = (np.concatenate(x) for x in zip(*c_parts, strict=True))
            C_blocks = sps.csr_matrix((v, (r, c)), shape=(nsub * nd, nsub * nd))
        self.CT_map = (C_blocks @ self.T_map).tocsr()
        ez = np.zeros(self.nglobal)
        for s in range(nsub):
            ez[self.global_dof[s][1::3]] = 1.0
        self.dead_load_global = _gravity_reactions(self.M_global, K, ez, self.support_global, free, lu.solve)
        """Dead-load reaction of every active support constraint, N."""

    def _support_lines(self) -> tuple[np.ndarray, np.ndarray]:
        """The support lines every substructure spans: ``(first, last)``, a span from its start
        to its end line, a pier at its own line."""
        lines = np.arange(self.spans)
        at = np.array([p.support for p in self.piers], dtype=np.intp)
        return np.concatenate([lines, at]), np.concatenate([lines + 1, at])

    def _quasi_static_direct(self, K: Any, free: np.ndarray, lu: Any, block: int = 64) -> Any:
        """``T`` of a short bridge (at most :data:`DIRECT_LIMIT` DOFs) from the factorization of the
        whole ``K_ff``, a block of supports at a time, trimmed below :data:`TRIM`."""
        import scipy.sparse as sps

        sup = self.support_global
        nsup = len(sup)
        K_fs = K[free][:, sup].tocsc()
        parts = [sps.csc_matrix((np.ones(nsup), (sup, np.arange(nsup))), shape=(self.nglobal, nsup))]
        for j0 in range(0, nsup, block):
            cols = np.arange(j0, min(j0 + block, nsup))
            x = -lu.solve(np.asarray(K_fs[:, cols].todense()))
            x[np.abs(x) < TRIM] = 0.0
            r, c = np.nonzero(x)
            parts.append(sps.csc_matrix((x[r, c], (free[r], cols[c])), shape=(self.nglobal, nsup)))
        self.influence_work = len(free) * nsup
        return sps.csr_matrix(sum(parts[1:], parts[0]))

    def _quasi_static_global(self, K: Any) -> Any:
        """``T``: the static displacement of every global DOF per unit motion of each active support
        (the others held), sparse, entries below :data:`TRIM` dropped.

        A support's field is local: it vanishes a span or two away on simply supported spans and
        decays geometrically along a continuous girder. The supports are taken
        :data:`WINDOW_LINES` support lines at a time, and solved on a window of the bridge around
        them (the substructures within ``margin`` lines; the DOFs outside held) by one sparse
        factorization. The margin doubles until the field on the window's outer substructures is
        below :data:`EDGE_TOL`, where holding the outside changes nothing to round-off; a support
        whose field reaches further (the longitudinal bearing of a continuous girder moves all of
        it) is solved again on a window twice as wide, and the next group starts from the margin
        the local fields needed. Each window has a bounded size, so time and memory are linear in
        the bridge's length. ``self.influence_work`` counts the unknowns solved for times the
        supports solved for (what the tests of that count)."""
        import scipy.sparse as sps
        import scipy.sparse.linalg as spla

        sup = self.support_global
        nsup = len(sup)
        first, last = self._support_lines()
        by_first = np.argsort(first, kind="stable")
        first_sorted = first[by_first]
        held = np.zeros(self.nglobal, dtype=bool)
        held[sup] = True
        position = np.full(self.nglobal, -1, dtype=np.intp)
        sup_sub = np.nonzero(self.support_active)[0]  # substructure of every active support
        group = first[sup_sub] // WINDOW_LINES
        order = np.argsort(group, kind="stable")
        bounds = np.flatnonzero(np.diff(group[order])) + 1
        rows, cols, vals = [sup], [np.arange(nsup)], [np.ones(nsup)]
        start, self.influence_work = 2, 0
        for group_cols in np.split(order, bounds):
            a, b = int(first[sup_sub[group_cols]].min()), int(last[sup_sub[group_cols]].max())
            margin, pending, needed = start, group_cols, None
            while len(pending):
                left, right = a - margin, b + margin
                i0 = np.searchsorted(first_sorted, left - 1, side="left")
                i1 = np.searchsorted(first_sorted, right, side="right")
                cand = by_first[i0:i1]
                win = cand[last[cand] >= left]
                dofs = np.unique(self.global_dof[win].ravel())
                free = dofs[~held[dofs]]
                k_ff, k_fs = _columns(K[free].tocoo(), (free, sup[pending]), position)
                x = -spla.splu(k_ff.tocsc()).solve(k_fs.toarray())
                self.influence_work += x.size
                outer = np.zeros(len(win), dtype=bool)
                if left > 0:
                    outer |= first[win] <= left
                if right < self.spans:
                    outer |= last[win] >= right
                edge = np.unique(self.global_dof[win[outer]].ravel())
                at = np.searchsorted(free, edge)
                at = at[(at < len(free)) & (free[np.minimum(at, len(free) - 1)] == edge)]
                done = np.abs(x[at]).max(axis=0, initial=0.0) <= EDGE_TOL
                if done.any() and outer.any():  # the margin a local field needs
                    needed = margin
                x = x[:, done]
                x[np.abs(x) < TRIM] = 0.0
                r, c = np.nonzero(x)
                rows.append(free[r])
                cols.append(pending[done][c])
                vals.append(x[r, c])
                pending, margin = pending[~done], 2 * margin
            start = needed if needed is not None else start
        shape = (self.nglobal, nsup)
        return sps.csr_matrix(
            (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=shape
        )

    def natural_frequencies(self, count: int = 10) -> np.ndarray:
        """The lowest natural frequencies (Hz) of the whole bridge, supports held."""
        n = len(self.free_global) if not self.uniform else self.spans * (self.ndof - 3)
        if n <= 1500:
            M, K, free = self.assembled()
            k, m = K[np.ix_(free, free)], M[np.ix_(free, free)]
            eig = sla.eigh(k, m, eigvals_only=True, subset_by_index=[0, min(count, len(free)) - 1])
        elif self.uniform:  # independent identical spans: each mode of a span, once per span
            k0 = self.kinds[0]
            free = np.setdiff1d(np.arange(self.ndof), self.support_dofs)
            span = _circular_frequencies(k0.Ms, k0.Ks, free, min(count, len(free))) ** 2
            eig = np.repeat(span, self.spans)[:count]
        else:  # a long bridge: the lowest modes by shift-invert Lanczos on the sparse matrices
            free = self.free_global
            K, M = self.K_global.tocsr(), self.M_global.tocsr()
            eig = lowest_eigenvalues(K[free][:, free], M[free][:, free], min(count, n - 2))
        return np.sqrt(np.clip(eig, 0.0, None)) / (2 * np.pi)

    def assembled(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Dense global ``M``, ``K`` (links merged) and the free DOFs (active supports held)."""
        if self.uniform:
            nd = self.ndof
            n = self.spans * nd
            M, K = np.zeros((n, n)), np.zeros((n, n))
            for s in range(self.spans):
                o = slice(s * nd, (s + 1) * nd)
                M[o, o], K[o, o] = self.M, self.K
            held = (np.arange(self.spans)[:, None] * nd + self.support_dofs[None, :]).ravel()
            return M, K, np.setdiff1d(np.arange(n), held)
        return self.M_global.toarray(), self.K_global.toarray(), self.free_global

    # ----------------------------------------------------------------------------------------------
    # per-step operations on the substructures (the uniform bridge keeps its one-matrix form)
    def per_kind(self, X: np.ndarray, name: str) -> np.ndarray:
        """``X[s] @ kind(s).<name>`` for every substructure row of ``X`` (``nsub x ndof``)."""
        if self.uniform:
            return X @ getattr(self, name)
        out = np.empty_like(X)
        for k, members in enumerate(self.kind_members):
            out[members] = X[members] @ getattr(self.kinds[k], name)
        return out

    def history_load(self, P: np.ndarray, Q: np.ndarray, q1: np.ndarray) -> np.ndarray:
        """The bridge rows' known load ``M P + C Q + C T q'`` (damping on the motion relative to
        the ground), ``nsub x ndof``; ``q1``: the support targets' velocities ``(nsub, 3)``."""
        return self.per_kind(P, "M") + self.per_kind(Q, "C") + self.support_damping_load(q1)

    def support_damping_load(self, q1: np.ndarray) -> np.ndarray:
        if self.uniform:
            return q1 @ self.CT.T
        return (self.CT_map @ q1[self.support_active]).reshape(self.nsub, self.ndof)

    def quasi_static(self, q: np.ndarray) -> np.ndarray:
        """``T q``: the quasi-static field of the support motion ``q`` (or its rates), ``nsub x ndof``."""
        if self.uniform:
            return q @ self.T.T
        return (self.T_map @ q[self.support_active]).reshape(self.nsub, self.ndof)

    def held_values(self, q: np.ndarray) -> np.ndarray:
        """Support targets ``(nsub, 3)`` as the constraint rows take them, flat: 0 in an unused slot."""
        return q.reshape(-1) if self.uniform else np.where(self.support_active, q, 0.0).reshape(-1)

    @property
    def support_table(self) -> SupportTable:
        if self.uniform:
            flat = np.arange(self.spans * 3)
            dead = np.tile(self.dead_load_reactions, self.spans)
            names = np.array(list(SUPPORT_COMPONENTS) * self.spans, dtype=object)
        else:
            flat = np.flatnonzero(self.support_active.ravel())
            dead = self.dead_load_global
            names = np.array([COMPONENT_NAMES[c] for c in self.support_component.ravel()[flat]], dtype=object)
        return SupportTable(flat, self.support_x_all.ravel()[flat], flat // 3, names, dead)

    def reaction_at_supports(self, F: np.ndarray) -> np.ndarray:
        """The support forces for the nodal force residual ``F`` (``nsub x ndof``) of the equations
        of motion: at each active support, summed over the DOFs a link merges with it (the link
        forces cancel), in the order of :attr:`support_table`."""
        if self.uniform:
            return F[:, self.support_dofs].reshape(-1)
        total = np.bincount(self.global_dof.ravel(), weights=F.ravel(), minlength=self.nglobal)
        return total[self.support_global]

    # ----------------------------------------------------------------------------------------------
    @property
    def active_supports(self) -> int:
        """How many support constraints tie the bridge to the ground (results dimension
        ``support``); known from the layout alone."""
        return int(self.support_active.sum())

    @property
    def length(self) -> float:
        return float(self.line_x[-1])

    @property
    def span_mass(self) -> float | np.ndarray:
        """Mass per length of the spans: one value for the paper's bridge, else one per span."""
        return self.mass_per_length if self.uniform else self.span_mass_per_length

    @property
    def contact_element_length(self) -> float | np.ndarray:
        """Element length of the spans: one value for the paper's bridge, else one per span (the
        contact kernels then evaluate each contact with its span's)."""
        return self.element_length if self.uniform else self.span_element_length

    def at_supports(self, X: np.ndarray) -> np.ndarray:
        """The values of ``X`` (``nsub x ndof``) at the support slots, ``(nsub, 3)``."""
        if self.uniform:
            return X[:, self.support_dofs]
        return X[np.arange(self.nsub)[:, None], self.support_dof]

    @property
    def support_vertical(self) -> np.ndarray:
        """Mask of the vertical support constraints, shape ``(nsupport,)`` (uniform bridge)."""
        return np.array([c == "vertical" for c in SUPPORT_COMPONENTS])

    def locate(self, x: np.ndarray) -> Location:
        """Span (``floor(x / L)``, so a point on a joint belongs to the span ahead), element
        (clamped to the span) and local coordinate of the points ``x``. Off the bridge, span,
        element and ``xi`` are clamped placeholders: always use them together with ``on``."""
        x = np.asarray(x, dtype=float)
        if self.uniform:
            span_f = np.floor(x * (1.0 / self.span_length))
            on = (span_f >= 0) & (span_f < self.spans)
            span = np.clip(span_f, 0, self.spans - 1)
            local = (x - span * self.span_length) * (1.0 / self.element_length)
        else:
            on = (x >= 0.0) & (x < self.length)
            span = np.clip(np.searchsorted(self.line_x, x, side="right") - 1, 0, self.spans - 1)
            local = (x - self.span_starts[span]) / self.span_element_length[span]
        element = np.clip(np.floor(local), 0, self.elements - 1)
        xi = np.clip(local - element, 0.0, 1.0)
        return Location(x, on, span.astype(np.intp), element.astype(np.intp), xi)

    def midspan_location(self) -> tuple[int, float]:
        """Element and local coordinate of the midspan point (same for every span: every span has
        ``elements_per_span`` equal elements)."""
        local = 0.5 * self.elements
        element = min(int(np.floor(local)), self.elements - 1)
        return element, local - element

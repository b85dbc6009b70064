"""The 3D bridge: girders over one or several spans, pier columns, bearings and ground supports,
assembled from the generated ``frame3d`` kernels (docs/three-d.md, "The 3D bridge").

The 3D counterpart of :class:`svbi.runtime.model.bridge.Bridge`, described by the same types
(:class:`~svbi.runtime.model.bridge.Girder`, :class:`~svbi.runtime.model.bridge.Pier`) plus a
:class:`~svbi.runtime.model.span3d.Section3D` per girder and per pier. A building block: the 3D
step (:mod:`svbi.runtime.methods.coupled3d`) takes it as its deck (:class:`Deck3D`), runs do not yet.

Layout. Nodes carry ``[u, v, w, phi, theta, psi]`` (the frame element's order). The deck's nodes
come first, girder after girder along the track: a girder over ``k`` spans has ``k
elements_per_span + 1`` nodes (a continuous girder shares its nodes over the interior supports:
continuous in all six DOFs), and two girders meeting at a support line have a node each (a joint).
Then the piers' nodes, base to top, ``elements_per_span`` column elements each (the generated
``column_mass``/``column_stiffness``: the frame element turned to the vertical; its local ``I_y``
(``Section3D.I_y``) bends it along ``x``, its local ``I_z`` along ``y``).

Bearings. At every support line each girder's node there is held vertically (``w``), laterally
(``v``) and in twist (``phi``: a fork, as :mod:`svbi.runtime.model.span3d`), and longitudinally
(``u``) at the girder's fixed line, as the 2D model holds ``w`` and ``u``. On a line with a pier
these are bearings to the pier top (rigid: the two DOFs merged into one; or a spring of the pier's
``bearing_vertical``, ``bearing_longitudinal`` or lateral stiffness); elsewhere supports on the
ground. A pier's base is fixed in all six DOFs. Slopes ``theta`` and ``psi`` of the deck are free
at bearings (simply supported in both planes).

Supports and ground motion. Every held DOF is a :class:`Support3D` with its support line, its
position and its direction: ``x``, ``y``, ``z`` (the three ground components) or ``phi``,
``theta``, ``psi`` (held rotations: the ground does not rotate). The held DOFs are the supports'
motion; the free DOFs' quasi-static (static influence) field is ``T = -K_ff^-1 K_fs`` per unit
support motion (:attr:`Bridge3D.T`), rigid-body for a uniform motion. As in 2D, Rayleigh damping
acts on the motion relative to the ground: its known load is ``C T q'``
(:meth:`Bridge3D.support_damping_load`).

Damping. ``C = alpha M + beta K`` per girder and per pier, ``alpha``, ``beta`` those of the 2D
bridge (fitted to the first two vertical modes of the girder alone on rigid supports, and to the
first two longitudinal sway modes of the pier), so the vertical plane is the 2D model's; the same
``alpha``, ``beta`` act on the lateral and torsional motion. Bearing springs carry no damping.

Dense matrices (a prototype for bridges of a few spans); the quasi-static field of the supports
comes from one sparse factorization of the free DOFs' stiffness.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sps
import scipy.sparse.linalg as spla

from .bridge import Bridge, Girder, Pier, Section
from .kernels import FRAME3D, load
from .span3d import NODE_DOFS, Section3D, element_matrices

GROUND_DIRECTIONS = ("x", "y", "z")
"""The ground-motion components of a support (longitudinal, lateral, vertical)."""
DIRECTIONS = ("x", "y", "z", "phi", "theta", "psi")
"""Direction of a held DOF, in the order of :data:`NODE_DOFS`."""
BEARING = {"z": "w", "y": "v", "phi": "phi", "x": "u"}
"""The deck DOF a bearing of each direction holds."""


@dataclass(frozen=True)
class Support3D:
    """A DOF held by the ground: its support line (0 = the first abutment), position along the
    bridge (m), direction (:data:`DIRECTIONS`), global DOF and what it holds."""

    line: int
    x: float
    direction: str
    dof: int
    where: str


def column_matrices(section: Section3D, height: float, elements: int) -> tuple[np.ndarray, np.ndarray]:
    """``(M, K)`` of a pier column of ``elements`` equal column elements, nodes from the base (node 0)
    to the top, global DOFs ``6 k + j`` (nothing held)."""
    k = load(FRAME3D)
    le = height / elements
    m_e = np.asarray(k.column_mass([section.mass_per_length, section.polar_inertia], le), dtype=float)
    k_e = np.asarray(
        k.column_stiffness([section.E, section.shear, section.A, section.I_y, section.I_z, section.J], le),
        dtype=float,
    )
    n = 6 * (elements + 1)
    M, K = np.zeros((n, n)), np.zeros((n, n))
    for e in range(elements):
        s = slice(6 * e, 6 * e + 12)
        M[s, s] += m_e
        K[s, s] += k_e
    return M, K


def _same_section(where: str, plane: Section, section: Section3D) -> None:
    """The 3D section must carry the 2D section's E, A, I (vertical or longitudinal bending) and mass."""
    pairs = (
        ("E", plane.youngs_modulus, section.E),
        ("A", plane.area, section.A),
        ("I_y", plane.second_moment, section.I_y),
        ("mass_per_length", plane.mass_per_length, section.mass_per_length),
    )
    for name, a, b in pairs:
        if not math.isclose(a, b, rel_tol=1e-12):
            raise ValueError(f"{where}: Section3D.{name} = {b!r} differs from the 2D section's {a!r}")


class Bridge3D:
    """Girders, piers, bearings and ground supports in 3D; see the module docstring.

    ``girder_sections[g]``: the 3D section of girder ``g`` (its ``E``, ``A``, ``I_y``, mass those of
    ``girders[g].section``); ``pier_sections[i]``: of pier ``i`` (``I_y`` its 2D second moment,
    bending along the bridge; ``I_z`` bending across); ``bearing_lateral[i]``: lateral stiffness
    (N/m) of the bearings on pier ``i`` (None: rigid). Satisfies :class:`~.span3d.Deck3D`.
    """

    def __init__(
        self,
        girders: Sequence[Girder],
        elements_per_span: int,
        girder_sections: Sequence[Section3D],
        piers: Sequence[Pier] = (),
        pier_sections: Sequence[Section3D] = (),
        bearing_lateral: Sequence[float | None] | None = None,
    ) -> None:
        self.girders = list(girders)
        self.piers = list(piers)
        ne = int(elements_per_span)
        if ne < 1:
            raise ValueError(f"elements_per_span must be at least 1, got {elements_per_span}")
        if not self.girders:
            raise ValueError("a bridge needs at least one girder")
        if len(girder_sections) != len(self.girders):
            raise ValueError(f"{len(girder_sections)} girder sections for {len(self.girders)} girders")
        if len(pier_sections) != len(self.piers):
            raise ValueError(f"{len(pier_sections)} pier sections for {len(self.piers)} piers")
        lateral = list(bearing_lateral) if bearing_lateral is not None else [None] * len(self.piers)
        if len(lateral) != len(self.piers):
            raise ValueError(f"{len(lateral)} lateral bearing stiffnesses for {len(self.piers)} piers")
        for g, (gi, sec) in enumerate(zip(self.girders, girder_sections, strict=True)):
            _same_section(f"girder {g}", gi.section, sec)
        for i, (p, sec) in enumerate(zip(self.piers, pier_sections, strict=True)):
            _same_section(f"pier {i}", p.section, sec)
        for i, k in enumerate(lateral):
            if k is not None and not (math.isfinite(k) and k > 0):
                raise ValueError(f"pier {i}: lateral bearing stiffness must be a positive number, got {k!r}")
        self.girder_sections = list(girder_sections)
        self.pier_sections = list(pier_sections)
        self.bearing_lateral = lateral
        self.elements = ne
        # the 2D layout (no matrices): support lines, spans, the checks of girders and piers, and
        # the Rayleigh coefficients of the 2D bridge
        self.plane = Bridge(
            0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, ne, girders=self.girders, piers=self.piers, matrices=False
        )
        self.span_lengths = self.plane.span_lengths
        self.spans = self.plane.spans
        self.line_x = self.plane.line_x
        self._layout()
        self._assemble()

    # ----------------------------------------------------------------------------------------------
    def _layout(self) -> None:
        ne = self.elements
        deck_nodes: list[int] = []  # first node of every deck element
        element_length: list[float] = []
        element_section: list[int] = []
        self.span_elements: list[np.ndarray] = []
        """Deck elements of every span, in order along the track."""
        self.span_nodes: list[np.ndarray] = []
        """Deck nodes of every span, from its start line to its end line."""
        self.girder_line_nodes: list[list[tuple[int, int]]] = []
        """``(support line, deck node)`` of every girder's support lines."""
        node, span = 0, 0
        for g, girder in enumerate(self.girders):
            lines = []
            for j, length in enumerate(girder.spans):
                first = node + j * ne
                self.span_nodes.append(first + np.arange(ne + 1))
                self.span_elements.append(len(deck_nodes) + np.arange(ne))
                deck_nodes += list(range(first, first + ne))
                element_length += [float(length) / ne] * ne
                element_section += [g] * ne
                lines.append((span + j, first))
            lines.append((span + len(girder.spans), node + len(girder.spans) * ne))
            self.girder_line_nodes.append(lines)
            node += len(girder.spans) * ne + 1
            span += len(girder.spans)
        self.deck_node_count = node
        self.deck_element_nodes = np.array(deck_nodes, dtype=np.intp)
        self.deck_element_length = np.array(element_length)
        self.deck_element_section = np.array(element_section, dtype=np.intp)
        self.pier_nodes = [node + i * (ne + 1) + np.arange(ne + 1) for i in range(len(self.piers))]
        """Nodes of every pier, base (index 0) to top."""
        self.nodes = node + len(self.piers) * (ne + 1)
        self.length = float(self.line_x[-1])
        """Length of the deck (m): from the first abutment to the last."""
        self.n_elements = len(deck_nodes)
        """Deck elements in all (``length / n_elements`` is the element length of a deck of equal
        elements)."""
        self.span_starts = self.line_x[:-1]

    def _assemble(self) -> None:
        nfull = 6 * self.nodes
        parent = np.arange(nfull)

        def find(i: int) -> int:
            while parent[i] != i:
                parent[i] = parent[parent[i]]
                i = parent[i]
            return i

        def merge(a: int, b: int) -> None:
            ra, rb = find(a), find(b)
            if ra != rb:
                parent[max(ra, rb)] = min(ra, rb)

        springs: list[tuple[int, int, float]] = []
        held: list[tuple[int, float, str, int, str]] = []  # (line, x, direction, full dof, where)
        pier_at = {p.support: i for i, p in enumerate(self.piers)}
        for g, (girder, lines) in enumerate(zip(self.girders, self.girder_line_nodes, strict=True)):
            for j, (line, node) in enumerate(lines):
                directions = ["x"] if j == girder.fixed_support else []
                directions += ["y", "z", "phi"]
                for d in directions:
                    full = 6 * node + NODE_DOFS.index(BEARING[d])
                    if line in pier_at:
                        i = pier_at[line]
                        p = self.piers[i]
                        top = 6 * int(self.pier_nodes[i][-1]) + NODE_DOFS.index(BEARING[d])
                        k = {
                            "x": p.bearing_longitudinal,
                            "y": self.bearing_lateral[i],
                            "z": p.bearing_vertical,
                        }.get(d)
                        if k:
                            springs.append((full, top, float(k)))
                        else:
                            merge(full, top)
                    else:
                        held.append((line, float(self.line_x[line]), d, full, f"girder {g} line {j}"))
        for i, p in enumerate(self.piers):
            base = int(self.pier_nodes[i][0])
            for j, d in enumerate(DIRECTIONS):
                held.append((p.support, float(self.line_x[p.support]), d, 6 * base + j, f"pier {i} base"))
        roots = np.array([find(i) for i in range(nfull)])
        uniq, gmap = np.unique(roots, return_inverse=True)
        self.global_dof = gmap.reshape(self.nodes, 6)
        """Global DOF of every node's six DOFs (rigid bearings merge two into one)."""
        n = len(uniq)
        self.ndof = n
        M, K, C = np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))
        self.rayleigh: list[tuple[float, float]] = []
        """``(alpha, beta)`` of every girder, then every pier (the 2D bridge's)."""
        girder_ab = [
            Bridge._rayleigh(self.plane.girder_frequencies(g, 2), g.section.damping_ratio)
            for g in self.girders
        ]
        pier_ab = [
            Bridge._rayleigh(self.plane._pier_frequencies(p, 2), p.section.damping_ratio) for p in self.piers
        ]
        self.rayleigh = girder_ab + pier_ab
        cache: dict[tuple[int, float], tuple[np.ndarray, np.ndarray]] = {}
        for e, first in enumerate(self.deck_element_nodes):
            g = int(self.deck_element_section[e])
            key = (g, float(self.deck_element_length[e]))
            if key not in cache:
                cache[key] = element_matrices(self.girder_sections[g], key[1])
            m_e, k_e = cache[key]
            dofs = self.global_dof[[first, first + 1]].ravel()
            ix = np.ix_(dofs, dofs)
            a, b = girder_ab[g]
            M[ix] += m_e
            K[ix] += k_e
            C[ix] += a * m_e + b * k_e
        for i, p in enumerate(self.piers):
            m_p, k_p = column_matrices(self.pier_sections[i], p.height, self.elements)
            dofs = self.global_dof[self.pier_nodes[i]].ravel()
            ix = np.ix_(dofs, dofs)
            a, b = pier_ab[i]
            M[ix] += m_p
            K[ix] += k_p
            C[ix] += a * m_p + b * k_p
        full = self.global_dof.ravel()
        for fa, fb, k in springs:
            ga, gb = full[fa], full[fb]
            K[ga, ga] += k
            K[gb, gb] += k
            K[ga, gb] -= k
            K[gb, ga] -= k
        self.M, self.K, self.C = M, K, C
        self.supports = [Support3D(line, x, d, int(full[f]), where) for line, x, d, f, where in held]
        """Every DOF held by the ground."""
        self.support_dofs = np.array([s.dof for s in self.supports], dtype=np.intp)
        if len(np.unique(self.support_dofs)) != len(self.support_dofs):
            raise ValueError("two supports hold the same DOF (check the piers' support lines)")
        self.free = np.setdiff1d(np.arange(n), self.support_dofs)
        f, s = self.free, self.support_dofs
        T = np.zeros((n, len(s)))
        T[s, np.arange(len(s))] = 1.0
        # one sparse factorization of the free DOFs' stiffness (a banded matrix: the deck's and the
        # piers' frame elements), as the 2D bridge's quasi-static field
        T[f] = -spla.splu(sps.csc_matrix(K[np.ix_(f, f)])).solve(K[np.ix_(f, s)])
        self.T = T
        """Quasi-static field (``ndof x supports``) per unit motion of each support, the others held."""
        self.CT = C @ T

    # ----------------------------------------------------------------------------------------------
    # the deck as the 3D step sees it (Deck3D)
    def dof(self, node: int, name: str) -> int:
        """Global index of DOF ``name`` (one of :data:`NODE_DOFS`) of ``node``."""
        return int(self.global_dof[node, NODE_DOFS.index(name)])

    def element_dofs(self, element: int) -> np.ndarray:
        """The 12 global DOFs of deck element ``element`` (numbered along the track from 0)."""
        first = int(self.deck_element_nodes[element])
        return self.global_dof[[first, first + 1]].ravel()

    @property
    def element_length(self) -> float:
        """The deck's one element length (m), for a deck of equal elements; ``ValueError`` if its
        spans' elements differ (:attr:`deck_element_length` has each element's: the 3D step takes
        those)."""
        le = self.deck_element_length
        if not np.allclose(le, le[0], rtol=1e-12, atol=0.0):
            raise ValueError(
                "the deck's elements differ in length (spans of different lengths): there is no one "
                "element length (deck_element_length has each element's)"
            )
        return float(le[0])

    def deck_location(self, x: float) -> tuple[int, float]:
        """``(deck element, xi)`` at ``x`` (m from the first abutment). A point on a support line
        belongs to the span ahead (as in 2D), the last abutment to the last span. ``ValueError``
        off the deck."""
        if not 0.0 <= x <= self.length:
            raise ValueError(f"x = {x} m is off the deck (0 to {self.length} m)")
        span = min(int(np.searchsorted(self.line_x, x, side="right")) - 1, self.spans - 1)
        le = self.span_lengths[span] / self.elements
        local = (x - self.line_x[span]) / le
        e = min(int(math.floor(local)), self.elements - 1)
        return int(self.span_elements[span][e]), float(local - e)

    def deck_locations(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`deck_location` of many points at once: ``(element, xi)`` arrays shaped like ``x``
        (int, float), for points on the deck (not checked)."""
        x = np.asarray(x, dtype=float)
        span = np.minimum(np.searchsorted(self.line_x, x, side="right") - 1, self.spans - 1)
        le = np.asarray(self.span_lengths, dtype=float)[span] / self.elements
        local = (x - np.asarray(self.line_x, dtype=float)[span]) / le
        e = np.minimum(np.floor(local).astype(np.intp), self.elements - 1)
        element = np.asarray(self.span_elements, dtype=np.intp)[span, e]
        return element, local - e

    def midspan(self, span: int) -> tuple[int, float]:
        """``(deck element, xi)`` of the middle of ``span``."""
        return self.deck_location(float(self.line_x[span] + 0.5 * self.span_lengths[span]))

    def midspan_node(self, span: int) -> int:
        """The deck node at the middle of ``span`` (``elements_per_span`` must be even)."""
        if self.elements % 2:
            raise ValueError(f"elements_per_span = {self.elements} is odd: no node at midspan")
        return int(self.span_nodes[span][self.elements // 2])

    def pier_top(self, pier: int) -> int:
        """The top node of ``pier``."""
        return int(self.pier_nodes[pier][-1])

    # ----------------------------------------------------------------------------------------------
    # ground motion at the supports
    def support_motion(self, line_motion: np.ndarray) -> np.ndarray:
        """The supports' displacements (or rates) from the ground's ``(x, y, z)`` motion at every
        support line, ``line_motion`` of shape ``(spans + 1, 3)``: a translation takes its line's
        component, a held rotation 0 (wave passage: give each line its own time shift)."""
        motion = np.asarray(line_motion, dtype=float)
        if motion.shape != (self.spans + 1, 3):
            raise ValueError(f"line_motion must have shape {(self.spans + 1, 3)}, got {motion.shape}")
        return np.array(
            [
                motion[s.line, GROUND_DIRECTIONS.index(s.direction)]
                if s.direction in GROUND_DIRECTIONS
                else 0.0
                for s in self.supports
            ]
        )

    def quasi_static(self, q: np.ndarray) -> np.ndarray:
        """``T q``: the displacement field that the support motion ``q`` imposes statically."""
        return self.T @ np.asarray(q, dtype=float)

    def support_damping_load(self, q1: np.ndarray) -> np.ndarray:
        """``C T q'``: the known damping load of the support rates ``q1`` (damping on the motion
        relative to the ground)."""
        return self.CT @ np.asarray(q1, dtype=float)

    def natural_frequencies(self, count: int = 10) -> np.ndarray:
        """The lowest natural frequencies (Hz) of the whole bridge, supports held."""
        f = self.free
        lam = sla.eigh(
            self.K[np.ix_(f, f)], self.M[np.ix_(f, f)], eigvals_only=True, subset_by_index=[0, count - 1]
        )
        return np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)


# --------------------------------------------------------------------------------------------------
# from plain values (the scenario's keys)
def section3d(
    section: Section,
    lateral_second_moment: float,
    torsion_constant: float,
    poisson_ratio: float | None = None,
    shear_modulus: float | None = None,
    torsional_mass_per_length: float | None = None,
) -> Section3D:
    """The 3D section of a 2D :class:`~svbi.runtime.model.bridge.Section`: its ``E``, ``A``,
    ``I`` (as ``I_y``) and mass, with the lateral second moment ``I_z``, the torsion constant ``J``
    and optionally Poisson's ratio or the shear modulus and the torsional mass per length."""
    extra: dict[str, float] = {}
    if poisson_ratio is not None:
        extra["poisson_ratio"] = float(poisson_ratio)
    return Section3D(
        E=section.youngs_modulus,
        A=section.area,
        I_y=section.second_moment,
        I_z=float(lateral_second_moment),
        J=float(torsion_constant),
        mass_per_length=section.mass_per_length,
        G=None if shear_modulus is None else float(shear_modulus),
        torsional_mass=None if torsional_mass_per_length is None else float(torsional_mass_per_length),
        **extra,
    )


SECTION_KEYS = (
    "lateral_second_moment",
    "torsion_constant",
    "poisson_ratio",
    "shear_modulus",
    "torsional_mass_per_length",
)
"""The 3D keys of a girder's or pier's section (:func:`section3d`)."""


def bridge3d(
    girders: Sequence[Girder],
    elements_per_span: int,
    girder_3d: Sequence[Mapping[str, float]],
    piers: Sequence[Pier] = (),
    pier_3d: Sequence[Mapping[str, float]] = (),
) -> Bridge3D:
    """A :class:`Bridge3D` from the 2D description and, per girder and per pier, a mapping of the
    3D keys (:data:`SECTION_KEYS`; a pier's may also hold ``bearing_lateral``, N/m)."""

    def section(where: str, plane: Section, values: Mapping[str, float]) -> Section3D:
        unknown = (
            set(values) - set(SECTION_KEYS) - ({"bearing_lateral"} if where.startswith("pier") else set())
        )
        if unknown:
            raise ValueError(f"{where}: unknown 3D key(s) {', '.join(sorted(unknown))}")
        for key in ("lateral_second_moment", "torsion_constant"):
            if key not in values:
                raise ValueError(f"{where}: missing 3D key {key!r}")
        return section3d(plane, **{k: v for k, v in values.items() if k in SECTION_KEYS})

    if len(girder_3d) != len(girders):
        raise ValueError(f"{len(girder_3d)} sets of 3D keys for {len(girders)} girders")
    if len(pier_3d) != len(piers):
        raise ValueError(f"{len(pier_3d)} sets of 3D keys for {len(piers)} piers")
    return Bridge3D(
        girders,
        elements_per_span,
        [
            section(f"girder {g}", gi.section, v)
            for g, (gi, v) in enumerate(zip(girders, girder_3d, strict=True))
        ],
        piers,
        [section(f"pier {i}", p.section, v) for i, (p, v) in enumerate(zip(piers, pier_3d, strict=True))],
        [v.get("bearing_lateral") for v in pier_3d],
    )

"""A simply supported span of 3D frame elements, assembled from the generated ``frame3d`` kernels.

A building block of the 3D model, not yet used by runs (docs/three-d.md). The element matrices come
from ``generated/frame3d/numpy_kernels.py`` (derived in :mod:`svbi.codegen.frame3d`); this module only
evaluates and assembles them, so nothing here imports SymPy.

Node DOFs ``[u, v, w, phi, theta, psi]`` (axial, lateral, vertical, twist, vertical slope ``dw/dx``,
lateral slope ``dv/dx``); global DOF ``6 k + j`` is DOF ``j`` of node ``k``, nodes numbered from the
left support. Supports are forks: ``v``, ``w`` and ``phi`` held at both ends, ``u`` at the left end,
slopes free (simply supported in both planes, torsionally restrained at the ends).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from scipy.linalg import eigh

from .kernels import FRAME3D, load

NODE_DOFS = ("u", "v", "w", "phi", "theta", "psi")
POISSON_DEFAULT = 0.2
"""Poisson's ratio of the shear modulus when neither is given (concrete)."""
GROUPS = {"axial": (0,), "lateral": (1, 5), "vertical": (2, 4), "torsion": (3,)}
"""The node DOFs of each family of motion (the section's shear centre on its centroid: uncoupled)."""


@dataclass(frozen=True)
class Section3D:
    """Section and material of a 3D span (SI units).

    ``shear_modulus`` defaults to ``E / (2 (1 + poisson_ratio))``; ``torsional_mass`` (the mass moment
    of inertia per length about the axis, kg m) defaults to ``mass_per_length (I_y + I_z) / A``,
    the mass per length times the polar radius of gyration squared (``rho J`` would underestimate it
    several times for a box girder).
    """

    E: float
    A: float
    I_y: float
    I_z: float
    J: float
    mass_per_length: float
    poisson_ratio: float = POISSON_DEFAULT
    G: float | None = None
    torsional_mass: float | None = None

    def __post_init__(self) -> None:
        for name in ("E", "A", "I_y", "I_z", "J", "mass_per_length"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"Section3D.{name}: must be a positive number, got {value!r}")
        if not -1.0 < self.poisson_ratio < 0.5:
            raise ValueError(f"Section3D.poisson_ratio: must lie in (-1, 0.5), got {self.poisson_ratio!r}")
        for name in ("G", "torsional_mass"):
            value = getattr(self, name)
            if value is not None and not (math.isfinite(value) and value > 0):
                raise ValueError(f"Section3D.{name}: must be a positive number, got {value!r}")

    @property
    def shear(self) -> float:
        """The shear modulus used: ``G`` if given, else from Poisson's ratio."""
        return self.G if self.G is not None else self.E / (2.0 * (1.0 + self.poisson_ratio))

    @property
    def polar_inertia(self) -> float:
        """The torsional mass moment of inertia per length used (kg m)."""
        if self.torsional_mass is not None:
            return self.torsional_mass
        return self.mass_per_length * (self.I_y + self.I_z) / self.A


def element_matrices(section: Section3D, length: float) -> tuple[np.ndarray, np.ndarray]:
    """``(M_e, K_e)``, 12x12, of one element of ``length``."""
    k = load(FRAME3D)
    mass = k.element_mass([section.mass_per_length, section.polar_inertia], length)
    stiffness = k.element_stiffness(
        [section.E, section.shear, section.A, section.I_y, section.I_z, section.J], length
    )
    return np.asarray(mass, dtype=float), np.asarray(stiffness, dtype=float)


class Deck3D(Protocol):
    """What the 3D step needs of a structure that carries the track: a simply supported span
    (:class:`Span3D`) or a whole bridge (:class:`svbi.runtime.model.bridge3d.Bridge3D`).

    ``M``, ``K`` are the global matrices over the structure's DOFs, ``free`` the DOFs not held by a
    support; deck elements are numbered along the track from 0; ``deck_element_length[e]`` is the
    length of deck element ``e`` (m: spans of different lengths have elements of different lengths,
    for which ``element_length``, the one length of a deck of equal elements, raises);
    ``element_dofs(e)`` gives the 12 global DOFs of deck element ``e`` in the frame element's order,
    and ``deck_location(x)`` the element and local coordinate under the track position ``x`` (m from
    the deck's start).
    """

    length: float
    n_elements: int
    M: np.ndarray
    K: np.ndarray
    free: np.ndarray

    @property
    def element_length(self) -> float: ...

    @property
    def deck_element_length(self) -> np.ndarray: ...

    def dof(self, node: int, name: str) -> int: ...

    def element_dofs(self, element: int) -> np.ndarray: ...

    def deck_location(self, x: float) -> tuple[int, float]: ...

    def deck_locations(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...


@dataclass(frozen=True)
class Span3D:
    """Assembled matrices of a simply supported span; ``free`` are the unrestrained global DOFs.
    Satisfies :class:`Deck3D` (deck element ``e`` joins nodes ``e`` and ``e + 1``)."""

    length: float
    n_elements: int
    M: np.ndarray
    K: np.ndarray
    free: np.ndarray

    def dof(self, node: int, name: str) -> int:
        """Global index of DOF ``name`` (one of :data:`NODE_DOFS`) of ``node``."""
        return 6 * node + NODE_DOFS.index(name)

    @property
    def element_length(self) -> float:
        """Length of every element (m)."""
        return self.length / self.n_elements

    @property
    def deck_element_length(self) -> np.ndarray:
        """The length of every element (m): all :attr:`element_length`."""
        return np.full(self.n_elements, self.element_length)

    def element_dofs(self, element: int) -> np.ndarray:
        """The 12 global DOFs of element ``element``: ``6 e .. 6 e + 11``."""
        return 6 * element + np.arange(12)

    def deck_location(self, x: float) -> tuple[int, float]:
        """``(element, xi)`` at ``x`` (m from the left support); the right support belongs to the last
        element. ``ValueError`` off the span."""
        if not 0.0 <= x <= self.length:
            raise ValueError(f"x = {x} m is off the span (0 to {self.length} m)")
        le = self.element_length
        e = min(int(x // le), self.n_elements - 1)
        return e, x / le - e

    def deck_locations(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`deck_location` of many points at once: ``(element, xi)`` arrays shaped like ``x``
        (int, float), for points on the span (not checked)."""
        x = np.asarray(x, dtype=float)
        le = self.element_length
        e = np.minimum((x // le).astype(np.intp), self.n_elements - 1)
        return e, x / le - e


def simply_supported_span(section: Section3D, length: float, n_elements: int) -> Span3D:
    """Assemble ``n_elements`` equal elements into a span on fork supports."""
    if n_elements < 1:
        raise ValueError(f"n_elements must be at least 1, got {n_elements}")
    if not (math.isfinite(length) and length > 0):
        raise ValueError(f"length must be a positive number, got {length!r}")
    n = 6 * (n_elements + 1)
    mass, stiffness = np.zeros((n, n)), np.zeros((n, n))
    m_e, k_e = element_matrices(section, length / n_elements)
    for e in range(n_elements):
        s = slice(6 * e, 6 * e + 12)
        mass[s, s] += m_e
        stiffness[s, s] += k_e
    fixed = {0, 1, 2, 3, 6 * n_elements + 1, 6 * n_elements + 2, 6 * n_elements + 3}
    free = np.array([i for i in range(n) if i not in fixed])
    return Span3D(length, n_elements, mass, stiffness, free)


def modes(span: Span3D) -> tuple[np.ndarray, list[str], np.ndarray]:
    """Natural frequencies (Hz, ascending), the family of each mode (the group of :data:`GROUPS`
    holding most of its kinetic energy) and the mode shapes (columns, full DOF vectors)."""
    f = span.free
    eigenvalues, vectors = eigh(span.K[np.ix_(f, f)], span.M[np.ix_(f, f)])
    shapes = np.zeros((span.M.shape[0], len(f)))
    shapes[f] = vectors
    families = []
    node_dof = np.arange(span.M.shape[0]) % 6
    for k in range(len(f)):
        phi = shapes[:, k]
        energy = {}
        for name, group in GROUPS.items():
            mask = np.isin(node_dof, group)
            part = np.where(mask, phi, 0.0)
            energy[name] = float(part @ span.M @ part)
        families.append(max(energy, key=lambda name: energy[name]))
    return np.sqrt(np.maximum(eigenvalues, 0.0)) / (2.0 * np.pi), families, shapes


def family_frequencies(span: Span3D, family: str, count: int) -> np.ndarray:
    """The ``count`` lowest natural frequencies (Hz) of one family of :data:`GROUPS`."""
    if family not in GROUPS:
        raise ValueError(f"unknown family {family!r} (known: {', '.join(GROUPS)})")
    freqs, families, _ = modes(span)
    picked = freqs[[i for i, name in enumerate(families) if name == family]]
    return picked[:count]


def static_displacement(span: Span3D, load: np.ndarray) -> np.ndarray:
    """Static displacements (full DOF vector, zeros at the supports) under a nodal ``load``."""
    load = np.asarray(load, dtype=float)
    if load.shape != (span.M.shape[0],):
        raise ValueError(f"load must have {span.M.shape[0]} entries, got shape {load.shape}")
    f = span.free
    out = np.zeros_like(load)
    out[f] = np.linalg.solve(span.K[np.ix_(f, f)], load[f])
    return out

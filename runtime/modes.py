"""Natural frequencies: a vehicle on rigid track, and one simply supported span.

Both come from the symbolically derived matrices (``svbi.codegen.vehicle`` and
``svbi.codegen.beam``); nothing here is typed in by hand.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np
import scipy.linalg as sla
import sympy as sp
from svbi.codegen import beam
from svbi.codegen.vehicle import NumericVehicle


@dataclass(frozen=True)
class VehicleModes:
    """Elastic natural frequencies (Hz, ascending) and the number of rigid (0 Hz) modes."""

    frequencies_hz: np.ndarray
    rigid_modes: int


def vehicle_modes(vehicle: NumericVehicle, rtol: float = 1e-9) -> VehicleModes:
    """Frequencies of a vehicle whose wheels rest on rigid, fixed track.

    The contact directions are held: the motion lives in the null space of ``W_N^T``. Modes with no
    stiffness (a free wheelset spin) are reported as rigid modes, not as frequencies.
    """
    basis = sla.null_space(vehicle.W_N.T) if vehicle.nwheels else np.eye(vehicle.ndof)
    k = basis.T @ vehicle.K @ basis
    m = basis.T @ vehicle.M @ basis
    eig = sla.eigh(k, m, eigvals_only=True)
    scale = max(float(np.max(np.abs(eig))), 1.0)
    rigid = int(np.sum(eig <= rtol * scale))
    elastic = np.sqrt(np.clip(eig[eig > rtol * scale], 0.0, None)) / (2 * np.pi)
    return VehicleModes(np.sort(elastic), rigid)


@cache
def _element_functions() -> tuple:
    args = (beam.E, beam.A, beam.I, beam.mu, beam.le)
    return (
        sp.lambdify(args, beam.element_mass(), "numpy"),
        sp.lambdify(args, beam.element_stiffness(), "numpy"),
    )


def span_matrices(
    span_length: float,
    elements: int,
    youngs_modulus: float,
    area: float,
    second_moment: float,
    mass_per_length: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Assembled mass and stiffness of one span, 3 DOFs per node ``(u, w, theta)``, no supports."""
    mass_fn, stiff_fn = _element_functions()
    le = span_length / elements
    me = np.asarray(mass_fn(youngs_modulus, area, second_moment, mass_per_length, le), dtype=float)
    ke = np.asarray(stiff_fn(youngs_modulus, area, second_moment, mass_per_length, le), dtype=float)
    n = 3 * (elements + 1)
    m, k = np.zeros((n, n)), np.zeros((n, n))
    for e in range(elements):
        idx = slice(3 * e, 3 * e + 6)
        m[idx, idx] += me
        k[idx, idx] += ke
    return m, k


def span_support_dofs(elements: int) -> list[int]:
    """Support DOFs of one span: the fixed bearing (u and w at the left node), w at the right node."""
    return [0, 1, 3 * elements + 1]


def span_modes(
    span_length: float,
    elements: int,
    youngs_modulus: float,
    area: float,
    second_moment: float,
    mass_per_length: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Vertical bending and axial frequencies (Hz) of a simply supported span."""
    m, k = span_matrices(span_length, elements, youngs_modulus, area, second_moment, mass_per_length)
    free = np.setdiff1d(np.arange(m.shape[0]), span_support_dofs(elements))
    bending = np.array([i for i in free if i % 3 != 0])
    axial = np.array([i for i in free if i % 3 == 0])
    fb = np.sqrt(sla.eigh(k[np.ix_(bending, bending)], m[np.ix_(bending, bending)], eigvals_only=True))
    fa = np.sqrt(sla.eigh(k[np.ix_(axial, axial)], m[np.ix_(axial, axial)], eigvals_only=True))
    return fb / (2 * np.pi), fa / (2 * np.pi)

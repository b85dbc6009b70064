"""Natural frequencies: a vehicle on rigid track, and one simply supported span.

Both come from the generated kernels of the symbolically derived matrices (the vehicle's
``NumericVehicle`` and the element matrices of ``generated/frame2d``); nothing here is typed in by
hand.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as sla

from ...codegen.plain_types import NumericVehicle
from .kernels import frame2d


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


def _assembled(me: np.ndarray, ke: np.ndarray, elements: int) -> tuple[np.ndarray, np.ndarray]:
    """``elements`` equal elements in a row, 3 DOFs per node: the assembled mass and stiffness."""
    n = 3 * (elements + 1)
    m, k = np.zeros((n, n)), np.zeros((n, n))
    for e in range(elements):
        idx = slice(3 * e, 3 * e + 6)
        m[idx, idx] += me
        k[idx, idx] += ke
    return m, k


def span_matrices(
    span_length: float,
    elements: int,
    youngs_modulus: float,
    area: float,
    second_moment: float,
    mass_per_length: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Assembled mass and stiffness of one span, 3 DOFs per node ``(u, w, theta)``, no supports."""
    section = (youngs_modulus, area, second_moment, mass_per_length)
    return _member(("element_mass", "element_stiffness"), span_length, elements, section)


def column_matrices(
    height: float,
    elements: int,
    youngs_modulus: float,
    area: float,
    second_moment: float,
    mass_per_length: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Assembled mass and stiffness of a pier column in global DOFs ``(u, w, theta)`` per node,
    node 0 at the base, node ``elements`` at the top (generated ``column_mass/column_stiffness``)."""
    section = (youngs_modulus, area, second_moment, mass_per_length)
    return _member(("column_mass", "column_stiffness"), height, elements, section)


def _member(
    kernels: tuple[str, str], length: float, elements: int, section: tuple[float, float, float, float]
) -> tuple[np.ndarray, np.ndarray]:
    """``elements`` equal elements of the generated mass and stiffness ``kernels`` over ``length``."""
    k = frame2d()
    le = length / elements
    me = np.asarray(getattr(k, kernels[0])(section, le), dtype=float)
    ke = np.asarray(getattr(k, kernels[1])(section, le), dtype=float)
    return _assembled(me, ke, elements)


def member_sparse(
    kernels: tuple[str, str], length: float, elements: int, section: tuple[float, float, float, float]
) -> tuple[Any, Any]:
    """The same assembly as :func:`span_matrices` / :func:`column_matrices` (``kernels``:
    ``("element_mass", "element_stiffness")`` or ``("column_mass", "column_stiffness")``) as sparse
    CSR matrices, built in memory and time linear in ``elements``; the element entries are summed in
    the same order as the dense assembly."""
    import scipy.sparse as sps

    k = frame2d()
    le = length / elements
    me = np.asarray(getattr(k, kernels[0])(section, le), dtype=float)
    ke = np.asarray(getattr(k, kernels[1])(section, le), dtype=float)
    n = 3 * (elements + 1)
    base = 3 * np.arange(elements)[:, None, None]
    local = np.arange(6)
    rows = np.broadcast_to(base + local[:, None], (elements, 6, 6)).ravel()
    cols = np.broadcast_to(base + local[None, :], (elements, 6, 6)).ravel()
    out = []
    for e in (me, ke):
        vals = np.broadcast_to(e, (elements, 6, 6)).ravel()
        out.append(sps.csr_matrix((vals, (rows, cols)), shape=(n, n)))
    return out[0], out[1]


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

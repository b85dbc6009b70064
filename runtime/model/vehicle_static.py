"""The vehicles at rest: static equilibrium of the cars with their wheels held at given heights
(rigid track), and the free (rigid-body) modes the static problem must hold."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sps
import scipy.sparse.linalg as spla

if TYPE_CHECKING:  # the train calls in here: a type only
    from .train import Train


class StaticEquilibriumError(ValueError):
    """The static problem has no solution (a rigid mode carries a load): bad input, so a ValueError
    (`svbi run` reports it in one line); the topology checks at load time catch the usual causes."""


def free_modes(train: Train) -> np.ndarray:
    """Vehicle motions with no stiffness and no contact (e.g. wheelset spins), as columns.

    They are rigid modes of the static problem; we hold them at zero, which is only right if gravity
    does no work on them.
    """
    v = train.vehicle
    Z = sla.null_space(np.vstack([v.K, train.W.T]))
    if Z.size and np.abs(Z.T @ v.F_gravity).max() > 1e-9 * max(np.abs(v.F_gravity).max(), 1.0):
        raise StaticEquilibriumError(
            "the vehicle has a free (rigid-body) mode loaded by gravity: "
            "it has no static equilibrium on the track"
        )
    return Z


def refined_solve(A: np.ndarray | sps.spmatrix, b: np.ndarray) -> np.ndarray:
    """LU solve with one step of iterative refinement (the blocks span ~12 orders of magnitude).

    A sparse ``A`` (the full system) goes to SuperLU, a dense one (one car's block) to LAPACK.
    """
    if sps.issparse(A):
        lu = spla.splu(sps.csc_matrix(A))
        x = lu.solve(b)
        return x + lu.solve(b - A @ x)
    lu = sla.lu_factor(A)
    x = sla.lu_solve(lu, b)
    return x + sla.lu_solve(lu, b - A @ x)


def vehicle_static_on_rigid_track(train: Train, z_track: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Static state of cars with their wheels held at heights ``z_track`` (cars x wheels).

    Full wheel masses (no aux split), gravity only: ``K u - W P = F``, ``W^T u = z``. Returns the car
    displacements (cars x ndof) and the wheel loads P (cars x wheels, compression positive).
    """
    n, nw = train.ndof, train.wheels
    W = train.W
    Z = free_modes(train)
    nz = Z.shape[1]
    A = np.block(
        [
            [train.vehicle.K, -W, Z],
            [W.T, np.zeros((nw, nw + nz))],
            [Z.T, np.zeros((nz, nw + nz))],
        ]
    )
    z_track = np.atleast_2d(np.asarray(z_track, dtype=float))
    cars = z_track.shape[0]
    rhs = np.concatenate(
        [
            np.repeat(train.vehicle.F_gravity[:, None], cars, axis=1),
            z_track.T,
            np.zeros((nz, cars)),
        ],
        axis=0,
    )
    sol = refined_solve(A, rhs)
    return sol[:n].T.copy(), sol[n : n + nw].T.copy()

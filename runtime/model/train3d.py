"""Trains of 3D cars: several :class:`~svbi.runtime.model.system3d.Vehicle3DNumeric` as one
(docs/three-d.md, "Trains of 3D cars").

As the 2D trains (:class:`svbi.runtime.model.train.Train`) the cars follow one another along the
track without coupling forces: the train's ``M``, ``C``, ``K`` are block-diagonal, car by car, and its
gravity load the cars' loads one after the other. Positions are measured backwards from the train's
leading axle: car ``k``'s wheelsets lie ``lead_k`` further back than in the car alone, where
``lead_0 = 0`` and ``lead_{k+1} = lead_k + spacing_k``, the distance between the leading axles of
two consecutive cars (the 2D trains' ``car_length``). DOFs and wheelsets are renamed
``car<k>.<name>`` (``k`` from 0 at the front), so outputs can say which car and which wheelset.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy.linalg import block_diag

from .system3d import Vehicle3DNumeric, Wheelset

SEPARATOR = "."
"""Between the car's label and a DOF or wheelset name: ``car1.y_ws``."""


def car_label(k: int) -> str:
    """The label of the ``k``-th car from the front (0-based)."""
    return f"car{k}"


def train3d(vehicles: Sequence[Vehicle3DNumeric], spacing: float | Sequence[float]) -> Vehicle3DNumeric:
    """One vehicle of the cars ``vehicles`` (front first). ``spacing``: the distance between the
    leading axles of consecutive cars (m), one value for all or one per pair of cars."""
    cars = list(vehicles)
    if not cars:
        raise ValueError("a train needs at least one car")
    gaps = [float(spacing)] * (len(cars) - 1) if np.isscalar(spacing) else [float(s) for s in spacing]  # type: ignore[arg-type]
    if len(gaps) != len(cars) - 1:
        raise ValueError(f"{len(gaps)} spacings for {len(cars)} cars: give one value or {len(cars) - 1}")
    for k, s in enumerate(gaps):
        if not (math.isfinite(s) and s > 0):
            raise ValueError(f"spacing {k} (car{k} to car{k + 1}): must be a positive number, got {s!r}")
    lead = np.concatenate([[0.0], np.cumsum(gaps)])
    names: list[str] = []
    wheelsets: list[Wheelset] = []
    start = 0
    for k, car in enumerate(cars):
        label = car_label(k)
        names += [f"{label}{SEPARATOR}{n}" for n in car.dof_names]
        wheelsets += [
            Wheelset(
                f"{label}{SEPARATOR}{w.name}",
                np.asarray(w.dofs) + start,
                float(lead[k] + w.offset),
                w.radius,
                w.half_gauge,
            )
            for w in car.wheelsets
        ]
        start += len(car.dof_names)
    return Vehicle3DNumeric(
        tuple(names),
        block_diag(*[c.M for c in cars]),
        block_diag(*[c.C for c in cars]),
        block_diag(*[c.K for c in cars]),
        np.concatenate([c.F for c in cars]),
        wheelsets,
    )

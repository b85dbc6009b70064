"""EN 1991-2 Annex E high-speed load model HSLM-A (trains A1 to A10) as moving axle loads.

Geometry (EN 1991-2:2003, Annex E, Figure E.2 and Table E.1). Every axle carries the point force
P. From the front:

* leading power car: 4 axles, spacings 3.0, 11.0, 3.0 m;
* 3.525 m to the leading end coach;
* leading end coach: its own bogie (2 axles, spacing d); the coach is D long from the coupling
  (3.525/2 m ahead of its first axle) to the centre of the first articulated bogie, so its second
  axle is ``D - 3·d/2 - 3.525/2`` m from the next axle;
* N intermediate coaches, articulated: N + 1 shared bogies, each 2 axles d apart, bogie centres D
  apart (axle gaps d, D - d, d, ..., d);
* the rear end coach and rear power car, mirror images of the leading ones.

So a train has 2N + 14 axles and a length, first to last axle, of (N + 2)·D + 37.525 m.

Table E.1 (N intermediate coaches, coach length D, bogie axle spacing d, point force P):

| train | N | D (m) | d (m) | P (kN) |
|---|---|---|---|---|
| A1 | 18 | 18 | 2.0 | 170 |
| A2 | 17 | 19 | 3.5 | 200 |
| A3 | 16 | 20 | 2.0 | 180 |
| A4 | 15 | 21 | 3.0 | 190 |
| A5 | 14 | 22 | 2.0 | 170 |
| A6 | 13 | 23 | 2.0 | 180 |
| A7 | 13 | 24 | 2.0 | 190 |
| A8 | 12 | 25 | 2.5 | 190 |
| A9 | 11 | 26 | 2.0 | 210 |
| A10 | 11 | 27 | 2.0 | 210 |

N decreases as D grows so that every train is 375-399 m long (the model is limited to trains of
about 400 m). A table that gives N = D for every train is a transcription error.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

POWER_CAR_GAPS = (3.0, 11.0, 3.0)
"""Axle spacings within a power car (m), from its outer end."""
COUPLING_GAP = 3.525
"""Distance from the power car's inner axle to the end coach's first axle (m)."""


@dataclass(frozen=True)
class HSLMTrain:
    """One row of EN 1991-2 Table E.1."""

    name: str
    coaches: int
    """N, number of intermediate coaches."""
    coach_length: float
    """D, coach length (m)."""
    bogie_spacing: float
    """d, axle spacing of a bogie (m)."""
    axle_load: float
    """P, point force on each axle (N)."""

    @property
    def n_axles(self) -> int:
        """2N + 14."""
        return 2 * self.coaches + 14

    @property
    def length(self) -> float:
        """Distance from the first to the last axle (m): (N + 2) D + 37.525."""
        return (self.coaches + 2) * self.coach_length + 2 * sum(POWER_CAR_GAPS) + COUPLING_GAP

    def gaps(self) -> NDArray[np.float64]:
        """Distances between consecutive axles (m), front to back."""
        d, big = self.bogie_spacing, self.coach_length
        end_coach = [d, big - 1.5 * d - COUPLING_GAP / 2.0]
        front = [*POWER_CAR_GAPS, COUPLING_GAP, *end_coach]
        articulated = [d] + [big - d, d] * self.coaches
        return np.array(front + articulated + front[::-1])


HSLM_A = {
    t.name: t
    for t in (
        HSLMTrain("A1", 18, 18.0, 2.0, 170e3),
        HSLMTrain("A2", 17, 19.0, 3.5, 200e3),
        HSLMTrain("A3", 16, 20.0, 2.0, 180e3),
        HSLMTrain("A4", 15, 21.0, 3.0, 190e3),
        HSLMTrain("A5", 14, 22.0, 2.0, 170e3),
        HSLMTrain("A6", 13, 23.0, 2.0, 180e3),
        HSLMTrain("A7", 13, 24.0, 2.0, 190e3),
        HSLMTrain("A8", 12, 25.0, 2.5, 190e3),
        HSLMTrain("A9", 11, 26.0, 2.0, 210e3),
        HSLMTrain("A10", 11, 27.0, 2.0, 210e3),
    )
}
"""EN 1991-2 Table E.1, keyed by "A1" ... "A10"."""


def hslm_train(name: str) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Axle loads (N) and axle offsets (m behind the leading axle) of HSLM-``name``.

    ``name`` is ``"A1"`` ... ``"A10"`` (``"HSLM-A1"`` and lower case are accepted too). The result
    feeds the ``moving-load`` vehicle (docs/scenario.md: ``axle_loads``, ``axle_offsets``).
    """
    key = name.strip().upper().removeprefix("HSLM-").removeprefix("HSLM")
    if key not in HSLM_A:
        raise ValueError(f"train.hslm = {name!r}: expected one of {', '.join(HSLM_A)}")
    train = HSLM_A[key]
    offsets = np.concatenate([[0.0], np.cumsum(train.gaps())])
    return np.full(offsets.size, train.axle_load), offsets


def hslm_axles(name: str) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """:func:`hslm_train` plus the train length, first to last axle (m): the ``moving-load``
    parameters ``axle_loads``, ``axle_offsets`` and ``car_length`` of a one-unit train."""
    loads, offsets = hslm_train(name)
    return loads, offsets, float(offsets[-1])


def hslm_parameters(name: str) -> dict[str, Any]:
    """Axle layout of an EN 1991-2 HSLM-A train (:func:`hslm_axles`) as moving-load parameters."""
    loads, offsets, length = hslm_axles(name)
    return {"axle_loads": tuple(loads), "axle_offsets": tuple(offsets), "car_length": length}

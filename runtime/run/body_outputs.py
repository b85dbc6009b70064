"""The ``body_uz``, ``body_az`` and ``body_pitch`` results: every rigid body of every car.

The recorder (``results.Recorder``, and the C loop through ``Outputs.vehicle_u`` / ``vehicle_a``)
stores every vehicle DOF at each output row; this module picks the bounce ``z_<body>`` and the pitch
``theta_<body>`` of each body of the topology, in its order (the first body is the car body of the
``carbody_*`` variables). A body without one of the two DOFs gets NaN there, not a fake zero.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np


def body_dofs(dof_names: Sequence[str]) -> tuple[list[str], list[int | None], list[int | None]]:
    """Body names (in topology order) and the index of each body's ``z`` and ``theta`` DOF.

    DOF names are ``<kind>_<body>`` with kind ``z`` or ``theta`` (``codegen.vehicle.derive_vehicle``),
    listed body by body."""
    bodies: list[str] = []
    z: dict[str, int] = {}
    theta: dict[str, int] = {}
    for i, name in enumerate(dof_names):
        kind, _, body = name.partition("_")
        if body not in bodies:
            bodies.append(body)
        (z if kind == "z" else theta)[body] = i
    return bodies, [z.get(b) for b in bodies], [theta.get(b) for b in bodies]


def _pick(values: np.ndarray, index: Sequence[int | None]) -> np.ndarray:
    """``values[..., index]`` along the last axis, NaN where the index is None."""
    out = np.full(values.shape[:-1] + (len(index),), np.nan)
    for j, i in enumerate(index):
        if i is not None:
            out[..., j] = values[..., i]
    return out


def body_variables(
    dof_names: Sequence[str], u: np.ndarray, a: np.ndarray
) -> tuple[list[str], dict[str, tuple[tuple[str, ...], np.ndarray, dict[str, str]]]]:
    """Body names and the Dataset variables built from the recorded DOFs ``u``, ``a``
    (time x car x DOF); none for a vehicle without bodies (moving loads)."""
    bodies, z, theta = body_dofs(dof_names)
    if not bodies:
        return [], {}
    dims = ("time", "car", "body")
    variables: dict[str, Any] = {
        "body_uz": (
            dims,
            _pick(u, z),
            {"units": "m", "long_name": "bounce of every body from static equilibrium on rigid track"},
        ),
        "body_az": (
            dims,
            _pick(a, z),
            {"units": "m/s^2", "long_name": "absolute vertical acceleration of every body"},
        ),
        "body_pitch": (
            dims,
            _pick(u, theta),
            {"units": "rad", "long_name": "pitch of every body from static equilibrium, front end up"},
        ),
    }
    return bodies, variables

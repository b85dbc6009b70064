"""The train: identical cars coupled only through the track (docs/design.md section 2).

Car k (0-based here, 1-based in the results) has its leading axle ``k * car_length`` behind the
train's leading axle, which is at ``start_position`` at t = 0 and moves at ``speed``, changing by
``acceleration`` (:class:`Kinematics`).
Contact points are numbered car by car, wheels from the front of each car (``c = k * nw + i``).

A rigid-body car brings its matrices, evaluated by the vehicle's generated kernels
(``svbi.runtime.model.vehicle``); a moving-load "car" only brings its axle forces and offsets.
"""

from __future__ import annotations

import math
from functools import cache
from typing import Any

import numpy as np

from ...codegen.plain_types import GRAVITY, NumericVehicle
from .vehicle import GeneratedVehicle, VehicleTopology, vehicle
from .vehicle_static import vehicle_static_on_rigid_track


@cache
def vehicle_model(name_or_path: str) -> GeneratedVehicle:
    """The vehicle of a built-in name or a topology file as its generated kernels, cached per
    process (a topology file is derived and emitted once into the compile cache)."""
    return vehicle(name_or_path)


def topology(name_or_path: str) -> VehicleTopology:
    """The plain data and parameter validation of a vehicle topology."""
    return vehicle_model(name_or_path).topology


class Kinematics:
    """The train's motion along the track: speed ``v0 + a t`` from ``v0`` at t = 0; a braking
    train (``a < 0``) stops at ``-v0 / a`` and then stands."""

    def __init__(self, speed: float, acceleration: float = 0.0) -> None:
        self.speed = float(speed)
        self.acceleration = float(acceleration)
        self.stop_time = -self.speed / self.acceleration if self.acceleration < 0.0 else float("inf")
        """When a braking train comes to rest (inf: never)."""

    def travel(self, t: Any) -> Any:
        """Distance moved at time(s) t."""
        if self.acceleration == 0.0:
            return self.speed * t
        tm = np.minimum(t, self.stop_time)
        return self.speed * tm + 0.5 * self.acceleration * tm * tm

    def speed_at(self, t: float) -> float:
        """Speed at time t, m/s."""
        if self.acceleration == 0.0:
            return self.speed
        return self.speed + self.acceleration * min(t, self.stop_time)

    def acceleration_at(self, t: float) -> float:
        """Acceleration at time t, m/s^2 (0 once a braking train stands)."""
        return self.acceleration if t < self.stop_time else 0.0

    def time_to_travel(self, distance: float) -> float:
        """When the train has moved ``distance`` (inf if it stops first or never moves)."""
        v, a = self.speed, self.acceleration
        if distance <= 0.0:
            return 0.0
        if a == 0.0:
            return distance / v if v > 0.0 else float("inf")
        disc = v * v + 2.0 * a * distance
        if disc < 0.0:  # a braking train stops first
            return float("inf")
        return (math.sqrt(disc) - v) / a


class Train:
    """Cars of one vehicle type, their wheel positions, and the per-car matrices for a split ``a``."""

    def __init__(
        self,
        vehicle: NumericVehicle,
        cars: int,
        speed: float,
        start_position: float = 0.0,
        contact_split: float = 0.5,
        topology_name: str = "",
        parameter_values: dict[str, Any] | None = None,
        acceleration: float = 0.0,
    ) -> None:
        self.vehicle = vehicle
        self.cars = int(cars)
        self.speed = float(speed)
        """Speed at t = 0 (m/s)."""
        self.acceleration = float(acceleration)
        """Acceleration along the track (m/s^2; negative: braking, until the train stands)."""
        self.motion = Kinematics(self.speed, self.acceleration)
        self.start_position = float(start_position)
        self.split = float(contact_split)
        self.topology_name = topology_name
        self.parameter_values = dict(parameter_values or {})
        self.moving_load = vehicle.kind == "moving-load"
        if self.moving_load:
            offsets = np.asarray(vehicle.axle_offsets, dtype=float)
            self.axle_loads = np.tile(np.asarray(vehicle.axle_loads, dtype=float), self.cars)
        else:
            offsets = np.asarray(vehicle.wheel_offsets, dtype=float)
            self.axle_loads = np.zeros(0)
        self.wheels = len(offsets)
        self.contacts = self.cars * self.wheels
        self.car_length = float(vehicle.car_length)
        # distance of every contact behind the train's leading axle
        self.offsets = (np.arange(self.cars)[:, None] * self.car_length + offsets[None, :]).reshape(-1)
        if not self.moving_load:
            self._rigid_body_setup()

    def _rigid_body_setup(self) -> None:
        v = self.vehicle
        self.ndof = v.ndof
        self.W = np.asarray(v.W_N, dtype=float)
        self.wheel_masses = np.asarray(v.wheel_masses, dtype=float)
        # Section 2.3: aux mass m^g = a W^T m W, active mass m~ = m - W m^g W^T. Gravity on the aux
        # point is its share of the wheel weight, so the vehicle keeps only the rest.
        self.aux_masses = self.split * self.wheel_masses
        self.M_active = v.M - self.W @ np.diag(self.aux_masses) @ self.W.T
        self.carbody_z = v.carbody_z
        self.carbody_theta = v.carbody_theta
        # Vehicle DOFs are measured from the static equilibrium on rigid level track, u = u_s + d
        # (an exact change of variables: the model is linear). W^T u_s = 0 there, so wheel heights
        # and gaps are unchanged, and the small d keeps digits that Newmark's a0 u would lose.
        u_s, _ = vehicle_static_on_rigid_track(self, np.zeros((1, self.wheels)))
        self.u_static = u_s[0]
        self.F_full = v.F_gravity - v.K @ self.u_static
        self.F_active = self.F_full + self.W @ (self.aux_masses * GRAVITY)

    def increment_load(
        self, u: np.ndarray, Pt: np.ndarray, Qt: np.ndarray, *, full_mass: bool = False
    ) -> np.ndarray:
        """``F - K u_n + M P~ + C Q~`` per car: the load of the vehicles' increment equation
        ``K^ du = ...`` (docs/method.md section 3), without contact or creep forces.

        ``full_mass`` gives the whole vehicle (coupled-classic, no aux points); otherwise the active
        mass and load of Section 2.3.
        """
        v = self.vehicle
        F, M = (self.F_full, v.M) if full_mass else (self.F_active, self.M_active)
        return F - u @ v.K + Pt @ M + Qt @ v.C

    # ----------------------------------------------------------------------------------------------
    def positions(self, t: float) -> np.ndarray:
        """x of every contact point at time t."""
        if self.acceleration == 0.0:
            return self.start_position + self.speed * t - self.offsets
        return self.start_position + self.travel(t) - self.offsets

    def travel(self, t: float) -> float:
        return self.motion.travel(t)

    def speed_at(self, t: float) -> float:
        return self.motion.speed_at(t)

    def acceleration_at(self, t: float) -> float:
        return self.motion.acceleration_at(t)

    def time_to_travel(self, distance: float) -> float:
        return self.motion.time_to_travel(distance)

    @property
    def length(self) -> float:
        """Distance from the leading to the last axle."""
        return float(self.offsets.max()) if self.contacts else 0.0

    def static_loads(self) -> np.ndarray:
        """Static wheel loads on rigid level track (N, compression positive), per contact."""
        if self.moving_load:
            return self.axle_loads.copy()
        _, loads = vehicle_static_on_rigid_track(self, np.zeros((self.cars, self.wheels)))
        return loads.reshape(-1)

"""Trains of 3D cars (runtime/model/train3d.py): block-diagonal matrices, the cars' modes once per
car, wheelset offsets from the train's leading axle, car-by-car names, errors."""

from __future__ import annotations

import numpy as np
import pytest
from cases import SPRUNG_WHEELSET_3D
from scipy.linalg import eigh

from svbi.codegen.topology3d import parse_topology3d
from svbi.runtime.model.system3d import vehicle3d
from svbi.runtime.model.train3d import train3d


@pytest.fixture(scope="module")
def cars():
    topo = parse_topology3d(SPRUNG_WHEELSET_3D)
    return vehicle3d(topo), vehicle3d(topo, {"m_s": 6500.0, "r0": 0.43})


def test_two_identical_cars_double_every_mode(cars) -> None:
    car, _ = cars
    train = train3d([car, car], 25.0)
    one = eigh(car.K, car.M, eigvals_only=True)
    both = eigh(train.K, train.M, eigvals_only=True)
    scale = np.abs(one).max()
    assert np.abs(both - np.repeat(one, 2)).max() < 1e-12 * scale
    n = len(car.dof_names)
    assert np.array_equal(train.M[:n, n:], np.zeros((n, n)))
    assert np.array_equal(train.F, np.concatenate([car.F, car.F]))
    assert [w.offset for w in train.wheelsets] == [0.0, 25.0]
    assert train.dof_names[:n] == tuple(f"car0.{d}" for d in car.dof_names)
    assert train.index("car1.y_ws") == n + car.index("y_ws")
    w1 = train.wheelsets[1]
    assert w1.name == "car1.ws" and np.array_equal(w1.dofs, car.wheelsets[0].dofs + n)


def test_offsets_from_the_leading_axle_and_mixed_cars(cars) -> None:
    a, b = cars
    train = train3d([a, b, a], [20.0, 26.5])
    assert [w.offset for w in train.wheelsets] == [0.0, 20.0, 46.5]
    assert train.wheelsets[1].radius == 0.43 and train.wheelsets[2].radius == 0.46
    # gravity: each car's weight, in its own rows
    n = len(a.dof_names)
    assert train.F[n + b.index("z_body")] == b.F[b.index("z_body")] != a.F[a.index("z_body")]


def test_errors(cars) -> None:
    a, _ = cars
    with pytest.raises(ValueError, match="1 spacings for 3 cars: give one value or 2"):
        train3d([a, a, a], [20.0])
    with pytest.raises(ValueError, match=r"spacing 0 \(car0 to car1\): must be a positive number"):
        train3d([a, a], -1.0)
    with pytest.raises(ValueError, match="at least one car"):
        train3d([], 1.0)
    assert train3d([a], []).dof_names[0] == f"car0.{a.dof_names[0]}"

"""The 3D set-up's factorizations: the inverses block by decoupled block, and the static state's
sparse Newton (its open constraints carry exactly no force)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from svbi.runtime.methods.coupled3d import block_inverse, static_state
from svbi.runtime.run.simulate3d import build_run3d
from svbi.runtime.scenario.schema import load_scenario

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "paper-2020-3d.toml"


def _blocks(sizes: list[int], seed: int) -> tuple[np.ndarray, list[np.ndarray]]:
    """A symmetric positive definite matrix of decoupled blocks, its rows shuffled (as a deck's
    fields interleave in the node numbering), and each block's indices."""
    rng = np.random.default_rng(seed)
    n = sum(sizes)
    perm = rng.permutation(n)
    a = np.zeros((n, n))
    groups, start = [], 0
    for s in sizes:
        idx = perm[start : start + s]
        b = rng.standard_normal((s, s))
        a[np.ix_(idx, idx)] = b @ b.T + s * np.eye(s)
        groups.append(idx)
        start += s
    return a, groups


def test_block_inverse_is_the_inverse() -> None:
    a, groups = _blocks([1, 3, 5, 2, 7], seed=3)
    inv = block_inverse(a)
    np.testing.assert_allclose(inv, np.linalg.inv(a), rtol=0, atol=1e-13 * np.abs(inv).max())
    np.testing.assert_allclose(inv @ a, np.eye(len(a)), rtol=0, atol=1e-13)
    label = np.empty(len(a), dtype=int)
    for g, idx in enumerate(groups):
        label[idx] = g
    between = label[:, None] != label[None, :]
    assert np.all(inv[between] == 0.0)  # exactly: no round-off between decoupled blocks


def test_block_inverse_of_one_block_is_numpys() -> None:
    a, _ = _blocks([6], seed=1)
    np.testing.assert_array_equal(block_inverse(a), np.linalg.inv(a))


@pytest.fixture(scope="module")
def paper_static():  # noqa: ANN201 - (system, state)
    sc = load_scenario(EXAMPLE, overrides=["solver.duration=0.001", "earthquake.arrival=0.0"])
    system = build_run3d(sc).system
    return system, static_state(system)


def test_static_state_open_flanges_carry_no_force(paper_static) -> None:  # noqa: ANN001
    """The open flanges' rows are ``lam = 0``: exactly 0, not the solve's round-off of either sign
    (a run's results refuse a negative flange force)."""
    _, st = paper_static
    open_ = ~st.contact.reshape(-1, 4)[:, 2:].reshape(-1)
    assert open_.any()
    assert np.all(st.flange[open_] == 0.0)


def test_static_state_carries_the_trains_weight(paper_static) -> None:  # noqa: ANN001
    """The normal contact forces hold up the train: their vertical components sum to its weight (the
    vehicle's gravity load summed over its vertical DOFs). A coned tread's normal leans by the
    conicity's angle, so the vertical component of ``P`` is ``P / sqrt(1 + conicity^2)``."""
    system, st = paper_static
    veh = system.vehicle
    z = [i for i, name in enumerate(veh.dof_names) if name.split(".")[-1].startswith("z_")]
    weight = -float(veh.F[z].sum())
    assert weight > 0
    vertical = float(st.P.sum()) / np.sqrt(1.0 + system.track.conicity**2)
    assert abs(vertical - weight) <= 1e-9 * weight

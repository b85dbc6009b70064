"""Rigid-body modes of the built-in 3D cars on their suspensions (wheelsets held), from the derived
matrices, against a direct-stiffness assembly written here: each suspension unit's three springs act
on the displacement of its attachment point, computed with NumPy cross products."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from scipy.linalg import eigh

from svbi.codegen.topology3d import Topology3D, builtin_topologies_3d
from svbi.codegen.vehicle3d import VehicleModel3D, derive_vehicle3d

KINDS = ("y", "z", "phi", "theta", "psi")


@functools.cache
def derived(name: str) -> VehicleModel3D:
    return derive_vehicle3d(name)


def direct_stiffness(
    topo: Topology3D, dof_names: tuple[str, ...]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """M, K and C assembled from the topology's numbers, without the symbolic derivation."""
    subs = {p.symbol: p.value for p in topo.parameters.values() if not isinstance(p.value, tuple)}

    def num(expr: object) -> float:
        return float(expr.subs(subs))  # type: ignore[attr-defined]

    n = len(dof_names)
    index = {name: i for i, name in enumerate(dof_names)}
    bodies = {b.name: b for b in topo.bodies}

    def point_matrix(body: str, position: float, lateral: float, height: float) -> np.ndarray:
        """3 x n: displacement (forward, left, up) of a body point from the body's DOFs."""
        b = bodies[body]
        r = np.array([-(position - num(b.position)), lateral, height - num(b.height)])
        out = np.zeros((3, n))
        unit = np.eye(3)
        translations = {"y": unit[1], "z": unit[2]}
        # rotation vectors of the DOFs: roll about +x, pitch about -y (front up), yaw about +z
        rotations = {"phi": unit[0], "theta": -unit[1], "psi": unit[2]}
        for kind in b.dofs:
            col = index[f"{kind}_{body}"]
            out[:, col] = translations[kind] if kind in translations else np.cross(rotations[kind], r)
        return out

    mass = np.zeros((n, n))
    for b in topo.bodies:
        for kind in b.dofs:
            i = index[f"{kind}_{b.name}"]
            mass[i, i] = num(b.mass) if kind in ("y", "z") else num(b.inertias[kind])
    stiffness, damping = np.zeros((n, n)), np.zeros((n, n))
    for s in topo.suspensions:
        p = (num(s.position), num(s.lateral), num(s.height))
        rel = point_matrix(s.body_a, *p) - point_matrix(s.body_b, *p)
        stiffness += rel.T @ np.diag([num(k) for k in s.stiffness]) @ rel
        damping += rel.T @ np.diag([num(c) for c in s.damping]) @ rel
    for r in topo.rotational_springs:
        e = np.zeros(n)
        e[index[f"{r.axis}_{r.body_a}"]] = 1.0
        e[index[f"{r.axis}_{r.body_b}"]] = -1.0
        stiffness += num(r.stiffness) * np.outer(e, e)
        damping += num(r.damping) * np.outer(e, e)
    return mass, stiffness, damping


def held_wheelsets(names: tuple[str, ...]) -> list[int]:
    return [i for i, name in enumerate(names) if "wheelset" not in name]


@pytest.mark.parametrize("name", builtin_topologies_3d())
def test_matrices_equal_the_direct_stiffness_assembly(name: str) -> None:
    model = derived(name)
    nv = model.numeric()
    mass, stiffness, damping = direct_stiffness(model.topology, nv.dof_names)
    np.testing.assert_allclose(nv.M, mass, rtol=1e-13, atol=1e-13 * np.abs(mass).max())
    np.testing.assert_allclose(nv.K, stiffness, rtol=1e-12, atol=1e-12 * np.abs(stiffness).max())
    np.testing.assert_allclose(nv.C, damping, rtol=1e-12, atol=1e-12 * np.abs(damping).max())


@pytest.mark.parametrize("name", builtin_topologies_3d())
def test_car_body_modes_on_the_suspensions(name: str) -> None:
    model = derived(name)
    nv = model.numeric()
    keep = held_wheelsets(nv.dof_names)
    m, k = nv.M[np.ix_(keep, keep)], nv.K[np.ix_(keep, keep)]
    eigenvalues, shapes = eigh(k, m)
    mass, stiffness, _ = direct_stiffness(model.topology, nv.dof_names)
    independent = eigh(stiffness[np.ix_(keep, keep)], mass[np.ix_(keep, keep)], eigvals_only=True)
    np.testing.assert_allclose(eigenvalues, independent, rtol=1e-10)
    assert eigenvalues.min() > 0  # every body restrained with the wheelsets held
    freqs = np.sqrt(eigenvalues) / (2 * np.pi)
    # the five lowest modes are the car body's (bounce, pitch, two sways, yaw): each has most of its
    # kinetic energy in the car body, and together they use all five of its DOFs
    names = [nv.dof_names[i] for i in keep]
    dominant = []
    for j in range(5):
        energy = shapes[:, j] * (m @ shapes[:, j])
        car = [i for i, n in enumerate(names) if n.endswith("_carbody")]
        assert energy[car].sum() > 0.5 * energy.sum()
        dominant.append(names[int(np.argmax(energy))].split("_")[0])
    assert sorted(dominant) == sorted(KINDS)
    assert (
        0.3 < freqs[0] and freqs[4] < 3.0
    )  # car-body modes of passenger cars: a fraction of a hertz to ~2 Hz


def test_vertical_plane_is_the_2d_derivation() -> None:
    """Without longitudinal springs and dashpots, the z and theta block of the 3D car is the 2D
    derivation (codegen.vehicle) of the same car with both sides' vertical units in one."""
    from svbi.codegen.topology import parse_topology
    from svbi.codegen.vehicle import derive_vehicle

    model = derived("manchester-3d")
    topo = model.topology
    zero_x = {
        "primary_stiffness_x": 0.0,
        "primary_damping_x": 0.0,
        "secondary_stiffness_x": 0.0,
        "secondary_damping_x": 0.0,
    }
    nv = model.numeric(zero_x)
    subs = {p.symbol: p.value for p in topo.parameters.values() if not isinstance(p.value, tuple)}

    def num(expr: object) -> float:
        return float(expr.subs(subs))  # type: ignore[attr-defined]

    bodies = {b.name: b for b in topo.bodies}
    lines = ['name = "flat"', "[parameters.car_length]", "value = 23.0"]
    for b in topo.bodies:
        lines += [
            "[[bodies]]",
            f'name = "{b.name}"',
            'dofs = ["z", "theta"]',
            f"mass = {num(b.mass)!r}",
            f"inertia = {num(b.inertias['theta'])!r}",
            f"position = {num(b.position)!r}",
        ]
    for s in topo.suspensions:
        if not s.name.endswith("_left"):
            continue  # the two sides act as one vertical unit of twice the stiffness
        pos = num(s.position)
        lines += [
            "[[suspensions]]",
            f'name = "{s.name}"',
            f'body_a = "{s.body_a}"',
            f"offset_a = {pos - num(bodies[s.body_a].position)!r}",
            f'body_b = "{s.body_b}"',
            f"offset_b = {pos - num(bodies[s.body_b].position)!r}",
            f"stiffness = {2 * num(s.stiffness[2])!r}",
            f"damping = {2 * num(s.damping[2])!r}",
        ]
    for w in topo.wheels:
        if w.name.endswith("_left"):
            lines += [
                "[[wheels]]",
                f'name = "{w.name}"',
                f'body = "{w.body}"',
                f"position = {num(w.position)!r}",
                f"radius = {num(w.radius)!r}",
            ]
    flat = derive_vehicle(parse_topology("\n".join(lines))).numeric()
    idx = [nv.dof_names.index(n) for n in flat.dof_names]
    for got, want in ((nv.M, flat.M), (nv.K, flat.K), (nv.C, flat.C)):
        np.testing.assert_allclose(got[np.ix_(idx, idx)], want, rtol=1e-12, atol=1e-12 * np.abs(want).max())

"""The initial state's full-system solves (``svbi.runtime.methods.initial``) against a dense reference.

The initial state solves two bordered full-system problems: the static equilibrium of the train on
the deflected bridge (``start="static"``) and the consistent accelerations. They are assembled
sparse from the blocks and solved by SuperLU, so that set-up grows linearly with cars and spans.
The truth here is the dense formulation the runtime used before, written out again below entry by
entry from the equations (a loop over cars, spans and contacts into a dense matrix, LAPACK LU with
one step of iterative refinement):

* the sparse matrices equal the dense ones entry for entry, and the right-hand sides agree;
* the solutions agree to 1e-12 of each quantity's peak, and leave residuals as small as the dense
  solve's, for pioneer-2d (with free wheelset spins), the sprung mass and moving loads, with the
  train off and partly on the bridge, rigid-track and static starts, under a ground motion and a
  rail profile that are not zero at t = 0;
* linear cost without timing: no dense factorization larger than one car's block happens, and the
  sparse LU's factors hold a bounded number of entries per unknown as cars and spans grow 16-fold.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sps
import scipy.sparse.linalg as spla

from svbi.examples import paper_section_keys
from svbi.runtime.methods import initial
from svbi.runtime.model.contact_rows import ShapeKernel
from svbi.runtime.model.system import FunctionGround, Model
from svbi.runtime.run.simulate import build_model
from svbi.runtime.scenario.schema import validate_scenario

VEHICLES = ("pioneer-2d", "sprung-mass", "moving-load")
RTOL = 1e-12


class WavyRail:
    """A rail profile with non-zero height, slope and curvature everywhere (also at t = 0)."""

    def evaluate(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        k = 2 * np.pi / 7.3
        return 1e-3 * np.sin(k * x + 0.4), 1e-3 * k * np.cos(k * x + 0.4), -1e-3 * k * k * np.sin(k * x + 0.4)


def _wave(amplitude: float, phase: float):  # noqa: ANN202
    w, c = 2 * np.pi * 1.3, 400.0

    def motion(t: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        arg = w * (t - x / c) + phase
        return amplitude * np.sin(arg), amplitude * w * np.cos(arg), -amplitude * w * w * np.sin(arg)

    return motion


def make_model(vehicle: str, cars: int, spans: int, start_position: float, excited: bool = True) -> Model:
    sc = validate_scenario(
        {
            "bridge": dict(
                spans=spans,
                span_length=32.0,
                **paper_section_keys(),
                damping_ratio=0.02,
                elements_per_span=8,
            ),
            "train": dict(vehicle=vehicle, cars=cars, speed_kmh=300.0, start_position=start_position),
            "contact": dict(creep=vehicle == "pioneer-2d"),  # only its wheels spin
            "solver": dict(method="localized-dynamic", backend="numpy", time_step=1e-3, duration=0.01),
        }
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        model = build_model(sc)
    if excited:
        model.irregularity = WavyRail()
        model.ground = FunctionGround(_wave(0.02, 0.3), _wave(0.01, 1.1), apparent_velocity=400.0)
    return model


# --------------------------------------------------------------------------------------------------
# the dense reference (the formulation as it was, one entry at a time)


def dense_static_system(model: Model) -> tuple[np.ndarray, np.ndarray]:
    b, tr = model.bridge, model.train
    c = model.contacts(0.0)
    q, _, _ = model.supports(0.0)
    (N0,) = ShapeKernel(b.element_length)(c.loc.xi)
    idx = c.element_dofs()
    nV, nd, ns = tr.ndof, b.ndof, b.nsupport
    NV, NB = tr.cars * nV, b.spans * nd
    nc, NS = tr.contacts, b.spans * ns
    Z = initial.free_modes(tr)
    nz = Z.shape[1]
    n = NV + NB + nc + NS + tr.cars * nz
    A = np.zeros((n, n))
    rhs = np.zeros(n)
    for k in range(tr.cars):
        sl = slice(k * nV, (k + 1) * nV)
        A[sl, sl] = tr.vehicle.K
        rhs[sl] = tr.F_full
        zs = slice(NV + NB + nc + NS + k * nz, NV + NB + nc + NS + (k + 1) * nz)
        A[sl, zs] = Z
        A[zs, sl] = Z.T
    for s in range(b.spans):
        sl = slice(NV + s * nd, NV + (s + 1) * nd)
        A[sl, sl] = b.K
        rows = NV + s * nd + b.support_dofs
        cols = NV + NB + nc + s * ns + np.arange(ns)
        A[rows, cols] = -1.0
        A[cols, rows] = 1.0
        rhs[cols] = q[s]
    for i in range(nc):
        car, w = divmod(i, tr.wheels)
        col = NV + NB + i
        A[car * nV : (car + 1) * nV, col] = -tr.W[:, w]
        A[col, car * nV : (car + 1) * nV] = tr.W[:, w]
        rhs[col] = c.r[i]
        if c.on[i]:
            dofs = NV + c.loc.span[i] * nd + idx[i]
            A[dofs, col] += N0[i]
            A[col, dofs] -= N0[i]
        else:
            rhs[col] += c.q[i]
    return A, rhs


def dense_acceleration_system(model: Model, uV, vV, uB, vB, P) -> tuple[np.ndarray, np.ndarray]:  # noqa: ANN001
    b, tr = model.bridge, model.train
    v = model.speed
    c = model.contacts(0.0)
    _, q1, q2 = model.supports(0.0)
    N0, N1, N2 = ShapeKernel(b.element_length, (0, 1, 2))(c.loc.xi)
    idx = c.element_dofs()
    nd, ns = b.ndof, b.nsupport
    NB = b.spans * nd
    nV = 0 if tr.moving_load else tr.ndof
    NV = tr.cars * nV
    nc = 0 if tr.moving_load else tr.contacts
    n = NV + NB + nc + b.spans * ns
    A = np.zeros((n, n))
    rhs = np.zeros(n)
    fB = -(vB - q1 @ b.T.T) @ b.C - uB @ b.K
    for k in range(tr.cars if nV else 0):
        sl = slice(k * nV, (k + 1) * nV)
        A[sl, sl] = tr.vehicle.M
        rhs[sl] = tr.F_full - tr.vehicle.C @ vV[k] - tr.vehicle.K @ uV[k]
    for s in range(b.spans):
        sl = slice(NV + s * nd, NV + (s + 1) * nd)
        A[sl, sl] = b.M
        rhs[sl] = fB[s]
        rows = NV + s * nd + b.support_dofs
        cols = NV + NB + nc + s * ns + np.arange(ns)
        A[rows, cols] = -1.0
        A[cols, rows] = 1.0
        rhs[cols] = q2[s]
    if tr.moving_load:
        for i in np.flatnonzero(c.on):
            rhs[NV + c.loc.span[i] * nd + idx[i]] -= N0[i] * P[i]
    else:
        for i in range(nc):
            car, w = divmod(i, tr.wheels)
            col = NV + NB + i
            A[car * nV : (car + 1) * nV, col] = -tr.W[:, w]
            A[col, car * nV : (car + 1) * nV] = tr.W[:, w]
            rhs[col] = v * v * c.r2[i]
            if c.on[i]:
                s = c.loc.span[i]
                dofs = NV + s * nd + idx[i]
                A[dofs, col] += N0[i]
                A[col, dofs] -= N0[i]
                rhs[col] += 2 * v * N1[i] @ vB[s, idx[i]] + v * v * N2[i] @ uB[s, idx[i]]
            else:
                rhs[col] += c.q2[i]
    return A, rhs


def dense_solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    lu = sla.lu_factor(A)
    x = sla.lu_solve(lu, b)
    return x + sla.lu_solve(lu, b - A @ x)


def residual(A: np.ndarray, x: np.ndarray, b: np.ndarray) -> float:
    """Normwise backward error ``|A x - b| / (|A| |x| + |b|)`` (infinity norms)."""
    scale = np.abs(A).sum(axis=1).max() * np.abs(x).max() + np.abs(b).max()
    return float(np.abs(A @ x - b).max() / scale)


def assert_close(x: np.ndarray, ref: np.ndarray, what: str) -> None:
    tol = RTOL * max(float(np.abs(ref).max(initial=0.0)), np.finfo(float).tiny)
    assert float(np.abs(x - ref).max(initial=0.0)) <= tol, what


def moving_state(model: Model) -> tuple[np.ndarray, ...]:
    """A state with the train moving on a vibrating bridge (deterministic), so that every term of
    the acceleration problem's right-hand side is exercised."""
    b, tr = model.bridge, model.train
    rng = np.random.default_rng(7)
    nV = 0 if tr.moving_load else tr.ndof
    uV, vV = 1e-3 * rng.standard_normal((2, tr.cars, nV))
    uB, vB = 1e-3 * rng.standard_normal((2, b.spans, b.ndof))
    P = 1e5 * (1 + rng.random(tr.contacts))
    return uV, vV, uB, vB, P


CASES = [(v, pos) for v in VEHICLES for pos in (-30.0, 15.0)]
"""Train off the bridge (leading axle 30 m before it), and partly on it (some wheels still off)."""


# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("vehicle", "position"), CASES)
def test_acceleration_system_equals_the_dense_reference(vehicle, position):
    model = make_model(vehicle, cars=2, spans=3, start_position=position)
    if position > 0:
        c = model.contacts(0.0)
        assert c.on.any() and not c.on.all()
    state = moving_state(model)
    system = initial.acceleration_system(model, *state)
    assert sps.issparse(system.A)
    A, rhs = dense_acceleration_system(model, *state)
    np.testing.assert_array_equal(system.A.toarray(), A)
    np.testing.assert_allclose(system.rhs, rhs, rtol=0, atol=1e-15 * np.abs(rhs).max())

    x = system.solve()
    x_ref = dense_solve(A, rhs)
    lay = system.layout
    for name, part in (("aV", slice(0, lay.oB)), ("aB", slice(lay.oB, lay.oP)), ("P", slice(lay.oP, lay.oS))):
        assert_close(x[part], x_ref[part], name)
    assert residual(A, x, rhs) <= max(4 * residual(A, x_ref, rhs), 1e-16)


@pytest.mark.parametrize(("vehicle", "position"), [c for c in CASES if c[0] != "moving-load"])
def test_static_system_equals_the_dense_reference(vehicle, position):
    model = make_model(vehicle, cars=2, spans=3, start_position=position)
    system = initial.static_system(model)
    A, rhs = dense_static_system(model)
    if vehicle == "pioneer-2d":
        assert system.layout.nz > 0  # the wheelset spins are held
    np.testing.assert_array_equal(system.A.toarray(), A)
    np.testing.assert_allclose(system.rhs, rhs, rtol=0, atol=1e-15 * np.abs(rhs).max())

    x_ref = dense_solve(A, rhs)
    uV, uB, P = initial.static_on_bridge(model)
    lay = system.layout
    assert_close(uV.reshape(-1), x_ref[: lay.oB], "uV")
    assert_close(uB.reshape(-1), x_ref[lay.oB : lay.oP], "uB")
    assert_close(P, x_ref[lay.oP : lay.oS], "P")
    assert residual(A, system.solve(), rhs) <= max(4 * residual(A, x_ref, rhs), 1e-16)


@pytest.mark.parametrize("start", ["rigid-track", "static"])
@pytest.mark.parametrize(("vehicle", "position"), CASES)
def test_initial_state_equals_the_dense_reference(vehicle, position, start):
    """The whole initial state, assembled from the dense solves as ``initial_state`` does."""
    model = make_model(vehicle, cars=2, spans=3, start_position=position)
    b, tr = model.bridge, model.train
    st = initial.initial_state(model, start)

    q, q1, _ = model.supports(0.0)
    uB, vB = q @ b.T.T, q1 @ b.T.T
    if tr.moving_load:
        uV, P = np.zeros((tr.cars, 0)), tr.axle_loads.copy()
    elif start == "static":
        A, rhs = dense_static_system(model)
        x = dense_solve(A, rhs)
        NV, NB = tr.cars * tr.ndof, b.spans * b.ndof
        uV, uB = x[:NV].reshape(tr.cars, -1), x[NV : NV + NB].reshape(b.spans, -1)
        P = x[NV + NB : NV + NB + tr.contacts]
    else:
        uV, P = st.uV, st.P  # rigid track: per-car dense solves, the same in both
    vV = np.zeros_like(uV)
    A, rhs = dense_acceleration_system(model, uV, vV, uB, vB, P)
    x = dense_solve(A, rhs)
    NV, NB = uV.size, b.spans * b.ndof
    assert_close(st.uV, uV, "uV")
    assert_close(st.uB, uB, "uB")
    if start == "static":
        # The accelerations of the static start balance elastic forces K u ~ 1e8 N against inertia:
        # they inherit the 1e-14 difference of u times K / M, so they are compared from the same u.
        aV, aB, P1 = initial.consistent_accelerations(model, uV, vV, uB, vB, P)
    else:
        aV, aB, P1 = st.aV, st.aB, st.P
    assert_close(aV.reshape(-1), x[:NV], "aV")
    assert_close(aB.reshape(-1), x[NV : NV + NB], "aB")
    assert_close(P1, P if tr.moving_load else x[NV + NB : NV + NB + tr.contacts], "P")


# --------------------------------------------------------------------------------------------------
# linear cost, checked by structure (no timing)


def _factor_fill(monkeypatch: pytest.MonkeyPatch, model: Model) -> list[tuple[int, int, int]]:
    """Run ``initial_state(start="static")`` and return ``(n, nnz(A), nnz(L) + nnz(U))`` of every
    sparse factorization; fail on any dense factorization larger than one car's bordered block."""
    tr = model.train
    largest = tr.ndof + tr.wheels + initial.free_modes(tr).shape[1]
    fills: list[tuple[int, int, int]] = []
    splu, lu_factor = spla.splu, sla.lu_factor

    def spy_splu(A, *args, **kw):  # noqa: ANN001, ANN002, ANN003, ANN202
        lu = splu(A, *args, **kw)
        fills.append((A.shape[0], A.nnz, lu.L.nnz + lu.U.nnz))
        return lu

    def spy_lu_factor(A, *args, **kw):  # noqa: ANN001, ANN002, ANN003, ANN202
        assert np.shape(A)[0] <= largest, f"a dense {np.shape(A)} factorization"
        return lu_factor(A, *args, **kw)

    monkeypatch.setattr(spla, "splu", spy_splu)
    monkeypatch.setattr(sla, "lu_factor", spy_lu_factor)
    st = initial.initial_state(model, "static")
    monkeypatch.undo()
    assert np.isfinite(st.uB).all() and np.isfinite(st.aB).all()
    return fills


def test_set_up_is_linear_in_cars_and_spans(monkeypatch):
    """From 5 cars on 25 spans to 80 cars on 400 spans (train on the bridge): every factorization
    is sparse with the same number of factor entries per unknown. A dense factorization of the
    large case would be a 26,000-square matrix (5.4 GB); the sparse one holds about 0.1% of it."""
    per_unknown = []
    for cars, spans in ((5, 25), (20, 100), (80, 400)):
        model = make_model("pioneer-2d", cars, spans, start_position=27.0 * cars, excited=False)
        assert model.contacts(0.0).on.all()
        fills = _factor_fill(monkeypatch, model)
        assert len(fills) == 2  # static equilibrium, consistent accelerations
        for n, nnz, fill in fills:
            assert nnz <= 60 * n and fill <= 60 * n, (cars, spans, n, nnz, fill)
        per_unknown.append([fill / n for n, _, fill in fills])
    small, large = np.array(per_unknown[0]), np.array(per_unknown[-1])
    assert np.all(large <= 1.1 * small), per_unknown

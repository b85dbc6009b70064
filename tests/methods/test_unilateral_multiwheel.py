"""Unilateral contact with several wheels on one flexible span, against an event-driven reference.

Two sprung masses (``sprung-mass`` vehicles, 10 m apart) stand on one 25 m span whose supports move
vertically as ``q(t) = A sin^3(w t)``, strongly enough that both wheels lift off, fly and land
again, at different times (they stand off-centre). The wheels interact through the span: one
wheel's lift-off or landing changes the force on the other.

The reference is written here, independently of the code under test, for the same discrete model:
the span's finite-element matrices ``M, C, K`` (damping on the motion relative to the ground, as the
model defines it), the support DOFs prescribed, the contact rows ``N0`` of the two wheels, and the
vehicles' own equations. It is integrated event by event with ``solve_ivp`` (DOP853, tight
tolerances): between events the wheels in contact follow the rail exactly (their forces from the
constrained equations of motion); an event is a contact force reaching zero or an airborne wheel
reaching its rail. At every event the contact state is the solution of the complementarity
problems over both wheels, found by enumeration: a landing is a perfectly plastic impact (impulses
``>= 0``, relative normal velocities after it ``>= 0``, complementary, through the mass of the
whole discrete system), and the wheels that stay on their rails are the set whose forces are
``>= 0`` while every wheel off it has a relative acceleration ``>= 0``.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from test_unilateral import BRIDGE, C_S, K_S, M_S, M_W, SPLIT, G, sine_cubed

import svbi
from svbi.runtime.model.contact_rows import ShapeKernel
from svbi.runtime.model.system import FunctionGround
from svbi.runtime.run.simulate import build_model
from svbi.runtime.scenario.schema import validate_scenario

GROUND = sine_cubed(0.05, 2.0)  # peak downward acceleration 1.4 g
SPACING, FRONT, DURATION = 10.0, 20.0, 1.0  # wheels at x = 20 m and 10 m on the 25 m span


def scenario(method="localized-dynamic", backend="numpy", dt=1e-4, duration=DURATION):
    return validate_scenario(
        {
            "bridge": BRIDGE,
            "train": dict(
                vehicle="sprung-mass",
                cars=2,
                speed=0.0,
                start_position=FRONT,
                parameters=dict(
                    sprung_mass=M_S, wheel_mass=M_W, stiffness=K_S, damping=C_S, car_length=SPACING
                ),
            ),
            "contact": dict(normal="unilateral", creep=False),
            "solver": dict(
                method=method,
                backend=backend,
                time_step=dt,
                output_every=1,
                duration=duration,
                contact_split=SPLIT,
            ),
        }
    )


def run(**kw):
    sc = scenario(**kw)
    model = build_model(sc)
    model.ground = FunctionGround(vertical=GROUND)
    return svbi.simulate(sc, model=model)


class Reference:
    """The event-driven solution of the same discrete model (module docstring)."""

    def __init__(self) -> None:
        model = build_model(scenario())
        b = model.bridge
        assert b.nsub == 1 and model.train.cars == 2
        c = model.contacts(0.0)
        assert c.on.all()
        (N0,) = ShapeKernel(b.contact_element_length)(c.loc.xi, c.loc.span)
        nd = b.ndof
        N = np.zeros((2, nd))
        for i in range(2):
            N[i, c.element_dofs()[i]] = N0[i]
        sup = np.asarray(b.support_dofs)
        self.vertical = np.asarray(b.support_vertical, dtype=float)  # the ground moves these
        free = np.setdiff1d(np.arange(nd), sup)
        M, C, K = b.M, b.C, b.K
        # quasi-static field of the support motion: damping acts on the motion relative to it
        T = np.zeros((nd, len(sup)))
        T[sup, np.arange(len(sup))] = 1.0
        T[free] = -np.linalg.solve(K[np.ix_(free, free)], K[np.ix_(free, sup)])
        self.f, self.s, self.N = free, sup, N
        self.Mff, self.Mfs = M[np.ix_(free, free)], M[np.ix_(free, sup)]
        self.Cff, self.Cfs = C[np.ix_(free, free)], C[np.ix_(free, sup)]
        self.Kff, self.Kfs = K[np.ix_(free, free)], K[np.ix_(free, sup)]
        self.CT = (C @ T)[free]
        self.Nf, self.Ns = N[:, free], N[:, sup]
        nf = len(free)
        self.nf = nf
        # generalised coordinates x = [u_f, z_body (2), z_wheel (2)]; masses
        n = nf + 4
        self.Mx = np.zeros((n, n))
        self.Mx[:nf, :nf] = self.Mff
        self.Mx[nf : nf + 2, nf : nf + 2] = M_S * np.eye(2)
        self.Mx[nf + 2 :, nf + 2 :] = M_W * np.eye(2)
        # contact rows: g_i = z_wheel_i - N_i u  (d g / d x)
        self.Jc = np.zeros((2, n))
        self.Jc[:, :nf] = -self.Nf
        self.Jc[:, nf + 2 :] = np.eye(2)
        self.n = n
        self._kkt: dict[tuple[int, ...], np.ndarray] = {}

    def ground(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q, q1, q2 = (float(v) for v in GROUND(t, 0.0))
        return self.vertical * q, self.vertical * q1, self.vertical * q2

    def free_forces(self, t: float, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Every force but the contacts', in the coordinates x."""
        nf = self.nf
        s, s1, s2 = self.ground(t)
        uf, vf = x[:nf], v[:nf]
        zb, zw, vb, vw = x[nf : nf + 2], x[nf + 2 :], v[nf : nf + 2], v[nf + 2 :]
        spring = K_S * (zb - zw) + C_S * (vb - vw)
        fB = -self.Mfs @ s2 - self.Cff @ vf - self.Cfs @ s1 + self.CT @ s1 - self.Kff @ uf - self.Kfs @ s
        return np.concatenate([fB, -M_S * G - spring, -M_W * G + spring])

    def gap(self, t: float, x: np.ndarray) -> np.ndarray:
        return x[self.nf + 2 :] - self.Nf @ x[: self.nf] - self.Ns @ self.ground(t)[0]

    def gap_rate(self, t: float, v: np.ndarray) -> np.ndarray:
        return v[self.nf + 2 :] - self.Nf @ v[: self.nf] - self.Ns @ self.ground(t)[1]

    def solve(
        self, t: float, x: np.ndarray, v: np.ndarray, A: tuple[int, ...]
    ) -> tuple[np.ndarray, np.ndarray]:
        """Accelerations and contact forces with the wheels ``A`` held on their rails (g'' = 0;
        the rows N are constant: the wheels stand)."""
        f = self.free_forces(t, x, v)
        idx = list(A)
        if A not in self._kkt:  # constant per set: the rows N do not move
            k = len(idx)
            J = self.Jc[idx]
            kkt = np.zeros((self.n + k, self.n + k))
            kkt[: self.n, : self.n] = self.Mx
            kkt[: self.n, self.n :] = -J.T  # the contact force P (compression) pushes along +g
            kkt[self.n :, : self.n] = J
            self._kkt[A] = np.linalg.inv(kkt)
        rhs = np.concatenate([f, self.Ns[idx] @ self.ground(t)[2]])
        sol = self._kkt[A] @ rhs
        P = np.zeros(2)
        P[idx] = sol[self.n :]
        return sol[: self.n], P

    def contact_set(
        self, t: float, x: np.ndarray, v: np.ndarray, closed: list[int], leaving: int = -1
    ) -> tuple[int, ...]:
        """The wheels (among ``closed``, at g = g' = 0) that stay on their rails: forces >= 0 on the
        set, relative accelerations >= 0 off it (the acceleration-level complementarity problem).
        ``leaving``: a wheel whose force has just fallen to zero (both states are consistent at
        the event itself; its force is about to go tensile, so the sets without it come first)."""
        sets = [A for k in range(len(closed), -1, -1) for A in itertools.combinations(closed, k)]
        sets.sort(key=lambda A: leaving in A)
        for A in sets:
            if True:
                a, P = self.solve(t, x, v, A)
                g2 = self.Jc @ a - self.Ns @ self.ground(t)[2]
                if all(P[i] >= 0 for i in A) and all(g2[i] >= -1e-9 for i in closed if i not in A):
                    return A
        raise AssertionError(f"no consistent contact set at t = {t}")

    def impact(self, t: float, x: np.ndarray, v: np.ndarray, A: tuple[int, ...], landing: int) -> np.ndarray:
        """Perfectly plastic impact of ``landing`` with the wheels ``A`` on their rails: impulses >= 0,
        relative velocities after it >= 0, complementary (enumerated)."""
        Minv = np.linalg.inv(self.Mx)
        g1 = self.gap_rate(t, v)
        cand = sorted(set(A) | {landing})
        for k in range(len(cand), -1, -1):
            for B in itertools.combinations(cand, k):
                idx = list(B)
                J = self.Jc[idx]
                imp = np.linalg.solve(J @ Minv @ J.T, -g1[idx]) if idx else np.zeros(0)
                dv = Minv @ J.T @ imp if idx else np.zeros(self.n)
                after = g1 + self.Jc @ dv
                if (imp >= 0).all() and all(after[i] >= -1e-12 for i in cand):
                    return v + dv
        raise AssertionError(f"no consistent impact at t = {t}")

    def static_start(self) -> tuple[np.ndarray, np.ndarray]:
        """Static equilibrium at t = 0 (the ground at rest there): both wheels carry their car."""
        P = np.full(2, (M_S + M_W) * G)
        uf = np.linalg.solve(self.Kff, -self.Nf.T @ P)
        zw = self.Nf @ uf
        zb = zw - M_S * G / K_S
        x = np.concatenate([uf, zb, zw])
        return x, np.zeros(self.n)

    def integrate(self, t_end: float) -> list[list[tuple[float, float, float]]]:
        """Flights per wheel: ``(lift-off time, landing time, peak uplift)``."""
        nf, n = self.nf, self.n
        x, v = self.static_start()
        t = 0.0
        A: tuple[int, ...] = (0, 1)
        flights: list[list[tuple[float, float, float]]] = [[], []]
        opened = [np.nan, np.nan]
        peak = [0.0, 0.0]
        opts = dict(method="DOP853", rtol=1e-10, atol=1e-12, max_step=1e-3, dense_output=True)

        def rhs(tt, y):
            a, _ = self.solve(tt, y[:n], y[n:], A)
            return np.concatenate([y[n:], a])

        events = []
        for i in range(2):

            def force(tt, y, i=i):
                return self.solve(tt, y[:n], y[n:], A)[1][i] if i in A else 1.0

            def landing(tt, y, i=i):
                return self.gap(tt, y[:n])[i] if i not in A else 1.0

            force.terminal, force.direction = True, -1
            landing.terminal, landing.direction = True, -1
            events += [force, landing]

        while t < t_end:
            sol = solve_ivp(rhs, (t, t_end), np.concatenate([x, v]), events=events, **opts)
            tt = np.linspace(sol.t[0], sol.t[-1], max(10, int((sol.t[-1] - sol.t[0]) / 1e-5)))
            yy = sol.sol(tt)
            ground = self.vertical[:, None] * GROUND(tt, 0.0)[0][None, :]
            gaps = (yy[nf + 2 : n] - self.Nf @ yy[:nf] - self.Ns @ ground).T
            for i in range(2):
                if i not in A:
                    peak[i] = max(peak[i], float(gaps[:, i].max()))
            if sol.status != 1:
                break
            hit = [k for k in range(4) if len(sol.t_events[k])]
            k = hit[0]
            t = float(sol.t_events[k][0])
            y = sol.y_events[k][0]
            x, v = y[:n].copy(), y[n:].copy()
            i = k // 2
            if k % 2 == 0:  # wheel i's force reached zero: it may leave
                opened[i], peak[i] = t, 0.0
                A = self.contact_set(t, x, v, sorted(set(A)), leaving=i)
                assert i not in A
            else:  # wheel i reached its rail: plastic impact, then the contact set
                v = self.impact(t, x, v, A, i)
                flights[i].append((opened[i], t, peak[i]))
                closed = [j for j in range(2) if j in A or j == i]
                A = self.contact_set(t, x, v, closed)
                for j in closed:
                    if j not in A:  # touched and left at once
                        opened[j], peak[j] = t, 0.0
            t += 1e-12
        for i in range(2):
            if i not in A:
                flights[i].append((opened[i], np.inf, peak[i]))
        return flights


def flights_of(ds, car: int) -> list[tuple[float, float, float]]:
    """Flights of the wheel of ``car`` (0-based): (first airborne step, first step back on, peak uplift)."""
    t = ds.time.values
    off = ds.contact_state.values[:, car, 0] == 0
    up = ds.wheel_uplift.values[:, car, 0]
    edges = np.flatnonzero(np.diff(np.concatenate([[0], off.astype(int), [0]])))
    return [
        (float(t[a]), float(t[b]) if b < len(t) else np.inf, float(up[a:b].max()))
        for a, b in zip(edges[::2], edges[1::2], strict=True)
    ]


@pytest.fixture(scope="module")
def reference():
    return Reference().integrate(DURATION)


def compare(ds, reference, dt):
    """Event times within a few steps, flight times and peak uplifts within 3 %; the worst errors."""
    worst = [0.0, 0.0, 0.0]
    for car in range(2):
        got, ref = flights_of(ds, car), reference[car]
        assert len(got) == len(ref), (car, got, ref)
        for (a, b, up), (ra, rb, rup) in zip(got, ref, strict=True):
            assert abs(a - ra) <= 3 * dt, ("lift-off", car, a, ra)
            if np.isfinite(rb):
                assert abs(b - rb) <= 3 * dt, ("landing", car, b, rb)
                assert abs((b - a) / (rb - ra) - 1) < 0.03, ("flight time", car, b - a, rb - ra)
                worst[1] = max(worst[1], abs((b - a) / (rb - ra) - 1))
                worst[0] = max(worst[0], abs(b - rb))
            assert abs(up / rup - 1) < 0.03, ("peak uplift", car, up, rup)
            worst[0] = max(worst[0], abs(a - ra))
            worst[2] = max(worst[2], abs(up / rup - 1))
    return worst


def test_reference_has_interacting_flights(reference):
    """Both wheels fly more than once, and not at the same times (they stand off-centre)."""
    assert all(len(f) >= 2 for f in reference), reference
    assert abs(reference[0][0][0] - reference[1][0][0]) > 1e-3, reference


@pytest.mark.parametrize(
    ("method", "backend"),
    [("localized-dynamic", "numpy"), ("localized-dynamic", "c"), ("coupled-dynamic", "numpy")],
)
def test_two_wheels_match_the_event_driven_reference(reference, method, backend):
    from conftest import c_compiler_works

    if backend == "c" and not c_compiler_works():
        pytest.skip("no C compiler")
    dt = 1e-4
    ds = run(method=method, backend=backend, dt=dt)
    worst = compare(ds, reference, dt)
    P = ds.contact_force.values
    state = ds.contact_state.values
    assert (P[state == 1] >= 0).all() and (P[state == 0] == 0).all()
    assert worst[1] < 0.03 and worst[2] < 0.03, worst

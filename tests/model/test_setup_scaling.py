"""Set-up of long bridges: sparse, linear in the spans, piers and elements, and the same numbers as
dense linear algebra.

* The quasi-static (influence) field of every support, solved window by window on sparse
  matrices, against ``-K_ff^-1 K_fs`` solved densely here, within the dense solve's own round-off
  bound ``eps cond(K_ff) max|T|`` (``K_ff`` scaled to a unit diagonal) plus the field's trim.
* The lowest frequencies of a girder and of a pier (Rayleigh damping's two) by shift-invert
  Lanczos against ``scipy.linalg.eigh`` of the dense matrices assembled here from the generated
  span and column matrices, within the dense solver's bound ``eps lambda_max``.
* Work and memory: the influence solves grow linearly with the bridge, no dense matrix of a
  substructure is formed at set-up, and the memory estimate of a 2,000-pier viaduct refuses it
  without building the bridge's matrices (``tracemalloc`` peak). No timing here: the times are in
  ``benchmarks/bench_setup.py``.
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
import scipy.linalg as sla

from svbi.examples import paper_section, paper_section_keys
from svbi.runtime.model import bridge as bridge_module
from svbi.runtime.model.bridge import Bridge, Girder, Pier, Section
from svbi.runtime.model.modes import column_matrices, span_matrices
from svbi.runtime.run.memory import MemoryLimitError, check_memory
from svbi.runtime.scenario.schema import validate_scenario

EPS = np.finfo(float).eps
L, MU, E, AREA, Iy = paper_section()
DECK = Section(MU, E, AREA, Iy, 0.02)
PIER = Section(22.5e3, 34.0e9, 9.0, 6.1, 0.02)


def mixed_bridge(elements: int = 4) -> Bridge:
    """Ten simply supported spans, a 40-56-40 m unit and a 30-span continuous girder (fixed
    bearing in its middle), on 13 piers (one with a vertical bearing spring): windows of the
    influence solve are cut short on the piers and grow along the long girder."""
    girders = [Girder((32.0,), DECK)] * 10 + [Girder((40.0, 56.0, 40.0), DECK, 1)]
    girders.append(Girder((32.0,) * 30, DECK, 15))
    piers = [Pier(j, 12.0, PIER, 5.0e9 if j == 3 else None) for j in range(1, 14)]
    return Bridge(0, 0.0, MU, E, AREA, Iy, 0.02, elements, 0.0, girders, piers)


def test_influence_field_matches_a_dense_solve(monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setattr(bridge_module, "DIRECT_LIMIT", 0)  # window by window, on a short bridge
    b = mixed_bridge()
    K = b.K_global.toarray()
    free, sup = b.free_global, b.support_global
    k_ff = K[np.ix_(free, free)]
    dense = np.zeros((b.nglobal, len(sup)))
    dense[sup, np.arange(len(sup))] = 1.0
    dense[free] = -np.linalg.solve(k_ff, K[np.ix_(free, sup)])
    got = np.zeros_like(dense)
    got[b.global_dof.ravel()] = b.T_map.toarray()
    d = np.sqrt(np.diag(k_ff))
    cond = np.linalg.cond(k_ff / d[:, None] / d[None, :])
    # forward error of a backward-stable solve: eps cond max|T| (2e-11 here; measured 1e-12), and
    # the sparse field drops entries below TRIM
    bound = EPS * cond * np.abs(dense).max() + bridge_module.TRIM
    assert np.abs(got - dense).max() <= bound
    # a column is the field of one support: 1 there, 0 at the other supports
    np.testing.assert_array_equal(got[sup], np.eye(len(sup)))


def _dense_lowest(M: np.ndarray, K: np.ndarray, dofs: np.ndarray, count: int) -> tuple[np.ndarray, float]:
    lam = sla.eigh(K[np.ix_(dofs, dofs)], M[np.ix_(dofs, dofs)], eigvals_only=True)
    return lam[:count], float(lam[-1])


def test_lowest_modes_by_lanczos_match_dense_eigh(monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setattr(bridge_module, "DENSE_LIMIT", 0)  # the sparse path, on a small bridge
    monkeypatch.setattr(bridge_module, "DIRECT_LIMIT", 0)
    b = mixed_bridge()
    ne = b.elements
    for g in b.girders[10:]:
        # the girder assembled here, densely, from the generated matrices of its spans
        n = 3 * (ne * len(g.spans) + 1)
        M, K = np.zeros((n, n)), np.zeros((n, n))
        for j, length in enumerate(g.spans):
            m, k = span_matrices(length, ne, E, AREA, Iy, MU)
            o = slice(3 * ne * j, 3 * ne * j + 3 * (ne + 1))
            M[o, o] += m
            K[o, o] += k
        held = [3 * ne * j + 1 for j in range(len(g.spans) + 1)] + [3 * ne * g.fixed_support]
        dofs = np.array([i for i in range(n) if i not in held and i % 3 != 0])
        lam, top = _dense_lowest(M, K, dofs, 2)
        got = b.girder_frequencies(g, 2) ** 2
        # the dense solver's error is eps lambda_max (absolute); margin 10
        np.testing.assert_allclose(got, lam, rtol=0, atol=10 * EPS * top)
    M, K = column_matrices(12.0, ne, PIER.youngs_modulus, PIER.area, PIER.second_moment, PIER.mass_per_length)
    dofs = np.array([i for i in range(3, M.shape[0]) if i % 3 != 1])
    lam, top = _dense_lowest(M, K, dofs, 2)
    np.testing.assert_allclose(b._pier_frequencies(b.piers[0], 2) ** 2, lam, rtol=0, atol=10 * EPS * top)
    # Rayleigh damping of the long girder's spans from those two frequencies
    w1, w2 = np.sqrt(_dense_lowest(*_girder_dense(b, b.girders[-1]), 2)[0])
    kind = b.kinds[b.kind[b.spans - 1]]
    assert kind.alpha == pytest.approx(2 * 0.02 * w1 * w2 / (w1 + w2), rel=1e-12)
    assert kind.beta == pytest.approx(2 * 0.02 / (w1 + w2), rel=1e-12)


def _girder_dense(b: Bridge, g: Girder) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    M, K, held = b._girder_matrices(g)
    dofs = np.array([i for i in range(M.shape[0]) if i not in held and i % 3 != 0])
    return M.toarray(), K.toarray(), dofs


def test_whole_bridge_frequencies_sparse_against_dense():
    b = mixed_bridge(elements=10)  # above 1500 free DOFs: natural_frequencies goes sparse
    assert len(b.free_global) > 1500
    M, K, free = b.assembled()
    lam, top = _dense_lowest(M, K, free, 4)
    got = (2 * np.pi * b.natural_frequencies(4)) ** 2
    np.testing.assert_allclose(got, lam, rtol=0, atol=10 * EPS * top)
    # the paper's bridge: every mode of a span once per span (a multiplicity Lanczos cannot see)
    b = Bridge(40, L, MU, E, AREA, Iy, 0.02, 16)
    M, K, free = b.assembled()
    assert len(free) > 1500
    lam, top = _dense_lowest(M, K, free, 45)
    got = (2 * np.pi * b.natural_frequencies(45)) ** 2
    np.testing.assert_allclose(got, lam, rtol=0, atol=10 * EPS * top)


def on_piers(spans: int, elements: int = 16) -> Bridge:
    girders = [Girder((32.0,), DECK)] * spans
    piers = [Pier(j, 12.0, PIER) for j in range(1, spans)]
    return Bridge(0, 0.0, MU, E, AREA, Iy, 0.02, elements, 0.0, girders, piers)


def test_influence_work_and_storage_grow_linearly(monkeypatch: pytest.MonkeyPatch):
    """Each added stretch of bridge adds the same work (unknowns solved for times supports) and the
    same entries of the field: the increments, free of the bridge ends, are equal (a solve with a
    right-hand side per support on the whole bridge would make them grow with its length)."""
    monkeypatch.setattr(bridge_module, "DIRECT_LIMIT", 0)  # short bridges too, window by window
    piers = [on_piers(n) for n in (40, 80, 120)]
    # a continuous girder: a support's field decays over about 30 spans, the windows are wider
    girders = [
        Bridge(0, 0.0, MU, E, AREA, Iy, 0.02, 2, 0.0, [Girder((32.0,) * n, DECK)], [])
        for n in (160, 320, 480)
    ]
    for b0, b1, b2 in (piers, girders):
        assert b2.influence_work - b1.influence_work <= 1.05 * (b1.influence_work - b0.influence_work)
        assert b2.T_map.nnz - b1.T_map.nnz <= 1.05 * (b1.T_map.nnz - b0.T_map.nnz)


def test_setup_forms_no_dense_substructure_matrix():
    b = on_piers(3, elements=400)  # above DIRECT_LIMIT
    for kind in b.kinds:  # dense M, K, C are formed on a stepper's first use, not at set-up
        assert not {"M", "K", "C"} & set(vars(kind))
    assert kind.M.shape == (b.ndof, b.ndof)
    np.testing.assert_array_equal(kind.M, kind.Ms.toarray())


def test_memory_estimate_of_2000_piers_refuses_without_building_the_bridge():
    pier = dict(height=12.0, mass_per_length=22.5e3, youngs_modulus=34.0e9, area=9.0, second_moment=6.1)
    scenario = validate_scenario(
        {
            "bridge": dict(
                **paper_section_keys(),
                elements_per_span=16,
                girders=[dict(spans=[32.0])] * 2000,
                piers=[dict(support=j, **pier) for j in range(1, 2000)],
            ),
            "train": dict(vehicle="pioneer-2d", cars=10, speed_kmh=300.0),
            "solver": dict(time_step=1e-3),
        }
    )
    tracemalloc.start()
    try:
        with pytest.raises(MemoryLimitError, match="bridge.spans = 2000"):
            check_memory(scenario, "1MB")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    # the layout of 4,000 substructures is under a megabyte; a sparse K of the bridge alone
    # would be 20 MiB (measured 3.3 MiB in all)
    assert peak < 16 * 2**20

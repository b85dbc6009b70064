"""The 3D bridge (runtime/model/bridge3d.py) restricted to the vertical plane is svbi's 2D bridge.

For the paper's chain of simply supported spans, a chain with a continuous girder, and a viaduct on
piers with bearing springs: the 3D ``M``, ``K``, ``C`` on the ``(u, w, theta)`` DOFs of every node
equal the 2D bridge's assembled matrices (``Bridge.assembled``, the 2D Rayleigh blocks) entry by
entry to round-off, under the map from 2D DOFs (substructure, node, DOF) to 3D DOFs built here from
the two layouts; the same DOFs are held; nothing couples the vertical plane to the lateral and
torsional DOFs. Also the layout: deck elements, spans, midspans, pier tops, supports, and errors.
"""

from __future__ import annotations

import numpy as np
import pytest

from svbi.runtime.model.bridge import Bridge, Girder, Pier, Section
from svbi.runtime.model.bridge3d import Bridge3D, bridge3d, section3d

DECK = Section(mass_per_length=2303.0, youngs_modulus=2.87e9, area=1.0, second_moment=2.9, damping_ratio=0.02)
PIER = Section(mass_per_length=12e3, youngs_modulus=3.0e10, area=5.0, second_moment=4.0, damping_ratio=0.05)
NE = 4
PLANE = ("u", "w", "theta")


def deck3d(section: Section = DECK) -> object:
    return section3d(section, lateral_second_moment=12.0, torsion_constant=5.0)


def pier3d(section: Section = PIER) -> object:
    return section3d(section, lateral_second_moment=9.0, torsion_constant=6.0, poisson_ratio=0.25)


CASES = {
    "paper-chain": ([Girder((25.0,), DECK)] * 3, []),
    "continuous": ([Girder((25.0,), DECK), Girder((20.0, 30.0, 20.0), DECK, fixed_support=2)], []),
    "viaduct": (
        [Girder((24.0,), DECK), Girder((30.0, 40.0), DECK, fixed_support=1)],
        [Pier(1, 10.0, PIER), Pier(2, 12.0, PIER, bearing_vertical=4e9, bearing_longitudinal=2e8)],
    ),
}


def build(case: str) -> tuple[Bridge, Bridge3D]:
    girders, piers = CASES[case]
    b2 = Bridge(0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, NE, girders=girders, piers=piers)
    if case == "paper-chain":  # the shorthand builds the same bridge as its long form
        b2 = Bridge(3, 25.0, 2303.0, 2.87e9, 1.0, 2.9, 0.02, NE)
        assert b2.uniform
    b3 = Bridge3D(girders, NE, [deck3d()] * len(girders), piers, [pier3d()] * len(piers), [3e8] * len(piers))
    return b2, b3


def dof_map(b2: Bridge, b3: Bridge3D) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """2D global DOF and 3D global DOF of every substructure DOF, and 2D's C scattered globally."""
    nd = b2.ndof
    rows2, rows3 = [], []
    for s in range(b2.nsub):
        nodes = b3.span_nodes[s] if s < b2.spans else b3.pier_nodes[s - b2.spans]
        for n, node in enumerate(nodes):
            for j, name in enumerate(PLANE):
                rows2.append(s * nd + 3 * n + j if b2.uniform else b2.global_dof[s, 3 * n + j])
                rows3.append(b3.dof(int(node), name))
    rows2, rows3 = np.array(rows2), np.array(rows3)
    n2 = b2.spans * nd if b2.uniform else b2.nglobal
    C2 = np.zeros((n2, n2))
    for s in range(b2.nsub):
        kind = b2.kinds[b2.kind[s]]
        g = np.arange(s * nd, (s + 1) * nd) if b2.uniform else b2.global_dof[s]
        C2[np.ix_(g, g)] += kind.C
    return rows2, rows3, C2


@pytest.mark.parametrize("case", list(CASES))
def test_vertical_plane_is_the_2d_bridge(case: str) -> None:
    b2, b3 = build(case)
    rows2, rows3, C2 = dof_map(b2, b3)
    # a one-to-one map: the 2D links and the 3D merges join the same DOFs
    pairs = set(zip(rows2.tolist(), rows3.tolist(), strict=True))
    assert len({a for a, _ in pairs}) == len({b for _, b in pairs}) == len(pairs)
    u2, u3 = (np.array(x) for x in zip(*sorted(pairs), strict=True))
    M2, K2, free2 = b2.assembled()
    assert len(u2) == M2.shape[0]
    for a2, a3 in ((M2, b3.M), (K2, b3.K), (C2, b3.C)):
        scale = np.abs(a2).max()
        assert np.abs(a3[np.ix_(u3, u3)] - a2[np.ix_(u2, u2)]).max() < 1e-13 * scale
        others = np.setdiff1d(np.arange(b3.ndof), u3)
        assert not np.any(a3[np.ix_(u3, others)])  # the plane is uncoupled from sway and twist
    held2 = set(np.setdiff1d(np.arange(M2.shape[0]), free2).tolist())
    held3 = set(b3.support_dofs.tolist())
    assert {int(b) for a, b in zip(u2, u3, strict=True) if a in held2} == held3 & set(u3.tolist())
    # Rayleigh coefficients: the 2D bridge's, girder by girder then pier by pier
    assert b3.rayleigh[0] == (b2.kinds[b2.kind[0]].alpha, b2.kinds[b2.kind[0]].beta)


def test_layout_and_supports() -> None:
    _, b3 = build("viaduct")
    assert b3.spans == 3 and b3.n_elements == 3 * NE and b3.length == 94.0
    # deck elements along the track; the joint at x = 24 belongs to the span ahead
    assert b3.deck_location(0.0) == (0, 0.0)
    assert b3.deck_location(24.0) == (NE, 0.0)
    e, xi = b3.deck_location(24.0 + 30.0 + 40.0 * 0.6)
    assert (e, xi) == (2 * NE + 2, pytest.approx(0.4))
    assert b3.deck_location(94.0) == (3 * NE - 1, 1.0)
    assert b3.midspan(1) == (NE + NE // 2, 0.0)
    assert b3.midspan_node(1) == int(b3.span_nodes[1][NE // 2])
    with pytest.raises(ValueError, match="off the deck"):
        b3.deck_location(94.5)
    # the continuous girder shares its node over line 2 (on pier 1)
    assert b3.span_nodes[1][-1] == b3.span_nodes[2][0]
    # element DOFs follow the merges: the joint nodes on pier 0 (rigid vertical bearings, the fork)
    # share w and phi with its top; laterally both piers carry bearing springs (build: 3e8 N/m)
    top = b3.pier_top(0)
    left_end, right_start = int(b3.span_nodes[0][-1]), int(b3.span_nodes[1][0])
    for name in ("w", "phi"):
        assert b3.dof(left_end, name) == b3.dof(right_start, name) == b3.dof(top, name)
    assert len({b3.dof(n, "v") for n in (left_end, right_start, top)}) == 3
    assert b3.dof(left_end, "theta") != b3.dof(top, "theta")
    assert b3.dof(left_end, "u") != b3.dof(top, "u")  # girder 0 is fixed at line 0, on the ground
    # pier 1 carries bearing springs vertically, laterally and longitudinally
    top1, on1 = b3.pier_top(1), int(b3.span_nodes[1][-1])
    assert b3.dof(on1, "w") != b3.dof(top1, "w") and b3.dof(on1, "v") != b3.dof(top1, "v")
    assert b3.dof(on1, "u") != b3.dof(top1, "u")  # the fixed bearing (line 2) is a spring too
    assert list(b3.element_dofs(NE)[[2, 8]]) == [b3.dof(right_start, "w"), b3.dof(right_start + 1, "w")]
    # ground supports: the abutments hold x (the fixed line 0), y, z, twist; pier bases all six
    held = {(s.line, s.direction, s.where) for s in b3.supports}
    assert {d for line, d, w in held if line == 0} == {"x", "y", "z", "phi"}
    assert {d for line, d, w in held if line == 3} == {"y", "z", "phi"}
    assert {d for line, d, w in held if w == "pier 0 base"} == {"x", "y", "z", "phi", "theta", "psi"}
    assert len(b3.supports) == 4 + 3 + 6 + 6


def test_plain_values_adapter() -> None:
    girders, piers = CASES["viaduct"]
    b = bridge3d(
        girders,
        NE,
        [dict(lateral_second_moment=12.0, torsion_constant=5.0)] * 2,
        piers,
        [
            dict(lateral_second_moment=9.0, torsion_constant=6.0, poisson_ratio=0.25, bearing_lateral=3e8),
            dict(lateral_second_moment=9.0, torsion_constant=6.0, shear_modulus=1.2e10),
        ],
    )
    assert b.pier_sections[0].shear == pytest.approx(3.0e10 / 2.5, rel=1e-15)
    assert b.pier_sections[1].shear == 1.2e10
    assert b.bearing_lateral == [3e8, None]
    assert b.girder_sections[0].I_y == 2.9 and b.girder_sections[0].I_z == 12.0
    with pytest.raises(ValueError, match="girder 0: missing 3D key 'torsion_constant'"):
        bridge3d(girders, NE, [dict(lateral_second_moment=1.0)] * 2)
    with pytest.raises(ValueError, match="girder 1: unknown 3D key"):
        bridge3d(
            girders,
            NE,
            [dict(lateral_second_moment=1.0, torsion_constant=1.0)] * 1 + [dict(bearing_lateral=1.0)],
        )


def test_errors() -> None:
    girders, piers = CASES["viaduct"]
    other = section3d(Section(2303.0, 3e9, 1.0, 2.9, 0.02), 12.0, 5.0)
    with pytest.raises(ValueError, match=r"girder 1: Section3D.E = 3000000000.0 differs"):
        Bridge3D(girders, NE, [deck3d(), other])
    with pytest.raises(ValueError, match="1 pier sections for 2 piers"):
        Bridge3D(girders, NE, [deck3d()] * 2, piers, [pier3d()])
    with pytest.raises(ValueError, match="pier support line 9"):
        Bridge3D(girders, NE, [deck3d()] * 2, [Pier(9, 10.0, PIER)], [pier3d()])
    b = Bridge3D([Girder((20.0, 30.0), DECK)], NE, [deck3d()])
    with pytest.raises(ValueError, match="elements differ in length"):
        _ = b.element_length

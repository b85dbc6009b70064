"""Numbers in topology expressions parse as numbers, whatever their notation.

``stiffness = "1.0e6"`` was refused as "unknown parameter(s) e6": the scan for parameter names
took the exponent of a number in scientific notation for a name.
"""

from __future__ import annotations

import pytest
import sympy as sp

from svbi.codegen.topology import TopologyError, parse_topology
from svbi.codegen.vehicle import derive_vehicle

TOPOLOGY = """
name = "one-axle"
[parameters.sprung_mass]
value = 5750.0
[parameters.wheel_mass]
value = 500.0
[parameters.k1e5]
value = 3.0
[parameters.car_length]
value = 10.0
[[bodies]]
name = "body"
dofs = ["z"]
mass = "sprung_mass"
[[bodies]]
name = "axle"
dofs = ["z"]
mass = "wheel_mass"
[[suspensions]]
name = "spring"
body_a = "body"
body_b = "axle"
stiffness = "{stiffness}"
damping = "{damping}"
[[wheels]]
name = "tyre"
body = "axle"
position = "0.0"
radius = "0.0"
"""


@pytest.mark.parametrize(
    ("stiffness", "damping", "k", "c"),
    [
        ("1.0e6", "2.5E+4", 1_000_000, 25_000),
        ("1e6", "1.5e-2*1e6", 1_000_000, 15_000),
        (".5e6 + 5e5", "2e4", 1_000_000, 20_000),
        ("k1e5 * 1.0e5", "1e4", 300_000, 10_000),  # a name with digits and an 'e' stays a name
    ],
)
def test_scientific_notation_in_expressions_is_a_number(stiffness: str, damping: str, k: int, c: int) -> None:
    topo = parse_topology(TOPOLOGY.format(stiffness=stiffness, damping=damping), "one-axle.toml")
    model = derive_vehicle(topo)
    # two bodies on one spring-dashpot: K = k [[1, -1], [-1, 1]], C the same with c (exact rationals)
    values = {p: sp.nsimplify(topo.parameters[p.name].value) for p in topo.symbols}
    K = sp.Matrix(model.stiffness_matrix).subs(values)
    C = sp.Matrix(model.damping_matrix).subs(values)
    assert K == sp.Matrix([[k, -k], [-k, k]])
    assert C == sp.Matrix([[c, -c], [-c, c]])


@pytest.mark.parametrize("expression", ["e6", "1.0e6 * stiff", "2x"])
def test_names_that_are_not_parameters_are_still_refused(expression: str) -> None:
    with pytest.raises(TopologyError, match="suspensions\\[0\\].stiffness"):
        parse_topology(TOPOLOGY.format(stiffness=expression, damping="1e4"), "one-axle.toml")

"""The 3D topology format: built-in files, the keys it adds, and errors that name file and key."""

from __future__ import annotations

from importlib import resources

import pytest

from svbi.codegen.plain_types import TopologyError, builtin_topologies
from svbi.codegen.topology import load_topology, parse_topology
from svbi.codegen.topology3d import builtin_topologies_3d, load_topology3d, parse_topology3d

MINIMAL = """
name = "one-body"
dimensions = 3
[parameters.m]
value = 1000.0
[parameters.car_length]
value = 10.0
[[bodies]]
name = "body"
dofs = ["y", "z", "phi", "theta", "psi"]
mass = "m"
roll_inertia = "m"
pitch_inertia = "m"
yaw_inertia = "m"
height = 1
[[bodies]]
name = "axle"
dofs = ["y"]
mass = "m"
[[suspensions]]
name = "spring"
body_a = "body"
body_b = "axle"
lateral = 1
height = 0.5
sides = 2
stiffness = ["1", "2", "3"]
[[wheels]]
name = "wheel"
body = "axle"
"""


def test_builtin_3d_vehicles_are_apart_from_the_runs() -> None:
    assert builtin_topologies_3d() == ["crh380a-3d", "manchester-3d"]
    assert not set(builtin_topologies_3d()) & set(builtin_topologies())


def test_manchester_data() -> None:
    topo = load_topology3d("manchester-3d")
    assert [b.name for b in topo.bodies][:3] == ["carbody", "bogie_front", "bogie_rear"]
    assert len(topo.suspensions) == 12  # 8 axle boxes, 4 secondary units
    assert {s.name for s in topo.suspensions} >= {"primary_1_left", "primary_1_right", "secondary_rear_right"}
    assert [r.axis for r in topo.rotational_springs] == ["psi", "phi", "psi", "phi"]
    d, f = topo.bump_stop_table(topo.bump_stops[0])
    assert d[1] == 0.025 and f[-1] == 230000.0 and len(d) == len(f) == 10
    assert topo.parameters["car_length"].assumed
    assert len(topo.wheels) == 8


def test_sides_make_a_mirrored_pair() -> None:
    topo = parse_topology3d(MINIMAL)
    left, right = topo.suspensions
    assert (left.name, right.name) == ("spring_left", "spring_right")
    assert (float(left.lateral), float(right.lateral)) == (1.0, -1.0)


def test_the_2d_loader_refuses_a_3d_file() -> None:
    with pytest.raises(TopologyError, match="dimensions: a 3D topology"):
        parse_topology(MINIMAL, "car.toml")
    path = resources.files("svbi.codegen.vehicles3d") / "manchester-3d.toml"
    with resources.as_file(path) as file, pytest.raises(TopologyError) as info:
        load_topology(file)
    # runs take 3D vehicles: the refusal says where a 3D file goes instead
    assert "runs take 2D vehicles only" not in str(info.value)
    assert "train.vehicle" in str(info.value)


def test_the_2d_loader_names_a_dimensions_that_is_neither_2_nor_3() -> None:
    with pytest.raises(TopologyError, match=r"car.toml: dimensions: must be 2 or 3 \(got 4\)$"):
        parse_topology(MINIMAL.replace("dimensions = 3", "dimensions = 4"), "car.toml")


@pytest.mark.parametrize(
    ("edit", "key", "problem"),
    [
        (('dofs = ["y"]', 'dofs = ["x"]'), "bodies[1].dofs", "non-empty list"),
        (('yaw_inertia = "m"\n', ""), "bodies[0].yaw_inertia", "no yaw_inertia"),
        (("sides = 2", "sides = 3"), "suspensions[0].sides", "1 or 2"),
        (('stiffness = ["1", "2", "3"]', 'stiffness = ["1", "2"]'), "suspensions[0].stiffness", "three"),
        (('body_b = "axle"', 'body_b = "nope"'), "suspensions[0].body_b", "unknown body"),
        (("dimensions = 3", "dimensions = 2"), "dimensions", "must be 3"),
        (("height = 1\n", "height = 1\ncolour = 2\n"), "bodies[0].colour", "unknown key"),
    ],
)
def test_errors_name_file_and_key(edit: tuple[str, str], key: str, problem: str) -> None:
    text = MINIMAL.replace(*edit, 1)
    assert text != MINIMAL
    with pytest.raises(TopologyError, match=problem) as info:
        parse_topology3d(text, "car.toml")
    assert info.value.source == "car.toml"
    assert info.value.key == key


def test_bump_stop_table_is_checked() -> None:
    text = (
        MINIMAL
        + """
[parameters.d]
value = [0.0, 0.02, 0.01]
[parameters.f]
value = [0.0, 10.0, 20.0]
[[bump_stops]]
name = "stop"
body_a = "body"
body_b = "axle"
direction = "y"
displacements = "d"
forces = "f"
"""
    )
    with pytest.raises(TopologyError, match="increase strictly") as info:
        parse_topology3d(text, "car.toml")
    assert info.value.key == "bump_stops[0].displacements"


@pytest.mark.parametrize("expression", ["m +", "m * (2", "m ** ** 2", "m 2"])
def test_an_expression_that_does_not_parse_is_one_line(expression: str) -> None:
    """SymPy's parse error is several lines of its own internals: the refusal is one line naming
    the file, the key and the expression, in a 3D topology and a 2D one (the same parser)."""
    text = MINIMAL.replace('mass = "m"', f'mass = "{expression}"', 1)
    assert text != MINIMAL
    pioneer = resources.files("svbi.codegen.vehicles").joinpath("pioneer-2d.toml").read_text()
    expression_2d = expression.replace("m", "carbody_mass")
    text_2d = pioneer.replace('mass = "carbody_mass"', f'mass = "{expression_2d}"', 1)
    assert text_2d != pioneer
    for parse, source_text, raw in (
        (parse_topology3d, text, expression),
        (parse_topology, text_2d, expression_2d),
    ):
        with pytest.raises(TopologyError) as info:
            parse(source_text, "car.toml")
        message = str(info.value)
        assert info.value.key == "bodies[0].mass", message
        assert "\n" not in message, message
        assert message.startswith(f"car.toml: bodies[0].mass: cannot parse expression {raw!r}"), message


@pytest.mark.parametrize(
    ("edit", "line"),
    [
        # a key of the second [[bodies]] table: its own line
        (('dofs = ["y"]', 'dofs = ["x"]'), 'dofs = ["x"]'),
        # an unknown key: its line
        (("height = 1\n", "height = 1\ncolour = 2\n"), "colour = 2"),
        # a key the file leaves out: the line of its table
        (('yaw_inertia = "m"\n', ""), "[[bodies]]"),
        # a parameter's value
        (("value = 1000.0", "value = -1000.0"), "value = -1000.0"),
    ],
)
def test_errors_of_a_file_name_its_line(tmp_path, edit: tuple[str, str], line: str) -> None:
    """A topology file's error names the line of the key at fault (or of its table, when the key is
    missing), ``file:line: key: problem``, counted independently here from the file's text."""
    text = MINIMAL.replace(*edit, 1)
    path = tmp_path / "car.toml"
    path.write_text(text, encoding="utf-8")
    expected = text.splitlines().index(line) + 1  # the first such line: the first body's
    with pytest.raises(TopologyError) as info:
        load_topology3d(str(path))
    assert str(info.value).startswith(f"{path}:{expected}: {info.value.key}: ")


def test_errors_of_a_2d_file_name_its_line(tmp_path) -> None:
    text = (resources.files("svbi.codegen.vehicles") / "sprung-mass.toml").read_text(encoding="utf-8")
    lines = text.splitlines()
    table = lines.index("[parameters.sprung_mass]")
    at = next(i for i in range(table + 1, len(lines)) if lines[i].startswith("value"))
    lines[at] = "value = -5.0"
    path = tmp_path / "car.toml"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(TopologyError) as info:
        load_topology(str(path))
    assert str(info.value) == f"{path}:{at + 1}: parameters.sprung_mass.value: must not be negative, got -5"


def test_errors_of_text_name_no_line() -> None:
    """Text that is no file (a string, a built-in's name): the message without a line, as before."""
    with pytest.raises(TopologyError) as info:
        parse_topology3d(MINIMAL.replace("value = 1000.0", "value = -1000.0", 1), "car.toml")
    assert str(info.value).startswith("car.toml: parameters.m.value: ")

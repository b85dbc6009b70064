"""Issue 15, input half: bad vehicles, bad numbers and silent cases end in one line naming the key.

Every case here was first reproduced as a failure (a traceback, a hang, a silent wrong result).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from svbi.runtime.cli import _register, app
from typer.testing import CliRunner

_register()
runner = CliRunner()

SPRUNG = """
name = "{name}"
[parameters.sprung_mass]
value = 5750.0
[parameters.wheel_mass]
value = 500.0
[parameters.stiffness]
value = 1.595e6
[parameters.damping]
value = 1.0e4
[parameters.car_length]
value = 10.0
[parameters.spin_inertia]
value = 50.0
[parameters.wheel_radius]
value = 0.45
[parameters.offset]
value = {offset}
[[bodies]]
name = "body"
dofs = ["z"]
mass = "sprung_mass"
[[bodies]]
name = "axle"
dofs = ["z", "theta"]
mass = "wheel_mass"
inertia = "spin_inertia"
[[suspensions]]
name = "spring"
body_a = "body"
body_b = "axle"
stiffness = "{stiffness}"
damping = "damping"
[[wheels]]
name = "tyre"
body = "axle"
position = "offset"
radius = "wheel_radius"
"""

SCENARIO = """
[bridge]
spans = 1
span_length = 20.0
mass_per_length = 20000.0
youngs_modulus = 3.0e10
area = 5.0
second_moment = 3.0
elements_per_span = 4

[train]
vehicle = "{vehicle}"
speed_kmh = 100.0
start_position = -5.0

[solver]
time_step = 1.0e-3
duration = 0.02
"""


def _topology(tmp_path: Path, text: str, name: str = "topo.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _sprung(
    name: str = "axle-car", offset: str = "0.0", stiffness: str = "stiffness", extra: str = ""
) -> str:
    return SPRUNG.format(name=name, offset=offset, stiffness=stiffness) + extra


LOOSE = """
[[bodies]]
name = "loose_box"
dofs = ["z"]
mass = "wheel_mass"
"""

TWO_AXLES = """
[[bodies]]
name = "rear_axle"
dofs = ["z", "theta"]
mass = "wheel_mass"
inertia = "spin_inertia"
position = "2.0"
[[suspensions]]
name = "rear_spring"
body_a = "body"
body_b = "rear_axle"
stiffness = "stiffness"
[[wheels]]
name = "second_tyre"
body = "axle"
position = "2.0"
radius = "wheel_radius"
"""


def _one_line_error(result, *names: str) -> None:  # noqa: ANN001 - click Result
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    for name in names:
        assert name in result.output, result.output


MECHANISMS = {
    # a body connected to nothing
    "loose": (_sprung(extra=LOOSE), ("'loose_box'", "mechanism")),
    # a suspension of zero stiffness: the body hangs from a dashpot only
    "zero-spring": (_sprung(stiffness="0"), ("'body'", "'spring'", "zero stiffness")),
    # a wheel away from its body's reference point: the body pivots about the contact
    "off-reference": (_sprung(offset="0.8"), ("'axle'", "'tyre'", "0.8 m")),
    # two wheels on one body, the other axle hangs free (no wheel, its rotation is no spin)
    "two-on-one": (_sprung(extra=TWO_AXLES), ("'rear_axle'", "mechanism")),
}


@pytest.mark.parametrize("case", sorted(MECHANISMS))
def test_mechanism_refused_by_derive_modes_and_run(tmp_path: Path, case: str) -> None:
    text, names = MECHANISMS[case]
    topo = _topology(tmp_path, text)
    for command in (["derive", str(topo)], ["modes", str(topo)]):
        _one_line_error(runner.invoke(app, command), *names)
    scenario = tmp_path / "s.toml"
    scenario.write_text(SCENARIO.format(vehicle="topo.toml"))
    out = tmp_path / "r.nc"
    result = runner.invoke(app, ["run", str(scenario), "-o", str(out), "-q"])
    _one_line_error(result, "train.vehicle", names[0])
    assert not out.exists()


def test_zero_stiffness_override_refused_with_the_parameter_key(tmp_path: Path) -> None:
    result = runner.invoke(app, ["modes", "sprung-mass", "--set", "stiffness=0"])
    _one_line_error(result, "mechanism", "'body'")
    scenario = tmp_path / "s.toml"
    text = SCENARIO.format(vehicle="sprung-mass")
    scenario.write_text(text.replace("[solver]", "[train.parameters]\nstiffness = 0.0\n[solver]"))
    result = runner.invoke(app, ["run", str(scenario), "-o", str(tmp_path / "r.nc"), "-q"])
    _one_line_error(result, "train.parameters", "'body'")


def test_restrained_vehicle_with_free_spin_passes_and_modes_names_the_spin(tmp_path: Path) -> None:
    topo = _topology(tmp_path, _sprung())
    result = runner.invoke(app, ["modes", str(topo)])
    assert result.exit_code == 0, result.output
    assert "free wheel spin of axle" in result.output
    pioneer = runner.invoke(app, ["modes", "pioneer-2d"])
    assert "wheelset_1, wheelset_2, wheelset_3, wheelset_4" in pioneer.output


DUPLICATE_WHEEL = '\n[[wheels]]\nname = "tyre"\nbody = "body"\n'
DUPLICATE_SPRING = '\n[[suspensions]]\nname = "spring"\nbody_a = "body"\nbody_b = "axle"\nstiffness = "1.0"\n'
RESERVED = "\n[parameters.mu]\nvalue = 1.0\n"


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (DUPLICATE_WHEEL, "duplicate wheel name 'tyre'"),
        (DUPLICATE_SPRING, "duplicate suspension name 'spring'"),
        (RESERVED, "reserved: a A E g h I le mu t v xi"),
    ],
)
def test_duplicate_and_reserved_names_refused(tmp_path: Path, extra: str, message: str) -> None:
    text = _sprung()
    text = text.replace("[[bodies]]", extra + "[[bodies]]", 1) if extra == RESERVED else text + extra
    topo = _topology(tmp_path, text)
    _one_line_error(runner.invoke(app, ["derive", str(topo)]), message)


def test_wheel_off_a_body_without_rotation_refused(tmp_path: Path) -> None:
    text = _sprung().replace('body = "axle"\nposition = "offset"', 'body = "body"\nposition = "1.5"')
    _one_line_error(
        runner.invoke(app, ["derive", str(_topology(tmp_path, text))]), "wheels[0].position", "'body'"
    )


def test_export_of_a_name_ending_in_an_odd_character(tmp_path: Path) -> None:
    # "two axle wagon!" cleans up to an identifier that ended in "_": CasADi refused the function name
    topo = _topology(tmp_path, _sprung(name="two axle wagon!"))
    target = tmp_path / "export"
    result = runner.invoke(app, ["export", str(topo), str(target)])
    assert result.exit_code == 0, result.output
    files = [p for p in target.rglob("*") if p.is_file()]
    assert any("svbi_two_axle_wagon_mass_matrix" in p.read_text(errors="ignore") for p in files)
    assert not any(
        "two_axle_wagon__" in p.read_text(errors="ignore") for p in target.rglob("*") if p.is_file()
    )

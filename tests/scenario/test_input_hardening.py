"""Issue 15, input half: bad vehicles, bad numbers and silent cases end in one line naming the key.

Every case here was first reproduced as a failure (a traceback, a hang, a silent wrong result).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from svbi.runtime.cli.app import _register, app

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
DOF_NAME = "\n[parameters.theta_axle]\nvalue = 1.0\n"


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (DUPLICATE_WHEEL, "duplicate wheel name 'tyre'"),
        (DUPLICATE_SPRING, "duplicate suspension name 'spring'"),
        (RESERVED, "reserved: a A E g h I le mu t v xi"),
        (DOF_NAME, "'theta_axle' is the name of a DOF"),
    ],
)
def test_duplicate_and_reserved_names_refused(tmp_path: Path, extra: str, message: str) -> None:
    text = _sprung()
    text = (
        text.replace("[[bodies]]", extra + "[[bodies]]", 1) if extra in (RESERVED, DOF_NAME) else text + extra
    )
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


# --------------------------------------------------------------------------------------------------
# item 2: every number finite, every error names its key, size guards

PAPER = Path(__file__).resolve().parents[2] / "examples" / "paper-2020.toml"


@pytest.mark.parametrize(
    ("setting", "key"),
    [
        ("youngs_modulus=nan", "youngs_modulus"),
        ("span_length=inf", "span_length"),
        ("mass_per_length=1e-300", "mass_per_length"),
        ("carbody_mass=nan", "carbody_mass"),
        ("primary_stiffness=1e308", "primary_stiffness"),  # an overflow in the matrices
        ("bogie_half_spacing=0", "bogie_half_spacing"),  # the car body pitches freely
    ],
)
def test_modes_set_checks_every_number(setting: str, key: str) -> None:
    result = runner.invoke(app, ["modes", "pioneer-2d", "--set", setting])
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output and key in result.output, result.output


def _run_error(tmp_path: Path, *sets: str, scenario: Path = PAPER) -> str:
    out = tmp_path / "r.nc"
    args = ["run", str(scenario), "-o", str(out), "-q"]
    for s in sets:
        args += ["--set", s]
    result = runner.invoke(app, args)
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    assert not out.exists()
    return result.output


@pytest.mark.parametrize(
    ("setting", "expected"),
    [
        ("track.seed=-1", "track.seed"),
        ("earthquake.seed=-1", "earthquake.seed"),
        ("train.speed_kmh=1e30", "train.speed_kmh"),
        ("solver=1", "solver: must be a table"),
        ("train.parameters=1", "train.parameters: must be a table"),
        # size guards: each named with the keys that drive it, before any computation
        ("solver.time_step=1e-9", "solver.time_step"),
        ("solver.duration=1e6", "solver.duration"),
        ("bridge.spans=10000", "bridge.spans"),
        ("track.wavelength_min=1e-6", "track.wavelength_min"),
        ("track.wavelength_min=0.002", "track.wavelength_min"),
        ("bridge.mass_per_length=1e-300", "bridge.mass_per_length"),
        ("earthquake.target_pga=1e300", "earthquake.target_pga"),
        # found by trying more of the same: a traceback, a meaningless message, a misleading hint
        ("earthquake.scale=1e300", "earthquake.scale"),
        ("solver.constraint_kappa=1e300", "solver.constraint_kappa"),
        ("train.start_position=-1e300", "train.start_position"),
        ("bridge.rail_height=1e300", "bridge.rail_height"),
        ("solver.contact_split=1e-300", "solver.contact_split"),
        ("contact.friction=1e300", "contact.friction"),
        ("contact.rail_head_radius=1e-300", "contact.rail_head_radius"),
        ("train.parameters.wheel_radius=1e300", "train.parameters.wheel_radius"),
        ("output.force_filter_hz=1e-300", "output.force_filter_hz"),
        ("train.parameters.primary_stiffness=1e300", "static equilibrium"),
    ],
)
def test_run_refuses_bad_numbers_naming_the_key(tmp_path: Path, setting: str, expected: str) -> None:
    assert expected in _run_error(tmp_path, setting)


def test_size_guards_explain_the_limit(tmp_path: Path) -> None:
    from svbi.runtime.scenario import limits

    text = _run_error(tmp_path, "solver.time_step=1e-9")
    assert f"{limits.MAX_STEPS:.0e}" in text or f"{limits.MAX_STEPS:,}" in text
    text = _run_error(tmp_path, "track.wavelength_min=0.002")
    assert "irregularity table" in text and f"{limits.MAX_IRREGULARITY_POINTS:,}" in text


def test_record_with_absurd_sample_names_file_and_line(tmp_path: Path) -> None:
    record = tmp_path / "quake.txt"
    lines = ["0.0 0.0", "0.01 0.1", "0.02 1e300", "0.03 0.0"]
    record.write_text("\n".join(lines) + "\n")
    scenario = tmp_path / "s.toml"
    scenario.write_text(SCENARIO.format(vehicle="sprung-mass") + '[earthquake]\nvertical = "quake.txt"\n')
    text = _run_error(tmp_path, scenario=scenario)
    assert f"{record}: line 3" in text, text
    assert "earthquake.vertical" in text, text


# --------------------------------------------------------------------------------------------------
# item 3: silent cases now say why not


def _small(tmp_path: Path, vehicle: str = "sprung-mass") -> Path:
    scenario = tmp_path / "small.toml"
    scenario.write_text(SCENARIO.format(vehicle=vehicle))  # dt = 1e-3 s, 0.02 s: 20 steps
    return scenario


def test_force_filter_above_nyquist_refused(tmp_path: Path) -> None:
    text = _run_error(tmp_path, "output.force_filter_hz=600", scenario=_small(tmp_path))
    assert "output.force_filter_hz" in text and "500" in text and "Nyquist" in text


def test_output_every_beyond_the_run_refused(tmp_path: Path) -> None:
    text = _run_error(tmp_path, "solver.output_every=50", scenario=_small(tmp_path))
    assert "solver.output_every" in text and "20 steps" in text


def test_overlapping_cars_refused(tmp_path: Path) -> None:
    text = _run_error(
        tmp_path, "train.parameters.car_length=10.0"
    )  # a Pioneer car is 20.5 m from first to last axle
    assert "train.parameters.car_length" in text and "20.5 m" in text


def test_overlap_with_default_car_length_names_the_vehicle(tmp_path: Path) -> None:
    long_car = _sprung().replace("value = 10.0", "value = 1.0", 1) + TWO_AXLES.split("[[wheels]]")[0]
    long_car = long_car.replace('position = "2.0"', 'position = "2.0"', 1)
    wheel = (
        '\n[[wheels]]\nname = "rear_tyre"\nbody = "rear_axle"\nposition = "2.0"\nradius = "wheel_radius"\n'
    )
    _topology(tmp_path, long_car + wheel)
    scenario = _small(tmp_path, "topo.toml")
    scenario.write_text(scenario.read_text().replace("speed_kmh", "cars = 2\nspeed_kmh"))
    text = _run_error(tmp_path, scenario=scenario)
    assert "train.vehicle" in text and "car_length" in text, text


def test_creep_on_a_wheel_without_spin_warns_naming_the_wheel(tmp_path: Path) -> None:
    out = tmp_path / "r.nc"
    result = runner.invoke(app, ["run", str(_small(tmp_path)), "-o", str(out), "-q"])
    assert result.exit_code == 0, result.output
    assert "warning" in result.output and "contact.creep" in result.output and "'wheel'" in result.output
    quiet = runner.invoke(
        app, ["run", str(_small(tmp_path)), "-o", str(out), "-q", "--set", "contact.creep=false"]
    )
    assert quiet.exit_code == 0 and "contact.creep" not in quiet.output, quiet.output


# --------------------------------------------------------------------------------------------------
# item 4: `svbi derive --format latex` is a LaTeX document


def _outside_math(text: str) -> str:
    """The text with every math region ($...$ and \\[...\\]) removed; fails on unbalanced delimiters."""
    out, i, mode = [], 0, None
    while i < len(text):
        if text.startswith("\\\\", i) or text.startswith("\\$", i):
            if mode is None:
                out.append(text[i : i + 2])
            i += 2
        elif text.startswith("\\[", i):
            assert mode is None, f"\\[ inside math at {i}"
            mode, i = "display", i + 2
        elif text.startswith("\\]", i):
            assert mode == "display", f"\\] outside display math at {i}"
            mode, i = None, i + 2
        elif text[i] == "$":
            assert mode in (None, "inline"), f"$ inside display math at {i}"
            mode, i = (None if mode == "inline" else "inline"), i + 1
        else:
            if mode is None:
                out.append(text[i])
            i += 1
    assert mode is None, "math region left open"
    return "".join(out)


@pytest.mark.parametrize("model", ["sprung-mass", "pioneer-2d", "moving-load"])
def test_derive_latex_is_a_balanced_document(model: str) -> None:
    import re

    result = runner.invoke(app, ["derive", model, "--format", "latex"])
    assert result.exit_code == 0, result.output
    tex = result.output
    assert tex.lstrip().startswith(("%", "\\documentclass"))
    assert "\\begin{document}" in tex and tex.rstrip().endswith("\\end{document}")
    # braces balance, ignoring escaped ones
    depth = 0
    for m in re.finditer(r"\\[{}]|[{}]", tex):
        if m.group() in "{}":
            depth += 1 if m.group() == "{" else -1
            assert depth >= 0, tex[max(0, m.start() - 80) : m.start() + 1]
    assert depth == 0
    # environments nest
    stack = []
    for kind, env in re.findall(r"\\(begin|end)\{(\w+\*?)\}", tex):
        if kind == "begin":
            stack.append(env)
        else:
            assert stack.pop() == env
    assert not stack
    # outside math no bare underscore or caret; multi-underscore names are not cut into subscripts
    plain = _outside_math(tex)
    assert not re.search(r"(?<!\\)[_^]", plain), re.search(r".{30}(?<!\\)[_^].{30}", plain)
    assert "pitch inertia" not in tex and "sprung_{mass}" not in tex
    if model == "pioneer-2d":
        assert "MaxMatrixCols" in tex  # the 14-column matrices need more than amsmath's default 10


# --------------------------------------------------------------------------------------------------
# item 5: every body of a car in the results

JACOBS = """
name = "two-body"
description = "two car bodies on three axles: a Jacobs-like pair, the middle axle shared"
[parameters.body_mass]
value = 20000.0
[parameters.body_inertia]
value = 4.0e5
[parameters.axle_mass]
value = 1500.0
[parameters.k]
value = 1.2e6
[parameters.c]
value = 3.0e4
[parameters.half]
value = 5.0
[parameters.car_length]
value = 22.0
[[bodies]]
name = "front_body"
dofs = ["z", "theta"]
mass = "body_mass"
inertia = "body_inertia"
position = "half"
[[bodies]]
name = "rear_body"
dofs = ["z", "theta"]
mass = "1.5*body_mass"
inertia = "body_inertia"
position = "3*half"
[[bodies]]
name = "axle_1"
dofs = ["z"]
mass = "axle_mass"
[[bodies]]
name = "axle_2"
dofs = ["z"]
mass = "axle_mass"
position = "2*half"
[[bodies]]
name = "axle_3"
dofs = ["z"]
mass = "axle_mass"
position = "4*half"
[[suspensions]]
name = "s1"
body_a = "front_body"
offset_a = "-half"
body_b = "axle_1"
stiffness = "k"
damping = "c"
[[suspensions]]
name = "s2"
body_a = "front_body"
offset_a = "half"
body_b = "axle_2"
stiffness = "k"
damping = "c"
[[suspensions]]
name = "s3"
body_a = "rear_body"
offset_a = "-half"
body_b = "axle_2"
stiffness = "k"
damping = "c"
[[suspensions]]
name = "s4"
body_a = "rear_body"
offset_a = "half"
body_b = "axle_3"
stiffness = "k"
damping = "c"
[[wheels]]
name = "w1"
body = "axle_1"
[[wheels]]
name = "w2"
body = "axle_2"
position = "2*half"
[[wheels]]
name = "w3"
body = "axle_3"
position = "4*half"
"""

JACOBS_SCENARIO = """
[bridge]
spans = 2
span_length = 15.0
mass_per_length = 15000.0
youngs_modulus = 3.0e10
area = 5.0
second_moment = 1.5
elements_per_span = 6
[train]
vehicle = "two-body.toml"
cars = 2
speed_kmh = 150.0
start_position = -2.0
[track]
irregularity = "german-high"
wavelength_min = 1.0
[contact]
creep = false
[solver]
time_step = 5.0e-4
duration = 0.6
output_every = 3
"""


def _jacobs(tmp_path: Path, backend: str):  # noqa: ANN202 - xarray.Dataset
    import svbi
    from svbi.runtime.scenario.schema import load_scenario

    (tmp_path / "two-body.toml").write_text(JACOBS)
    scenario = tmp_path / "s.toml"
    scenario.write_text(JACOBS_SCENARIO)
    return svbi.simulate(load_scenario(scenario, overrides=[f"solver.backend={backend}"]))


def test_results_carry_every_body_of_a_car_in_both_backends(tmp_path: Path) -> None:
    import numpy as np

    ref = _jacobs(tmp_path, "numpy")
    c = _jacobs(tmp_path, "c")
    assert c.attrs["backend"] == "c"
    names = ["front_body", "rear_body", "axle_1", "axle_2", "axle_3"]
    for ds in (ref, c):
        assert list(ds["body"].values) == names
        for var in ("body_uz", "body_az", "body_pitch"):
            assert ds[var].dims == ("time", "car", "body")
        # the first body is the car body of the carbody_* variables
        np.testing.assert_array_equal(ds["body_uz"].sel(body="front_body"), ds["carbody_uz"])
        np.testing.assert_array_equal(ds["body_az"].sel(body="front_body"), ds["carbody_az"])
        np.testing.assert_array_equal(ds["body_pitch"].sel(body="front_body"), ds["carbody_pitch"])
        # axles have no pitch DOF: not a number, not a fake zero
        assert np.isnan(ds["body_pitch"].sel(body="axle_2")).all()
        # the rear body moves (it was lost before): irregularity excites it
        assert float(abs(ds["body_uz"].sel(body="rear_body")).max()) > 1e-6
    for var in ("body_uz", "body_az", "body_pitch"):
        a, b = ref[var].values, c[var].values
        scale = float(np.nanmax(abs(a)))
        assert scale > 0
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
        assert float(np.nanmax(abs(a - b))) <= 1e-10 * scale, var
    # the rear body's bounce is not the front body's (a different mass): an independent series
    assert not np.allclose(ref["body_uz"].sel(body="rear_body"), ref["body_uz"].sel(body="front_body"))

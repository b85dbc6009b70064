"""Scenario errors a user can act on: each names the file and line, or the ``--set`` that caused it.

* a continuous girder whose spans differ too much for its matrices is one error naming the span
  (it used to end in NumPy warnings and "array must not contain infs or NaNs");
* ``"none"`` in a list of per-support records is a support at rest (it used to be refused with
  "expected 'none', ...");
* a UTF-8 byte-order mark (Windows editors) is accepted in scenario, study, profile and record
  files; text that is not UTF-8 is refused naming the file and line;
* a problem that a ``--set`` value causes names the ``--set``, not the file line of its key;
  list entries can be set (``bridge.girders[0].spans=[...]``);
* a study or topology file given where a scenario is expected is told what it is.
"""

from __future__ import annotations

import textwrap
import warnings
from pathlib import Path

import numpy as np
import pytest

from svbi.runtime.scenario.schema import ScenarioError, load_scenario

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = REPO / "examples"

LONG_FORM = """\
[bridge]
mass_per_length = 22.40e3
youngs_modulus = 35.5e9
area = 8.63
second_moment = 6.58
elements_per_span = 8

[[bridge.girders]]
spans = {spans}

[train]
vehicle = "moving-load"
hslm = "A1"
speed_kmh = 300.0

[solver]
time_step = 1.0e-3
output_every = 1
"""

SHORT = """\
[bridge]
spans = 2
span_length = 20.0
mass_per_length = 22.40e3
youngs_modulus = 35.5e9
area = 8.63
second_moment = 6.58
elements_per_span = 8

[train]
vehicle = "moving-load"
hslm = "A1"
speed_kmh = 300.0

[solver]
time_step = 1.0e-3
output_every = 1
"""


def _write(tmp_path: Path, text: str, name: str = "s.toml", bom: bool = False) -> Path:
    path = tmp_path / name
    path.write_bytes((b"\xef\xbb\xbf" if bom else b"") + text.encode("utf-8"))
    return path


def _problems(path: Path, overrides: list[str] | None = None) -> list:
    with pytest.raises(ScenarioError) as info:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            load_scenario(path, overrides=overrides)
    return info.value.problems


# --------------------------------------------------------------------------------------------------
# a girder whose spans differ too much


def test_a_girder_with_a_millimetre_span_is_one_error_naming_the_span(tmp_path: Path) -> None:
    path = _write(tmp_path, LONG_FORM.format(spans="[32.0, 0.001]"))
    (p,) = _problems(path)
    assert p.key == "bridge.girders[0].spans[1]"
    assert p.where == f"{path}:9"
    assert "0.001 m" in p.message and "32 m" in p.message


def test_the_girder_limit_is_where_the_girders_modes_lose_their_digits() -> None:
    """Independent truth: a 32 m span continuous with one at least 100 times shorter is a propped
    cantilever to within 2 %: the short span holds the joint's rotation with at least 100 times the
    long span's own end stiffness (3 EI / L each, far ends pinned), so omega_1 lies between 0.98 and
    1 times the clamped-pinned 15.418 sqrt(EI / (m L^4)), approached from below as the short span
    shrinks. Within the limit the computed frequency is in that interval; at three times the limit
    the eigensolver returns one outside it (or none)."""
    from svbi.runtime.model.bridge import Bridge, Girder, Section
    from svbi.runtime.scenario.limits import MAX_GIRDER_RATIO

    sec = Section(22.4e3, 35.5e9, 8.63, 6.58, 0.02)
    bound = 15.418 * np.sqrt(35.5e9 * 6.58 / (22.4e3 * 32.0**4))
    ne = 16
    for ratio, ok in ((MAX_GIRDER_RATIO / 1.25, True), (3 * MAX_GIRDER_RATIO, False)):
        short = 32.0 / (ratio / ne)
        b = Bridge(2, 32.0, 22.4e3, 35.5e9, 8.63, 6.58, 0.02, ne, girders=[Girder((32.0, short), sec, 0)])
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            w1 = float(b.girder_frequencies(b.girders[0])[0])
        assert bool(0.98 * bound <= w1 <= bound) is ok, (ratio, w1, bound)


def test_svbi_run_of_such_a_girder_prints_no_numpy_warning(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from svbi.runtime.cli.app import _register, app

    _register()
    path = _write(tmp_path, LONG_FORM.format(spans="[32.0, 0.001]"))
    result = CliRunner().invoke(app, ["run", str(path), "-o", str(tmp_path / "r.nc"), "-q"])
    assert result.exit_code == 2, result.output
    assert "Warning" not in result.output and "infs or NaNs" not in result.output
    assert f"{path}:9: bridge.girders[0].spans[1]" in result.output


# --------------------------------------------------------------------------------------------------
# "none" among per-support records


def test_none_in_a_list_of_per_support_records_is_a_support_at_rest() -> None:
    from svbi.runtime.excitation.ground import ground_motion

    positions = [0.0, 20.0, 40.0]
    gm = ground_motion(vertical=["synthetic", "none", "synthetic"], support_positions=positions)
    t = np.linspace(0.0, 10.0, 2001)
    at_rest = gm.motion("vertical", t, 20.0)
    moving = gm.motion("vertical", t, 0.0)
    for q in at_rest:
        assert np.all(q == 0.0)
    assert np.max(np.abs(moving[2])) > 0.1  # the synthetic record's acceleration, m/s^2


def test_a_scenario_with_none_among_its_per_support_records_runs(tmp_path: Path) -> None:
    from svbi.runtime.run.simulate import simulate

    text = SHORT + '\n[earthquake]\nvertical = ["synthetic", "none", "synthetic"]\n'
    sc = load_scenario(_write(tmp_path, text))
    ds = simulate(sc, variables=("ground_uz",))
    assert int(ds.attrs["complete"]) == 1
    uz = np.asarray(ds["ground_uz"].transpose("time", "support").values)
    x = np.asarray(ds["support_x"].values)
    assert np.all(uz[:, np.isclose(x, 20.0)] == 0.0)
    assert np.max(np.abs(uz[:, np.isclose(x, 0.0)])) > 0.0


# --------------------------------------------------------------------------------------------------
# byte-order marks and text that is not UTF-8


def test_a_byte_order_mark_is_accepted_in_a_scenario(tmp_path: Path) -> None:
    plain = load_scenario(_write(tmp_path, SHORT, "plain.toml"))
    marked = load_scenario(_write(tmp_path, SHORT, "bom.toml", bom=True))
    assert plain.to_dict() == marked.to_dict()


def test_a_byte_order_mark_is_accepted_in_a_profile_a_record_and_a_study(tmp_path: Path) -> None:
    from svbi.runtime.excitation.irregularity import read_profile
    from svbi.runtime.excitation.records import read_record
    from svbi.runtime.study.sweep import load_study

    profile = "\n".join(f"{x:.1f} 0.001" for x in range(-100, 200)) + "\n"
    xs, rs = read_profile(_write(tmp_path, profile, "p.txt", bom=True))
    assert xs[0] == -100.0 and rs[0] == 0.001
    record = "\n".join(f"{0.01 * np.sin(i / 5):.6f}" for i in range(400)) + "\n"
    rec = read_record(_write(tmp_path, record, "r.txt", bom=True), dt=0.01)
    assert rec.accel.size == 400
    _write(tmp_path, SHORT, "base.toml", bom=True)
    text = 'scenario = "base.toml"\n[axes]\n"train.speed_kmh" = [200.0, 250.0]\n'
    study = _write(tmp_path, text, "st.toml", bom=True)
    assert len(load_study(study).runs) == 2


def test_a_profile_that_is_not_utf8_names_the_profile_the_line_and_the_key(tmp_path: Path) -> None:
    lines = [f"{x:.1f} 0.001" for x in range(-100, 200)]
    head, tail = ("\n".join(lines[:6]) + "\n").encode(), ("\n".join(lines[7:]) + "\n").encode()
    raw = head + b"6.0 0.001 \xb5m\n" + tail
    (tmp_path / "prof.txt").write_bytes(raw)
    path = _write(tmp_path, SHORT + '\n[track]\nirregularity = "prof.txt"\n')
    (p,) = _problems(path)
    assert p.key == "track.irregularity" and p.where == f"{path}:20"
    assert f"{tmp_path / 'prof.txt'}:7" in p.message and "UTF-8" in p.message


def test_a_scenario_that_is_not_utf8_names_its_line(tmp_path: Path) -> None:
    path = tmp_path / "latin1.toml"
    path.write_bytes(SHORT.replace('hslm = "A1"', 'hslm = "A1"  # \xe9t\xe9').encode("latin-1"))
    (p,) = _problems(path)
    assert p.where == f"{path}:12" and "UTF-8" in p.message


# --------------------------------------------------------------------------------------------------
# --set


def test_a_problem_caused_by_a_set_value_names_the_set_not_the_file_line() -> None:
    (p,) = _problems(EXAMPLES / "paper-2020.toml", ["bridge.elements_per_span=100000"])
    assert p.key == "bridge.spans"  # the limit is on spans x elements_per_span
    assert p.where == "--set bridge.elements_per_span=100000"


def test_each_problem_names_the_set_that_causes_it_and_the_files_own_stay_at_their_line(
    tmp_path: Path,
) -> None:
    bad = SHORT.replace("output_every = 1", "output_every = 1\nduration = 0.00001")
    path = _write(tmp_path, bad)
    problems = _problems(path, ["solver.max_gap=2.0", "bridge.elements_per_span=100000"])
    where = {p.key: p.where for p in problems}
    assert where["solver.duration"] == f"{path}:18"
    assert where["bridge.spans"] == "--set bridge.elements_per_span=100000"


def test_list_entries_can_be_set() -> None:
    sc = load_scenario(
        EXAMPLES / "viaduct.toml",
        overrides=["bridge.girders[0].spans=[30.0]", "bridge.piers[1].height=13.0"],
    )
    assert sc.bridge.girders[0].spans == [30.0]
    assert sc.bridge.piers[1].height == 13.0
    assert sc.bridge.girders[1].spans == [32.0]


def test_a_list_entry_that_does_not_exist_is_one_clear_problem() -> None:
    (p,) = _problems(EXAMPLES / "viaduct.toml", ["bridge.girders[9].spans=[30.0]"])
    assert p.where == "--set bridge.girders[9].spans=[30.0]"
    assert "bridge.girders has 6 entries (0 … 5)" in p.message
    (p,) = _problems(EXAMPLES / "paper-2020.toml", ["bridge.span_length[0]=3.0"])
    assert "bridge.span_length is not a list" in p.message


def test_a_problem_in_a_set_list_entry_names_the_set(tmp_path: Path) -> None:
    (p,) = _problems(EXAMPLES / "viaduct.toml", ["bridge.girders[5].spans=[40.0, -1.0]"])
    assert p.key == "bridge.girders[5].spans[1]"
    assert p.where == "--set bridge.girders[5].spans=[40.0, -1.0]"


# --------------------------------------------------------------------------------------------------
# a file of another kind


def test_a_study_file_given_as_a_scenario_is_told_what_it_is() -> None:
    (p,) = _problems(EXAMPLES / "hslm-sweep.toml")
    assert "this is a study file" in p.message and "svbi sweep" in p.message


def test_a_scenario_given_as_a_study_is_told_what_it_is() -> None:
    from svbi.runtime.study.sweep import StudyError, load_study

    with pytest.raises(StudyError) as info:
        load_study(EXAMPLES / "hslm-span.toml")
    assert "this is a scenario file" in str(info.value) and "svbi run" in str(info.value)


def test_a_topology_given_as_a_scenario_is_told_what_it_is(tmp_path: Path) -> None:
    from importlib import resources

    text = resources.files("svbi.codegen.vehicles").joinpath("pioneer-2d.toml").read_text(encoding="utf-8")
    (p,) = _problems(_write(tmp_path, textwrap.dedent(text), "v.toml"))
    assert "vehicle topology file" in p.message and "svbi derive" in p.message

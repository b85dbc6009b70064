"""A 3D scenario's checks and defaults read a built-in vehicle's parameters from its generated module
(no SymPy at run time), the same as the parsed topology; a topology file is parsed once."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from svbi.codegen.plain_types import TopologyError, builtin_topologies_3d
from svbi.codegen.topology3d import load_topology3d
from svbi.runtime.model import system3d
from svbi.runtime.model.system3d import vehicle_parameters3d

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "paper-2020-3d.toml"


@pytest.mark.parametrize("name", builtin_topologies_3d())
def test_builtin_parameters_are_the_parsed_topologys(name: str) -> None:
    """Every parameter, in file order, with its default and sign, as the parser reads the file."""
    topo = load_topology3d(name)
    got = vehicle_parameters3d(name)
    assert got.name == topo.name
    assert list(got.parameters) == list(topo.parameters)
    for key, p in topo.parameters.items():
        assert got.parameters[key].value == p.value
        assert got.parameters[key].signed == p.signed


def test_a_file_is_parsed_once_until_it_changes(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    text = load_topology3d("manchester-3d").text
    path = tmp_path / "car.toml"
    key = "[parameters.car_length]\nvalue = "
    path.write_text(text.replace(key + "23.0", key + "24.0"), encoding="utf-8")
    calls: list[str] = []
    real = system3d.load_topology3d
    monkeypatch.setattr(system3d, "load_topology3d", lambda ref: calls.append(str(ref)) or real(ref))
    system3d._file_parameters3d.cache_clear()
    first = vehicle_parameters3d(path)
    assert vehicle_parameters3d(str(path)) == first
    assert len(calls) == 1
    assert first.parameters["car_length"].value == 24.0
    path.write_text(text + "\n# changed\n", encoding="utf-8")
    assert vehicle_parameters3d(path).parameters["car_length"].value == 23.0
    assert len(calls) == 2


def test_unknown_name_names_the_vehicle_key(tmp_path: Path) -> None:
    with pytest.raises(TopologyError) as err:
        vehicle_parameters3d(tmp_path / "nope.toml")
    assert err.value.key == "vehicle"
    assert "not a built-in 3D vehicle" in err.value.problem


def test_a_3d_run_of_a_builtin_vehicle_imports_no_sympy() -> None:
    """Loading, checking and building the 3D example, and its static state, without SymPy."""
    code = (
        "import sys\n"
        "from svbi.runtime.scenario.schema import load_scenario\n"
        "from svbi.runtime.run.simulate3d import build_run3d\n"
        "from svbi.runtime.methods.coupled3d import static_state\n"
        f"sc = load_scenario({str(EXAMPLE)!r},\n"
        "    overrides=['solver.duration=0.001', 'earthquake.arrival=0.0'])\n"
        "static_state(build_run3d(sc).system)\n"
        "print(sorted(m for m in sys.modules if m == 'sympy' or m.startswith('sympy.')))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"

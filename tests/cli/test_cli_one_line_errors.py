"""Bad input to any command is one line and exit status 2, never a traceback.

Each case here ended in a Python traceback: a binary file given as a topology (``UnicodeDecodeError``),
`svbi export` to a file or an uncreatable folder, of an unknown model or of a topology with an error,
`svbi demo -o` an existing file, `svbi plot -o` an uncreatable folder, an over-long output name
(``ENAMETOOLONG``) and a deeply nested TOML file (``RecursionError``).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from typer.testing import CliRunner

from svbi.runtime.cli.app import _register, app

_register()
runner = CliRunner()

SCENARIO = """\
[bridge]
spans = 1
span_length = 25.0
mass_per_length = 2303.0
youngs_modulus = 2.87e9
area = 1.0
second_moment = 2.9
elements_per_span = 4

[train]
vehicle = "sprung-mass"
speed_kmh = 100.0

[solver]
time_step = 2.0e-3
duration = 0.2

[contact]
creep = false
"""

LONG = "a" * 300  # above NAME_MAX (255 bytes) of every common file system


def _one_line_error(result, *words: str) -> str:  # noqa: ANN001 - click Result
    """Exit 2 and one line ``error: ...``; a scenario or study error lists its problems, one per
    indented line, below that line."""
    output = result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), (
        f"{type(result.exception).__name__}: {result.exception}\n{output}"
    )
    lines = [line for line in output.splitlines() if line.strip()]
    assert result.exit_code == 2, output
    assert "Traceback" not in output
    assert lines[0].startswith("error: "), output
    assert all(line.startswith("  ") for line in lines[1:]), output
    for word in words:
        assert word in output, output
    return lines[0]


@pytest.fixture
def files(tmp_path: Path) -> dict[str, Path]:
    binary = tmp_path / "binary.toml"
    binary.write_bytes(bytes(range(256)) * 8)
    deep = tmp_path / "deep.toml"
    deep.write_text("a = " + "[" * 5000 + "]" * 5000 + "\n", encoding="utf-8")
    existing = tmp_path / "existing.txt"
    existing.write_text("a user's file\n", encoding="utf-8")
    broken = tmp_path / "broken.toml"
    broken.write_text('name = "broken"\n[[bodies]]\nname = "b"\ndofs = ["q"]\n', encoding="utf-8")
    scenario = tmp_path / "scenario.toml"
    scenario.write_text(SCENARIO, encoding="utf-8")
    return {"binary": binary, "deep": deep, "existing": existing, "broken": broken, "scenario": scenario}


@pytest.mark.parametrize("command", ["export", "modes", "derive"])
def test_a_binary_file_as_a_topology(files: dict[str, Path], tmp_path: Path, command: str) -> None:
    args = [command, str(files["binary"])] + ([str(tmp_path / "out")] if command == "export" else [])
    _one_line_error(runner.invoke(app, args), str(files["binary"]), "UTF-8")


@pytest.mark.parametrize("command", ["export", "modes", "derive", "run", "sweep"])
def test_a_deeply_nested_toml_file(files: dict[str, Path], tmp_path: Path, command: str) -> None:
    extra = {
        "export": [str(tmp_path / "out")],
        "run": ["-o", str(tmp_path / "r.nc")],
        "sweep": ["-o", str(tmp_path / "s.nc")],
    }.get(command, [])
    _one_line_error(runner.invoke(app, [command, str(files["deep"]), *extra]), "nested")


def test_export_to_an_existing_file(files: dict[str, Path]) -> None:
    _one_line_error(runner.invoke(app, ["export", "sprung-mass", str(files["existing"])]), "not a folder")
    assert files["existing"].read_text() == "a user's file\n"


def test_export_to_an_uncreatable_folder(files: dict[str, Path]) -> None:
    _one_line_error(
        runner.invoke(app, ["export", "sprung-mass", str(files["existing"] / "sub" / "out")]),
        str(files["existing"]),
    )


def test_export_of_an_unknown_model(tmp_path: Path) -> None:
    _one_line_error(runner.invoke(app, ["export", "no-such-model", str(tmp_path / "out")]), "no-such-model")
    assert not (tmp_path / "out").exists()


def test_export_of_a_topology_with_an_error(files: dict[str, Path], tmp_path: Path) -> None:
    _one_line_error(
        runner.invoke(app, ["export", str(files["broken"]), str(tmp_path / "out")]), str(files["broken"])
    )


def test_export_to_an_over_long_name(tmp_path: Path) -> None:
    _one_line_error(runner.invoke(app, ["export", "sprung-mass", str(tmp_path / LONG)]), "too long")


def test_demo_into_an_existing_file(files: dict[str, Path]) -> None:
    _one_line_error(runner.invoke(app, ["demo", "-o", str(files["existing"]), "--quick"]), "not a folder")
    assert files["existing"].read_text() == "a user's file\n"


def test_run_to_an_over_long_name(files: dict[str, Path], tmp_path: Path) -> None:
    _one_line_error(
        runner.invoke(app, ["run", str(files["scenario"]), "-o", str(tmp_path / f"{LONG}.nc")]), "too long"
    )


def test_run_to_a_name_too_long_for_its_partial_results(files: dict[str, Path], tmp_path: Path) -> None:
    """The name fits, but ``<stem>.incomplete.nc`` or the write's temporary name would not: refused
    before the run, not after it."""
    name_max = os.pathconf(tmp_path, "PC_NAME_MAX")
    out = tmp_path / ("b" * (name_max - 3) + ".nc")
    _one_line_error(runner.invoke(app, ["run", str(files["scenario"]), "-o", str(out)]), "too long")


@pytest.fixture
def results(files: dict[str, Path], tmp_path: Path) -> Path:
    out = tmp_path / "run.nc"
    done = runner.invoke(app, ["run", str(files["scenario"]), "-o", str(out), "-q"])
    assert done.exit_code == 0, done.output
    return out


def test_plot_into_an_uncreatable_folder(results: Path, files: dict[str, Path]) -> None:
    _one_line_error(
        runner.invoke(app, ["plot", str(results), "-o", str(files["existing"] / "figures")]),
        str(files["existing"]),
    )


def test_plot_into_an_over_long_name(results: Path, tmp_path: Path) -> None:
    _one_line_error(runner.invoke(app, ["plot", str(results), "-o", str(tmp_path / LONG)]), "too long")


@pytest.mark.parametrize(
    "args",
    [
        ["modes", f"{LONG}.toml"],
        ["derive", f"{LONG}.toml"],
        ["plot", f"{LONG}.nc"],
        ["metrics", f"{LONG}.nc"],
        ["run", f"{LONG}.toml", "-o", "r.nc"],
        ["sweep", f"{LONG}.toml", "-o", "s.nc"],
        ["export", f"{LONG}.toml", "out"],
    ],
    ids=lambda args: args[0],
)
def test_an_over_long_input_name(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, args: list[str]) -> None:
    monkeypatch.chdir(tmp_path)
    _one_line_error(runner.invoke(app, args), LONG[:50])

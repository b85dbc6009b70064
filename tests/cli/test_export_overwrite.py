"""`svbi export` never overwrites a user's files unless told to (``--force``).

It wrote ``main.c`` and ``Makefile`` over the files of the same name in an existing folder.
"""

from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner

from svbi.runtime.cli.app import _register, app

_register()
runner = CliRunner()

MINE = b"/* my own program: must survive */\n"


def _one_line_error(result) -> str:  # noqa: ANN001 - click Result
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert result.exit_code == 2, result.output
    assert len(lines) == 1 and lines[0].startswith("error: "), result.output
    return lines[0]


def test_export_refuses_a_folder_with_files_it_would_overwrite(tmp_path: Path) -> None:
    folder = tmp_path / "project"
    folder.mkdir()
    (folder / "main.c").write_bytes(MINE)
    (folder / "Makefile").write_bytes(b"all:\n\techo mine\n")
    (folder / "notes.txt").write_bytes(b"unrelated")
    line = _one_line_error(runner.invoke(app, ["export", "sprung-mass", str(folder)]))
    assert "main.c" in line and "Makefile" in line and "--force" in line
    assert "notes.txt" not in line
    assert (folder / "main.c").read_bytes() == MINE  # nothing written at all
    assert sorted(p.name for p in folder.iterdir()) == ["Makefile", "main.c", "notes.txt"]


def test_export_solver_refuses_too(tmp_path: Path) -> None:
    folder = tmp_path / "project"
    folder.mkdir()
    (folder / "main.c").write_bytes(MINE)
    line = _one_line_error(runner.invoke(app, ["export", "pioneer-2d", str(folder), "--solver"]))
    assert "main.c" in line and "--force" in line
    assert (folder / "main.c").read_bytes() == MINE


def test_export_with_force_overwrites(tmp_path: Path) -> None:
    folder = tmp_path / "project"
    folder.mkdir()
    (folder / "main.c").write_bytes(MINE)
    result = runner.invoke(app, ["export", "sprung-mass", str(folder), "--force"])
    assert result.exit_code == 0, result.output
    assert (folder / "main.c").read_bytes() != MINE


def test_export_again_into_its_own_folder_is_allowed(tmp_path: Path) -> None:
    """Files with the same content are not overwritten: exporting twice is fine."""
    folder = tmp_path / "export"
    first = runner.invoke(app, ["export", "sprung-mass", str(folder)])
    assert first.exit_code == 0, first.output
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    again = runner.invoke(app, ["export", "sprung-mass", str(folder)])
    assert again.exit_code == 0, again.output
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before

"""Module boundaries (issue 11 item 3): no svbi module imports another module's private names.

A leading underscore marks what a module keeps to itself; another module (or a benchmark) reaching
for it couples the two silently. Checked on the source with ``ast``: ``from svbi.x import _name``
and ``import svbi.x as m`` followed by ``m._name``.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
FOLDERS = ("runtime", "codegen", "svbi", "benchmarks")


def _sources() -> list[Path]:
    return sorted(p for folder in FOLDERS for p in (REPO / folder).rglob("*.py"))


def _private_uses(path: Path) -> list[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    where = path.relative_to(REPO) if path.is_relative_to(REPO) else path.name
    found: list[str] = []
    aliases: dict[str, str] = {}  # local name -> svbi module
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("svbi"):
            for alias in node.names:
                if alias.name.startswith("_") and not alias.name.startswith("__"):
                    found.append(f"{where}:{node.lineno}: from {node.module} import {alias.name}")
                else:
                    aliases[alias.asname or alias.name] = f"{node.module}.{alias.name}"
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("svbi"):
                    aliases[alias.asname or alias.name.split(".")[0]] = alias.name
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Attribute)
            and isinstance(node.value, ast.Name)
            and node.value.id in aliases
            and node.attr.startswith("_")
            and not node.attr.startswith("__")
        ):
            found.append(f"{where}:{node.lineno}: {node.value.id}.{node.attr}")
    return found


def test_the_check_finds_a_private_import(tmp_path: Path) -> None:
    """The check itself: it must flag both forms (else the test below could never fail)."""
    bad = tmp_path / "probe.py"
    bad.write_text(
        "from svbi.runtime.run.simulate import _hidden\nimport svbi.runtime.run.simulate as s\ns._other()\n"
    )
    found = _private_uses(bad)
    assert len(found) == 2, found


@pytest.mark.parametrize("path", _sources(), ids=lambda p: str(p.relative_to(REPO)))
def test_no_module_uses_another_modules_private_names(path: Path) -> None:
    assert not _private_uses(path)

"""The runtime's architecture (docs/architecture.md): wings that import only the wings below them
(import-linter, the contracts in pyproject.toml), no import circle between modules, relative imports
inside the package."""

from __future__ import annotations

import ast
import shutil
from pathlib import Path

from lint_imports import lint

REPO = Path(__file__).resolve().parents[2]
RUNTIME = REPO / "runtime"


def module_graph(root: Path, package: str = "svbi.runtime") -> dict[str, set[str]]:
    """Module-level imports between the modules under ``root`` (imports inside functions and under
    ``if TYPE_CHECKING`` are not executed at import time and are left out)."""
    mods: dict[str, tuple[Path, bool]] = {}
    for p in root.rglob("*.py"):
        parts = list(p.relative_to(root).with_suffix("").parts)
        is_pkg = parts[-1] == "__init__"
        mods[".".join([package, *(parts[:-1] if is_pkg else parts)])] = (p, is_pkg)

    def owner(name: str) -> str | None:
        while name not in mods and "." in name:
            name = name.rsplit(".", 1)[0]
        return name if name in mods else None

    graph: dict[str, set[str]] = {}
    for m, (p, is_pkg) in mods.items():
        deps: set[str] = set()
        for node in ast.parse(p.read_text(encoding="utf-8")).body:
            names: list[str] = []
            if isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    here = m.split(".") if is_pkg else m.split(".")[:-1]
                    base = ".".join(
                        here[: len(here) - node.level + 1] + ([node.module] if node.module else [])
                    )
                names = [f"{base}.{a.name}" if f"{base}.{a.name}" in mods else base for a in node.names]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            for name in names:
                target = owner(name)
                if target is not None and target != m:
                    deps.add(target)
        graph[m] = deps
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_no_import_circle_in_the_runtime():
    assert cycles(module_graph(RUNTIME)) == []


def test_the_circle_check_finds_a_planted_circle(tmp_path):
    (tmp_path / "a.py").write_text("from . import b\n")
    (tmp_path / "b.py").write_text("import os\n\nfrom .c import x\n")
    (tmp_path / "c.py").write_text("from .a import y\n")
    (tmp_path / "d.py").write_text("def f():\n    from . import a\n")  # inside a function: not a circle
    assert cycles(module_graph(tmp_path, "pkg")) == [["pkg.a", "pkg.b", "pkg.c"]]


def test_runtime_imports_svbi_relatively():
    """Inside the package, svbi's modules (the runtime's and the generator's) are imported
    relatively: ``from ...codegen.plain_types import GRAVITY``, never ``from svbi.codegen...``."""
    absolute = []
    for p in RUNTIME.rglob("*.py"):
        for node in ast.walk(ast.parse(p.read_text(encoding="utf-8"))):
            named = [node.module or ""] if isinstance(node, ast.ImportFrom) else []
            if isinstance(node, ast.Import):
                named = [alias.name for alias in node.names]
            if getattr(node, "level", 0) == 0 and any(n == "svbi" or n.startswith("svbi.") for n in named):
                absolute.append(f"{p.relative_to(REPO)}:{node.lineno}")
    assert absolute == []


def test_import_contracts_hold():
    assert lint(quiet=True) == 0


def test_import_contracts_catch_an_upward_import(tmp_path):
    """The layers contract must be able to fail: a model module that imports the command line."""
    repo = tmp_path / "repo"
    repo.mkdir()
    for name in ("runtime", "codegen", "templates", "generated", "examples"):
        shutil.copytree(REPO / name, repo / name, ignore=shutil.ignore_patterns("__pycache__"))
    bridge = repo / "runtime" / "model" / "bridge.py"
    bridge.write_text(
        bridge.read_text(encoding="utf-8") + "\nfrom ..cli import app  # noqa\n", encoding="utf-8"
    )
    assert lint(repo, quiet=True) != 0

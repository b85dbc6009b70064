"""Run import-linter (the contracts in pyproject.toml) over any copy of the repository.

svbi installs its folders under one namespace through ``package-dir`` (``runtime/`` is
``svbi.runtime``), which import-linter cannot follow: it walks the ``svbi`` package's folder. The
repository's ``svbi/`` therefore holds links to its folders, so that ``lint-imports`` works from the
repository root (``make lint``); for a copy (tests/architecture/test_architecture.py plants a
violation in one), the package is staged the same way in a temporary folder put first on the path.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
FOLDERS = ("runtime", "codegen", "templates", "generated", "examples")


def lint(repo: Path = REPO, quiet: bool = False) -> int:
    """``lint-imports`` over ``repo``'s folders staged as the ``svbi`` package; its exit status."""
    with tempfile.TemporaryDirectory(prefix="svbi-lint-") as stage:
        package = Path(stage) / "svbi"
        package.mkdir()
        shutil.copy(REPO / "svbi" / "__init__.py", package / "__init__.py")
        for name in FOLDERS:
            (package / name).symlink_to(repo / name, target_is_directory=True)
        env = dict(os.environ, PYTHONPATH=os.pathsep.join([stage, os.environ.get("PYTHONPATH", "")]))
        lint_imports = Path(sys.executable).with_name("lint-imports")
        # run from the stage: lint-imports puts its working folder first on the path
        done = subprocess.run(
            [str(lint_imports), str(REPO / "pyproject.toml"), "--no-cache"],
            cwd=stage,
            env=env,
            check=False,
            capture_output=quiet,
        )
        return done.returncode


if __name__ == "__main__":
    sys.exit(lint())

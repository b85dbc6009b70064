"""Shared test fixtures: paths to the repository and to the read-only ../shared folder."""

from __future__ import annotations

import functools
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"


@pytest.fixture
def shared_dir() -> Path:
    """The ../shared folder beside the repository; tests that need it skip cleanly without it."""
    if not SHARED.is_dir():
        pytest.skip(f"../shared not found at {SHARED}: reference data (papers, records) unavailable")
    return SHARED


@functools.cache
def c_compiler_works() -> bool:
    """Whether the C loop compiles here (the C backend falls back to NumPy without a compiler;
    tests of the C loop skip)."""
    from svbi.runtime import c_solver_build, kernel_cache

    try:
        c_solver_build.load_loop(c_solver_build.LoopSpec("moving-load", 0, 0))
    except kernel_cache.CompilerError:
        return False
    return True

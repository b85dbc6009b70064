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
    """Whether a C compiler works here (the C backend falls back to NumPy without one; tests of the
    C loop skip). Where one works, the loop must build: a build error of svbi's own sources fails
    the tests that ask, instead of skipping every test of the C loop."""
    from svbi.runtime import c_solver_build, kernel_cache

    try:
        kernel_cache.load_library(
            {"probe.c": b"int svbi_probe(void) { return 1; }\n"}, "svbi_probe", flags=("-fPIC", "-shared")
        )
    except kernel_cache.CompilerError:
        return False
    c_solver_build.load_loop(c_solver_build.LoopSpec("moving-load", 0, 0))  # raises with the message
    return True

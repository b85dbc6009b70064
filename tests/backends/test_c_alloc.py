"""The C loop allocates nothing: every loop library imports no allocator.

The workspace is carved out of two arrays the caller sizes once (``svbi_solver_workspace``); after
that nothing in the loop may allocate (docs/c-backend.md, "Memory footprint"). Truth: the dynamic
symbol table of every compiled loop library (``nm -D --undefined-only``), i.e. what the loop can
call outside itself. It must hold no allocator (``malloc``, ``calloc``, ``realloc``, ``free``,
``aligned_alloc``, ``posix_memalign``, ...) and, as a control, must hold the maths the loop does use
(``sqrt``), so an empty or unreadable table cannot pass.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from svbi.runtime import toolchain as kernel_cache
from svbi.runtime.backends.c import build as c_solver_build

ALLOCATORS = {
    "malloc",
    "calloc",
    "realloc",
    "reallocarray",
    "free",
    "aligned_alloc",
    "posix_memalign",
    "memalign",
    "valloc",
    "pvalloc",
    "alloca",
    "strdup",
    "strndup",
    "mmap",
    "sbrk",
    "brk",
    "_Znwm",
    "_Znam",
}

SPECS = (c_solver_build.LoopSpec("pioneer-2d", 14, 4), c_solver_build.LoopSpec("moving-load", 0, 0))


def _imports(spec: c_solver_build.LoopSpec) -> set[str]:
    try:
        library = c_solver_build.load_loop(spec)
    except kernel_cache.CompilerError:
        pytest.skip("no working C compiler")
    path = Path(library._library._name)
    out = subprocess.run(
        ["nm", "-D", "--undefined-only", str(path)], check=True, capture_output=True, text=True
    ).stdout
    return {line.split()[-1].split("@")[0] for line in out.splitlines() if line.strip()}


@pytest.mark.skipif(shutil.which("nm") is None, reason="needs nm (binutils)")
@pytest.mark.parametrize("spec", SPECS, ids=[s.model for s in SPECS])
def test_loop_library_imports_no_allocator(spec: c_solver_build.LoopSpec) -> None:
    names = _imports(spec)
    assert "sqrt" in names  # the control: the table was read (the band Cholesky takes roots)
    assert not names & ALLOCATORS, sorted(names & ALLOCATORS)

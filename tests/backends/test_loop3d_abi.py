"""The compiled 3D loop's ABI has one definition: the field lists and status codes of
:mod:`svbi.codegen.loop3d_abi`, from which ``svbi generate`` renders
``generated/solver3d/svbi_loop3d_types.h`` (which ``runtime/csrc/loop3d/loop3d.h`` includes) and
:mod:`svbi.runtime.backends.c.stepper3d` builds its ctypes mirrors.

* the committed header is the one the lists render (``svbi generate --check`` holds the same);
* ``sizeof`` and ``offsetof`` of every member, compiled from the header the loop is built with,
  equal the ctypes mirrors' (a member added, removed, moved or retyped on one side only fails);
* the status codes the header defines are the lists', and the static C declares none of the
  generated structs or codes itself.
"""

from __future__ import annotations

import ctypes
import re
from functools import cache
from importlib import resources

import pytest

from svbi.codegen import loop3d_abi
from svbi.runtime import toolchain as kernel_cache
from svbi.runtime.backends.c import build as c_solver_build
from svbi.runtime.backends.c import stepper3d


def header() -> str:
    """The header the 3D loop is compiled with."""
    return stepper3d.loop3d_sources()[loop3d_abi.TYPES3D_HEADER].decode()


@cache
def layout() -> ctypes.CDLL:
    """C that reports sizeof and offsetof of every member of the generated structs."""
    lines = ["#include <stddef.h>", f'#include "{loop3d_abi.TYPES3D_HEADER}"', ""]
    for ctype, fields in loop3d_abi.STRUCTS3D.items():
        values = [f"(long)sizeof({ctype})"] + [f"(long)offsetof({ctype}, {f.name})" for f in fields]
        lines.append(f"const long svbi_layout_{ctype}[{len(values)}] = {{{', '.join(values)}}};")
    sources = {
        loop3d_abi.TYPES3D_HEADER: header().encode(),
        "layout3d.c": ("\n".join(lines) + "\n").encode(),
    }
    return kernel_cache.load_library(sources, "svbi_test_loop3d_abi", flags=c_solver_build.LOOP_FLAGS)


def _compiler_works() -> bool:
    try:
        layout()
    except kernel_cache.CompilerError:
        return False
    return True


def test_the_committed_header_is_the_rendered_one() -> None:
    from svbi.codegen import loop_glue

    assert header().encode() == loop_glue.loop3d_types()[loop3d_abi.TYPES3D_HEADER]


@pytest.mark.skipif(not _compiler_works(), reason="no working C compiler")
@pytest.mark.parametrize("ctype", list(loop3d_abi.STRUCTS3D))
def test_generated_structs_match_the_ctypes_mirrors(ctype: str) -> None:
    assert list(stepper3d.MIRRORS) == list(loop3d_abi.STRUCTS3D)  # svbi3d_sizes' order
    mirror, fields = stepper3d.MIRRORS[ctype], loop3d_abi.STRUCTS3D[ctype]
    assert [name for name, _ in mirror._fields_] == [f.name for f in fields]
    values = (ctypes.c_long * (len(fields) + 1)).in_dll(layout(), f"svbi_layout_{ctype}")
    assert values[0] == ctypes.sizeof(mirror)
    for i, f in enumerate(fields):
        assert values[i + 1] == getattr(mirror, f.name).offset, f.name


def test_the_status_codes_are_the_lists() -> None:
    defined = {m[0]: int(m[1]) for m in re.findall(r"^#define S3_(\w+) (\d+)$", header(), re.M)}
    assert defined == loop3d_abi.STATUS3D_CODES
    assert set(stepper3d.STATUS) == set(defined.values())
    assert stepper3d.NOT_FINITE == defined["NOT_FINITE"] and stepper3d.SINGULAR == defined["SINGULAR"]


def test_the_static_c_declares_none_of_the_generated_names() -> None:
    folder = resources.files("svbi.runtime").joinpath(c_solver_build.CSRC).joinpath(c_solver_build.CSRC_3D)
    for source in folder.iterdir():
        if not source.name.endswith((".c", ".h")):
            continue
        text = source.read_text()
        assert not re.search(r"#define\s+S3_", text), source.name
        for ctype in loop3d_abi.STRUCTS3D:
            assert not re.search(rf"}}\s*{ctype}\s*;", text), (source.name, ctype)
    assert f'#include "{loop3d_abi.TYPES3D_HEADER}"' in folder.joinpath("loop3d.h").read_text()

"""The generated NumPy kernel modules (``generated/<model>/numpy_kernels.py``), loaded by path.

Built-in models load from the package's committed ``generated/`` tree; a user's topology file is
derived and emitted once into the compile cache, keyed by its content
(:func:`svbi.runtime.toolchain.python_module`), and loaded from there. The model folders have
hyphens in their names, so a module is compiled from its file and run in a fresh namespace (which
also leaves no ``__pycache__`` next to the committed files). Nothing here imports SymPy.
"""

from __future__ import annotations

import re
import types
from functools import cache
from pathlib import Path

from ...codegen.plain_types import (
    PYTHON_KERNELS_FILE,
    TopologyError,
    builtin_topologies,
    builtin_topologies_3d,
)
from ..toolchain import generated_root, python_module

FRAME2D = "frame2d"
"""The bridge element model (``svbi.codegen.kernels.FRAME2D``)."""
FRAME3D = "frame3d"
"""The 3D frame element model (``svbi.codegen.kernels.FRAME3D``): the 3D bridge and its runs."""
CONTACT3D = "contact3d"
"""The 3D contact model (``svbi.codegen.kernels.CONTACT3D``), not yet used by runs."""


def module_path(model: str) -> Path:
    """The file of a model's generated module: committed for ``frame2d``, ``frame3d``,
    ``contact3d``, the built-in vehicles and the built-in 3D vehicles, emitted into the cache for a
    (2D) topology file."""
    models = (FRAME2D, FRAME3D, CONTACT3D, *builtin_topologies_3d())
    if model in models or model in builtin_topologies():
        committed = generated_root() / model / PYTHON_KERNELS_FILE
        if committed.is_file():
            return committed
        if model in models:
            raise FileNotFoundError(f"{committed} is missing: run `svbi generate --all`")
        from importlib import resources

        with resources.as_file(resources.files("svbi.codegen.vehicles") / f"{model}.toml") as path:
            return python_module(path)
    path = Path(model)
    if not path.is_file():
        known = ", ".join(builtin_topologies())
        raise TopologyError(model, "vehicle", f"not a built-in vehicle ({known}) and no such file")
    return python_module(path)


@cache
def load(model: str) -> types.ModuleType:
    """The generated module of ``model`` (a built-in name, ``frame2d`` or a topology file path)."""
    return load_path(module_path(model))


@cache
def load_path(path: Path) -> types.ModuleType:
    """The generated module in the file ``path``."""
    source = path.read_text(encoding="utf-8")
    module = types.ModuleType(f"svbi.generated.{re.sub(r'[^A-Za-z0-9_]', '_', path.parent.name)}")
    module.__file__ = str(path)
    exec(compile(source, str(path), "exec"), module.__dict__)  # noqa: S102 - our own generated code
    return module


def frame2d() -> types.ModuleType:
    """The bridge element's kernels: element matrices, contact-row tables, constraint masses, creep."""
    return load(FRAME2D)


class _BroadcastingNumpy:
    """NumPy for a generated module whose kernels are evaluated at arrays of their scalar inputs:
    ``array`` broadcasts the entries of the nested lists it is given (a kernel builds a matrix
    output from scalar expressions and constant zeros) and stacks them on the last axes, so that a
    matrix kernel of ``(r, c)`` called with inputs of shape ``s`` returns ``s + (r, c)``; the rest is
    NumPy's."""

    def __getattr__(self, name: str) -> object:
        import numpy

        return getattr(numpy, name)

    @staticmethod
    def array(obj: object, dtype: object = None) -> object:
        import numpy

        def shape_of(o: object) -> tuple[int, ...]:
            return (len(o), *shape_of(o[0])) if isinstance(o, list | tuple) else ()  # type: ignore[index]

        def flat(o: object) -> list:
            return [v for item in o for v in flat(item)] if isinstance(o, list | tuple) else [o]  # type: ignore[union-attr]

        outer = shape_of(obj)
        entries = numpy.broadcast_arrays(*(numpy.asarray(e, dtype=dtype) for e in flat(obj)))
        batch = entries[0].shape
        return numpy.stack(entries, axis=-1).reshape(*batch, *outer)


@cache
def load_broadcasting(model: str) -> types.ModuleType:
    """The generated module of ``model`` (:func:`load`) in a namespace in which its kernels take
    arrays for their scalar inputs: a matrix output ``(r, c)`` comes back as ``input shape + (r,
    c)``, each entry the same expression as :func:`load`'s kernel evaluates at one point."""
    path = module_path(model)
    source = path.read_text(encoding="utf-8")
    module = types.ModuleType(
        f"svbi.generated.broadcasting.{re.sub(r'[^A-Za-z0-9_]', '_', path.parent.name)}"
    )
    module.__file__ = str(path)
    exec(compile(source, str(path), "exec"), module.__dict__)  # noqa: S102 - our own generated code
    module.__dict__["numpy"] = _BroadcastingNumpy()
    return module

"""C emitter: CasADi ``CodeGenerator`` for the math, Jinja2 templates for the glue.

One model (a vehicle topology, or the bridge element ``frame2d``) becomes one folder::

    <model>/<c>_kernels.c, <c>_kernels.h   every kernel, by casadi.CodeGenerator
    <model>/<c>.h, <c>_model.c             sizes as #define, kernel table, parameter struct
    <model>/main.c                         example: evaluates every kernel and prints the values
    <model>/Makefile, CMakeLists.txt       builds lib<c>.a and the example with no Python
    <model>/manifest.json                  what the Python loader needs (names, shapes, defaults)
    <model>/<kernel>.casadi                serialized casadi.Function of every kernel

where ``<c>`` is the model name as a C identifier (``pioneer-2d`` -> ``pioneer_2d``). Exported C
symbols are ``svbi_<c>_<kernel>`` and CasADi's internal helpers get the prefix ``svbi_<c>_cg_``, so
several models link into one program without clashes.

Determinism: the output depends only on the specs, the options and the SymPy/CasADi versions. Every
text file starts with a banner naming this module, the template and the sha256 of those inputs; no
timestamps. (``.casadi`` files are CasADi's serialization format and cannot carry a banner;
``manifest.json`` carries it as its first keys.)

Compiler warnings: the glue compiles with ``-std=c99 -Wall -Wextra -Werror``. CasADi's own
evaluation functions all share the signature ``(arg, res, iw, w, mem)`` and an SX function without
integer work or memory never reads ``iw`` and ``mem``; CasADi 3.8 has no option to mark them unused,
so ``-Wunused-parameter`` (part of ``-Wextra``) fires on ``<c>_kernels.c`` only. The build files
compile that one file with ``-Wno-unused-parameter`` and everything else with the full set.
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import tempfile
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import casadi as ca
import jinja2

from svbi.codegen.c_flags import CASADI_WARNING_EXCEPTION, STRICT_FLAGS
from svbi.codegen.casadi_emit import build_functions, casadi_files
from svbi.codegen.kernels import ModelSpec

GENERATOR = "svbi.codegen.c_emit"

_TEMPLATES = {
    "{c}.h": "c/model.h.j2",
    "{c}_model.c": "c/model.c.j2",
    "main.c": "c/main.c.j2",
    "Makefile": "build/Makefile.j2",
    "CMakeLists.txt": "build/CMakeLists.txt.j2",
}


@dataclass(frozen=True)
class EmitOptions:
    """Code-generation options.

    ``casadi_int`` is the integer type of CasADi's sparsity and work arrays (``"int"`` for 32-bit
    embedded targets); ``avoid_stack`` puts CasADi's temporaries in the caller's work array instead
    of on the stack (small-stack microcontrollers).
    """

    casadi_int: str = "long long int"
    avoid_stack: bool = False

    @classmethod
    def embedded(cls) -> EmitOptions:
        return cls(casadi_int="int", avoid_stack=True)


def _environment() -> jinja2.Environment:
    return jinja2.Environment(
        loader=jinja2.PackageLoader("svbi.templates", "."),
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
        trim_blocks=True,
        lstrip_blocks=True,
        autoescape=False,
    )


def _c_double(value: float) -> str:
    """Shortest round-tripping C literal of a double."""
    if not math.isfinite(value):
        raise ValueError(f"cannot write the non-finite default {value!r} as a C constant")
    return repr(float(value))


def _sparsity(sp: ca.Sparsity) -> dict[str, Any]:
    rows, cols = sp.get_triplet()
    return {
        "rows": sp.size1(),
        "cols": sp.size2(),
        "nnz": sp.nnz(),
        "nz_row": list(rows),
        "nz_col": list(cols),
    }


def input_hash(model: ModelSpec, options: EmitOptions) -> str:
    """sha256 of everything the emitted files depend on."""
    return model.fingerprint(extra=[f"{GENERATOR} {json.dumps(asdict(options), sort_keys=True)}"])


def build_context(model: ModelSpec, options: EmitOptions, functions: list[ca.Function]) -> dict[str, Any]:
    """The plain dict every template renders from."""
    c = model.c_name
    kernels = []
    for index, (spec, fn) in enumerate(zip(model.kernels, functions, strict=True)):
        inputs = [
            {
                "name": name,
                "size": int(column.rows),
                "symbols": [s.name for s in column],
                "sample": [_c_double(v) for v in values],
            }
            for (name, column), values in zip(spec.inputs, spec.sample_inputs(), strict=True)
        ]
        outputs = [
            {"name": name, **_sparsity(fn.sparsity_out(i))} for i, (name, _) in enumerate(spec.outputs)
        ]
        kernels.append(
            {
                "index": index,
                "name": spec.name,
                "symbol": fn.name(),
                "doc": spec.doc,
                "doc_lines": spec.doc.strip().splitlines() or [""],
                "inputs": inputs,
                "outputs": outputs,
                "sz_arg": int(fn.sz_arg()),
                "sz_res": int(fn.sz_res()),
                "sz_iw": int(fn.sz_iw()),
                "sz_w": int(fn.sz_w()),
            }
        )

    def biggest(values: list[int]) -> int:
        return max([1, *values])

    return {
        "generator": GENERATOR,
        "input_hash": input_hash(model, options),
        "sympy_version": __import__("sympy").__version__,
        "casadi_version": ca.__version__,
        "model": {
            "name": model.name,
            "c": c,
            "upper": c.upper(),
            "doc_lines": model.doc.strip().splitlines() or [""],
            "prefix": f"svbi_{c}_cg",
        },
        "options": {"casadi_int": options.casadi_int, "avoid_stack": options.avoid_stack},
        "files": {
            "kernels_c": f"{c}_kernels.c",
            "kernels_h": f"{c}_kernels.h",
            "model_h": f"{c}.h",
            "model_c": f"{c}_model.c",
            "library": f"libsvbi_{c}.a",
            "example": f"{c}_main",
        },
        "flags": {"strict": " ".join(STRICT_FLAGS), "casadi_exception": CASADI_WARNING_EXCEPTION},
        "sizes": [{"name": k.upper(), "value": int(v)} for k, v in sorted(model.sizes.items())],
        "parameters": [{"name": n, "default": _c_double(v)} for n, v in model.parameters],
        "kernels": kernels,
        "max": {
            "sz_arg": biggest([k["sz_arg"] for k in kernels]),
            "sz_res": biggest([k["sz_res"] for k in kernels]),
            "sz_iw": biggest([k["sz_iw"] for k in kernels]),
            "sz_w": biggest([k["sz_w"] for k in kernels]),
            "input": biggest([i["size"] for k in kernels for i in k["inputs"]]),
            "output_dense": biggest([o["rows"] * o["cols"] for k in kernels for o in k["outputs"]]),
        },
    }


_CASADI_HELPER = re.compile(r"^casadi_real (casadi_\w+)\(", re.MULTILINE)


def _internal_helpers(source: str) -> str:
    """CasADi's scalar helpers (``casadi_sq``, ``casadi_fabs``, ``casadi_sign``) as ``static inline``.

    CasADi defines them as global functions. In a shared library a global function may be
    interposed, so the compiler calls it through the PLT instead of inlining it: the creep law took
    three such calls per wheel and step. Each kernel file keeps its own copy, as before.
    """
    return _CASADI_HELPER.sub(r"static inline casadi_real \1(", source)


def _casadi_sources(model: ModelSpec, options: EmitOptions, functions: list[ca.Function]) -> dict[str, str]:
    c = model.c_name
    cg = ca.CodeGenerator(
        f"{c}_kernels",
        {
            "with_header": True,
            "prefix": f"svbi_{c}_cg",
            "casadi_int": options.casadi_int,
            "casadi_real": "double",
            "avoid_stack": options.avoid_stack,
            "verbose": False,
            "indent": 2,
        },
    )
    for fn in functions:
        cg.add(fn)
    with tempfile.TemporaryDirectory(prefix="svbi-cg-") as tmp:
        cg.generate(tmp + os.sep)
        return {
            f"{c}_kernels.c": _internal_helpers(Path(tmp, f"{c}_kernels.c").read_text(encoding="utf-8")),
            f"{c}_kernels.h": Path(tmp, f"{c}_kernels.h").read_text(encoding="utf-8"),
        }


def render_model(model: ModelSpec, options: EmitOptions | None = None) -> dict[str, bytes]:
    """Every file of a model folder, ``{relative name: bytes}``; no I/O besides a scratch folder."""
    options = options or EmitOptions()
    functions = build_functions(model)
    context = build_context(model, options, functions)
    env = _environment()
    banner = env.get_template("_banner.j2").module
    files: dict[str, bytes] = {}

    for name, text in _casadi_sources(model, options, functions).items():
        head = str(banner.c_banner(context, "casadi.CodeGenerator (no template)"))
        files[name] = (head + text.rstrip() + "\n").encode()
    for pattern, template in _TEMPLATES.items():
        name = pattern.format(c=model.c_name)
        text = env.get_template(template).render({**context, "ctx": context, "template": template})
        files[name] = text.encode()
    files["manifest.json"] = (json.dumps(manifest(context), indent=1) + "\n").encode()
    files.update(casadi_files(model, functions))
    return dict(sorted(files.items()))


def manifest(context: dict[str, Any]) -> dict[str, Any]:
    """What the Python loader (``svbi.runtime.toolchain``) needs to call the kernels."""
    return {
        "generated_by": context["generator"],
        "inputs_sha256": context["input_hash"],
        "sympy": context["sympy_version"],
        "casadi": context["casadi_version"],
        "model": context["model"]["name"],
        "c_name": context["model"]["c"],
        "options": context["options"],
        "sources": [context["files"]["kernels_c"], context["files"]["model_c"]],
        "headers": [context["files"]["kernels_h"], context["files"]["model_h"]],
        "parameters": [{"name": p["name"], "default": float(p["default"])} for p in context["parameters"]],
        "sizes": {s["name"].lower(): s["value"] for s in context["sizes"]},
        "kernels": [
            {
                "name": k["name"],
                "symbol": k["symbol"],
                "doc": k["doc"],
                "casadi_file": f"{k['name']}.casadi",
                "inputs": [
                    {
                        "name": i["name"],
                        "size": i["size"],
                        "symbols": i["symbols"],
                        "sample": [float(v) for v in i["sample"]],
                    }
                    for i in k["inputs"]
                ],
                "outputs": [{key: o[key] for key in ("name", "rows", "cols", "nnz")} for o in k["outputs"]],
            }
            for k in context["kernels"]
        ],
    }


def write_files(files: dict[str, bytes], out_dir: str | os.PathLike[str], *, prune: bool = True) -> Path:
    """Write a rendered model folder; with ``prune``, delete files of that folder not in ``files``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if prune:
        for old in out.iterdir():
            if old.name not in files:
                if old.is_dir():
                    shutil.rmtree(old)
                else:
                    old.unlink()
    for name, data in files.items():
        path = out / name
        if path.exists() and path.read_bytes() == data:
            continue
        tmp = path.with_name(f".{name}.tmp")
        tmp.write_bytes(data)
        os.replace(tmp, path)
    return out


def write_model(
    model: ModelSpec, out_dir: str | os.PathLike[str], options: EmitOptions | None = None
) -> Path:
    """Render a model and write it to ``out_dir`` (the model folder itself)."""
    return write_files(render_model(model, options), out_dir)

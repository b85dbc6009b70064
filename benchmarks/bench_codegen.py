"""Code generation and kernel call costs (``python benchmarks/bench_codegen.py``).

1. Generation time of every built-in model: SymPy derivation of the kernel specs, then CasADi
   Functions + C sources + templates (``c_emit.render_model``), then C compilation (``-O3``).
2. Per-call cost of kernels at their sample inputs:
   * from C: a small timing harness linked against the generated sources (no Python at all);
   * from Python: the ctypes wrapper of ``svbi.runtime.toolchain`` (C backend);
   * from Python: the CasADi backend (the serialized Function in CasADi's virtual machine).
   Medians of repeated runs; the ratio columns are measured in the same run.
"""

from __future__ import annotations

import json
import os
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
import timeit
from pathlib import Path

import numpy as np

from svbi.codegen import c_emit
from svbi.codegen.kernels import builtin_models, model_spec
from svbi.runtime import toolchain as kernel_cache

KERNELS = [
    ("pioneer-2d", "mass_matrix"),
    ("pioneer-2d", "stiffness_matrix"),
    ("pioneer-2d", "vehicle_constraint"),
    ("pioneer-2d", "creepage"),
    ("frame2d", "contact_rows"),
    ("frame2d", "discrete_bridge_row"),
    ("frame2d", "creep_force"),
    ("sprung-mass", "mass_matrix"),
]

HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <time.h>
#include "{header}"

static double now(void) {{
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}}

static casadi_real out[{max_out}];
static casadi_int iw[SVBI_{upper}_MAX_SZ_IW];
static casadi_real w[SVBI_{upper}_MAX_SZ_W];
{inputs}

int main(void) {{
  const casadi_real* arg[SVBI_{upper}_MAX_SZ_ARG] = {{0}};
  casadi_real* res[SVBI_{upper}_MAX_SZ_RES] = {{0}};
  int rep, i;
  long n = {calls};
{setup}
  res[0] = out;
  for (rep = 0; rep < 7; ++rep) {{
    double t0 = now();
    for (i = 0; i < n; ++i) {symbol}(arg, res, iw, w, 0);
    printf("%.3f\n", 1e9 * (now() - t0) / n);
  }}
  return 0;
}}
"""


def c_harness_ns(folder: Path, kernel: dict, c_name: str, calls: int = 200_000) -> float:
    """Median ns per call of one kernel from a C loop (output 0 only, like the runtime's hot path)."""
    inputs = "\n".join(
        f"static const casadi_real in{i}[{inp['size']}] = {{{', '.join(repr(v) for v in inp['sample'])}}};"
        for i, inp in enumerate(kernel["inputs"])
    )
    setup = "\n".join(f"  arg[{i}] = in{i};" for i in range(len(kernel["inputs"])))
    max_out = max(o["rows"] * o["cols"] for o in kernel["outputs"])
    source = HARNESS.format(
        header=f"{c_name}.h",
        upper=c_name.upper(),
        max_out=max_out,
        inputs=inputs,
        setup=setup,
        symbol=kernel["symbol"],
        calls=calls,
    )
    with tempfile.TemporaryDirectory() as tmp:
        harness = Path(tmp, "harness.c")
        harness.write_text(source)
        exe = Path(tmp, "harness")
        cc = shlex.split(os.environ.get("CC") or "cc")
        sources = [str(folder / f"{c_name}_kernels.c"), str(folder / f"{c_name}_model.c"), str(harness)]
        subprocess.run([*cc, "-O3", "-I", str(folder), "-o", str(exe), *sources, "-lm"], check=True)
        out = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.split()
    return statistics.median(float(v) for v in out)


def python_ns(kernel: kernel_cache.Kernel, inputs: list[np.ndarray], number: int) -> float:
    runs = timeit.repeat(lambda: kernel(*inputs), number=number, repeat=7)
    return 1e9 * statistics.median(runs) / number


def generation_table() -> None:
    print("Code generation (first call in this process; seconds)")
    print(f"{'model':<14}{'kernels':>8}{'derive':>10}{'render':>10}{'compile':>10}{'files kB':>10}")
    with tempfile.TemporaryDirectory() as cache:
        for name in builtin_models():
            t0 = time.perf_counter()
            spec = model_spec(name)
            t1 = time.perf_counter()
            files = c_emit.render_model(spec)
            t2 = time.perf_counter()
            manifest = json.loads(files["manifest.json"])
            sources = {n: files[n] for n in manifest["sources"] + manifest["headers"]}
            kernel_cache.build_library(sources, f"svbi_{manifest['c_name']}", cache_dir=cache)
            t3 = time.perf_counter()
            size = sum(len(v) for v in files.values()) / 1024
            times = f"{t1 - t0:>10.2f}{t2 - t1:>10.2f}{t3 - t2:>10.2f}"
            print(f"{name:<14}{len(spec.kernels):>8}{times}{size:>10.0f}")


def call_table() -> None:
    print("\nPer-call cost at the sample inputs (ns, median of 7)")
    header = f"{'kernel':<34}{'C loop':>10}{'ctypes':>10}{'CasADi':>11}{'ctypes/C':>10}{'CasADi/ctypes':>15}"
    print(header)
    loaded = {}
    for model, name in KERNELS:
        if model not in loaded:
            loaded[model] = (
                kernel_cache.load_kernels(model, "c"),
                kernel_cache.load_kernels(model, "casadi"),
            )
        c_kernels, ca_kernels = loaded[model]
        manifest = json.loads((c_kernels.folder / "manifest.json").read_text())
        entry = next(k for k in manifest["kernels"] if k["name"] == name)
        inputs = [np.array(i["sample"]) for i in entry["inputs"]]
        c_ns = c_harness_ns(c_kernels.folder, entry, manifest["c_name"])
        py_ns = python_ns(c_kernels[name], inputs, 20_000)
        ca_ns = python_ns(ca_kernels[name], inputs, 2_000)
        costs = f"{c_ns:>10.1f}{py_ns:>10.0f}{ca_ns:>11.0f}"
        print(f"{model + '.' + name:<34}{costs}{py_ns / c_ns:>10.0f}{ca_ns / py_ns:>15.1f}")


def main() -> int:
    print(f"python {sys.version.split()[0]}, {os.cpu_count()} CPUs")
    generation_table()
    call_table()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""``svbi export MODEL DIR --solver``: the C time loop plus one scenario baked into C, no Python.

The scenario is assembled exactly as the C backend does for ``svbi run`` (the same
:class:`~svbi.runtime.backends.c.stepper.CStepper`), and every number the loop receives is written into a
generated ``scenario_data.c`` with ``repr`` (which reads back to the same bits): the setup, the
initial state, the excitation tables, the output buffers (with the initial row 0) and a static
workspace of the size the loop asks for. The loop's own files are those the C backend compiles: the
static C of ``runtime/csrc/`` and the generated glue of the model (``c_solver_build.render_sources``).
``main.c`` runs it and writes a CSV; the Makefile builds it with the kernels' warning policy
(``-std=c99 -Wall -Wextra -Werror``).
"""

from __future__ import annotations

import ctypes
import math
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from ...codegen import loop_abi
from ...examples import paper_section_keys
from ..backends.c import build as c_solver_build
from ..backends.c.stepper import CStepper
from ..methods.initial import initial_state
from ..scenario.schema import validate_scenario
from .results import Recorder
from .simulate import DivergenceGuard, build_model

GENERATOR = "svbi.runtime.run.export"
PER_LINE = 4
PROGRAM = "svbi_solver_example"
OUTPUT_NAMES = loop_abi.OUTPUT_NAMES


def example_scenario(vehicle: str) -> dict[str, Any]:
    """The built-in scenario of the exported example: two cars over two spans, quake and irregularity."""
    # deferred: brings SymPy and Jinja2 (about 0.5 s), for derivation and emission only
    from ...codegen.topology import load_topology

    moving = load_topology(vehicle).kind == "moving-load"
    return {
        "title": f"svbi export example: 2 cars of {vehicle} over 2 spans, synthetic quake, German-low track",
        "bridge": dict(
            spans=2,
            span_length=32.0,
            **paper_section_keys(),
            elements_per_span=8,
        ),
        "train": dict(vehicle=vehicle, cars=2, speed_kmh=300.0),
        "track": dict(irregularity="german-low", seed=3),
        "earthquake": dict(vertical="synthetic", longitudinal="synthetic", arrival=0.1),
        "solver": dict(
            method="localized-dynamic",
            backend="c",
            time_step=1e-3,
            duration=0.5 if moving else 0.6,
            output_every=5,
        ),
    }


def _double(value: float) -> str:
    if math.isnan(value):
        return "(0.0 / 0.0)"
    if math.isinf(value):
        return "(1.0 / 0.0)" if value > 0 else "(-1.0 / 0.0)"
    return repr(float(value))


def _lines(values: list[str]) -> list[str]:
    return [", ".join(values[i : i + PER_LINE]) + "," for i in range(0, len(values), PER_LINE)] or ["0"]


class _Baker:
    """Names every array a struct points at and renders it as a C initializer."""

    def __init__(self, known: dict[int, np.ndarray]) -> None:
        self.known = known
        self.arrays: list[dict[str, Any]] = []
        self.names: dict[int, str] = {}

    def array(self, address: int | None, name: str, const: bool = True) -> str:
        if not address:
            return "0"
        if address in self.names:
            return self.names[address]
        if address not in self.known:
            raise ValueError(f"cannot export {name}: the loop reads an array the exporter does not know")
        a = self.known[address]
        integer = a.dtype.kind in "iub"
        values = [str(int(v)) for v in a.reshape(-1)] if integer else [_double(v) for v in a.reshape(-1)]
        self.arrays.append(
            {
                "name": name,
                "ctype": ("unsigned char" if a.itemsize == 1 else "int") if integer else "double",
                "const": const,
                "values": values,
                "lines": _lines(values),
            }
        )
        self.names[address] = name
        return name

    def ppoly(self, p: Any, name: str) -> str:
        fields = []
        for f in loop_abi.PPOLY_FIELDS:
            value = getattr(p, f.name)
            if f.kind == "double*":
                fields.append(self.array(value, f"{name}_{f.name}"))
            elif f.kind == "double":
                fields.append(_double(value))
            else:
                fields.append(str(int(value)))
        return ", ".join(fields)


def scenario_files(
    model_name: str, scenario: Any, extra: dict[str, bytes] | None = None, embedded: bool = False
) -> tuple[dict[str, bytes], Any]:
    """``{file name: bytes}`` of the exported solver for ``scenario`` (plus ``extra`` files, which the
    Makefile builds too), and the validated scenario."""
    if isinstance(scenario, dict):
        scenario = validate_scenario(scenario)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        model = build_model(scenario)
    state = initial_state(model, scenario.train.initial)
    stepper = CStepper(model, state, model.settings.method)
    if stepper.excitation.streamed:
        raise ValueError(
            f"cannot export this scenario: its excitations ({stepper.excitation.describe}) are "
            "evaluated by Python while the loop runs"
        )
    # localized-dynamic keeps the whole active set in C (lift-offs, flights, landings and their
    # impact): the standalone loop runs unilateral contact as svbi run does. The coupled methods hand
    # contact events to NumPy, which the standalone loop does not have: they run the bilateral step
    # (docs/c-backend.md, "Export")
    unilateral = bool(stepper.setup.unilateral)
    if not unilateral:
        stepper.cstate.in_contact = None
    spec = stepper.library.spec
    recorder = Recorder(model)
    recorder.force(0, state.P, state.contact_state)
    recorder.record(state, model.contacts(0.0), model.settings.method == "coupled-classic")
    stepper.setup.force_limit = float(DivergenceGuard(model).force_limit)

    known: dict[int, np.ndarray] = {}
    for a in [*stepper.keep, *stepper.excitation.keep]:
        if isinstance(a, np.ndarray):
            known[a.ctypes.data] = a
    for key in ("uV", "vV", "aV", "uB", "vB", "aB", "ug", "vg", "ag", "P", "PV", "creepage", "creep_force"):
        a = getattr(state, key)
        known[a.ctypes.data] = a
    if unilateral:
        a = stepper.reference.act.in_contact
        known[a.ctypes.data] = a
    for a in stepper.lam.values():
        known[a.ctypes.data] = a
    baker = _Baker(known)

    setup = []
    for f in loop_abi.SETUP_FIELDS:
        value = getattr(stepper.setup, f.name)
        if f.kind in ("int*", "double*"):
            setup.append({"name": f.name, "value": baker.array(value, f"setup_{f.name}")})
        elif f.kind == "double":
            setup.append({"name": f.name, "value": _double(value)})
        else:
            setup.append({"name": f.name, "value": str(int(value)) + ("L" if f.kind == "long" else "")})
    st = []
    for f in loop_abi.STATE_FIELDS:
        value = getattr(stepper.cstate, f.name)
        if f.kind == "double":
            st.append({"name": f.name, "value": _double(value)})
        else:
            st.append({"name": f.name, "value": baker.array(value, f"state_{f.name}", const=False)})
    exc = []
    ppolys = []
    e = stepper.excitation.struct
    for f in loop_abi.EXCITATION_FIELDS:
        value = getattr(e, f.name)
        if f.kind == "ppoly":
            ppolys.append(
                {"name": f"exc_{f.name}", "count": 1, "items": [baker.ppoly(value, f"exc_{f.name}")]}
            )
            exc.append({"name": f.name, "value": f"exc_{f.name}[0]"})
        elif f.kind == "ppoly*":
            if value:
                count = model.bridge.spans + 1
                items = (c_solver_build.PPoly * count).from_address(value)
                ppolys.append(
                    {
                        "name": f"exc_{f.name}",
                        "count": count,
                        "items": [baker.ppoly(p, f"exc_{f.name}_{k}") for k, p in enumerate(items)],
                    }
                )
                exc.append({"name": f.name, "value": f"exc_{f.name}"})
            else:
                exc.append({"name": f.name, "value": "0"})
        elif f.kind in ("int*", "double*"):
            exc.append({"name": f.name, "value": baker.array(value, f"exc_{f.name}")})
        elif f.kind == "double":
            exc.append({"name": f.name, "value": _double(value)})
        else:
            exc.append({"name": f.name, "value": str(int(value)) + ("L" if f.kind == "long" else "")})

    outputs = []
    for name in OUTPUT_NAMES:
        a = recorder.data.get(name, np.zeros((1, 0)))  # pier_top_ux: a bridge with piers only
        if a.size == 0:  # vehicle_u / vehicle_a of moving loads: ISO C has no zero-length arrays
            outputs.append({"name": name, "size": 1, "row0": np.zeros(1)})
            continue
        outputs.append({"name": name, "size": a.size, "row0": a.reshape(a.shape[0], -1)[0]})
    outputs.append({"name": "forces", "size": recorder.forces.size, "row0": recorder.forces[0]})
    if unilateral:  # the wheels' states (one byte each) and uplifts
        for name in ("contact_state", "wheel_uplift"):
            a = recorder.data[name]
            outputs.append({"name": name, "size": a.size, "row0": a[0]})
        steps = recorder.in_contact
        outputs.append({"name": "contact_steps", "size": steps.size, "row0": steps[0]})
    for o in outputs:  # the initial row 0, as svbi.simulate records it before the loop
        byte = o["row0"].dtype.itemsize == 1
        o["ctype"] = "unsigned char" if byte else "double"
        row0 = o["row0"].reshape(-1)
        o["init"] = _lines([str(int(v)) for v in row0] if byte else [_double(v) for v in row0])

    n_double, n_int = ctypes.c_long(), ctypes.c_long()
    stepper.library.workspace(ctypes.byref(stepper.setup), ctypes.byref(n_double), ctypes.byref(n_int))
    s = model.settings
    c = spec.c_name
    header = "solver.h"
    context = {
        "generator": GENERATOR,
        "model": spec.model,
        "c": c,
        "M": c.upper(),
        "title": scenario.title or "(untitled)",
        "header": header,
        "scenario_header": "scenario_data.h",
        "steps": s.steps,
        "dt": repr(s.time_step),
        "nout": recorder.nout,
        "cars": model.train.cars,
        "nw": model.train.wheels,
        "spans": model.bridge.spans,
        "n_double": int(n_double.value),
        "n_int": int(n_int.value),
        "arrays": baker.arrays,
        "ppolys": ppolys,
        "outputs": outputs,
        "setup": setup,
        "state": st,
        "excitation": exc,
    }
    if spec.model != model_name and Path(spec.model).name != model_name:
        raise ValueError(f"the scenario's vehicle is {spec.model!r}, not the exported model {model_name!r}")
    # deferred: brings SymPy and Jinja2 (about 0.5 s), for derivation and emission only
    from ...codegen.loop_glue import environment

    env = environment()
    files = {**(extra or {}), **c_solver_build.render_sources(spec, embedded=embedded)}
    for template, name in (
        ("solver/scenario_data.c.j2", "scenario_data.c"),
        ("solver/scenario.h.j2", "scenario_data.h"),
        ("solver/main.c.j2", "main.c"),
    ):
        files[name] = env.get_template(template).render({**context, "template": template}).encode()
    casadi = sorted(n for n in files if n.endswith("_kernels.c"))
    strict = sorted(n for n in files if n.endswith(".c") and n not in casadi)
    files["Makefile"] = (
        env.get_template("solver/Makefile.j2")
        .render(
            {
                "generator": GENERATOR,
                "template": "solver/Makefile.j2",
                "model": spec.model,
                "program": PROGRAM,
                "casadi_objects": [n.replace(".c", ".o") for n in casadi],
                "strict_objects": [n.replace(".c", ".o") for n in strict],
                "objects": [n.replace(".c", ".o") for n in casadi + strict],
                "headers": sorted(n for n in files if n.endswith(".h")),
            }
        )
        .encode()
    )
    return files, scenario


def write_solver(
    model_name: str,
    folder: str | Path,
    scenario: Any = None,
    extra: dict[str, bytes] | None = None,
    embedded: bool = False,
) -> tuple[Path, dict[str, bytes]]:
    """Write the solver example of ``model_name`` (built-in scenario unless ``scenario`` is given)."""
    # deferred: brings SymPy and Jinja2 (about 0.5 s), for derivation and emission only
    from ...codegen.c_emit import write_files

    files, _ = scenario_files(model_name, scenario or example_scenario(model_name), extra, embedded)
    return write_files(files, folder, prune=False), files

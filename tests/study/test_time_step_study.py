"""The shipped study of a 3D run's time step (examples/time-step-3d.toml, docs/three-d.md, "Checking
the time step"): its runs are the 3D example at its own step and at half of it, stored at the same
instants, so that their indices compare sample for sample."""

from __future__ import annotations

from pathlib import Path

import pytest

from svbi.runtime.scenario.schema import load_scenario
from svbi.runtime.study.sweep import load_study

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def test_the_time_step_study_halves_the_example_step_at_the_same_output_instants() -> None:
    study = load_study(EXAMPLES / "time-step-3d.toml")
    assert study.scenario_path.resolve() == (EXAMPLES / "paper-2020-3d.toml").resolve()
    steps = study.spec.zip["solver.time_step"]
    every = study.spec.zip["solver.output_every"]
    base = load_scenario(study.scenario_path)
    assert base.dimensions == 3
    # the example's own step first, then half of it
    assert steps[0] == base.solver.time_step and steps[1] == pytest.approx(steps[0] / 2, rel=1e-15)
    # the same output interval in every run: the instants coincide
    interval = {round(dt * n, 15) for dt, n in zip(steps, every, strict=True)}
    assert interval == {round(base.solver.time_step * base.solver.output_every, 15)}

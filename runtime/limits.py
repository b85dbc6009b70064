"""Early sanity limits of a scenario: sizes and magnitudes that no sensible run reaches.

They are checked with the scenario (``svbi.runtime.scenario``), before anything is built, so that a
typing slip (``time_step = 1e-9``, ``speed_kmh = 1e30``) ends in one line naming the key instead of
a ``MemoryError``, a hang or a ``nan`` minutes later. Each limit is far beyond the paper's case and
the largest documented runs (README: 100 cars on 1000 spans); ``docs/scenario.md`` lists them. They
are not a memory estimate: a run within every limit can still be too large for the machine.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from svbi.runtime.scenario import Scenario

MAX_STEPS = 20_000_000
"""Time steps of one run: 2000 s of simulated time at 1e-4 s (the paper's run has 71,460). The
loop keeps the contact forces of every step for the force filter, so memory grows with steps."""

MAX_ELEMENTS = 100_000
"""Bridge frame elements, ``bridge.spans * bridge.elements_per_span``: 200 km of 32 m spans at the
default 16 elements per span (the longest bridge built is 164 km)."""

MAX_IRREGULARITY_POINTS = 5_000_000
"""Points of the rail-irregularity table: one every ``track.wavelength_min / 50`` over the track the
train covers. 32 km at the default 0.5 m make 3.2 million; each point sums about
``length / wavelength_min`` frequencies, so the table's cost grows with the square of the ratio."""

MAX_SPEED = 500.0
"""Train speed (m/s, 1800 km/h): three times the rail speed record (160 m/s); a larger value is a
unit slip, and it would carry the train across kilometres of table per time step."""

MAX_PGA = 50.0 * 9.81
"""Peak ground acceleration (m/s², 50 g): more than ten times the largest ever recorded (about 4 g)."""


def _train_length(s: Scenario, values: Mapping[str, Any]) -> float:
    """Upper bound of the train length (m): ``cars * car_length`` (a car's axles lie within it)."""
    return s.train.cars * float(values.get("car_length", 0.0) or 0.0)


def size_problems(s: Scenario, values: Mapping[str, Any]) -> Iterable[tuple[str, str]]:
    """(key, message) for every limit the scenario ``s`` exceeds; ``values`` are its vehicle
    parameters (for the car length of the default duration)."""
    b, sol, trk, t = s.bridge, s.solver, s.track, s.train
    speed = t.speed_ms
    speed_key = "train.speed" if t.speed is not None else "train.speed_kmh"
    if speed > MAX_SPEED:
        yield (
            speed_key,
            f"{speed:.3g} m/s ({speed * 3.6:.3g} km/h) is above the limit of {MAX_SPEED:g} m/s "
            f"({MAX_SPEED * 3.6:g} km/h), beyond any rail vehicle: a unit slip?",
        )
        return  # the sizes below all scale with the speed
    elements = b.spans * b.elements_per_span
    if elements > MAX_ELEMENTS:
        yield (
            "bridge.spans",
            f"{b.spans} spans x {b.elements_per_span} elements (bridge.elements_per_span) = {elements:,} "
            f"frame elements, above the limit of {MAX_ELEMENTS:,} (200 km of 32 m spans)",
        )
    if sol.duration is not None:
        duration, duration_from = sol.duration, "solver.duration"
    else:
        way = b.spans * b.span_length + _train_length(s, values) - t.start_position
        duration, duration_from = max(way, 0.0) / speed, "the crossing time; solver.duration is unset"
    steps = duration / sol.time_step
    if not math.isfinite(steps) or steps > MAX_STEPS:
        key = "solver.duration" if sol.duration is not None and sol.duration > 1.0 else "solver.time_step"
        yield (
            key,
            f"{duration:.4g} s ({duration_from}) at solver.time_step = {sol.time_step:g} s is "
            f"{steps:.3g} steps, above the limit of {MAX_STEPS:.0e} ({MAX_STEPS:,}) steps of one run",
        )
    if trk.irregularity != "none":
        covered = max(speed * duration, 1.0)
        points = covered / (trk.wavelength_min / 50.0)
        if points > MAX_IRREGULARITY_POINTS:
            yield (
                "track.wavelength_min",
                f"{trk.wavelength_min:g} m over the {covered:.4g} m the train covers ({speed_key} x "
                f"{duration_from}) needs an irregularity table of {points:.3g} points (one every "
                f"wavelength_min / 50), above the limit of {MAX_IRREGULARITY_POINTS:,}: raise "
                "track.wavelength_min or shorten the run",
            )
    # the span's stiffness-to-mass ratios set its frequencies: they must be finite numbers
    for stiffness, name in ((b.youngs_modulus * b.area, "E A"), (b.youngs_modulus * b.second_moment, "E I")):
        ratio = stiffness / b.mass_per_length
        if not (math.isfinite(ratio) and ratio > 0 and math.isfinite(ratio * b.span_length**2)):
            yield (
                "bridge.mass_per_length",
                f"{name} / mass_per_length = {stiffness:.3g} / {b.mass_per_length:.3g} is not a finite "
                "positive number (bridge.youngs_modulus, area, second_moment, mass_per_length)",
            )
            break
    eq = s.earthquake
    if eq is not None and eq.target_pga is not None and eq.target_pga > MAX_PGA:
        yield (
            "earthquake.target_pga",
            f"{eq.target_pga:.3g} m/s² is above the limit of {MAX_PGA:g} m/s² (50 g); it is in m/s², not g",
        )

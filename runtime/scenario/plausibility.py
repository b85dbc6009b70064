"""Plausibility of a scenario: values outside the range of real railway bridges, trains and records.

A value outside its band is not an error (a study may explore it on purpose) but is most often a
unit slip: a span in millimetres, a modulus in GPa, a profile in millimetres, a braking rate in g.
Each is one warning naming the key, the value, the band and the likely slip::

    bridge.span_length = 32000 m is outside 2 … 300 m for railway spans; millimetres?

:data:`BANDS` is the one table of bands (``docs/scenario.md`` prints it); ``svbi run`` and the
other commands print the warnings once and go on. The hard limits, beyond which a run is refused,
are :mod:`svbi.runtime.scenario.limits`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ..excitation.irregularity import read_profile_cached
from ..excitation.records import RecordError, read_record

if TYPE_CHECKING:
    from .schema import Scenario


@dataclass(frozen=True)
class Band:
    """The range of a quantity in real railway bridges and trains, and the slip each side hints at."""

    low: float
    high: float
    unit: str
    what: str
    """What the band is of ("railway spans")."""
    below: str
    """The likely slip of a value under ``low`` ("kilometres?")."""
    above: str
    """The likely slip of a value over ``high`` ("millimetres?")."""


BANDS: dict[str, Band] = {
    "span": Band(2.0, 300.0, "m", "railway spans", "kilometres?", "millimetres?"),
    "pier_height": Band(0.5, 200.0, "m", "railway bridge piers", "kilometres?", "millimetres?"),
    "mass_per_length": Band(
        500.0, 500.0e3, "kg/m", "railway decks and piers", "tonnes per metre?", "grams per metre?"
    ),
    "youngs_modulus": Band(1.0e9, 4.0e11, "Pa", "steel, concrete and timber", "MPa or GPa?", "not Pa?"),
    "area": Band(1.0e-3, 200.0, "m²", "deck and pier sections", "square metres? (check)", "cm² or mm²?"),
    "second_moment": Band(1.0e-5, 2.0e3, "m⁴", "deck and pier sections", "m⁴? (check)", "cm⁴ or mm⁴?"),
    "damping_ratio": Band(0.0, 0.2, "", "structural damping", "", "a percentage? 0.02 is 2 %"),
    "rail_height": Band(-10.0, 10.0, "m", "rail heads above a girder's axis", "millimetres?", "millimetres?"),
    "bearing_stiffness": Band(1.0e5, 1.0e13, "N/m", "bridge bearings", "kN/m or MN/m?", "N/mm?"),
    "speed": Band(0.0, 160.0, "m/s", "rail vehicles (record 160 m/s)", "", "km/h given as m/s?"),
    "speed_kmh": Band(0.0, 575.0, "km/h", "rail vehicles (record 574.8 km/h)", "", "m/h?"),
    "acceleration": Band(-5.0, 5.0, "m/s²", "trains braking or accelerating", "g? (1 g = 9.81 m/s²)", "g?"),
    "profile": Band(0.0, 0.05, "m", "rail irregularity amplitudes", "", "millimetres?"),
    "record_dt": Band(1.0e-4, 0.1, "s", "the time step of ground-motion records", "", "milliseconds?"),
    "target_pga": Band(0.01, 30.0, "m/s²", "recorded ground motions (about 3 g at most)", "g?", "cm/s²?"),
    # 3D scenarios (docs/three-d.md)
    "lateral_second_moment": Band(
        1.0e-5, 2.0e3, "m⁴", "deck and pier sections", "m⁴? (check)", "cm⁴ or mm⁴?"
    ),
    "torsion_constant": Band(1.0e-6, 2.0e3, "m⁴", "deck and pier sections", "m⁴? (check)", "cm⁴ or mm⁴?"),
    "poisson_ratio": Band(0.1, 0.35, "", "concrete, steel and timber", "", ""),
    "shear_modulus": Band(3.0e8, 1.0e11, "Pa", "steel, concrete and timber", "MPa or GPa?", "not Pa?"),
    "torsional_mass_per_length": Band(
        1.0, 5.0e7, "kg m", "decks and piers (mass per length x radius of gyration²)", "", "kg mm?"
    ),
    "track_eccentricity": Band(-10.0, 10.0, "m", "tracks on a deck", "millimetres?", "millimetres?"),
    "conicity": Band(0.01, 0.6, "", "equivalent conicities of wheel profiles", "", "an angle in degrees?"),
    "flange_clearance": Band(
        0.001, 0.02, "m", "wheelsets in track (about 5 … 10 mm a side)", "", "millimetres?"
    ),
}
"""The bands, by kind of quantity (the keys that use each are in :func:`plausibility_warnings`)."""


def _format(value: float) -> str:
    return f"{value:.6g}"


def _check(key: str, value: float, band: Band) -> Iterator[str]:
    if band.low <= value <= band.high or not math.isfinite(value):
        return
    unit = f" {band.unit}" if band.unit else ""
    hint = band.below if value < band.low else band.above
    line = (
        f"{key} = {_format(value)}{unit} is outside {_format(band.low)} … {_format(band.high)}{unit} "
        f"for {band.what}"
    )
    yield f"{line}; {hint}" if hint else line


def _keyed(key: str, value: float | None, band: str) -> Iterator[tuple[str, str]]:
    """(key, message) when ``value`` (None: not given) is outside ``BANDS[band]``."""
    if value is not None:
        yield from ((key, m) for m in _check(key, float(value), BANDS[band]))


SECTION_BANDS = {
    "mass_per_length": "mass_per_length",
    "youngs_modulus": "youngs_modulus",
    "area": "area",
    "second_moment": "second_moment",
    "damping_ratio": "damping_ratio",
    "lateral_second_moment": "lateral_second_moment",
    "torsion_constant": "torsion_constant",
    "poisson_ratio": "poisson_ratio",
    "shear_modulus": "shear_modulus",
    "torsional_mass_per_length": "torsional_mass_per_length",
}
"""The band of each section key of ``[bridge]``, a girder and a pier."""


def _section(prefix: str, obj: object) -> Iterator[tuple[str, str]]:
    for name, band in SECTION_BANDS.items():
        yield from _keyed(f"{prefix}.{name}", getattr(obj, name, None), band)


def plausibility_warnings(s: Scenario) -> list[tuple[str, str]]:
    """(key, message) for every value of ``s`` outside :data:`BANDS`: the key, so that the message
    can name where it was written (file line or ``--set``)."""
    return list(_warnings(s))


def _warnings(s: Scenario) -> Iterable[tuple[str, str]]:
    b, t = s.bridge, s.train
    yield from _section("bridge", b)
    if b.girders is None:
        yield from _keyed("bridge.span_length", b.span_length, "span")
    for i, g in enumerate(b.girders or []):
        for j, length in enumerate(g.spans):
            yield from _keyed(f"bridge.girders[{i}].spans[{j}]", length, "span")
        yield from _section(f"bridge.girders[{i}]", g)
    for i, p in enumerate(b.piers or []):
        key = f"bridge.piers[{i}]"
        yield from _keyed(f"{key}.height", p.height, "pier_height")
        yield from _section(key, p)
        for name in (
            "bearing_stiffness_vertical",
            "bearing_stiffness_longitudinal",
            "bearing_stiffness_lateral",
        ):
            yield from _keyed(f"{key}.{name}", getattr(p, name), "bearing_stiffness")
    yield from _keyed("bridge.rail_height", b.rail_height, "rail_height")
    yield from _keyed("bridge.track_eccentricity", b.track_eccentricity, "track_eccentricity")
    yield from _keyed("contact.conicity", s.contact.conicity, "conicity")
    yield from _keyed("contact.flange_clearance", s.contact.flange_clearance, "flange_clearance")
    yield from _keyed("train.speed", t.speed, "speed")
    yield from _keyed("train.speed_kmh", t.speed_kmh, "speed_kmh")
    yield from _keyed("train.acceleration", t.acceleration, "acceleration")
    if s.track.is_profile:
        yield from _profile(s)
    if s.earthquake is not None:
        yield from _earthquake(s)


def _profile(s: Scenario) -> Iterable[tuple[str, str]]:
    try:
        _, rs = read_profile_cached(s.resolve_path(s.track.irregularity))
    except (OSError, ValueError):
        return  # reported by the scenario's own check of the file
    peak = float(max(abs(float(r)) for r in rs)) if len(rs) else 0.0
    band = BANDS["profile"]
    if peak > band.high:
        yield (
            "track.irregularity",
            f"track.irregularity = {s.track.irregularity!r}: the profile reaches |r| = {_format(peak)} m, "
            f"outside {_format(band.low)} … {_format(band.high)} m for {band.what}; {band.above}",
        )


def _earthquake(s: Scenario) -> Iterable[tuple[str, str]]:
    eq = s.earthquake
    assert eq is not None
    yield from _keyed("earthquake.record_dt", eq.record_dt, "record_dt")
    yield from _keyed("earthquake.target_pga", eq.target_pga, "target_pga")
    if eq.record_dt is not None:
        return  # a record's own DT must agree with record_dt (checked when it is read)
    seen: set[str] = set()
    band = BANDS["record_dt"]
    for comp in eq.components:
        names = eq.sources(comp)
        for k, name in enumerate(names):
            if name in ("none", "synthetic") or name in seen:
                continue
            seen.add(name)
            key = f"earthquake.{comp}[{k}]" if isinstance(getattr(eq, comp), list) else f"earthquake.{comp}"
            try:
                record = read_record(s.resolve_path(name), dt=eq.record_dt)
            except (OSError, RecordError, ValueError):
                continue  # reported when the run reads it
            if not band.low <= record.dt <= band.high:
                yield (
                    key,
                    f"{key} = {name!r}: the record's time step DT = {_format(record.dt)} s is outside "
                    f"{_format(band.low)} … {_format(band.high)} s for {band.what}; {band.above}",
                )

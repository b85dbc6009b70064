"""Excitations: track irregularity, earthquake records, their processing, and support motion.

The runtime calls:

* :func:`make_irregularity` (or the classes in :mod:`.irregularity`) → ``evaluate(x)``;
* :func:`ground_motion` → :class:`GroundMotion` with ``motion(component, t, x)``;
* :func:`read_record`, :func:`process_record` and :func:`synthetic_motion` for single records.

Conventions and choices are documented in ``docs/excitations.md``.
"""

from .ground import COMPONENTS, ComponentMotion, GroundMotion, ground_motion
from .irregularity import (
    GermanSpectrum,
    Irregularity,
    NoIrregularity,
    OnsetRamp,
    SampledIrregularity,
    SpectralIrregularity,
    horner,
    make_irregularity,
    read_profile,
)
from .processing import MotionHistory, Processing, integrate, process_record
from .records import G, Record, RecordError, read_record
from .synthetic import HORIZONTAL, VERTICAL, StochasticModel, synthetic_motion, synthetic_record

__all__ = [
    "COMPONENTS",
    "G",
    "HORIZONTAL",
    "VERTICAL",
    "ComponentMotion",
    "GermanSpectrum",
    "GroundMotion",
    "Irregularity",
    "MotionHistory",
    "NoIrregularity",
    "OnsetRamp",
    "Processing",
    "Record",
    "RecordError",
    "SampledIrregularity",
    "SpectralIrregularity",
    "StochasticModel",
    "ground_motion",
    "horner",
    "integrate",
    "make_irregularity",
    "process_record",
    "read_profile",
    "read_record",
    "synthetic_motion",
    "synthetic_record",
]

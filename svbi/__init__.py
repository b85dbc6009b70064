"""svbi: seismic vehicle-bridge interaction with localized dynamic Lagrange multipliers.

Implements Stoura, Paraskevopoulos & Dimitrakopoulos (17WCEE 2020). The symbolic pipeline lives in
``svbi.codegen``; the time integration, scenario files and CLI in ``svbi.runtime``.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the runtime imports are deferred so that `import svbi` stays light
    import xarray as xr

    from svbi.runtime.scenario.schema import Scenario

__version__ = "0.1.0"
"""The one place the version is written: pyproject.toml reads it from here. A literal, not
``importlib.metadata.version``, whose import and lookup cost every ``svbi`` command about 0.03 s."""

__all__ = ["__version__", "load_scenario", "simulate"]


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario TOML file (see ``svbi.runtime.scenario.schema.load_scenario``)."""
    from svbi.runtime.scenario.schema import load_scenario as _load

    return _load(path)


def simulate(scenario: Scenario | str | Path, **kwargs: Any) -> xr.Dataset:
    """Run a scenario and return the results as an ``xarray.Dataset`` (``svbi.runtime.run.simulate``)."""
    from svbi.runtime.run.simulate import simulate as _simulate

    return _simulate(scenario, **kwargs)

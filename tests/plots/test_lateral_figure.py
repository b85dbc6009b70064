"""The lateral figure of a 3D run (``plots/lateral.py``): drawn for results that carry the 3D
variables and only for them, with the wheel and wheelset of the run's peaks and the limits at their
values (Nadal 1.34, EN 14363 0.8, ± Prud'homme's limit of that wheelset's own static load)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from cases import histories3d

from svbi.runtime.plots.lateral import LATERAL, is_3d, lateral_figure
from svbi.runtime.run.results3d import dataset3d


def run3d():
    steps = 300
    t = np.arange(steps) * 1e-3
    flange = np.zeros((steps, 1, 2, 2))
    flange[:, 0, 1, 0] = 20e3 * np.exp(-(((t - 0.15) / 0.01) ** 2))
    load = np.full((1, 2, 2), 50e3 * math.cos(0.05))
    load[0, 1] = 40e3  # wheelset 2 carries less: its Prud'homme limit is its own
    return dataset3d(
        histories3d(
            normal=50e3,
            angle=0.05,
            steps=steps,
            cars=1,
            axles=2,
            flange_force=flange,
            flange_contact=flange > 1.0,
            static_wheel_load=load,
        )
    )


def lines_of(ax):
    return {line.get_label(): line for line in ax.get_lines()}


def test_lateral_figure_draws_the_peaks_against_their_limits():
    ds = run3d()
    assert is_3d(ds)
    fig = lateral_figure(ds, "a 3D run")
    axes = fig.axes
    assert len(axes) == 5  # four panels, the last with a twin axis for the twist
    quotient = lines_of(axes[0])
    assert "Y/Q (car 1, wheelset 2, left)" in quotient
    np.testing.assert_array_equal(quotient["Nadal 1.34"].get_ydata(), [1.34, 1.34])
    np.testing.assert_array_equal(quotient["EN 14363 (Y/Q)_2m 0.8"].get_ydata(), [0.8, 0.8])
    shift = lines_of(axes[1])
    limit = 10 + 2 * 40e3 / 3e3  # kN: α = 1, P0 = 2 x 40 kN
    label = next(k for k in shift if k.startswith("Prud'homme"))
    assert label == f"Prud'homme 1 (10 + P0/3) = {limit:.4g} kN"
    bounds = sorted(
        float(line.get_ydata()[0]) for line in axes[1].get_lines() if line.get_linestyle() == "--"
    )
    assert bounds == pytest.approx([-limit, limit], rel=1e-12)
    assert "sum Y, filtered (car 1, wheelset 2)" in shift


def test_make_figures_adds_it_for_3d_results_only(tmp_path):
    from svbi.runtime.plots.results import FIGURE_NAMES, make_figures, save_figures

    assert LATERAL not in FIGURE_NAMES  # a 2D run's figures are unchanged
    figures = make_figures({"3d": run3d()})
    assert list(figures) == [*FIGURE_NAMES, LATERAL]
    (path,) = save_figures({LATERAL: figures[LATERAL]}, tmp_path)
    assert path.name == f"{LATERAL}.png" and path.stat().st_size > 10_000

"""`svbi plot` / `svbi compare` and the figures and summary of runtime/plots/results.py.

Results files here are synthetic but follow the docs/design.md section 7 contract exactly; the
summary is checked against peaks computed in the test straight from the arrays that went into the file.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import typer
import xarray as xr
from PIL import Image
from typer.testing import CliRunner

from svbi.runtime.cli import plot as cli_plot
from svbi.runtime.plots import results as plots

runner = CliRunner()
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
SCENARIO = 'title = "{title}"\n[solver]\nmethod = "{method}"\n[output]\nforce_filter_hz = 20.0\n'


def make_app() -> typer.Typer:
    app = typer.Typer(add_completion=False)
    cli_plot.register(app)
    return app


def make_results(
    method: str,
    *,
    backend: str = "numpy",
    steps: int = 600,
    time_step: float = 1e-3,
    output_every: int = 5,
    cars: int = 3,
    wheels: int = 4,
    spans: int = 2,
    supports: int = 4,
    drift: float = 0.0,
    gap_scale: float = 1e-15,
    wall_time_s: float = 1.0,
    title: str = "synthetic crossing",
    complete: int | None = None,
    seed: int = 0,
) -> xr.Dataset:
    """A results Dataset with every variable, dim and attribute of docs/design.md section 7.

    The bridge response is the same for every method (as in the paper), the car body drifts by
    `drift` m/s² · t², and the gaps are noise of size `gap_scale`, so that methods differ as in Fig. 4.
    """
    rng = np.random.default_rng(seed)
    t = np.arange(steps // output_every + 1) * time_step * output_every
    n = t.size
    span_phase = np.arange(spans)[None, :]
    midspan_uz = -2e-3 * np.sin(np.pi * np.clip(t[:, None] / t[-1] - 0.1 * span_phase, 0, 1)) ** 2
    midspan_uz = midspan_uz + 2e-4 * np.sin(2 * np.pi * 6.0 * t)[:, None]
    midspan_ux = 1e-5 * np.sin(2 * np.pi * 3.0 * t)[:, None] * (1 + span_phase)
    static = 140e3
    dyn = 15e3 * np.sin(2 * np.pi * 4.0 * t)[:, None, None] * (1 + 0.1 * np.arange(cars))[None, :, None]
    spikes = np.zeros((n, cars, wheels))
    spikes[n // 2, :, :] = 60e3  # a slope kink: the raw force peak that filtering removes
    jitter = 3e3 * rng.standard_normal((n, cars, wheels))
    contact_force = static + dyn + spikes + jitter + drift * 5e4 * t[:, None, None] ** 2
    kernel = np.ones(7) / 7.0
    padded = np.pad(contact_force, ((3, 3), (0, 0), (0, 0)), mode="edge")
    filtered = np.apply_along_axis(lambda x: np.convolve(x, kernel, mode="valid"), 0, padded)
    carbody_uz = -3e-3 * np.sin(2 * np.pi * 1.1 * t)[:, None] * np.ones(cars) + drift * t[:, None] ** 2
    carbody_az = -(3e-3 * (2 * np.pi * 1.1) ** 2) * np.sin(2 * np.pi * 1.1 * t)[:, None] * np.ones(cars)
    carbody_az = carbody_az + 2 * drift + 0.05 * rng.standard_normal((n, cars))
    gap_vehicle = gap_scale * rng.standard_normal((n, cars, wheels)) * (1 + 1e6 * drift * t[:, None, None])
    gap_bridge = gap_scale * rng.standard_normal((n, cars, wheels))
    gap_support = gap_scale * rng.standard_normal((n, supports))
    gap_vehicle[0] = gap_bridge[0] = gap_support[0] = 0.0  # static start: exact zeros at t = 0
    ground = 1e-3 * np.sin(2 * np.pi * 2.0 * t)
    twc, tc = ("time", "car", "wheel"), ("time", "car")
    ds = xr.Dataset(
        {
            "midspan_uz": (("time", "span"), midspan_uz),
            "midspan_ux": (("time", "span"), midspan_ux),
            "ground_uz": ("time", ground),
            "ground_ux": ("time", 0.1 * ground),
            "contact_force": (twc, contact_force),
            "contact_force_filtered": (twc, filtered),
            "creep_force": (twc, 1e3 * rng.standard_normal((n, cars, wheels))),
            "carbody_uz": (tc, carbody_uz),
            "carbody_az": (tc, carbody_az),
            "carbody_pitch": (tc, 1e-4 * rng.standard_normal((n, cars))),
            "gap_vehicle": (twc, gap_vehicle),
            "gap_bridge": (twc, gap_bridge),
            "gap_support": (("time", "support"), gap_support),
        },
        coords={
            "time": t,
            "car": np.arange(1, cars + 1),
            "wheel": np.arange(1, wheels + 1),
            "span": np.arange(1, spans + 1),
            "support": np.arange(1, supports + 1),
        },
        attrs={
            "svbi_version": "0.1.0",
            "method": method,
            "backend": backend,
            "time_step": time_step,
            "steps": steps,
            "wall_time_s": wall_time_s,
            "scenario": SCENARIO.format(title=title, method=method),
            "title": title,
        },
    )
    if complete is not None:
        ds.attrs["complete"] = complete
    return ds


def write(ds: xr.Dataset, path: Path) -> Path:
    ds.to_netcdf(path, engine="h5netcdf")
    return path


def three_methods(tmp_path: Path) -> list[Path]:
    return [
        write(make_results("localized-dynamic", wall_time_s=2.0, seed=1), tmp_path / "loc.nc"),
        write(make_results("coupled-dynamic", wall_time_s=4.5, seed=1), tmp_path / "cdyn.nc"),
        write(
            make_results("coupled-classic", wall_time_s=3.0, drift=2e-3, gap_scale=1e-9, seed=2),
            tmp_path / "ccl.nc",
        ),
    ]


def assert_png(path: Path) -> None:
    data = path.read_bytes()
    assert data[:8] == PNG_SIGNATURE, f"{path} is not a PNG"
    assert len(data) > 20_000, f"{path} is suspiciously small ({len(data)} bytes)"
    with Image.open(path) as img:
        img.load()  # decodes every pixel: a truncated file fails here
        pixels = np.asarray(img.convert("L"), dtype=float)
    assert min(pixels.shape) >= 500
    # Something is drawn: a fair share of the pixels is not background white.
    assert np.mean(pixels < 250) > 0.02, f"{path} looks blank"


def parse_summary(text: str) -> dict[str, list[str]]:
    rows: dict[str, list[str]] = {}
    for line in text.splitlines()[1:]:
        cells = re.split(r"\s{2,}", line.strip())
        if len(cells) > 1:
            rows[cells[0]] = cells[1:]
    return rows


def expected_peaks(ds: xr.Dataset) -> dict[str, float]:
    """Peaks computed directly from the NumPy arrays (span 1, car 1 = index 0; all wheels)."""
    v = {name: np.asarray(ds[name].values) for name in ds.data_vars}
    return {
        "max |midspan_uz| span 1 (mm)": np.max(np.abs(v["midspan_uz"][:, 0])) * 1e3,
        "max |midspan_ux| span 1 (mm)": np.max(np.abs(v["midspan_ux"][:, 0])) * 1e3,
        "max contact force, all wheels (kN)": np.max(v["contact_force"]) / 1e3,
        "max filtered contact force (kN)": np.max(v["contact_force_filtered"]) / 1e3,
        "max |carbody_az| car 1 (m/s2)": np.max(np.abs(v["carbody_az"][:, 0])),
        "max |gap_vehicle| (m)": np.max(np.abs(v["gap_vehicle"])),
        "max |gap_bridge|, wheels in contact (m)": np.max(
            np.abs(np.where(v.get("contact_state", 1) == 1, v["gap_bridge"], 0.0))
        ),
        "max |gap_support| (m)": np.max(np.abs(v["gap_support"])),
        "wall time (s)": ds.attrs["wall_time_s"],
    }


def test_compare_writes_every_figure_and_a_correct_summary(tmp_path: Path) -> None:
    paths = three_methods(tmp_path)
    out = tmp_path / "figs"
    result = runner.invoke(make_app(), ["compare", *map(str, paths), "-o", str(out)])
    assert result.exit_code == 0, result.output
    for name in plots.FIGURE_NAMES:
        assert_png(out / f"{name}.png")
        assert f"wrote {out / name}.png" in result.output
    assert sorted(p.name for p in out.iterdir()) == sorted(
        [f"{n}.png" for n in plots.FIGURE_NAMES] + ["summary.txt"]
    ), "temporary files left behind"
    summary = (out / "summary.txt").read_text()
    assert summary in result.output
    rows = parse_summary(summary)
    assert rows["run"] == ["localized-dynamic", "coupled-dynamic", "coupled-classic"]
    datasets = [make_results("localized-dynamic", wall_time_s=2.0, seed=1)]
    datasets.append(make_results("coupled-dynamic", wall_time_s=4.5, seed=1))
    datasets.append(make_results("coupled-classic", wall_time_s=3.0, drift=2e-3, gap_scale=1e-9, seed=2))
    for column, ds in enumerate(datasets):
        for row, value in expected_peaks(ds).items():
            # The table prints 6 significant digits.
            assert float(rows[row][column]) == pytest.approx(value, rel=1e-5), row
    ratios = [float(x) for x in rows["wall time / localized-dynamic"]]
    assert ratios == pytest.approx([1.0, 4.5 / 2.0, 3.0 / 2.0], rel=1e-5)
    assert rows["complete"] == ["yes", "yes", "yes"]


def test_plot_one_file_defaults_to_a_folder_next_to_it(tmp_path: Path) -> None:
    path = write(make_results("localized-dynamic", backend="c"), tmp_path / "run1.nc")
    result = runner.invoke(make_app(), ["plot", str(path)])
    assert result.exit_code == 0, result.output
    out = tmp_path / "run1-figures"
    for name in plots.FIGURE_NAMES:
        assert_png(out / f"{name}.png")
    rows = parse_summary((out / "summary.txt").read_text())
    assert rows["backend"] == ["c"]
    assert rows["wall time / localized-dynamic"] == ["1"]


def test_no_ratio_row_without_a_localized_run(tmp_path: Path) -> None:
    text = plots.summary_text([make_results("coupled-dynamic"), make_results("coupled-classic")])
    assert "wall time /" not in text
    assert parse_summary(text)["run"] == ["coupled-dynamic", "coupled-classic"]


def test_same_method_twice_is_told_apart_by_backend_then_file(tmp_path: Path) -> None:
    a = make_results("localized-dynamic", backend="numpy")
    b = make_results("localized-dynamic", backend="c")
    assert plots.default_labels([a, b]) == ["localized-dynamic (numpy)", "localized-dynamic (c)"]
    assert plots.default_labels([a, a], ["x", "y"]) == [
        "localized-dynamic (numpy) [x]",
        "localized-dynamic (numpy) [y]",
    ]
    pa, pb = write(a, tmp_path / "x.nc"), write(a, tmp_path / "y.nc")
    result = runner.invoke(make_app(), ["compare", str(pa), str(pb), "-o", str(tmp_path / "o")])
    assert result.exit_code == 0, result.output
    assert parse_summary((tmp_path / "o" / "summary.txt").read_text())["run"] == [
        "localized-dynamic (numpy) [x]",
        "localized-dynamic (numpy) [y]",
    ]


def test_overlaid_runs_differ_in_colour_dash_and_width_and_later_ones_lie_on_top() -> None:
    runs = [make_results(m) for m in ("localized-dynamic", "coupled-dynamic", "coupled-classic")]
    fig = plots.make_figures(runs)["fig4a_midspan_uz"]
    lines = fig.axes[0].get_lines()
    assert [ln.get_label() for ln in lines] == ["localized-dynamic", "coupled-dynamic", "coupled-classic"]
    assert len({ln.get_color() for ln in lines}) == 3
    styles = [plots.line_style(i) for i in range(3)]
    assert len({s.dashes for s in styles}) == 3
    assert [ln.get_linestyle() for ln in lines] == ["-", "--", "--"]  # solid, then two dash patterns
    widths = [ln.get_linewidth() for ln in lines]
    zorders = [ln.get_zorder() for ln in lines]
    assert widths == sorted(widths, reverse=True) and len(set(widths)) == 3
    assert zorders == sorted(zorders) and len(set(zorders)) == 3
    # The legend and the axis labels carry the units.
    ax = fig.axes[0]
    assert "(mm)" in ax.get_ylabel() and "(s)" in ax.get_xlabel()
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [ln.get_label() for ln in lines]
    assert "synthetic crossing" in fig.get_suptitle()


def test_panel_f_leaves_out_coupled_classic_and_panel_e_keeps_it() -> None:
    runs = [make_results(m) for m in ("localized-dynamic", "coupled-dynamic", "coupled-classic")]
    figures = plots.make_figures(runs)
    labels_e = [ln.get_label() for ln in figures["fig4e_carbody_uz"].axes[0].get_lines()]
    labels_f = [ln.get_label() for ln in figures["fig4f_carbody_uz_without_classic"].axes[0].get_lines()]
    assert labels_e == ["localized-dynamic", "coupled-dynamic", "coupled-classic"]
    assert labels_f == ["localized-dynamic", "coupled-dynamic"]
    # Colours stay with their run across panels.
    colours_e = [ln.get_color() for ln in figures["fig4e_carbody_uz"].axes[0].get_lines()]
    colours_f = [ln.get_color() for ln in figures["fig4f_carbody_uz_without_classic"].axes[0].get_lines()]
    assert colours_f == colours_e[:2]


def test_contact_force_panel_is_the_first_wheel_of_the_last_car_raw_and_filtered() -> None:
    ds = make_results("localized-dynamic", cars=4)
    ax = plots.make_figures(ds)["fig4c_contact_force"].axes[0]
    raw, filtered = ax.get_lines()
    np.testing.assert_allclose(raw.get_ydata(), ds["contact_force"].values[:, 3, 0] / 1e3, rtol=1e-14)
    np.testing.assert_allclose(
        filtered.get_ydata(), ds["contact_force_filtered"].values[:, 3, 0] / 1e3, rtol=1e-14
    )
    assert raw.get_linewidth() < filtered.get_linewidth() and raw.get_alpha() < 1
    assert "car 4" in ax.get_title() and "(kN" in ax.get_ylabel()
    assert "20 Hz" in filtered.get_label()


def test_gap_figure_is_log_scale_and_guards_exact_zeros() -> None:
    ds = make_results("localized-dynamic", gap_scale=0.0)  # every gap exactly zero
    fig = plots.make_figures(ds)["constraint_violation"]
    for ax in fig.axes:
        assert ax.get_yscale() == "log"
        (line,) = ax.get_lines()
        assert np.all(line.get_ydata() > 0)
        assert any("drawn at" in t.get_text() for t in ax.texts)
    ds = make_results("coupled-classic", gap_scale=1e-9)
    (line,) = plots.make_figures(ds)["constraint_violation"].axes[2].get_lines()
    expected = np.abs(ds["gap_support"].values).max(axis=1)
    np.testing.assert_array_equal(line.get_ydata()[1:], expected[1:])


def test_incomplete_run_and_missing_optional_variables_still_plot_with_a_note(tmp_path: Path) -> None:
    ds = make_results("coupled-classic", complete=0)
    cut = ds.sizes["time"] // 2
    for name in ds.data_vars:
        ds[name][cut:] = np.nan  # the run stopped here
    ds = ds.drop_vars(["contact_force_filtered", "carbody_az"])
    path = write(ds, tmp_path / "stopped.nc")
    out = tmp_path / "f"
    result = runner.invoke(make_app(), ["plot", str(path), "-o", str(out)])
    assert result.exit_code == 0, result.output
    for name in plots.FIGURE_NAMES:
        assert_png(out / f"{name}.png")
    rows = parse_summary((out / "summary.txt").read_text())
    assert rows["complete"] == ["no"]
    assert rows["max filtered contact force (kN)"] == ["n/a"]
    assert rows["max |carbody_az| car 1 (m/s2)"] == ["n/a"]
    kept = ds.isel(time=slice(0, cut))
    assert float(rows["max |midspan_uz| span 1 (mm)"][0]) == pytest.approx(
        np.max(np.abs(kept["midspan_uz"].values[:, 0])) * 1e3, rel=1e-5
    )
    figures = plots.make_figures(plots.read_results(path))
    stop = float(kept["time"].values[-1])
    assert f"incomplete run, last stored t = {stop:.4g} s" in figures["fig4a_midspan_uz"].axes[0].get_title()
    assert "carbody_az missing" in figures["fig4d_carbody_az"].axes[0].get_title()
    assert "contact_force_filtered missing" in figures["fig4c_contact_force"].axes[0].get_title()


def test_simulator_style_file_without_title_attribute_and_with_a_stop_message(tmp_path: Path) -> None:
    """As `svbi.simulate` writes it: title only in the scenario text, `incomplete` message, extra
    support coordinates, uniform ground motion per time only."""
    ds = make_results("coupled-classic", title="from the scenario text")
    del ds.attrs["title"]
    ds.attrs["complete"] = 0
    ds.attrs["incomplete"] = "t = 0.3 s: |gap_vehicle| = 2 m exceeds 1 m: the run diverged"
    ds = ds.assign_coords(support_component=("support", ["uz", "uz", "ux", "uz"]))
    path = write(ds, tmp_path / "sim.nc")
    out = tmp_path / "f"
    result = runner.invoke(make_app(), ["plot", str(path), "-o", str(out)])
    assert result.exit_code == 0, result.output
    text = (out / "summary.txt").read_text()
    assert text.startswith("Summary: from the scenario text")
    assert ds.attrs["incomplete"] in text
    figures = plots.make_figures(plots.read_results(path))
    assert figures["fig4a_midspan_uz"].get_suptitle() == "from the scenario text"
    assert "the run diverged" in figures["fig4a_midspan_uz"].axes[0].get_title()


def test_missing_file_is_a_clear_error(tmp_path: Path) -> None:
    missing = tmp_path / "nope.nc"
    result = runner.invoke(make_app(), ["plot", str(missing)])
    assert result.exit_code == 2
    assert str(missing) in result.output and "not found" in result.output
    assert "Traceback" not in result.output


def test_unreadable_file_is_a_clear_error(tmp_path: Path) -> None:
    bad = tmp_path / "garbage.nc"
    bad.write_bytes(b"this is not a NetCDF file\n" * 10)
    good = write(make_results("localized-dynamic"), tmp_path / "good.nc")
    result = runner.invoke(make_app(), ["compare", str(good), str(bad), "-o", str(tmp_path / "o")])
    assert result.exit_code == 2
    assert str(bad) in result.output and "cannot read" in result.output
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("variable", ["midspan_uz", "midspan_ux", "contact_force"])
def test_missing_required_variable_names_file_and_variable(tmp_path: Path, variable: str) -> None:
    path = write(make_results("localized-dynamic").drop_vars(variable), tmp_path / "partial.nc")
    result = runner.invoke(make_app(), ["plot", str(path)])
    assert result.exit_code == 2
    assert str(path) in result.output and f"'{variable}'" in result.output
    assert not (tmp_path / "partial-figures").exists()


def test_variable_with_wrong_dims_is_a_clear_error(tmp_path: Path) -> None:
    ds = make_results("localized-dynamic")
    ds["carbody_uz"] = (("time",), ds["carbody_uz"].values[:, 0])
    path = write(ds, tmp_path / "odd.nc")
    result = runner.invoke(make_app(), ["plot", str(path)])
    assert result.exit_code == 2
    assert str(path) in result.output and "'carbody_uz'" in result.output and "car" in result.output


def test_compare_needs_two_files(tmp_path: Path) -> None:
    path = write(make_results("localized-dynamic"), tmp_path / "one.nc")
    result = runner.invoke(make_app(), ["compare", str(path)])
    assert result.exit_code == 2 and "at least two" in result.output


def test_time_with_a_units_attribute_stays_seconds(tmp_path: Path) -> None:
    ds = make_results("localized-dynamic")
    ds["time"].attrs["units"] = "seconds"
    path = write(ds, tmp_path / "units.nc")
    loaded = plots.read_results(path)
    (line, *_) = plots.make_figures(loaded)["fig4a_midspan_uz"].axes[0].get_lines()
    np.testing.assert_array_equal(line.get_xdata(), ds["time"].values)

"""``[bridge]`` long form (issue 13 item 1): ``[[bridge.girders]]`` / ``[[bridge.piers]]``.

The shorthand ``spans`` x ``span_length`` must give the same results as the equivalent long form
(one single-span girder per span) on both backends; what the mechanics cannot build (a per-girder
element count, a fixed bearing off the girder, two piers on one line) is refused
with the key, file and line, never approximated. The mechanics of continuous girders, unequal spans
and piers is verified in ``test_continuous_bridges.py``.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from conftest import c_compiler_works

import svbi
from svbi.examples import paper_section_keys
from svbi.runtime.run.simulate import build_model
from svbi.runtime.scenario.schema import ScenarioError, load_scenario, loads_scenario

SECTION = "".join(f"{k} = {v!r}\n" for k, v in paper_section_keys().items()) + "elements_per_span = 6\n"

TAIL = """
[train]
vehicle = "moving-load"
speed_kmh = 300.0

[contact]
creep = false

[earthquake]
vertical = "synthetic"
longitudinal = "synthetic"
arrival = 0.1

[solver]
backend = "{backend}"
time_step = 2.0e-3
output_every = 2
"""

SHORT = "[bridge]\nspans = 3\nspan_length = 24.0\n" + SECTION + TAIL

LONG = (
    "[bridge]\n"
    + SECTION
    + "\n[[bridge.girders]]\nspans = [24.0]\n"
    + "\n[[bridge.girders]]\nspans = [24.0]\nfixed_support = 0\narea = 8.63\n"
    + "\n[[bridge.girders]]\nspans = [24.0]\n"
    + TAIL
)


def run(text: str):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # synthetic record shorter than the run
        return svbi.simulate(loads_scenario(text))


@pytest.mark.parametrize(
    "backend",
    [
        "numpy",
        pytest.param("c", marks=pytest.mark.skipif(not c_compiler_works(), reason="no working C compiler")),
    ],
)
def test_shorthand_equals_long_form(backend):
    short = loads_scenario(SHORT.format(backend=backend))
    long = loads_scenario(LONG.format(backend=backend))
    assert (long.bridge.spans, long.bridge.span_length) == (3, 24.0)
    a = build_model(short)
    b = build_model(long)
    for name in ("M", "C", "K"):
        np.testing.assert_array_equal(getattr(a.bridge, name), getattr(b.bridge, name))
    ra, rb = run(SHORT.format(backend=backend)), run(LONG.format(backend=backend))
    assert ra.attrs["backend"] == rb.attrs["backend"] == backend
    assert set(ra.data_vars) == set(rb.data_vars)
    assert ra.sizes["time"] > 100
    for name in ra.data_vars:
        np.testing.assert_array_equal(ra[name].values, rb[name].values, err_msg=name)
    assert float(np.abs(ra["midspan_uz"]).max()) > 0.0


def test_long_form_echo_reloads(tmp_path):
    """The echoed (normalised) long form is itself a valid scenario with the same bridge."""
    sc = loads_scenario(LONG.format(backend="numpy"))
    text = sc.to_toml()
    assert "girders" in text and "span_length" not in text
    again = loads_scenario(text)
    assert again.bridge == sc.bridge


def line_of(text: str, needle: str, nth: int = 0) -> int:
    hits = [i for i, line in enumerate(text.splitlines(), start=1) if needle in line]
    return hits[nth]


def problems(tmp_path, text: str) -> list[str]:
    path = tmp_path / "s.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    return [str(p) for p in info.value.problems]


@pytest.mark.parametrize(
    ("girders", "key", "needle", "nth", "words"),
    [
        (
            "spans = [32.0]\nelements_per_span = 8",
            "bridge.girders[1].elements_per_span",
            "elements_per_span = 8",
            0,
            "no per-girder value",
        ),
        (
            "spans = [32.0, 40.0]\nfixed_support = 3",
            "bridge.girders[1].fixed_support",
            "fixed_support",
            0,
            "girder's lines 0..2",
        ),
    ],
)
def test_unbuildable_long_form_is_refused_with_key_and_line(tmp_path, girders, key, needle, nth, words):
    text = (
        "[bridge]\n"
        + SECTION
        + "\n[[bridge.girders]]\nspans = [32.0]\n\n[[bridge.girders]]\n"
        + girders
        + TAIL.format(backend="numpy")
    )
    found = problems(tmp_path, text)
    line = line_of(text, needle, nth)
    assert any(f"s.toml:{line}: {key}:" in p and words in p for p in found), found


PIER = "mass_per_length = 3e4\nyoungs_modulus = 3.2e10\narea = 9.0\nsecond_moment = 6.0\n"


def test_misplaced_piers_are_refused(tmp_path):
    text = (
        "[bridge]\n"
        + SECTION
        + "\n[[bridge.girders]]\nspans = [32.0]\n"
        + "\n[[bridge.piers]]\nsupport = 1\nheight = 12.0\nbearing_stiffness_vertical = 1e9\n"
        + PIER
        + "\n[[bridge.piers]]\nsupport = 1\nheight = 10.0\n"
        + PIER
        + "\n[[bridge.piers]]\nsupport = 5\nheight = 10.0\n"
        + PIER
        + TAIL.format(backend="numpy")
    )
    found = problems(tmp_path, text)
    line = line_of(text, "support = 1", 1)
    assert any(
        f"s.toml:{line}: bridge.piers[1].support: support line 1 already has pier 0" in p for p in found
    ), found
    assert any("bridge.piers[2].support: support line 5 is not one of 0..1" in p for p in found), found
    assert not any("bearing_stiffness" in p for p in found), found  # bearing springs are modelled
    # validated without the checks, the model is still refused, not built wrong
    sc = loads_scenario(text, check=False)
    with pytest.raises(ScenarioError, match="already has pier 0"):
        build_model(sc)


def test_a_continuous_viaduct_on_piers_loads_and_builds(tmp_path):
    text = (
        "[bridge]\n"
        + SECTION
        + "\n[[bridge.girders]]\nspans = [24.0]\n"
        + "\n[[bridge.girders]]\nspans = [30.0, 40.0, 30.0]\nfixed_support = 1\nsecond_moment = 9.0\n"
        + "\n[[bridge.piers]]\nsupport = 1\nheight = 12.0\n"
        + PIER
        + "\n[[bridge.piers]]\nsupport = 2\nheight = 14.0\n"
        + PIER
        + TAIL.format(backend="numpy")
    )
    sc = loads_scenario(text)
    assert sc.bridge.spans == 4
    b = build_model(sc).bridge
    assert not b.uniform
    assert b.spans == 4 and b.nsub == 6
    np.testing.assert_allclose(b.line_x, [0.0, 24.0, 54.0, 94.0, 124.0])
    # continuity over two interior lines (u, w, theta); bearings (w) on the pier tops: the
    # simple span's right end and the continuous girder's first line on pier 1, its second line
    # on pier 2, which also carries its fixed bearing (u); the simple span's is on the abutment
    kinds = sorted(b.links.kind)
    assert kinds.count("continuity-w") == 2 and kinds.count("bearing-w") == 3
    assert kinds.count("bearing-u") == 1
    assert b.kinds[b.kind[1]].section.second_moment == 9.0


def test_long_form_key_errors_name_the_girder_line(tmp_path):
    base = "[bridge]\n" + SECTION + "\n[[bridge.girders]]\nspans = [32.0]\n\n[[bridge.girders]]\n"
    text = base + "spans = [32.0]\ncolour = 1\n" + TAIL.format(backend="numpy")
    found = problems(tmp_path, text)
    assert any(
        f"s.toml:{line_of(text, 'colour')}: bridge.girders[1].colour: unknown key (allowed: spans" in p
        for p in found
    ), found
    text = base + "spans = [-32.0]\n" + TAIL.format(backend="numpy")
    found = problems(tmp_path, text)
    assert any(f"s.toml:{line_of(text, 'spans = [-32')}: bridge.girders[1].spans[0]:" in p for p in found), (
        found
    )


def test_shorthand_and_long_form_together_or_neither(tmp_path):
    text = "[bridge]\nspan_length = 32.0\n" + SECTION + "\n[[bridge.girders]]\nspans = [32.0]\n"
    text += TAIL.format(backend="numpy")
    found = problems(tmp_path, text)
    assert any(
        f"s.toml:{line_of(text, 'span_length')}: bridge.span_length: the shorthand cannot" in p for p in found
    ), found
    text = "[bridge]\n" + SECTION + TAIL.format(backend="numpy")
    found = problems(tmp_path, text)
    assert any(
        f"s.toml:{line_of(text, '[bridge]')}: bridge.span_length: required key is missing" in p for p in found
    ), found


def test_modes_of_a_refused_scenario_is_one_line(tmp_path):
    from typer.testing import CliRunner

    from svbi.runtime.cli.app import _register, app

    _register()
    text = (
        LONG.format(backend="numpy")
        .replace("spans = [24.0]\nfixed_support", "spans = [24.0, 30.0]\nfixed_support = 5\nx_support")
        .replace("x_support = 0\n", "")
    )
    path = tmp_path / "bridge.toml"
    path.write_text(text, encoding="utf-8")
    result = CliRunner().invoke(app, ["modes", str(path)])
    assert result.exit_code == 2
    assert "bridge.girders[1].fixed_support: 5 is not one of" in result.output


def test_override_of_the_shorthand_on_a_long_form_names_the_set(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(LONG.format(backend="numpy"), encoding="utf-8")
    with pytest.raises(ScenarioError) as info:
        load_scenario(path, overrides=["bridge.span_length=30.0"])
    found = [str(p) for p in info.value.problems]
    assert any(
        p.startswith("--set bridge.span_length=30.0: bridge.span_length: the shorthand") for p in found
    ), found

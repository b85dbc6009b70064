"""HSLM-A trains against EN 1991-2:2003 Annex E (Table E.1 and Figure E.2)."""

from __future__ import annotations

import numpy as np
import pytest

from svbi.runtime.model.hslm import hslm_train

# EN 1991-2:2003, Table E.1: train -> (N intermediate coaches, D coach length m, d bogie axle
# spacing m, P point force kN). Retyped here from the standard as the independent reference.
TABLE_E1 = {
    "A1": (18, 18.0, 2.0, 170.0),
    "A2": (17, 19.0, 3.5, 200.0),
    "A3": (16, 20.0, 2.0, 180.0),
    "A4": (15, 21.0, 3.0, 190.0),
    "A5": (14, 22.0, 2.0, 170.0),
    "A6": (13, 23.0, 2.0, 180.0),
    "A7": (13, 24.0, 2.0, 190.0),
    "A8": (12, 25.0, 2.5, 190.0),
    "A9": (11, 26.0, 2.0, 210.0),
    "A10": (11, 27.0, 2.0, 210.0),
}


@pytest.mark.parametrize("name", list(TABLE_E1))
def test_axles_match_en1991_2(name: str) -> None:
    n_coaches, coach, d, p_kn = TABLE_E1[name]
    loads, offsets = hslm_train(name)
    # Figure E.2: 2 power cars x 4 axles, 2 end coaches x 2 own axles, N + 1 articulated bogies.
    assert loads.size == offsets.size == 8 + 4 + 2 * (n_coaches + 1)
    np.testing.assert_array_equal(loads, p_kn * 1e3)
    assert offsets[0] == 0.0 and np.all(np.diff(offsets) > 0)
    gaps = np.diff(offsets)
    # Power cars (3 + 11 + 3 m) and the 3.525 m to the end coach, at both ends.
    np.testing.assert_allclose(gaps[:4], [3.0, 11.0, 3.0, 3.525], atol=1e-12)
    np.testing.assert_allclose(gaps[::-1][:4], [3.0, 11.0, 3.0, 3.525], atol=1e-12)
    # End coaches: own bogie d; D measured from the coupling (3.525/2 m ahead of the first axle)
    # to the first articulated bogie centre.
    end_gap = coach - d / 2 - (3.525 / 2 + d)
    np.testing.assert_allclose([gaps[4], gaps[5]], [d, end_gap], atol=1e-12)
    np.testing.assert_allclose([gaps[-5], gaps[-6]], [d, end_gap], atol=1e-12)
    # Articulated bogies: N + 1 bogies with axles d apart, bogie centres D apart.
    inner = gaps[6:-6]
    np.testing.assert_allclose(inner[0::2], d, atol=1e-12)
    np.testing.assert_allclose(inner[1::2], coach - d, atol=1e-12)
    centres = offsets[6:-6].reshape(-1, 2).mean(axis=1)
    np.testing.assert_allclose(np.diff(centres), coach, atol=1e-9)
    assert centres.size == n_coaches + 1
    # Total length: 2 x 17 m power cars + 3.525 + (N + 2) D; symmetric train.
    assert offsets[-1] == pytest.approx(2 * 17.0 + 3.525 + (n_coaches + 2) * coach, abs=1e-9)
    np.testing.assert_allclose(offsets[-1] - offsets[::-1], offsets, atol=1e-9)


def test_trains_are_about_400_m() -> None:
    lengths = [hslm_train(name)[1][-1] for name in TABLE_E1]
    assert max(lengths) <= 400.0 and min(lengths) > 370.0


def test_names() -> None:
    np.testing.assert_array_equal(hslm_train("hslm-a3")[1], hslm_train("A3")[1])
    with pytest.raises(ValueError, match="A1, A2"):
        hslm_train("A11")

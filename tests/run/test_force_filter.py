"""The compiled zero-phase filter of the contact forces (svbi.runtime.run.force_filter) is SciPy's
``sosfiltfilt``: odd padding, ``sosfilt_zi`` states, forward and backward passes, decimated rows."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal as sig
from conftest import c_compiler_works

from svbi.runtime.run import force_filter as zero_phase

pytestmark = pytest.mark.skipif(not c_compiler_works(), reason="no working C compiler")


@pytest.mark.parametrize(
    ("n", "every", "order", "cut_hz", "columns"),
    [
        (71461, 10, 4, 20.0, slice(0, 40)),  # the paper run's forces: 40 contacts, dt = 1e-4 s
        (5001, 1, 4, 20.0, slice(7, 19)),  # a column block (rows further apart than its width)
        (3000, 7, 2, 150.0, slice(3, 4)),  # one column, an odd decimation, another order
        (40, 3, 4, 20.0, slice(0, 5)),  # padding shorter than the default (padlen = n - 1)
    ],
)
def test_compiled_filter_is_scipy_sosfiltfilt(
    n: int, every: int, order: int, cut_hz: float, columns: slice
) -> None:
    assert zero_phase.compiled()
    rng = np.random.default_rng(n)
    # a static load with a vibration: the shape of a contact force
    forces = 1e5 + 2e4 * rng.standard_normal((n, 40)).cumsum(axis=0) / np.sqrt(n)
    x = forces[:, columns]
    sos = sig.butter(order, cut_hz, btype="low", fs=1e4, output="sos")
    padlen = min(3 * (2 * len(sos) + 1), n - 1)
    count = -(-n // every)
    got = zero_phase.sosfiltfilt_rows(sos, x, padlen, every, count)
    want = sig.sosfiltfilt(sos, x, axis=0, padlen=padlen)[::every][:count]
    assert got.shape == want.shape
    # the same arithmetic channel by channel: equal bits here (measured); 1e-13 of the peak allows
    # a platform whose compiler fuses multiply-adds
    np.testing.assert_allclose(got, want, rtol=0.0, atol=1e-13 * np.abs(want).max())
    # fewer rows asked for than there are: the first ones
    np.testing.assert_array_equal(zero_phase.sosfiltfilt_rows(sos, x, padlen, every, 3), got[:3])


def test_results_filter_falls_back_to_scipy_with_the_same_numbers(monkeypatch: pytest.MonkeyPatch) -> None:
    """Without the compiled filter (no compiler) the results are SciPy's: the same filtered forces."""
    rng = np.random.default_rng(3)
    x = 1e5 + rng.standard_normal((2000, 8)).cumsum(axis=0)
    sos = sig.butter(4, 20.0, btype="low", fs=1e4, output="sos")
    compiled = zero_phase.sosfiltfilt_rows(sos, x, 27, 10, 200)
    monkeypatch.setattr(zero_phase, "_library", lambda: None)
    assert not zero_phase.compiled()
    fallback = zero_phase.sosfiltfilt_rows(sos, x, 27, 10, 200)
    np.testing.assert_allclose(compiled, fallback, rtol=0.0, atol=1e-13 * np.abs(fallback).max())


def test_design_is_scipys_and_is_read_back_from_the_cache(tmp_path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The filter design a run reads from the cache is SciPy's butter and sosfilt_zi, bit for bit;
    a damaged cache file is designed again."""
    monkeypatch.setenv("SVBI_CACHE_DIR", str(tmp_path))
    assert not zero_phase.design_cached(4, 20.0, 1e4)
    sos, zi = zero_phase.design(4, 20.0, 1e4)
    want = sig.butter(4, 20.0, btype="low", fs=1e4, output="sos")
    np.testing.assert_array_equal(sos, want)
    np.testing.assert_array_equal(zi, sig.sosfilt_zi(want))
    assert zero_phase.design_cached(4, 20.0, 1e4)
    again = zero_phase.design(4, 20.0, 1e4)  # from the file
    np.testing.assert_array_equal(again[0], want)
    np.testing.assert_array_equal(again[1], zi)
    assert not zero_phase.design_cached(4, 25.0, 1e4)  # another cutoff: another entry
    (stored,) = (tmp_path / "filters").glob("*.npz")
    stored.write_bytes(b"not an npz")
    np.testing.assert_array_equal(zero_phase.design(4, 20.0, 1e4)[0], want)
    np.testing.assert_array_equal(np.load(stored)["sos"], want)  # written again

"""Zero-phase low-pass filtering of the contact forces, compiled (``csrc_filter/zero_phase.c``).

``scipy.signal.sosfiltfilt`` filters each channel on its own through a generic loop: on the paper
run (40 contact forces, 71,461 samples) that took 36 ms, about half of what a sweep's run spends
outside its time loop. The contact forces are stored a time step per row, so the compiled version
filters all channels of a row in one vectorised pass, with SciPy's arithmetic channel by channel
(odd padding, ``sosfilt_zi`` initial states, transposed direct form II, forward then backward). The
filter's design (``scipy.signal.butter``) and initial states (``sosfilt_zi``) stay SciPy's: SciPy
computes them once per machine, SciPy version and filter (:func:`design`), and later runs read them
from the kernel cache, so that a run needs not import ``scipy.signal`` (0.35 s, with ``scipy.stats``)
at all. The routine is built once per machine into the kernel cache with the loop's flags
(contraction off where AVX2 is used, so the results are SciPy's bits); with no working C compiler,
:func:`sosfiltfilt_rows` is SciPy's own.
"""

from __future__ import annotations

import ctypes
import hashlib
import io
from functools import cache
from importlib import resources
from pathlib import Path

import numpy as np

from ...codegen.c_flags import STRICT_FLAGS
from .. import toolchain as kernel_cache
from ..backends.c.build import simd_flags
from ..toolchain import cache_root
from .atomic import write_atomic

SOURCE = "zero_phase.c"


def _design_path(order: int, cutoff_hz: float, fs: float) -> Path:
    import scipy

    key = hashlib.sha256(f"butter-sos|{scipy.__version__}|{order}|{cutoff_hz!r}|{fs!r}".encode()).hexdigest()
    return cache_root() / "filters" / f"{key}.npz"


def design_cached(order: int, cutoff_hz: float, fs: float) -> bool:
    """Whether :func:`design` finds this low-pass filter in the cache (no ``scipy.signal`` needed)."""
    return _design_path(order, cutoff_hz, fs).is_file()


def design(order: int, cutoff_hz: float, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """``(sos, zi)``: ``scipy.signal.butter(order, cutoff_hz, "low", fs=fs, output="sos")`` and
    ``scipy.signal.sosfilt_zi(sos)``, from the cache where this SciPy designed the same filter before
    (the same numbers: SciPy's, stored), else designed now and stored (atomically)."""
    path = _design_path(order, cutoff_hz, fs)
    try:
        with np.load(path) as stored:
            sos, zi = stored["sos"], stored["zi"]
        if sos.shape == (-(-order // 2), 6) and zi.shape == (len(sos), 2):
            return sos, zi
    except (OSError, KeyError, ValueError):
        pass
    import scipy.signal as sig

    sos = sig.butter(order, cutoff_hz, btype="low", fs=fs, output="sos")
    zi = sig.sosfilt_zi(sos)
    stored = io.BytesIO()
    np.savez(stored, sos=sos, zi=zi)
    try:
        write_atomic(path, lambda tmp: tmp.write_bytes(stored.getvalue()))
    except OSError:  # a read-only cache costs the import next time, nothing else
        pass
    return sos, zi


@cache
def _library() -> ctypes.CDLL | None:

    source = resources.files("svbi.runtime").joinpath("csrc_filter", SOURCE).read_bytes()
    try:
        lib = kernel_cache.load_library(
            {SOURCE: source},
            "svbi_zero_phase",
            flags=(*STRICT_FLAGS, "-O3", "-fPIC", "-shared", *simd_flags()),
        )
    except kernel_cache.CompilerError:
        return None
    dp = ctypes.POINTER(ctypes.c_double)
    lib.svbi_sosfiltfilt.argtypes = [
        dp,
        ctypes.c_long,
        ctypes.c_long,
        ctypes.c_long,
        dp,
        ctypes.c_int,
        dp,
        ctypes.c_long,
        ctypes.c_long,
        ctypes.c_long,
        dp,
        ctypes.c_long,
        dp,
    ]
    lib.svbi_sosfiltfilt.restype = None
    return lib


def compiled() -> bool:
    """Whether the compiled filter is there (it is built into the kernel cache on the first call)."""
    return _library() is not None


def _ptr(a: np.ndarray) -> ctypes._Pointer:
    return a.ctypes.data_as(ctypes.POINTER(ctypes.c_double))


def sosfiltfilt_rows(
    sos: np.ndarray, x: np.ndarray, padlen: int, every: int, count: int, zi: np.ndarray | None = None
) -> np.ndarray:
    """``scipy.signal.sosfiltfilt(sos, x, axis=0, padlen=padlen)[::every][:count]``.

    ``x`` is float64, ``(n, m)``, rows contiguous (a column block of the forces array is fine: rows
    may be further apart than ``m``); ``0 < padlen < n``; ``zi`` is ``sosfilt_zi(sos)`` (computed
    here when None). The compiled filter when it builds, else SciPy.
    """
    n, m = x.shape
    lib = _library()
    if lib is None or x.dtype != np.float64 or x.strides[1] != 8 or not 0 < padlen < n:
        import scipy.signal as sig

        return sig.sosfiltfilt(sos, x, axis=0, padlen=padlen)[::every][:count]
    if zi is None:
        import scipy.signal as sig

        zi = sig.sosfilt_zi(sos)
    sos = np.ascontiguousarray(sos, dtype=float)
    zi = np.ascontiguousarray(zi, dtype=float)
    k = min(count, -(-n // every))
    out = np.empty((k, m))
    work = np.empty((n + 2 * padlen) * m + 2 * len(sos) * m)
    lib.svbi_sosfiltfilt(
        _ptr(x),
        x.strides[0] // 8,
        n,
        m,
        _ptr(sos),
        len(sos),
        _ptr(zi),
        padlen,
        every,
        k,
        _ptr(out),
        m,
        _ptr(work),
    )
    return out

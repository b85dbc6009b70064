"""What every backend shares: the warning of a fallback to the NumPy backend."""

from __future__ import annotations


class BackendFallback(UserWarning):
    """The requested backend is not available; the NumPy backend runs instead."""

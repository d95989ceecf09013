"""Compiled kernels for the few per-cell / per-beam loops numpy cannot batch well.

``kernel`` is numba's ``njit`` with its on-disk cache (next to the source, or the user's cache when the
package directory is read-only), so a node pays about 0.5 s once at its first call, not a compile per
run. No ``fastmath``: kernels must give the same bits as the numpy code they replace (the tests compare
them against numpy references). Only algorithm modules that need it import this.
"""

from __future__ import annotations

from numba import njit


def kernel(fn=None, **options):
    """``@kernel`` or ``@kernel(...)``: ``numba.njit(cache=True, nogil=True, ...)``."""
    options.setdefault("cache", True)
    options.setdefault("nogil", True)
    if fn is None:
        return lambda f: njit(**options)(f)
    return njit(**options)(fn)

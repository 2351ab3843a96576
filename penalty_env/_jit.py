"""Numba configuration shared by every kernel.

Kernels are compiled with ``cache=True`` so a second process starts in well under a second.
Numba writes its cache next to the source (``__pycache__``) when that is writable and otherwise in
a user-wide cache folder; when neither is writable (a read-only install in a locked-down
container), numba would raise at decoration time. We point ``NUMBA_CACHE_DIR`` at a temporary
folder instead, and if even that fails we compile without a cache: slower to start, never a crash.

``fastmath`` is deliberately not used: it lets LLVM assume no NaN/inf, which would delete the
``np.isfinite`` guards the kernels rely on to report a blown-up simulation.
"""

from __future__ import annotations

import os
import tempfile
import warnings

import numba
from numba.core import config as _numba_config

__all__ = ["njit", "prange"]

prange = numba.prange


def _writable(path: str) -> bool:
    try:
        os.makedirs(path, exist_ok=True)
        probe = tempfile.NamedTemporaryFile(dir=path, prefix=".probe", delete=True)
        probe.close()
        return True
    except OSError:
        return False


def _choose_cache_dir() -> None:
    """Use the package tree if writable; else NUMBA_CACHE_DIR as given; else a temp folder."""
    if _numba_config.CACHE_DIR:  # the user chose one (NUMBA_CACHE_DIR); respect it
        return
    here = os.path.join(os.path.dirname(os.path.abspath(__file__)), "__pycache__")
    if _writable(here):
        return
    fallback = os.path.join(tempfile.gettempdir(), f"penalty_env-numba-{os.getuid() if hasattr(os, 'getuid') else 'user'}")
    if _writable(fallback):
        _numba_config.CACHE_DIR = fallback


_choose_cache_dir()


def njit(*args, **kwargs):
    """``numba.njit`` with ``cache=True`` and numpy's error model, falling back to no cache.

    Use as ``@njit`` or ``@njit(parallel=True)``.
    """
    kwargs.setdefault("cache", True)
    kwargs.setdefault("error_model", "numpy")
    kwargs.setdefault("_nrt", False)  # see the module docstring
    if kwargs.get("fastmath"):
        raise ValueError("fastmath is banned in penalty_env kernels: it removes NaN/inf checks")

    def decorate(func):
        try:
            return numba.njit(**kwargs)(func)
        except RuntimeError as exc:  # "cannot cache function ...: no locator available"
            if not kwargs.get("cache"):
                raise
            warnings.warn(
                f"numba cannot cache {func.__qualname__} ({exc}); compiling without a cache",
                RuntimeWarning,
                stacklevel=2,
            )
            return numba.njit(**dict(kwargs, cache=False))(func)

    if len(args) == 1 and callable(args[0]) and not kwargs.get("_called"):
        return decorate(args[0])
    return decorate

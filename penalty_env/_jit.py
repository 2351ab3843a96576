"""Numba configuration shared by every kernel.

Kernels are compiled with ``cache=True`` so a second process starts in well under a second.
Numba writes its cache next to the source (``__pycache__``) when that is writable. When the
package is installed read-only, we point numba's cache at the user's own cache folder
(``~/.cache/penalty_env/numba``), or failing that at a private temporary folder (``mkdtemp``: never
a predictable shared path, since numba loads cache files as pickles); a user's
``NUMBA_CACHE_DIR`` always wins. If even that fails we compile without a cache: slower to start,
never a crash.

Kernels are compiled without Numba's reference-counting runtime (``_nrt=False``): they never
allocate, and with NRT every non-inlined call increfs and decrefs each array argument atomically,
which cost ~100 ns per pair check (measured) and contends between threads.

``fastmath`` is deliberately not used: it lets LLVM assume no NaN/inf, which would delete the
``np.isfinite`` guards the kernels rely on to report a blown-up simulation.

Stale caches: an index written by an older version of the package that names a class which no
longer exists is treated as a cache miss (recompiled), not an error (``_tolerate_stale_cache_indexes``).

Threading layer: the large-world kernels run in parallel through Numba's threading layer. Its
default on Linux is GNU OpenMP where it is installed, and GNU OpenMP does not survive ``fork``: a
forked child that runs a parallel kernel after its parent did is killed ("fork() called from a
process already using GNU OpenMP"). So unless the user chose a layer (``NUMBA_THREADING_LAYER``),
we ask Numba for a fork-safe one: TBB where its library loads, else Numba's own ``workqueue``
(always present). ``workqueue`` does not allow two threads to launch parallel kernels at once, so
the runner launches them one at a time (``runner.PARALLEL_LOCK``). Results do not depend on the
layer: every parallel kernel splits its work by a fixed rule, not by the scheduler.
"""

from __future__ import annotations

import os
import pickle
import tempfile
import warnings
from typing import Any

import numba
from numba.core import config as _numba_config

__all__ = ["njit", "prange", "entry_point"]

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
    package = os.path.dirname(os.path.abspath(__file__))
    # the kernels live in these subpackages; each caches into its own __pycache__
    if all(_writable(os.path.join(package, sub, "__pycache__")) for sub in ("physics", "envs")):
        return
    user = os.path.join(os.path.expanduser("~"), ".cache", "penalty_env", "numba")
    if _writable(user):
        _numba_config.CACHE_DIR = user
        return
    try:
        _numba_config.CACHE_DIR = tempfile.mkdtemp(prefix="penalty_env-numba-")
    except OSError:
        pass  # no writable folder at all: numba raises at decoration and njit() compiles uncached


_choose_cache_dir()


def _choose_threading_layer() -> None:
    """A fork-safe threading layer, unless the user chose one (see the module docstring)."""
    if os.environ.get("NUMBA_THREADING_LAYER"):
        return
    _numba_config.THREADING_LAYER = "forksafe"


_choose_threading_layer()


def _tolerate_stale_cache_indexes() -> None:
    """Treat a Numba cache index that cannot be unpickled as empty (a cache miss), instead of
    crashing the first call. An index pickles the argument types of every compiled signature; one
    written by an older version of this package may name a class that no longer exists (the cache
    survives a ``pip install --upgrade``: pip removes only the files it installed), and Numba
    unpickles the index before it checks that the source is unchanged. Numba then recompiles and
    overwrites the index, as for any stale cache. Applies to every Numba cache of the process."""
    from numba.core import caching

    original = caching.IndexDataCacheFile._load_index
    if getattr(original, "_penalty_env_tolerant", False):
        return

    def _load_index(self):
        try:
            return original(self)
        except (AttributeError, ImportError, EOFError, TypeError, ValueError, pickle.UnpicklingError):
            return {}

    _load_index._penalty_env_tolerant = True  # type: ignore[attr-defined]
    caching.IndexDataCacheFile._load_index = _load_index


_tolerate_stale_cache_indexes()


def njit(*args, **kwargs):
    """``numba.njit`` with ``cache=True`` and numpy's error model, falling back to no cache.

    Use as ``@njit`` or ``@njit(parallel=True)``.
    """
    kwargs.setdefault("cache", True)
    kwargs.setdefault("error_model", "numpy")
    kwargs.setdefault("_nrt", False)  # kernels never allocate: see the module docstring
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

    if len(args) == 1 and callable(args[0]):
        return decorate(args[0])
    return decorate


def entry_point(fn: Any, args: tuple) -> Any:
    """The compiled function of Numba dispatcher ``fn`` for these arguments' types (compiled or
    loaded from the cache now), to call without Numba's per-call type resolution: that costs about
    a microsecond for each field of a NamedTuple argument, as much as a small world's whole step.
    Only for calls whose argument types are fixed by construction: the entry point does not check
    them again."""
    return fn.compile(tuple(fn.typeof_pyval(a) for a in args))

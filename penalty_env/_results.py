"""Results the package derives from its inputs alone, kept on disk between processes.

Some things a scene needs are pure functions of its arguments and of the package's code, and cost
more than the rest of a warm start: :func:`.physics.configure.configure` (root finding on the
closed forms, ~0.1 s) and a sand scene's settled bed (a second of physics). They are computed once
and kept, as the compiled kernels are, so that a process with a filled cache starts in a fraction
of a second.

An entry is a pickle named by a hash of what it is (``kind``), its inputs (``key``: a tuple whose
``repr`` is exact, floats included) and :func:`._jit.source_hash` (every source a result can come
from), so that an edit of the package, like an edit of a kernel, can never serve a stale result.
Entries sit beside the compiled kernels: in ``NUMBA_CACHE_DIR/penalty_env/results`` when the user
set it, else in the package's ``__pycache__/results`` when writable, else in
``~/.cache/penalty_env/results``; when neither is writable nothing is kept. A read that fails (a
truncated or foreign file) is a miss. Writes go through a temporary file and ``os.replace``, so
concurrent processes (vector-env workers, test workers) never read half a file.
``PENALTY_ENV_RESULTS_CACHE=0`` turns the cache off.

Loading an entry gives the very object that was stored (pickle round-trips floats and arrays
exactly), so a result from the cache is bit-identical to a computed one.
"""

from __future__ import annotations

import hashlib
import os
import pickle
import tempfile
from collections.abc import Callable
from typing import TypeVar

from numba.core import config as _numba_config

from ._jit import _PACKAGE, _writable, source_hash

__all__ = ["cached", "results_dir"]

T = TypeVar("T")
_DIR: list[str | None] = []


def results_dir() -> str | None:
    """The folder the results are kept in, or None when there is none (see the module docstring)."""
    if os.environ.get("PENALTY_ENV_RESULTS_CACHE", "1") == "0":
        return None
    if _numba_config.CACHE_DIR:  # the user's choice is read each time, as Numba does
        return os.path.join(_numba_config.CACHE_DIR, "penalty_env", "results")
    if not _DIR:
        here = os.path.join(_PACKAGE, "__pycache__", "results")
        user = os.path.join(os.path.expanduser("~"), ".cache", "penalty_env", "results")
        _DIR.append(here if _writable(here) else user if _writable(user) else None)
    return _DIR[0]


def _path(folder: str, kind: str, key: tuple) -> str:
    digest = hashlib.sha256(repr((kind, key, source_hash())).encode()).hexdigest()[:32]
    return os.path.join(folder, f"{kind}-{digest}.pkl")


def cached(kind: str, key: tuple, compute: Callable[[], T]) -> T:
    """``compute()``, or the result it gave before for the same ``kind`` and ``key`` (exact
    ``repr``) under the same package sources."""
    folder = results_dir()
    if folder is None:
        return compute()
    path = _path(folder, kind, key)
    try:
        with open(path, "rb") as f:
            return pickle.load(f)  # noqa: S301 (the package's own cache folder, as Numba's)
    except Exception:  # a miss: absent, truncated, or written by something else
        pass
    value = compute()
    tmp = None
    try:
        os.makedirs(folder, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=folder, suffix=".tmp")
        with os.fdopen(fd, "wb") as f:
            pickle.dump(value, f, protocol=pickle.HIGHEST_PROTOCOL)
        os.chmod(tmp, 0o644)  # (mkstemp's 0600 would hide it from a shared cache's other users)
        os.replace(tmp, path)
        tmp = None
    except OSError:  # a full or vanished disk only costs the next process the computation
        pass
    finally:
        if tmp is not None and os.path.exists(tmp):
            os.unlink(tmp)
    return value

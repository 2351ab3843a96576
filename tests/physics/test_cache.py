"""The kernel cache cannot go stale, and a read-only install still compiles and caches.

Numba keys a cached kernel on its own source file; the package keys every kernel's entry on a hash
of every Python source of the package (``penalty_env._jit.source_hash``), so an edit of any module a
kernel compiles from is a cache miss. Each test runs a copy of the package in a fresh process.
"""

from __future__ import annotations

import os
import pathlib
import shutil
import subprocess
import sys

import pytest

import penalty_env

PACKAGE = pathlib.Path(penalty_env.__file__).parent


@pytest.fixture
def copy(tmp_path):
    """A copy of the package's sources (no caches) under tmp_path/src."""
    dest = tmp_path / "src" / "penalty_env"
    shutil.copytree(PACKAGE, dest, ignore=shutil.ignore_patterns("__pycache__"))
    return dest


def _run(src: pathlib.Path, code: str, **env: str) -> str:
    full = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    full.update(PYTHONPATH=str(src.parent), PYTHONDONTWRITEBYTECODE="1", **env)
    done = subprocess.run([sys.executable, "-c", code], env=full, capture_output=True, text=True, cwd=src.parent)
    assert done.returncode == 0, done.stderr[-3000:]
    return done.stdout.strip()


_HASH = "import penalty_env._jit as J; print(J.source_hash())"


def test_an_edit_of_any_package_source_changes_every_kernels_cache_key(copy):
    original = _run(copy, _HASH)
    assert _run(PACKAGE, _HASH) == original  # the same sources, elsewhere: the same key
    law = copy / "physics" / "contact" / "law.py"
    law.write_text(law.read_text() + "\n# an edit\n")
    after_law = _run(copy, _HASH)
    assert after_law != original
    bench = copy / "bench" / "env.py"  # not the core, but it may hold kernels that call the core
    bench.write_text(bench.read_text() + "\n# an edit\n")
    assert _run(copy, _HASH) not in (original, after_law)


def test_every_package_kernel_is_keyed_on_the_package_hash(copy):
    code = (
        "import penalty_env._jit as J\n"
        "from penalty_env.envs.balls import kernel\n"
        "from penalty_env.physics import diagnostics\n"
        "for k in (kernel.step_worlds, diagnostics.world_max_penetration):\n"
        "    loc = k._cache._impl.locator\n"
        "    print(type(loc).__name__, loc.get_source_stamp() == ('penalty_env', J.source_hash()))\n"
    )
    assert _run(copy, code).splitlines() == ["PackageCacheLocator True"] * 2


# a World whose construction compiles one small kernel (the start check)
_WORLD = (
    "import penalty_env._jit as J\n"
    "if READ_ONLY:\n"
    "    writable = J._writable\n"
    "    J._writable = lambda p: not p.startswith(J._PACKAGE) and writable(p)\n"
    "import numpy as np\n"
    "from penalty_env.physics import Bowl, World\n"
    "w = World(np.array([[0.0, 0.0, 0.5]]), [0.1], [1.0], terrain=(Bowl((0, 0, 2.0), 2.0),), ks=1e3, kd=1.0, dt=1e-3)\n"
    "print(w.max_penetration())\n"
)


def test_a_read_only_install_compiles_into_the_users_cache_and_loads_from_it(copy, tmp_path):
    """The package folder not writable (really, or, for root who may write anywhere, as the
    package sees it): the kernels go to ``~/.cache/penalty_env/numba``, and the next process
    loads them from there."""
    home = tmp_path / "home"
    home.mkdir()
    as_root = os.geteuid() == 0
    if not as_root:
        for root, _dirs, _files in os.walk(copy):
            os.chmod(root, 0o555)
    code = f"READ_ONLY = {as_root}\n" + _WORLD
    try:
        first = _run(copy, code, HOME=str(home))
        user_cache = home / ".cache" / "penalty_env" / "numba"
        entries = list(user_cache.rglob("*.nbi"))
        assert entries, "nothing was cached in the user's cache folder"
        assert not list(copy.rglob("*.nbi")), "the read-only package folder was written to"
        stamp = {p: p.stat().st_mtime_ns for p in user_cache.rglob("*")}
        second = _run(copy, code, HOME=str(home))
        assert second == first
        assert {p: p.stat().st_mtime_ns for p in user_cache.rglob("*")} == stamp  # loaded, not compiled again
    finally:
        for root, _dirs, _files in os.walk(copy):
            os.chmod(root, 0o755)


def test_a_first_call_that_compiles_says_so_once_and_a_cached_one_is_silent(capsys):
    """``_jit.compile_notice`` (around every first step of a World or an env): a newcomer waiting
    on the compiler is told so, once per kind of kernel, with the time it took."""
    import time
    import uuid

    import numba

    from penalty_env._jit import compile_notice

    @numba.njit
    def fresh(x):  # a new function: its first call compiles
        return x + 1.5

    what = f"test-notice-{uuid.uuid4().hex}"  # (said once per process: a new one per run)
    with compile_notice(what, after=0.01):  # (a compile takes far longer than 10 ms)
        fresh(1.0)
    err = capsys.readouterr().err
    assert f"compiling the {what} kernels" in err and "compiled in" in err
    with compile_notice(what, after=0.01):
        fresh(2.0)  # compiled: nothing to say, and said once anyway
        time.sleep(0.05)  # (past the notice's timer)
    assert capsys.readouterr().err == ""

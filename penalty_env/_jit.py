"""Numba configuration shared by every kernel: compile options, the cache, the threading layer.

Compile options. Kernels are compiled with numpy's error model and without Numba's
reference-counting runtime (``_nrt=False``): they never allocate, and with NRT every call that is
not inlined increfs and decrefs each array argument atomically (measured: ~100 ns per pair check,
and contention between threads). ``fastmath`` is banned: it lets LLVM assume no NaN or inf, which
would delete the ``np.isfinite`` guards that report a blown-up simulation.

Compile time is user time (docs/architecture.md, "Compile time"). Numba's front end (type
inference, lowering) costs more than linearly in a function's size, and ``inline="always"``
copies a callee's IR into every call site and types it again. So kernels are small plain
functions called by value, which LLVM inlines into their callers anyway; arguments are arrays
and scalars of fixed types (shapes and flags are data, not types), so each function compiles
once per dimension.

The cache (:class:`PackageCacheLocator`). Kernels are cached on disk (``cache=True``). Numba keys a
cached kernel on its own source file only, so editing one kernel module would leave code compiled
from it in the caches of the kernels of other modules; here every kernel's cache entry is keyed on
a hash of every Python source of the package (this file included), so an
edit anywhere recompiles everything and nothing stale can run. The cache lives next to the
sources (``__pycache__``) when that is writable, else in the user's cache folder
(``~/.cache/penalty_env/numba``), else in a private temporary folder (``mkdtemp``: never a
predictable shared path, since Numba loads cache files as pickles); a user's ``NUMBA_CACHE_DIR``
always wins. An index written by an older version of the package that names a class that no longer
exists is a cache miss, not an error (``_tolerate_stale_cache_indexes``).

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

import functools
import hashlib
import os
import pickle
import sys
import tempfile
import threading
import time
import types
import warnings
from typing import Any

import numba
import numpy as np
from numba.core import caching
from numba.core import codegen as _codegen
from numba.core import config as _numba_config
from numba.core import event as _numba_event
from numba.extending import overload as _overload

__all__ = [
    "njit",
    "overload_kernel",
    "prange",
    "entry_point",
    "source_hash",
    "PackageCacheLocator",
    "compile_notice",
    "readonly_paths",
    "restore_readonly",
]

prange = numba.prange

_PACKAGE = os.path.dirname(os.path.abspath(__file__))


def _kernel_sources() -> list[str]:
    """Every Python source of the package: any of them may hold a kernel (the benchmarks' and the
    scenarios' too, which call the core's), and a kernel compiles from the sources it calls."""
    files = []
    for root, dirs, names in os.walk(_PACKAGE):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__")
        paths = (os.path.join(root, n) for n in sorted(names) if n.endswith(".py"))
        files += [p for p in paths if os.path.isfile(p)]  # (not an editor's dangling lock link)
    return files


_HASH: list[str] = []


def source_hash() -> str:
    """A hash of every source a kernel of the package can compile from (computed once per process)."""
    if not _HASH:
        digest = hashlib.sha256()
        for path in _kernel_sources():
            with open(path, "rb") as f:
                text = f.read()
            name = os.path.relpath(path, _PACKAGE).replace(os.sep, "/").encode()
            digest.update(b"%d:%s:%d:" % (len(name), name, len(text)) + text)
        _HASH.append(digest.hexdigest()[:20])
    return _HASH[0]


def _writable(path: str) -> bool:
    try:
        os.makedirs(path, exist_ok=True)
        tempfile.TemporaryFile(dir=path).close()
        return True
    except OSError:
        return False


_FALLBACK_DIR: list[str] = []


def _cache_root(py_file: str) -> str:
    """Where the cache of a kernel defined in ``py_file`` goes (see the module docstring)."""
    subpath = os.path.relpath(os.path.dirname(py_file), _PACKAGE).replace(os.sep, "_")
    if _numba_config.CACHE_DIR:  # the user chose (NUMBA_CACHE_DIR)
        return os.path.join(_numba_config.CACHE_DIR, "penalty_env", subpath)
    here = os.path.join(os.path.dirname(py_file), "__pycache__")
    if _writable(here):
        return here
    user = os.path.join(os.path.expanduser("~"), ".cache", "penalty_env", "numba", subpath)
    if _writable(user):
        return user
    if not _FALLBACK_DIR:
        _FALLBACK_DIR.append(tempfile.mkdtemp(prefix="penalty_env-numba-"))
    return os.path.join(_FALLBACK_DIR[0], subpath)


class PackageCacheLocator(caching._CacheLocator):
    """Numba cache locator for this package's kernels: the entry's freshness stamp is the hash of
    every kernel source of the package (:func:`source_hash`), not the one file's; the folder is
    chosen as the module docstring says. Functions of other packages are left to Numba's own
    locators (``from_function`` returns None for them)."""

    def __init__(self, py_func: Any, py_file: str) -> None:
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        self._cache_path = _cache_root(py_file)

    def get_cache_path(self) -> str:
        return self._cache_path

    def get_source_stamp(self) -> Any:
        return ("penalty_env", source_hash())

    def get_disambiguator(self) -> str:
        return str(self._lineno)

    @classmethod
    def from_function(cls, py_func: Any, py_file: str) -> PackageCacheLocator | None:
        path = os.path.abspath(py_file)
        if not path.startswith(_PACKAGE + os.sep) or not os.path.exists(path):
            return None
        self = cls(py_func, path)
        try:
            self.ensure_cache_path()
        except OSError:
            return None
        return self


def _install_locator() -> None:
    classes = caching.CacheImpl._locator_classes
    if PackageCacheLocator.__name__ not in [c.__name__ for c in classes]:
        classes.insert(0, PackageCacheLocator)


_install_locator()


def _choose_threading_layer() -> None:
    """A fork-safe threading layer, unless the user chose one (see the module docstring)."""
    if os.environ.get("NUMBA_THREADING_LAYER"):
        return
    _numba_config.THREADING_LAYER = "forksafe"


_choose_threading_layer()


def _tolerate_stale_cache_indexes() -> None:
    """Treat a Numba cache index that cannot be unpickled as empty (a cache miss), instead of
    crashing the first call. An index pickles the argument types of every compiled signature; one
    written by an older version of this package may name a class that no longer exists, and Numba
    unpickles the index before it checks that the source is unchanged. Numba then recompiles and
    overwrites the index, as for any stale cache. Applies to every Numba cache of the process."""
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


class _CompileDepth(_numba_event.Listener):
    """How deep the compile in progress is nested (1: a kernel called from Python; 2 and more: the
    kernels it calls, compiled while it is typed). Numba compiles under one global lock."""

    depth = 0

    def on_start(self, event: Any) -> None:
        _CompileDepth.depth += 1

    def on_end(self, event: Any) -> None:
        _CompileDepth.depth -= 1


_KERNELS: set[str] = set()  # the qualified names of this package's kernels


def _call_tree(root: Any) -> list:
    """Every library ``root`` links, each once, callers before callees (reversed post-order)."""
    order: list = []
    seen: set[int] = set()
    stack = [(root, iter(root._linking_libraries))]
    while stack:
        _, children = stack[-1]
        child = next(children, None)
        if child is None:
            order.append(stack.pop()[0])
        elif id(child) not in seen:
            seen.add(id(child))
            stack.append((child, iter(child._linking_libraries)))
    order.pop()  # the root itself
    return order[::-1]


def _optimize_once() -> None:
    """Link and optimise a kernel's call tree once, in the kernel called from Python (see the
    module docstring).

    Numba links every callee's LLVM module into its caller's, then optimises and generates machine
    code for the linked whole, at every level of the call tree: a kernel ten calls deep went
    through LLVM ten times, and most of a step's compile time went there (measured: 60%). Here a
    kernel of this package compiled inside another kernel's compile (a callee, depth 2 and more)
    keeps its own code only, unlinked and unoptimised as a module (its calls resolve to the callees'
    own compiled code if it is ever called directly), and a kernel called from Python links its
    whole call tree, once, and optimises it once. Floating-point results do not depend on this (no
    fast-math, no contraction). Callees are not cached on disk (their code is not complete); the
    entry kernels are.
    """
    library_class = getattr(_codegen, "CPUCodeLibrary", None)
    original = getattr(library_class, "finalize", None)
    if original is None or getattr(original, "_penalty_env", False):
        return  # a Numba without this hook: compile as Numba does

    def finalize(self):
        self._codegen._check_llvm_bugs()
        self._raise_if_finalized()
        if _CompileDepth.depth >= 2 and self.name in _KERNELS:
            # a callee: its IR only, for its entries to link (no machine code: without Python
            # wrappers nothing calls it but the kernels it is linked into)
            self._final_module.verify()
            self._finalized = True
            return None
        # an entry (or a library of Numba's, which may link a callee): its whole call tree, once
        for library in _call_tree(self):  # callers before callees: LLVM links a callee's
            # (linkonce) code only where something linked already calls it
            self._reload_init.update(library._reload_init)
            self._final_module.link_in(library._get_module_for_linking(), preserve=True)
        self._optimize_final_module()
        self._final_module.verify()
        self._finalize_final_module()
        return None

    original_functions = library_class._optimize_functions

    def _optimize_functions(self, ll_module):
        if _CompileDepth.depth >= 2 and self.name in _KERNELS:
            ll_module.data_layout = self._codegen._data_layout
            return None  # a callee: optimised once, with its entry
        return original_functions(self, ll_module)

    library_class._optimize_functions = _optimize_functions
    codegen_class = _codegen.JITCPUCodegen
    original_set_env = codegen_class.set_env

    def set_env(self, env_name, env):
        if not self._engine.is_symbol_defined(env_name):
            return None  # a callee's: it has no machine code of its own
        return original_set_env(self, env_name, env)

    finalize._penalty_env = True  # type: ignore[attr-defined]
    library_class.finalize = finalize
    codegen_class.set_env = set_env
    _numba_event.register("numba:compile", _CompileDepth())


_optimize_once()


def _load_without_refresh() -> None:
    """Load this package's cached kernels without first loading every Numba registry.

    Numba refreshes its compilation context (importing all of its typing and lowering modules,
    and through them SciPy: about 0.3 s) before it loads a cached kernel, though the load itself
    compiles nothing; every compile refreshes the context again on its own. So a process whose
    kernels all come from the cache skips that time."""
    original = caching.Cache.load_overload
    if getattr(original, "_penalty_env", False):
        return

    def load_overload(self, sig, target_context):
        if not isinstance(self._impl.locator, PackageCacheLocator):
            return original(self, sig, target_context)
        with self._guard_against_spurious_io_errors():
            return self._load_overload(sig, target_context)

    load_overload._penalty_env = True  # type: ignore[attr-defined]
    caching.Cache.load_overload = load_overload


_load_without_refresh()


def njit(*args, entry: bool = False, hot: bool = False, **kwargs):
    """``numba.njit`` for this package's kernels. Use as ``@njit``, ``@njit(hot=True)``,
    ``@njit(entry=True)`` or ``@njit(entry=True, parallel=True)``.

    ``hot``: LLVM always inlines the kernel into its callers (``forceinline``: the IR is copied by
    LLVM, after Numba compiled the kernel once, so the front end pays nothing). For the kernels
    called once per contact or pair: a call that is not inlined passes every array of its tuple
    arguments (a Model, a shape table) by value, field by field (measured: 20x a rotating pair's
    cost), and LLVM's own heuristics leave a large callee out of line.

    A kernel called from Python is an *entry* (``entry=True``): it is cached on disk (falling back
    to no cache where no folder is writable) and its call tree is linked and optimised into it. Every
    other kernel is a *callee*, compiled only into the entries that call it: without the wrappers
    that let Python call it (each costs as much to compile as a small kernel) and without a cache
    entry of its own. Numpy's error model, no NRT (see the module docstring); ``fastmath`` and
    ``inline="always"`` are refused.
    """
    kwargs.setdefault("error_model", "numpy")
    kwargs.setdefault("_nrt", False)  # kernels never allocate: see the module docstring
    kwargs["forceinline"] = bool(hot) and not entry  # (set either way: Numba's callees inherit it)
    if entry:
        kwargs.setdefault("cache", True)
    else:
        kwargs.update(cache=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
    if kwargs.get("fastmath"):
        raise ValueError("fastmath is banned in penalty_env kernels: it removes NaN/inf checks")
    if kwargs.get("inline", "never") != "never":
        raise ValueError("inline='always' is not used in penalty_env kernels: it multiplies compile time")

    def decorate(func):
        _KERNELS.add(func.__qualname__)
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


_TWINS: dict[Any, Any] = {}


def python_twin(kernel: Any) -> Any:
    """A kernel's source run by Python, its kernel callees likewise (a callee has no wrapper that
    Python could call): one source for a rule that a reset runs compiled over many worlds and a
    constructor runs once, without compiling it."""
    twin = _TWINS.get(kernel)
    if twin is None:
        func = kernel.py_func
        names = dict(func.__globals__)
        twin = _TWINS[kernel] = types.FunctionType(
            func.__code__, names, func.__name__, func.__defaults__, func.__closure__
        )
        for k, v in func.__globals__.items():  # (after the entry above: a module's kernels name each other)
            if isinstance(v, numba.core.registry.CPUDispatcher):
                names[k] = python_twin(v)
    return twin


def overload_kernel(func: Any, hot: bool = False) -> Any:
    """``numba.extending.overload(func)`` for this package: the implementation it returns is a
    callee kernel (see :func:`njit`): no wrappers, no cache entry of its own; ``hot`` as for
    :func:`njit` (a dispatching overload called per world and step: inlined)."""

    def decorate(typer: Any) -> Any:
        @functools.wraps(typer)
        def registering(*args: Any, **kwargs: Any) -> Any:
            impl = typer(*args, **kwargs)
            if impl is not None:
                _KERNELS.add(impl.__qualname__)
            return impl

        options = {
            "error_model": "numpy",
            "_nrt": False,
            "no_cpython_wrapper": True,
            "no_cfunc_wrapper": True,
            "forceinline": bool(hot),
        }
        return _overload(func, jit_options=options)(registering)

    return decorate


class _CompileWatch(_numba_event.Listener):
    """Counts the seconds Numba spends compiling (outermost compiles only) on this thread."""

    def __init__(self) -> None:
        self.depth = 0
        self.start = 0.0
        self.seconds = 0.0

    def on_start(self, event: Any) -> None:
        if self.depth == 0:
            self.start = time.perf_counter()
        self.depth += 1

    def on_end(self, event: Any) -> None:
        self.depth -= 1
        if self.depth == 0:
            self.seconds += time.perf_counter() - self.start


_NOTICE_LOCK = threading.Lock()
_NOTICED: set[str] = set()


class compile_notice:
    """Context manager around a first call that may compile: if Numba compiles for more than
    ``after`` seconds inside it, say so once per ``what`` and process on stderr (a newcomer waiting
    silently thinks the program hung), and how long it took. Silent when the cache was warm."""

    def __init__(self, what: str, after: float = 1.0) -> None:
        self.what = what
        self.after = after
        self._watch = _CompileWatch()
        self._timer: threading.Timer | None = None
        self._said = False

    def _say(self) -> None:
        with _NOTICE_LOCK:
            if self.what in _NOTICED:
                return
            _NOTICED.add(self.what)
        self._said = True
        print(
            f"penalty_env: compiling the {self.what} kernels (once; cached for later processes)...",
            file=sys.stderr,
            flush=True,
        )

    def __enter__(self) -> compile_notice:
        _numba_event.register("numba:compile", self._watch)
        if self.what not in _NOTICED:
            self._timer = threading.Timer(self.after, self._check)
            self._timer.daemon = True
            self._timer.start()
        return self

    def _check(self) -> None:
        if self._watch.depth > 0 or self._watch.seconds > 0.0:
            self._say()

    def __exit__(self, *exc: Any) -> None:
        if self._timer is not None:
            self._timer.cancel()
        _numba_event.unregister("numba:compile", self._watch)
        if self._said:
            print(f"penalty_env: compiled in {self._watch.seconds:.1f} s", file=sys.stderr, flush=True)


def entry_point(fn: Any, args: tuple) -> Any:
    """The compiled function of Numba dispatcher ``fn`` for these arguments' types (compiled or
    loaded from the cache now), to call without Numba's per-call type resolution: that costs about
    a microsecond for each field of a NamedTuple argument, as much as a small world's whole step.
    Only for calls whose argument types are fixed by construction: the entry point does not check
    them again."""
    return fn.compile(tuple(fn.typeof_pyval(a) for a in args))


# ---------------------------------------------------------------- read-only arrays across pickling
# A read-only array is another Numba type than a writable one (``readonly array(float64, ...)``),
# and pickling does not keep numpy's writeable flag: an unpickled object whose kernels were
# compiled for its read-only arrays (a settled bed, the radii, a shape's rotation) would compile
# them anew on its first step (seconds) and run with writable copies. ``readonly_paths`` notes
# where the read-only arrays sit under an object (through its attributes, tuples, lists and dicts,
# and the attributes of the package's own objects) before pickling; ``restore_readonly`` sets the
# flag again at those places after.


def readonly_paths(root: Any) -> list[tuple]:
    """The paths (``("a", name)`` attribute, ``("i", index)`` item steps) from ``root`` to every
    read-only numpy array under it."""
    out: list[tuple] = []
    seen: set[int] = set()

    def walk(value: Any, path: tuple) -> None:
        if isinstance(value, np.ndarray):
            if not value.flags.writeable:
                out.append(path)
            return
        if id(value) in seen:
            return
        if isinstance(value, (tuple, list)):
            seen.add(id(value))
            for i, item in enumerate(value):
                walk(item, path + (("i", i),))
        elif isinstance(value, dict):
            seen.add(id(value))
            for key, item in value.items():
                walk(item, path + (("i", key),))
        elif type(value).__module__.startswith("penalty_env") and hasattr(value, "__dict__"):
            seen.add(id(value))
            for name, item in vars(value).items():
                walk(item, path + (("a", name),))

    walk(root, ())
    return out


def restore_readonly(root: Any, paths: list[tuple]) -> None:
    """Mark the arrays at ``paths`` (from :func:`readonly_paths`) under ``root`` read-only; a path
    no longer there (state an object drops when pickled) is skipped."""
    for path in paths:
        value = root
        try:
            for kind, key in path:
                value = getattr(value, key) if kind == "a" else value[key]
        except (AttributeError, KeyError, IndexError, TypeError):
            continue
        if isinstance(value, np.ndarray):
            value.flags.writeable = False

"""The record of one lever tried on the neighbour list's force pass: SIMD over a ball's listed
pairs (docs/scale.md, section 4).

    python -m penalty_env.bench.simd_lever            # the settled 100,000-ball bed
    python -m penalty_env.bench.simd_lever --n 10000

It times, on one thread, alternately, best of ``--reps`` blocks, over the very list and state a
World of the settled bed steps (``scale.settled_bed``, its ``NeighbourLists``):

  current    the frictionless listed pair law as ``contact_listed.pair_contact_listed`` has it
             (one pair at a time: a gather of x_j, v_j, r_j, the law, a masked scatter-add to a_j);
  two-pass   the same law split in two loops per ball: the first computes every listed pair's
             force magnitude into a buffer (no scatter, no reduction: the shape LLVM's loop
             vectoriser takes), the second scatters them (as the current loop);
  unrolled   the first loop of two-pass written four pairs at a time, straight-line (the shape
             LLVM's SLP vectoriser takes);
  force pass the package's own force pass (``scale._force_pass``: the pairs above plus the
             terrain contacts of the balls near it), for scale;

checks that the current loop's forces are bit for bit the package's force pass's (without the
terrain) and the variants' the current loop's, and reports, from the
compiled code, whether LLVM emitted any vector arithmetic (``<4 x double>`` in the IR, ``vsqrtpd``
/ ``vdivpd`` in the assembly). Kernels are compiled as the package's (no fastmath: LLVM may not
reassociate the sums nor assume a finite distance). The variants have the frictionless law
with tension only, and treat coincident centres as apart (the package hands those to
``pair_contact``; a settled bed has none): ``measure`` checks the forces it compares.
"""

from __future__ import annotations

import argparse
import math
import re
import time
from pathlib import Path

import numba
import numpy as np

from .._jit import njit
from .scale import _force_pass, default_cache_dir, listed_world, settled_bed


@njit(inline="always")
def _law(xs, vs, radii, escaped, ne, j, ri, p0, p1, p2, u0, u1, u2, ks, kd):  # type: ignore[no-untyped-def]
    """Listed pair (i, j)'s normal force over its distance (0 when apart, coincident or escaped)."""
    l0 = ri + radii[j]
    d0 = xs[0, j, 0] - p0
    d1 = xs[0, j, 1] - p1
    d2 = xs[0, j, 2] - p2
    dist2 = d0 * d0 + d1 * d1 + d2 * d2
    dist = np.sqrt(dist2)
    inv = 1.0 / dist
    w0 = vs[0, j, 0] - u0
    w1 = vs[0, j, 1] - u1
    w2 = vs[0, j, 2] - u2
    vn = (w0 * d0 + w1 * d1 + w2 * d2) * inv
    fn = -ks * (l0 - dist) + kd * vn
    touch = (dist2 < l0 * l0) & (dist2 != 0.0) & ((ne == 0) | (escaped[j] == 0))
    return fn * inv if touch else 0.0


@njit(inline="always")
def _ball(i, xs, vs, radii):  # type: ignore[no-untyped-def]
    return radii[i], xs[0, i, 0], xs[0, i, 1], xs[0, i, 2], vs[0, i, 0], vs[0, i, 1], vs[0, i, 2]


@njit(inline="always")
def _push(j, fn, xs, a, p0, p1, p2):  # type: ignore[no-untyped-def]
    """Subtract listed pair (i, j)'s force from a_j; returns it (i's share)."""
    e0 = fn * (xs[0, j, 0] - p0)
    e1 = fn * (xs[0, j, 1] - p1)
    e2 = fn * (xs[0, j, 2] - p2)
    a[0, j, 0] -= e0
    a[0, j, 1] -= e1
    a[0, j, 2] -= e2
    return e0, e1, e2


@njit(inline="always")
def _scatter(i, xs, a, nbr, c, buf, p0, p1, p2):  # type: ignore[no-untyped-def]
    f0 = 0.0
    f1 = 0.0
    f2 = 0.0
    for m in range(c):
        e0, e1, e2 = _push(nbr[i, m], buf[m], xs, a, p0, p1, p2)
        f0 += e0
        f1 += e1
        f2 += e2
    a[0, i, 0] += f0
    a[0, i, 1] += f1
    a[0, i, 2] += f2


@njit(cache=False)  # not cached: vector_code inspects the compiled code
def current(xs, vs, a, nbr, cnt, radii, ks, kd, escaped, ne, buf):  # type: ignore[no-untyped-def]
    for i in range(xs.shape[1]):
        ri, p0, p1, p2, u0, u1, u2 = _ball(i, xs, vs, radii)
        f0 = 0.0
        f1 = 0.0
        f2 = 0.0
        for m in range(cnt[i]):
            j = nbr[i, m]
            fn = _law(xs, vs, radii, escaped, ne, j, ri, p0, p1, p2, u0, u1, u2, ks, kd)
            e0, e1, e2 = _push(j, fn, xs, a, p0, p1, p2)
            f0 += e0
            f1 += e1
            f2 += e2
        a[0, i, 0] += f0
        a[0, i, 1] += f1
        a[0, i, 2] += f2


@njit(cache=False)  # not cached: vector_code inspects the compiled code
def two_pass(xs, vs, a, nbr, cnt, radii, ks, kd, escaped, ne, buf):  # type: ignore[no-untyped-def]
    for i in range(xs.shape[1]):
        ri, p0, p1, p2, u0, u1, u2 = _ball(i, xs, vs, radii)
        c = cnt[i]
        for m in range(c):
            buf[m] = _law(xs, vs, radii, escaped, ne, nbr[i, m], ri, p0, p1, p2, u0, u1, u2, ks, kd)
        _scatter(i, xs, a, nbr, c, buf, p0, p1, p2)


@njit(cache=False)  # not cached: vector_code inspects the compiled code
def unrolled(xs, vs, a, nbr, cnt, radii, ks, kd, escaped, ne, buf):  # type: ignore[no-untyped-def]
    for i in range(xs.shape[1]):
        ri, p0, p1, p2, u0, u1, u2 = _ball(i, xs, vs, radii)
        c = cnt[i]
        m = 0
        while m + 4 <= c:
            g0 = _law(xs, vs, radii, escaped, ne, nbr[i, m], ri, p0, p1, p2, u0, u1, u2, ks, kd)
            g1 = _law(xs, vs, radii, escaped, ne, nbr[i, m + 1], ri, p0, p1, p2, u0, u1, u2, ks, kd)
            g2 = _law(xs, vs, radii, escaped, ne, nbr[i, m + 2], ri, p0, p1, p2, u0, u1, u2, ks, kd)
            g3 = _law(xs, vs, radii, escaped, ne, nbr[i, m + 3], ri, p0, p1, p2, u0, u1, u2, ks, kd)
            buf[m] = g0
            buf[m + 1] = g1
            buf[m + 2] = g2
            buf[m + 3] = g3
            m += 4
        while m < c:
            buf[m] = _law(xs, vs, radii, escaped, ne, nbr[i, m], ri, p0, p1, p2, u0, u1, u2, ks, kd)
            m += 1
        _scatter(i, xs, a, nbr, c, buf, p0, p1, p2)


VARIANTS = {"current": current, "two-pass": two_pass, "unrolled": unrolled}


def vector_code(fn) -> dict[str, int]:  # type: ignore[no-untyped-def]
    """Counts of vector arithmetic in ``fn``'s compiled code (its one signature)."""
    ir = "".join(fn.inspect_llvm().values())
    asm = "".join(fn.inspect_asm().values())
    return {
        "<4 x double>": len(re.findall(r"<4 x double>", ir)),
        "<2 x double>": len(re.findall(r"<2 x double>", ir)),
        "vsqrtpd": len(re.findall(r"vsqrtpd", asm)),
        "vdivpd": len(re.findall(r"vdivpd", asm)),
    }


def measure(n: int = 100_000, steps: int = 10, reps: int = 5, cache_dir: Path | None = None) -> dict[str, float]:
    """ns per ball of each variant and of the package's force pass, on one thread (best of
    ``reps`` alternating blocks of ``steps`` passes). Raises if the current loop's forces are not
    the package's force pass's without the terrain, or a variant's not the current loop's, bit for
    bit."""
    w, _, lw, sm = listed_world(settled_bed(n, cache_dir or default_cache_dir()))
    ne = int(lw.state[3])
    if w._runner.friction is not None or sm.no_tension:
        raise ValueError("the variants have the frictionless law with tension only")
    if ne != 0:
        raise ValueError(f"n={n}: {ne} balls escaped the fresh list; the variants do not skip them as the package does")
    buf = np.zeros(lw.nbr.shape[1])
    args = (lw.x, lw.v)
    rest = (lw.nbr, lw.count, sm.radii, float(sm.ks), float(sm.kd), lw.escaped, ne, buf)
    ref = np.zeros_like(lw.a)
    current(*args, ref, *rest)
    grid = lw.grid
    fargs = (int(grid.dims[0, 2]), int(grid.dims[0, 0] * grid.dims[0, 1]), grid.start[0], lw.x, lw.v)
    friction, g = w._runner.friction, w._runner.g
    package = np.zeros_like(lw.a)
    _force_pass(*fargs, package, lw.nbr, lw.count, np.zeros_like(lw.near), sm, friction, g, lw.escaped, ne, lw.pairs[0])
    if not np.array_equal(package, ref):
        raise AssertionError("current: forces differ from the package's listed pair law")
    for name, fn in VARIANTS.items():
        out = np.zeros_like(lw.a)
        fn(*args, out, *rest)
        if not np.array_equal(out, ref):
            raise AssertionError(f"{name}: forces differ from the current loop's")
    scratch = np.zeros_like(lw.a)

    def pass_(a):  # type: ignore[no-untyped-def]
        _force_pass(*fargs, a, lw.nbr, lw.count, lw.near, sm, friction, g, lw.escaped, ne, lw.pairs[0])

    timed = {name: (lambda a, fn=fn: fn(*args, a, *rest)) for name, fn in VARIANTS.items()}
    timed["force pass"] = pass_
    best = dict.fromkeys(timed, math.inf)
    saved = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        pass_(scratch)
        for _ in range(reps):
            for name, f in timed.items():
                t = time.perf_counter()
                for _ in range(steps):
                    f(scratch)
                best[name] = min(best[name], (time.perf_counter() - t) / steps)
    finally:
        numba.set_num_threads(saved)
    return {name: t / n * 1e9 for name, t in best.items()}


def main(argv=None) -> None:  # type: ignore[no-untyped-def]
    p = argparse.ArgumentParser(prog="python -m penalty_env.bench.simd_lever", description=__doc__.split("\n")[0])
    p.add_argument("--n", type=int, default=100_000, help="balls of the settled bed (default 10^5)")
    p.add_argument("--reps", type=int, default=5, help="alternating blocks (best taken)")
    args = p.parse_args(argv)
    ns = measure(args.n, reps=args.reps)
    print(f"settled bed of {args.n:,} balls, 1 thread, ns per ball and pass (best of {args.reps}):")
    for name, t in ns.items():
        print(f"  {name:<11} {t:7.1f}  ({t / ns['current']:.2f}x current)")
    for name, fn in VARIANTS.items():
        print(f"  {name:<11} vector code: {vector_code(fn)}")


if __name__ == "__main__":
    main()

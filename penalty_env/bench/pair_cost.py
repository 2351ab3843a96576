"""Where a listed pair's time goes: the neighbour list's frictionless pair loop with parts taken
out (docs/scale.md, section 4).

    python -m penalty_env.bench.pair_cost            # the settled 100,000-ball bed
    python -m penalty_env.bench.pair_cost --n 10000

On the very list and state a World of the settled bed steps (``scale.listed_world``), one thread,
alternately, best of ``--reps`` blocks, ns per ball of:

  law            the loop as ``contact_listed.pair_contact_listed`` runs it without friction (flat
                 views, unsigned slots): a gather of x_j, v_j, r_j, the spring-dashpot law, i's
                 share summed in registers, a scatter-add of j's to a_j. Its forces are checked bit
                 for bit against the package's force pass (terrain left out);
  1/dist as dist/dist^2   the law with 1 / dist computed as dist x (1 / dist^2), the division no
                 longer waiting for the square root (other round-off: not the package's law);
  no scatter     the law without the scatter-add to a_j;
  no sqrt, no division    the law with dist = dist^2 and 1 / dist = dist^2 (wrong forces: timing only);
  loads, scatter the gathers and the scatter-add of a stand-in force (no law);
  loads          the gathers alone (and i's sum);
  force pass     the package's force pass (``scale._force_pass``: the pairs and the terrain).

The differences between the rows are what each part costs. Only the first row's forces are
physics; the others exist to be timed.
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

U0, U1, U2, U3 = np.uint64(0), np.uint64(1), np.uint64(2), np.uint64(3)
# the variants' parts: (scatter to a_j, how 1/dist is had, the law at all)
PACKAGE, VIA_DIST2, NO_SQRT = 0, 1, 2


def _variant(scatter: bool, inverse: int, law: bool):  # type: ignore[no-untyped-def]
    @njit(cache=False)  # one per variant, compiled on first use (a few seconds)
    def loop(x, v, a, nbr, cap, cnt, radii, ks, kd, escaped):  # type: ignore[no-untyped-def]
        for i in range(cnt.shape[0]):
            ui = np.uint64(i)
            b = ui * U3
            ri = radii[ui]
            p0, p1, p2 = x[b], x[b + U1], x[b + U2]
            u0, u1, u2 = v[b], v[b + U1], v[b + U2]
            f0 = 0.0
            f1 = 0.0
            f2 = 0.0
            row = ui * np.uint64(cap)
            for m in range(cnt[ui]):
                j = np.uint64(nbr[row + np.uint64(m)])
                c = j * U3
                l0 = ri + radii[j]
                d0 = x[c + U0] - p0
                d1 = x[c + U1] - p1
                d2 = x[c + U2] - p2
                dist2 = d0 * d0 + d1 * d1 + d2 * d2
                if law:
                    if inverse == PACKAGE:
                        dist = np.sqrt(dist2)
                        inv = 1.0 / dist
                    elif inverse == VIA_DIST2:
                        r2 = 1.0 / dist2
                        dist = np.sqrt(dist2)
                        inv = dist * r2
                    else:
                        dist = dist2
                        inv = dist2
                    vn = ((v[c + U0] - u0) * d0 + (v[c + U1] - u1) * d1 + (v[c + U2] - u2) * d2) * inv
                    fn = -ks * (l0 - dist) + kd * vn
                    touch = (dist2 < l0 * l0) & (dist2 != 0.0) & (escaped[j] == 0)
                    fn = fn * inv if touch else 0.0
                else:
                    fn = l0
                e0 = fn * d0
                e1 = fn * d1
                e2 = fn * d2
                f0 += e0
                f1 += e1
                f2 += e2
                if scatter:
                    a[c + U0] -= e0
                    a[c + U1] -= e1
                    a[c + U2] -= e2
            a[b] += f0
            a[b + U1] += f1
            a[b + U2] += f2

    return loop


VARIANTS = {
    "law": (True, PACKAGE, True),
    "1/dist as dist/dist^2": (True, VIA_DIST2, True),
    "no scatter": (False, PACKAGE, True),
    "no sqrt, no division": (True, NO_SQRT, True),
    "loads, scatter": (True, PACKAGE, False),
    "loads": (False, PACKAGE, False),
}


def block_law_vector_code() -> dict[str, int]:
    """Vector instructions in the package's block law (``contact_listed._block_law``) as LLVM
    compiles it on this machine: its source compiled afresh (uncached, so its code can be read)
    with the package's settings, for the signature the force pass calls."""
    from numba import types

    from ..physics.contact_listed import _block_law

    fn = njit(cache=False)(_block_law.py_func)
    fn.compile((types.int64, types.float64[:, ::1], types.float64, types.float64, types.float64, types.int64))
    ir = "".join(fn.inspect_llvm().values())
    asm = "".join(fn.inspect_asm().values())
    return {
        "<4 x double>": ir.count("<4 x double>"),
        "<2 x double>": ir.count("<2 x double>"),
        "vsqrtpd": len(re.findall(r"\bv?sqrtpd\b", asm)),
        "vdivpd": len(re.findall(r"\bv?divpd\b", asm)),
    }


def measure(n: int = 100_000, steps: int = 10, reps: int = 5, cache_dir: Path | None = None) -> dict[str, float]:
    """ns per ball of each variant and of the package's force pass, on one thread (best of ``reps``
    alternating blocks of ``steps`` passes). Raises if the "law" row's forces are not the package's
    force pass's without the terrain, bit for bit, or the bed does not suit the variants."""
    w, _, lw, sm = listed_world(settled_bed(n, cache_dir or default_cache_dir()))
    ne = int(lw.state[3])
    if w._runner.friction is not None or sm.no_tension or lw.x.shape[2] != 3:
        raise ValueError("the variants have the frictionless 3D law with tension only")
    if ne != 0:
        raise ValueError(f"n={n}: {ne} balls escaped the fresh list; the variants do not skip them as the package does")
    loops = {name: _variant(*parts) for name, parts in VARIANTS.items()}
    flat = (lw.x.reshape(-1), lw.v.reshape(-1))
    rest = (lw.nbr.reshape(-1), lw.nbr.shape[1], lw.count, sm.radii, float(sm.ks), float(sm.kd), lw.escaped)
    grid = lw.grid
    fargs = (int(grid.dims[0, 2]), int(grid.dims[0, 0] * grid.dims[0, 1]), grid.start[0], lw.x, lw.v)
    friction, g = w._runner.friction, w._runner.g
    package = np.zeros_like(lw.a)
    _force_pass(*fargs, package, lw.nbr, lw.count, np.zeros_like(lw.near), sm, friction, g, lw.escaped, ne, lw.pairs[0])
    ours = np.zeros_like(lw.a)
    loops["law"](*flat, ours.reshape(-1), *rest)
    if not np.array_equal(package, ours):
        raise AssertionError("law: forces differ from the package's listed pair law")
    scratch = np.zeros_like(lw.a)
    timed = {name: (lambda fn=fn: fn(*flat, scratch.reshape(-1), *rest)) for name, fn in loops.items()}
    timed["force pass"] = lambda: _force_pass(
        *fargs, scratch, lw.nbr, lw.count, lw.near, sm, friction, g, lw.escaped, ne, lw.pairs[0]
    )  # fmt: skip
    best = dict.fromkeys(timed, math.inf)
    saved = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        for f in timed.values():
            f()  # compile
        for _ in range(reps):
            for name, f in timed.items():
                t = time.perf_counter()
                for _ in range(steps):
                    f()
                best[name] = min(best[name], (time.perf_counter() - t) / steps)
    finally:
        numba.set_num_threads(saved)
    out = {name: t / n * 1e9 for name, t in best.items()}
    out["listed pairs per ball"] = float(lw.count.mean())
    return out


def main(argv=None) -> None:  # type: ignore[no-untyped-def]
    p = argparse.ArgumentParser(prog="python -m penalty_env.bench.pair_cost", description=__doc__.split("\n")[0])
    p.add_argument("--n", type=int, default=100_000, help="balls of the settled bed (default 10^5)")
    p.add_argument("--reps", type=int, default=5, help="alternating blocks (best taken)")
    args = p.parse_args(argv)
    ns = measure(args.n, reps=args.reps)
    pairs = ns.pop("listed pairs per ball")
    print(f"settled bed of {args.n:,} balls, {pairs:.2f} listed pairs per ball, 1 thread (best of {args.reps}):")
    print(f"  {'':<22} {'ns / ball':>9} {'ns / pair':>9}")
    for name, t in ns.items():
        print(f"  {name:<22} {t:9.1f} {t / pairs:9.2f}")
    print(f"  the package's block law, vector code: {block_law_vector_code()}")


if __name__ == "__main__":
    main()

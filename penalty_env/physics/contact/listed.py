"""The pair law over neighbour-list pairs (the large-world path), each applied to both balls.

:func:`listed_forces` is :func:`.pair.pair_force` for the balls of a range of the Verlet neighbour
list (:mod:`..broadphase.verlet`). Without friction it runs in blocks of pairs, in three loops: a
gather of each listed pair's centre offset, v.d and rest length (from the two balls' states; with
every radius equal, the rest length without reading the partner's radius), one loop over the
block that computes every pair's force vector with the law (:func:`block_law`: no branch, so LLVM
vectorises it, four pairs per instruction), and the scatter of those forces to both balls, masked
by the contact test. With friction, or for coincident centres, it calls the scalar pair law
itself. The gather and the scatter address the block's rows through one flat view; for the usual
block (PAIR_BLOCK long) their stride is a compile-time constant, so one base register serves all
five.

The terrain here is the static spheres and bowls (:func:`round_terrain_force`, the scalar law's
own :func:`.terrain.round_force`); the neighbour-list path evaluates every other shape in a serial
pass of its own.
"""

from __future__ import annotations

import numpy as np

from ..._jit import njit
from .law import normal_force
from .pair import pair_force
from .terrain import round_force

__all__ = ["PAIR_BLOCK", "PAIR_ROWS", "block_law", "listed_forces", "round_terrain_force"]


@njit(hot=True)
def round_terrain_force(b, i, x, v, out, sm, D):
    """Ball i against every static sphere and bowl of the neighbour list's model ``sm`` (its flat
    ``round_sign``, ``round_center``, ``round_radius``), each force added as it comes."""
    r = sm.radii[i]
    p0 = x[b, i, 0]
    p1 = x[b, i, 1]
    p2 = x[b, i, 2] if D == 3 else 0.0
    u0 = v[b, i, 0]
    u1 = v[b, i, 1]
    u2 = v[b, i, 2] if D == 3 else 0.0
    for s in range(sm.round_radius.shape[0]):
        c = sm.round_center[s]
        touching, f0, f1, f2 = round_force(
            p0,
            p1,
            p2,
            u0,
            u1,
            u2,
            r,
            sm.round_sign[s],
            c[0],
            c[1],
            (c[2] if D == 3 else 0.0),
            sm.round_radius[s],
            sm,
            D,
        )
        if touching:
            out[b, i, 0] += f0
            out[b, i, 1] += f1
            if D == 3:
                out[b, i, 2] += f2


# Pairs per block of the frictionless pass (the block buffer's length is at least this and at
# least the list's capacity, so that any one ball's pairs fit): 128 to 512 measured alike on the
# settled 10^5 bed (docs/scale.md, section 4); 128 keeps a batch of small worlds' buffers small.
PAIR_BLOCK = 128
# the block buffer's rows: per pair, the centre offset x_j - x_i (its third component only in 3D),
# the dot product of the relative velocity with it, and the rest distance r_i + r_j (-1 when j has
# escaped the list); the law overwrites the offset with the force on j (the force over distance
# times the offset), which the scatter adds
_D0, _D1, _D2, _DOT, _REST = 0, 1, 2, 3, 4
PAIR_ROWS = 5


@njit
def block_law(pairs, buf, ks, kd, no_tension, D):
    """Every pair of the block's force along its centre offset (0 when apart, coincident or
    escaped), written over the offset: the law (:func:`.law.normal_force`) of the overlap and the
    opening rate v.d / |d|. One loop with no branch and no gather: LLVM vectorises it
    (``<4 x double>``, ``vsqrtpd``, ``vdivpd``: the same IEEE results lane by lane). Returns how many
    of the pairs have coincident centres (masked here: their normal is 0 / 0)."""
    r0 = buf[_D0]
    r1 = buf[_D1]
    r2 = buf[_D2]
    dots = buf[_DOT]
    rest = buf[_REST]
    coincident = 0
    for k in range(pairs):
        d0 = r0[k]
        d1 = r1[k]
        d2 = r2[k] if D == 3 else 0.0
        dist2 = d0 * d0 + d1 * d1 + d2 * d2
        l0 = rest[k]
        dist = np.sqrt(dist2)
        inv = 1.0 / dist
        vn = dots[k] * inv
        fn = -normal_force(ks, kd, l0 - dist, vn, no_tension)  # along +n on i, as in pair_force
        touch = (dist2 < l0 * l0) & (dist2 != 0.0) & (l0 > 0.0)
        over = fn * inv if touch else 0.0
        r0[k] = over * d0
        r1[k] = over * d1
        if D == 3:
            r2[k] = over * d2
        coincident += dist2 == 0.0
    return coincident


@njit(hot=True)
def _skips(i, escaped, ne):
    """Ball i has escaped its list: its pairs are not listed ones (the caller meets them)."""
    return ne > 0 and escaped[i] != 0


@njit(hot=True)
def _gather(i0, i1, xf, vf, nbf, width, cnt, radii, diameter, escaped, ne, buf, stride, D):
    """The block's pairs (rows _D0 to _REST) for balls i0, i0 + 1, ... of [i0, i1) while their
    pairs fit in ``buf``. ``diameter`` > 0: every pair's r_i + r_j (all radii equal: no partner's
    radius read). Returns the ball after the last one gathered and the pairs gathered."""
    bf = buf.reshape(buf.size)
    S = np.uint64(stride)
    k = np.uint64(0)
    i = i0
    while i < i1 and k + np.uint64(cnt[i]) <= S:
        if not _skips(i, escaped, ne):
            ui = np.uint64(i) * np.uint64(D)
            row = np.uint64(i) * np.uint64(width)
            ri = radii[i]
            p0 = xf[ui]
            p1 = xf[ui + np.uint64(1)]
            p2 = xf[ui + np.uint64(2)] if D == 3 else 0.0
            u0 = vf[ui]
            u1 = vf[ui + np.uint64(1)]
            u2 = vf[ui + np.uint64(2)] if D == 3 else 0.0
            for m in range(cnt[i]):
                # an unsigned slot: no negative-index wraparound to compute on every load
                j = np.uint64(nbf[row + np.uint64(m)])
                c = j * np.uint64(D)
                l0 = diameter if diameter > 0.0 else ri + radii[j]
                d0 = xf[c] - p0
                d1 = xf[c + np.uint64(1)] - p1
                d2 = xf[c + np.uint64(2)] - p2 if D == 3 else 0.0
                w0 = vf[c] - u0
                w1 = vf[c + np.uint64(1)] - u1
                w2 = vf[c + np.uint64(2)] - u2 if D == 3 else 0.0
                bf[np.uint64(_D0) * S + k] = d0
                bf[np.uint64(_D1) * S + k] = d1
                if D == 3:
                    bf[np.uint64(_D2) * S + k] = d2
                bf[np.uint64(_DOT) * S + k] = w0 * d0 + w1 * d1 + w2 * d2
                # a pair with an escaped ball is not a listed one (the caller meets it): never
                # touching, marked by a negative rest length (r_i + r_j > 0 for any pair)
                bf[np.uint64(_REST) * S + k] = l0 if (ne == 0 or escaped[j] == 0) else -1.0
                k += np.uint64(1)
        i += 1
    return i, np.int64(k)


@njit(hot=True)
def _scatter_pairs(bf, stride, k, af, nbf, row, count, D):
    """One ball's listed pairs from the block (its force rows ``stride`` apart in the flat view
    ``bf``, from slot k): each partner's share subtracted from its acceleration, the ball's summed.
    Returns the next slot and the ball's sum."""
    S = np.uint64(stride)
    f0 = 0.0
    f1 = 0.0
    f2 = 0.0
    for m in range(count):
        j = np.uint64(nbf[row + np.uint64(m)])
        c = j * np.uint64(D)
        e0 = bf[np.uint64(_D0) * S + k]
        e1 = bf[np.uint64(_D1) * S + k]
        f0 += e0
        f1 += e1
        af[c] -= e0
        af[c + np.uint64(1)] -= e1
        if D == 3:
            e2 = bf[np.uint64(_D2) * S + k]
            f2 += e2
            af[c + np.uint64(2)] -= e2
        k += np.uint64(1)
    return k, f0, f1, f2


@njit(hot=True)
def _scatter(i0, i1, xs, vs, a, xf, af, nbr, nbf, width, cnt, near, sm, escaped, ne, buf, coincident, D):
    """Apply the block's forces (rows _D0 to _D2 after the law) of balls [i0, i1), ball after
    ball in the order gathered: j's share subtracted from a_j, i's summed in registers and added
    after its pairs; coincident centres through pair_force (before i's sum, as if in the loop: each listed j
    appears once); then the terrain of a ball listed near it or escaped."""
    bf = buf.reshape(buf.size)
    fixed = buf.shape[1] == PAIR_BLOCK  # the usual buffer: its rows' stride a constant
    k = np.uint64(0)
    for i in range(i0, i1):
        escaped_i = _skips(i, escaped, ne)
        if not escaped_i:
            ui = np.uint64(i) * np.uint64(D)
            p0 = xf[ui]
            p1 = xf[ui + np.uint64(1)]
            p2 = xf[ui + np.uint64(2)] if D == 3 else 0.0
            row = np.uint64(i) * np.uint64(width)
            if fixed:  # the same loop, its rows at a compile-time stride
                k, f0, f1, f2 = _scatter_pairs(bf, PAIR_BLOCK, k, af, nbf, row, cnt[i], D)
            else:
                k, f0, f1, f2 = _scatter_pairs(bf, buf.shape[1], k, af, nbf, row, cnt[i], D)
            if coincident > 0:  # in this block: test this ball's pairs
                for m in range(cnt[i]):
                    j = np.uint64(nbr[i, m])
                    c = j * np.uint64(D)
                    d0 = xf[c] - p0
                    d1 = xf[c + np.uint64(1)] - p1
                    d2 = xf[c + np.uint64(2)] - p2 if D == 3 else 0.0
                    if d0 * d0 + d1 * d1 + d2 * d2 == 0.0 and (ne == 0 or escaped[j] == 0):
                        pair_force(0, i, nbr[i, m], xs, vs, a, sm, D)
            af[ui] += f0
            af[ui + np.uint64(1)] += f1
            if D == 3:
                af[ui + np.uint64(2)] += f2
        if escaped_i or (near[i] & 1) != 0:
            round_terrain_force(0, i, xs, vs, a, sm, D)


@njit(hot=True)
def listed_forces(i0, i1, xs, vs, a, nbr, cnt, near, sm, g, escaped, ne, buf):
    """Listed pair forces (each pair once: added to i, subtracted from j) and terrain contacts of
    the balls in storage slots [i0, i1), in that order, skipping escaped balls' pairs (and pairs
    with an escaped ball); the terrain is tested for the balls listed near it and the escaped ones.
    ``buf`` is a (PAIR_ROWS, >= max(PAIR_BLOCK, the list's capacity)) scratch block.

    Without friction the pairs go block by block (gather, :func:`block_law`, scatter): the same
    arithmetic in the same order as one loop over the list (every entry evaluated without a
    branch, masked by the contact test, i's share summed in registers), so the same forces bit for
    bit, with the law's square roots and divisions four pairs at a time. It agrees with
    pair_force to round-off (``tests/physics/test_neighbour_list.py``). The partners are read
    through flat views with unsigned slots (``j * D + k``: no negative-index wraparound, no runtime
    stride). Friction goes through pair_force itself, one ball after another.
    """
    D = len(g)
    if sm.mu > 0.0:
        for i in range(i0, i1):
            escaped_i = _skips(i, escaped, ne)
            if not escaped_i:
                for m in range(cnt[i]):
                    j = nbr[i, m]
                    if ne == 0 or escaped[j] == 0:
                        pair_force(0, i, j, xs, vs, a, sm, D)
            if escaped_i or (near[i] & 1) != 0:
                round_terrain_force(0, i, xs, vs, a, sm, D)
        return
    xf = xs.reshape(xs.size)
    vf = vs.reshape(vs.size)
    af = a.reshape(a.size)
    nbf = nbr.reshape(nbr.size)
    width = nbr.shape[1]
    # the usual buffer is PAIR_BLOCK long: its five rows then sit at compile-time offsets from one
    # base register (the arithmetic loops only are compiled twice, not the calls of the reference)
    fixed = buf.shape[1] == PAIR_BLOCK
    start = i0
    while start < i1:
        if fixed:
            end, pairs = _gather(
                start, i1, xf, vf, nbf, width, cnt, sm.radii, sm.diameter, escaped, ne, buf, PAIR_BLOCK, D
            )  # fmt: skip
        else:
            end, pairs = _gather(
                start, i1, xf, vf, nbf, width, cnt, sm.radii, sm.diameter, escaped, ne, buf, buf.shape[1], D
            )  # fmt: skip
        coincident = block_law(pairs, buf, sm.ks, sm.kd, sm.no_tension, D)
        _scatter(start, end, xs, vs, a, xf, af, nbr, nbf, width, cnt, near, sm, escaped, ne, buf, coincident, D)
        start = end

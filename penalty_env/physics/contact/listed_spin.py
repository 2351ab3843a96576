"""The rotating law over neighbour-list pairs (the large-world path of spinning balls).

:func:`listed_spin_forces` is :func:`.spin.spin_forces` for the balls of a range of the Verlet
neighbour list (:mod:`..broadphase.verlet`): each listed pair once, through the scalar law itself
(:func:`.spin.spin_pair`: the normal law, the slip at the middle of the overlap, the tangential
force with or without history, the torques, rolling resistance), its spring in the list's packed store
(:mod:`..broadphase.history`); then the static spheres and bowls of a ball listed near them or
escaped (:func:`.spin.spin_terrain_contact`, the spring at ``sp.hist[0, i, s]``, s the shape's row
in the table). The other shapes, and the pairs of escaped balls, go in the serial
passes of :mod:`..stepping.large_spin`. Nothing of the law is written here: only where the springs
are and which pairs are met.
"""

from __future__ import annotations

import numpy as np

from ..._jit import njit
from ..geometry.sdf import sdf_round
from .pair import pair_normal
from .spin import spin_pair_law, spin_terrain_contact

__all__ = ["listed_spin_forces", "spin_block_law", "spin_round_terrain", "SPIN_BLOCK", "SPIN_ROWS"]


@njit(hot=True)
def spin_round_terrain(i, xs, vs, a, sm, sp, round_row, first, D):
    """Ball i against every static sphere and bowl of the list's model ``sm`` (its flat copies), each
    contact's spring at slot ``first + round_row[s]``."""
    r = sm.radii[i]
    p0 = xs[0, i, 0]
    p1 = xs[0, i, 1]
    p2 = xs[0, i, 2] if D == 3 else 0.0
    for s in range(sm.round_radius.shape[0]):
        sign = sm.round_sign[s]
        R = sm.round_radius[s]
        d0 = p0 - sm.round_center[s, 0]
        d1 = p1 - sm.round_center[s, 1]
        q2 = p2 - sm.round_center[s, 2] if D == 3 else 0.0
        d2 = d0 * d0 + d1 * d1
        if D == 3:
            d2 += q2 * q2
        # the miss test without a square root (as contact.terrain.round_force)
        if sign > 0.0:
            if d2 >= (R + r) * (R + r):
                continue
        elif R > r and d2 <= (R - r) * (R - r):
            continue
        phi, n0, n1, n2 = sdf_round(d0, d1, q2, R, 0.0, 0.0, D)
        pen = r - sign * phi
        if not pen > 0.0:
            continue
        spin_terrain_contact(
            0, i, first + round_row[s], pen, sign * n0, sign * n1, sign * n2, 0.0, 0.0, 0.0, vs, a, sm, sp, D
        )


# Pairs per block of the spinning pass (a ball's pairs may span two blocks) and the block's rows,
# each SPIN_BLOCK long in one flat buffer: at compile-time offsets from one base, so LLVM needs no
# run-time check that a row's stores miss the other rows' loads, and vectorises the law's loop
SPIN_BLOCK = 128
# inputs: the centre offset x_j - x_i, v_j - v_i, w_i, w_j (3-vectors), r_i, r_j, the rest length
# (-1: j has escaped, not a listed pair) and the spring from the step before (zero: a new contact);
# the law writes over them: the force on i over the offset, i's torque over v_j - v_i, j's torque
# over w_i, the spring over itself, and 1 (touching) or 0 over the rest length
_DX, _UX, _WI, _WJ, _RI, _RJ, _L0, _HX = 0, 3, 6, 9, 12, 13, 14, 15
SPIN_ROWS = 18


@njit(hot=True)
def _spin_gather(i, m, i1, xs, vs, nbr, cnt, sm, sp, first, springs, escaped, ne, bf, D):
    """The block's pairs, from ball i's m-th listed partner on, ball after ball of [i, i1) (escaped
    balls skipped), until the block is full. Returns where it stopped (i, m) and the pairs. The
    arrays are read through flat views with unsigned indices (no negative-index wraparound and no
    run-time stride per element, as :mod:`.listed`'s gather)."""
    B = SPIN_BLOCK
    R = sp.w.shape[2]
    width = np.uint64(nbr.shape[1])
    xf = xs.reshape(xs.size)
    vf = vs.reshape(vs.size)
    wf = sp.w.reshape(sp.w.size)
    hf = springs.reshape(springs.size)
    nf = nbr.reshape(nbr.size)
    history = sm.mu > 0.0 and sp.kt > 0.0
    same = sm.diameter > 0.0  # every radius equal: no partner's radius read
    k = 0
    while i < i1 and k < B:
        if ne > 0 and escaped[i] != 0:
            i += 1
            m = 0
            continue
        ri = sm.radii[i]
        ui = np.uint64(i) * np.uint64(D)
        wi = np.uint64(i) * np.uint64(R)
        p0 = xf[ui]
        p1 = xf[ui + np.uint64(1)]
        p2 = xf[ui + np.uint64(2)] if D == 3 else 0.0
        u0 = vf[ui]
        u1 = vf[ui + np.uint64(1)]
        u2 = vf[ui + np.uint64(2)] if D == 3 else 0.0
        wi0 = wf[wi] if D == 3 else 0.0
        wi1 = wf[wi + np.uint64(1)] if D == 3 else 0.0
        wi2 = wf[wi + np.uint64(2)] if D == 3 else wf[wi]
        row = np.uint64(i) * width
        base = np.uint64(first[i]) * np.uint64(3)
        while m < cnt[i] and k < B:
            j = np.uint64(nf[row + np.uint64(m)])
            rj = ri if same else sm.radii[j]
            cj = j * np.uint64(D)
            wj = j * np.uint64(R)
            bf[_DX * B + k] = xf[cj] - p0
            bf[(_DX + 1) * B + k] = xf[cj + np.uint64(1)] - p1
            bf[(_DX + 2) * B + k] = xf[cj + np.uint64(2)] - p2 if D == 3 else 0.0
            bf[_UX * B + k] = vf[cj] - u0
            bf[(_UX + 1) * B + k] = vf[cj + np.uint64(1)] - u1
            bf[(_UX + 2) * B + k] = vf[cj + np.uint64(2)] - u2 if D == 3 else 0.0
            bf[_WI * B + k] = wi0
            bf[(_WI + 1) * B + k] = wi1
            bf[(_WI + 2) * B + k] = wi2
            bf[_WJ * B + k] = wf[wj] if D == 3 else 0.0
            bf[(_WJ + 1) * B + k] = wf[wj + np.uint64(1)] if D == 3 else 0.0
            bf[(_WJ + 2) * B + k] = wf[wj + np.uint64(2)] if D == 3 else wf[wj]
            bf[_RI * B + k] = ri
            bf[_RJ * B + k] = rj
            bf[_L0 * B + k] = ri + rj if (ne == 0 or escaped[j] == 0) else -1.0
            h = base + np.uint64(m) * np.uint64(3)  # (zero: a new contact, see ..broadphase.history)
            bf[_HX * B + k] = hf[h] if history else 0.0
            bf[(_HX + 1) * B + k] = hf[h + np.uint64(1)] if history else 0.0
            bf[(_HX + 2) * B + k] = hf[h + np.uint64(2)] if history and D == 3 else 0.0
            k += 1
            m += 1
        if m >= cnt[i]:
            i += 1
            m = 0
    return i, m, k


@njit
def spin_block_law(pairs, bf, sm, sp, D):
    """:func:`.spin.spin_pair_law` of every pair of the block (the contact test and the normal as
    :func:`.pair.pair_geometry`'s), its results written over the block's inputs; apart (or with an
    escaped partner), zeros. One loop without a branch or a gather: LLVM vectorises it, the law's
    square roots and divisions several pairs per instruction, the same IEEE results as one at a
    time (``tests/physics/test_neighbour_list_spin.py`` checks that it vectorises)."""
    B = SPIN_BLOCK
    for k in range(pairs):
        d0 = bf[_DX * B + k]
        d1 = bf[(_DX + 1) * B + k]
        d2 = bf[(_DX + 2) * B + k]
        l0 = bf[_L0 * B + k]
        dist2 = d0 * d0 + d1 * d1
        if D == 3:
            dist2 += d2 * d2
        touch = (dist2 < l0 * l0) & (l0 > 0.0)
        overlap, n0, n1, n2 = pair_normal(d0, d1, d2, dist2, l0, D)
        h = (bf[_HX * B + k], bf[(_HX + 1) * B + k], bf[(_HX + 2) * B + k])
        f0, f1, f2, q0, q1, q2, li, lj, m0, m1, m2, x0, x1, x2 = spin_pair_law(
            overlap,
            n0,
            n1,
            n2,
            bf[_UX * B + k],
            bf[(_UX + 1) * B + k],
            bf[(_UX + 2) * B + k],
            bf[_WI * B + k],
            bf[(_WI + 1) * B + k],
            bf[(_WI + 2) * B + k],
            bf[_WJ * B + k],
            bf[(_WJ + 1) * B + k],
            bf[(_WJ + 2) * B + k],
            bf[_RI * B + k],
            bf[_RJ * B + k],
            h,
            sm,
            sp,
            D,
            True,  # (select-style: this pass vectorises)
        )
        bf[_DX * B + k] = f0 if touch else 0.0
        bf[(_DX + 1) * B + k] = f1 if touch else 0.0
        bf[(_DX + 2) * B + k] = f2 if touch else 0.0
        # torques: on i l_i q + m, on j l_j q - m (q = n x f_t, m the rolling torque)
        bf[_UX * B + k] = li * q0 + m0 if touch else 0.0
        bf[(_UX + 1) * B + k] = li * q1 + m1 if touch else 0.0
        bf[(_UX + 2) * B + k] = li * q2 + m2 if touch else 0.0
        bf[_WI * B + k] = lj * q0 - m0 if touch else 0.0
        bf[(_WI + 1) * B + k] = lj * q1 - m1 if touch else 0.0
        bf[(_WI + 2) * B + k] = lj * q2 - m2 if touch else 0.0
        bf[_HX * B + k] = x0
        bf[(_HX + 1) * B + k] = x1
        bf[(_HX + 2) * B + k] = x2
        bf[_L0 * B + k] = 1.0 if touch else 0.0


@njit(hot=True)
def _spin_scatter(i, m, pairs, a, nbr, cnt, sm, sp, first, springs, escaped, ne, bf, D):
    """Apply the block gathered from ball i's m-th partner on (the same walk as
    :func:`_spin_gather`): each pair's spring stored (zero for a pair apart), j's force and torque
    subtracted and added as they come, i's summed and added after its pairs of the block (flat
    views, unsigned indices)."""
    B = SPIN_BLOCK
    R = sp.w.shape[2]
    width = np.uint64(nbr.shape[1])
    af = a.reshape(a.size)
    tf = sp.alpha.reshape(sp.alpha.size)
    hf = springs.reshape(springs.size)
    nf = nbr.reshape(nbr.size)
    history = sm.mu > 0.0 and sp.kt > 0.0
    k = 0
    while k < pairs:
        if (ne > 0 and escaped[i] != 0) or m >= cnt[i]:
            i += 1
            m = 0
            continue
        F0 = F1 = F2 = T0 = T1 = T2 = 0.0
        row = np.uint64(i) * width
        base = np.uint64(first[i]) * np.uint64(3)
        while m < cnt[i] and k < pairs:
            touching = bf[_L0 * B + k] != 0.0
            if history:
                h = base + np.uint64(m) * np.uint64(3)
                hf[h] = bf[_HX * B + k] if touching else 0.0
                hf[h + np.uint64(1)] = bf[(_HX + 1) * B + k] if touching else 0.0
                hf[h + np.uint64(2)] = bf[(_HX + 2) * B + k] if touching else 0.0
            if touching:
                j = np.uint64(nf[row + np.uint64(m)])
                cj = j * np.uint64(D)
                wj = j * np.uint64(R)
                f0 = bf[_DX * B + k]
                f1 = bf[(_DX + 1) * B + k]
                F0 += f0
                F1 += f1
                af[cj] -= f0
                af[cj + np.uint64(1)] -= f1
                T2 += bf[(_UX + 2) * B + k]
                if D == 3:
                    f2 = bf[(_DX + 2) * B + k]
                    F2 += f2
                    af[cj + np.uint64(2)] -= f2
                    T0 += bf[_UX * B + k]
                    T1 += bf[(_UX + 1) * B + k]
                    tf[wj] += bf[_WI * B + k]
                    tf[wj + np.uint64(1)] += bf[(_WI + 1) * B + k]
                    tf[wj + np.uint64(2)] += bf[(_WI + 2) * B + k]
                else:
                    tf[wj] += bf[(_WI + 2) * B + k]
            k += 1
            m += 1
        ui = np.uint64(i) * np.uint64(D)
        wi = np.uint64(i) * np.uint64(R)
        af[ui] += F0
        af[ui + np.uint64(1)] += F1
        if D == 3:
            af[ui + np.uint64(2)] += F2
            tf[wi] += T0
            tf[wi + np.uint64(1)] += T1
            tf[wi + np.uint64(2)] += T2
        else:
            tf[wi] += T2


@njit
def listed_spin_forces(i0, i1, xs, vs, a, nbr, cnt, near, sm, sp, first, springs, round_row, escaped, ne, buf, D):
    """Listed pair forces and torques (each pair once, from its lower slot i: added to i, the
    opposite to j) of the balls in storage slots [i0, i1), block by block (gather,
    :func:`spin_block_law`, scatter; ``buf`` a flat scratch of SPIN_ROWS x SPIN_BLOCK), skipping
    escaped balls' pairs and pairs with an escaped ball (their springs packed in the list's order:
    ``springs[first[i] + m]``, :mod:`..broadphase.history`); then the static spheres' and bowls'
    contacts of the balls listed near them and of the escaped ones. Agrees with the scalar path to
    round-off (``tests/physics/test_neighbour_list_spin.py``): the same law per pair, bit for bit,
    summed in another order."""
    i = i0
    m = 0
    while i < i1:
        i2, m2, pairs = _spin_gather(i, m, i1, xs, vs, nbr, cnt, sm, sp, first, springs, escaped, ne, buf, D)
        spin_block_law(pairs, buf, sm, sp, D)
        _spin_scatter(i, m, pairs, a, nbr, cnt, sm, sp, first, springs, escaped, ne, buf, D)
        i = i2
        m = m2
    for i in range(i0, i1):
        if (ne > 0 and escaped[i] != 0) or (near[i] & 1) != 0:
            spin_round_terrain(i, xs, vs, a, sm, sp, round_row, 0, D)

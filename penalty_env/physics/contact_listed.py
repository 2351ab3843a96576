"""The pair contact law's neighbour-list twin: one ball's listed pairs, each applied to both balls.

:func:`pair_contact_listed` is :func:`.contact.pair_contact` (FORCE mode) for the Verlet neighbour
list of :mod:`.neighbour_list`: without friction it evaluates every listed pair branch-free, masked
by the contact test, and sums ball i's share in registers; with friction, or for coincident centres,
it calls the reference itself.
"""

from __future__ import annotations

import numpy as np

from .._jit import njit
from .contact import FORCE, pair_contact

__all__ = ["pair_contact_listed"]


@njit(inline="always")
def pair_contact_listed(i, xs, vs, a, nbr, cnt, sm, friction, g, escaped, ne, xf, vf, af):
    """Apply the pair forces of ball i's list (each pair once: added to i, subtracted from j),
    skipping escaped balls. ``xf``, ``vf``, ``af`` are flat views of ``xs``, ``vs``, ``a`` (one world).

    Without friction this is :func:`.contact.pair_contact`'s FORCE law written for the list: every entry is
    evaluated without a branch and masked by the contact test, and i's share is summed in registers
    (the contact test is a coin flip in a pile, and a mispredicted branch costs more than the
    arithmetic it skips: 2x faster, measured). Same law, operations in a different order: it agrees
    with pair_contact to round-off (``tests/physics/test_neighbour_list.py``). Friction goes through
    pair_contact itself, and so do coincident centres (after the loop, before i's sum is added: what
    a ball receives, and in which order, is as if they had been called in the loop).

    The loop reads its partners through the flat views with an unsigned slot (``j * D + k``: no
    negative-index wraparound and no runtime stride per load or store), tests ``escaped[j]``
    without ``ne`` (at force time a slot is marked only while ``ne > 0``: ``run_large`` clears every
    mark when it rebuilds and counts every mark into ``ne`` at the end of the step that set it),
    and takes coincident centres out of the loop: 15% less time for the settled 10^5 bed's force
    pass, bit for bit the same forces (docs/scale.md, section 4).
    """
    D = len(g)
    if friction is not None:
        for m in range(cnt[i]):
            j = nbr[i, m]
            if ne == 0 or escaped[j] == 0:
                pair_contact(FORCE, 0, i, j, xs, vs, a, 0.0, True, sm, friction, g)
        return
    ks = sm.ks
    kd = sm.kd
    radii = sm.radii
    no_tension = sm.no_tension
    ri = radii[i]
    p0 = xs[0, i, 0]
    p1 = xs[0, i, 1]
    p2 = xs[0, i, 2] if D == 3 else 0.0
    u0 = vs[0, i, 0]
    u1 = vs[0, i, 1]
    u2 = vs[0, i, 2] if D == 3 else 0.0
    f0 = 0.0
    f1 = 0.0
    f2 = 0.0
    coincident = False
    for m in range(cnt[i]):
        # an unsigned slot: no negative-index wraparound to compute on every load and store
        j = np.uint64(nbr[i, m])
        c = j * np.uint64(D)
        l0 = ri + radii[j]
        d0 = xf[c + np.uint64(0)] - p0
        d1 = xf[c + np.uint64(1)] - p1
        d2 = xf[c + np.uint64(2)] - p2 if D == 3 else 0.0
        dist2 = d0 * d0 + d1 * d1 + d2 * d2
        dist = np.sqrt(dist2)
        inv = 1.0 / dist
        w0 = vf[c + np.uint64(0)] - u0
        w1 = vf[c + np.uint64(1)] - u1
        w2 = vf[c + np.uint64(2)] - u2 if D == 3 else 0.0
        vn = (w0 * d0 + w1 * d1 + w2 * d2) * inv
        fn = -ks * (l0 - dist) + kd * vn  # along +n on i, as in pair_contact
        if no_tension:
            fn = min(fn, 0.0)
        # coincident centres (inv = inf, fn nan) are masked here and handed to pair_contact below;
        # & rather than and / or: no branch
        coincident |= dist2 == 0.0
        touch = (dist2 < l0 * l0) & (dist2 != 0.0) & (escaped[j] == 0)
        fn = fn * inv if touch else 0.0
        e0 = fn * d0
        e1 = fn * d1
        f0 += e0
        f1 += e1
        af[c + np.uint64(0)] -= e0
        af[c + np.uint64(1)] -= e1
        if D == 3:
            e2 = fn * d2
            f2 += e2
            af[c + np.uint64(2)] -= e2
    if coincident:  # before i's sum is added, as if in the loop: each listed j appears once
        for m in range(cnt[i]):
            j = np.uint64(nbr[i, m])
            d0 = xs[0, j, 0] - p0
            d1 = xs[0, j, 1] - p1
            d2 = xs[0, j, 2] - p2 if D == 3 else 0.0
            if d0 * d0 + d1 * d1 + d2 * d2 == 0.0 and (ne == 0 or escaped[j] == 0):
                pair_contact(FORCE, 0, i, nbr[i, m], xs, vs, a, 0.0, True, sm, friction, g)
    a[0, i, 0] += f0
    a[0, i, 1] += f1
    if D == 3:
        a[0, i, 2] += f2

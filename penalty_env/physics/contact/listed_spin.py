"""The rotating law over neighbour-list pairs (the large-world path of spinning balls).

:func:`listed_spin_forces` is :func:`.spin.spin_forces` for the balls of a range of the Verlet
neighbour list (:mod:`..broadphase.verlet`): each listed pair once, through the scalar law itself
(:func:`.spin.spin_pair`: the normal law, the slip at the middle of the overlap, the tangential
force with or without history, the torques, rolling resistance), its spring at the list's address
``sp.hist[0, i, m]`` (:mod:`..broadphase.history`); then the static spheres and bowls of a ball
listed near them or escaped (:func:`.spin.spin_terrain_contact`, the spring at ``[0, i, cap + s]``,
s the shape's row in the table). The other shapes, and the pairs of escaped balls, go in the serial
passes of :mod:`..stepping.large_spin`. Nothing of the law is written here: only where the springs
are and which pairs are met.
"""

from __future__ import annotations

from ..._jit import njit
from ..geometry.sdf import sdf_round
from .spin import spin_pair, spin_terrain_contact

__all__ = ["listed_spin_forces", "spin_round_terrain"]


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


@njit
def listed_spin_forces(i0, i1, xs, vs, a, nbr, cnt, near, sm, sp, round_row, escaped, ne, D):
    """Listed pair forces and torques (each pair once, from its lower slot i: added to i, the
    opposite to j) and the static spheres' and bowls' contacts of the balls in storage slots
    [i0, i1), in that order, skipping escaped balls' pairs (and pairs with an escaped ball); the
    terrain for the balls listed near it and the escaped ones. Agrees with the scalar path to
    round-off (``tests/physics/test_neighbour_list_spin.py``)."""
    cap = nbr.shape[1]
    for i in range(i0, i1):
        escaped_i = ne > 0 and escaped[i] != 0
        if not escaped_i:
            for m in range(cnt[i]):
                j = nbr[i, m]
                if ne == 0 or escaped[j] == 0:
                    spin_pair(0, i, j, i, m, xs, vs, a, sm, sp, D)
        if escaped_i or (near[i] & 1) != 0:
            spin_round_terrain(i, xs, vs, a, sm, sp, round_row, cap, D)

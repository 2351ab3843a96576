"""The tangential springs of a neighbour-list world: stored per list slot, carried through rebuilds.

On the scalar path a spring lives at ``Spin.hist[b, i, j]``, one slot per ball pair: O(n^2), which
a world of 10^5 balls cannot hold. The neighbour-list path (:mod:`..stepping.large_spin`) keeps a
:class:`~..model.Spin` of its own whose rows are its storage slots and whose columns are the
list's: ``hist[0, i, m]`` is the spring of i and its m-th listed partner ``nbr[i, m]`` (kept from
i's side, the pair's lower slot), ``hist[0, i, cap + s]`` that of i and terrain shape s. Memory:
``n x (cap + shapes) x 32`` bytes (the spring and its stamp), O(n x neighbours).

A pair whose ball has escaped its list (:mod:`..stepping.large`) is met by the serial escaped pass,
which finds its spring where the list holds it, and else in a small table of the escaped ball's
own (:attr:`ListHistory.over_partner`, the springs in a second ``Spin``: ``over.hist[0, e, k]``
for the e-th escaped ball, keyed by the partner's slot; sized by a count before each escaped pass,
grown when short). Every pair is evaluated from its lower slot's side (the law is antisymmetric to
the bit), so a spring has one orientation wherever it is kept.

Carried through a rebuild as LAMMPS's ``fix neigh/history`` carries its partners' values:

1. before the storage is re-sorted, :func:`save_springs` copies every live spring (written in the
   last step: its stamp is the clock) of the list and of the escaped balls' tables into a compact
   table by the old lower slot (``carry_start`` / ``carry_partner`` / ``carry_hist``), and notes
   which ball held each old slot (``slot_ball``, the storage order the list was built in);
2. the storage is re-sorted and the list rebuilt; each ball's terrain springs move with it;
3. :func:`restore_springs`, for each new listed pair, maps both new slots to their balls and
   those to their old slots, looks the pair up in the compact table (a few entries per ball) and
   takes its spring, negated when the pair's lower slot is now the other ball (the orientation
   follows the lower slot). A listed pair without a saved spring starts at zero, as a new contact.

A contact that persists keeps its spring whatever the rebuilds and re-sorts; one that has ended
is not carried (not being live), exactly as the scalar path forgets it. Should the list be too
small for the new build, the saved springs wait (``state[0]``) while the caller grows it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..._jit import njit, prange

__all__ = [
    "ListHistory",
    "new_list_history",
    "save_springs",
    "restore_springs",
    "listed_slot",
    "overflow_slot",
    "PENDING",
    "CARRY_NEEDED",
    "OVERFLOW_NEEDED",
]

# ListHistory.state: [springs saved and not yet restored, carry entries needed (0: enough),
# escaped-ball table entries needed per escaped ball (0: enough)]
PENDING, CARRY_NEEDED, OVERFLOW_NEEDED = 0, 1, 2


class ListHistory(NamedTuple):
    """What a neighbour-list world of spinning balls keeps besides its :class:`~..model.Spin`: the
    escaped balls' tables, the compact table of a rebuild, and which ball each slot held."""

    over_partner: np.ndarray  # (1, E, K) int64: partner slot of each spring of the e-th escaped ball
    carry_start: np.ndarray  # (n + 1,) int64: the compact table's entries of old slot i
    carry_cursor: np.ndarray  # (n,) int64 scratch
    carry_partner: np.ndarray  # (M,) int64: each entry's other (higher) old slot
    carry_hist: np.ndarray  # (M, 3): its spring, from the lower slot's side
    slot_ball: np.ndarray  # (n,) int64: the ball in each slot when the list (and tables) were made
    old_slot: np.ndarray  # (n,) int64: its inverse, at a rebuild
    shape_tmp: np.ndarray  # (n, S, 3) scratch: the terrain springs while re-sorted
    stamp_tmp: np.ndarray  # (n, S) int64 scratch
    inertia_tmp: np.ndarray  # (n,) scratch
    round_row: np.ndarray  # (R,) int64: the table row of each static sphere and bowl (SlimModel's order)
    state: np.ndarray  # (3,) int64: see PENDING, CARRY_NEEDED, OVERFLOW_NEEDED


def new_list_history(n: int, shapes: int, escapes: int, per_escape: int, carry: int, round_row) -> ListHistory:
    """The buffers of one world: n balls, ``shapes`` terrain rows, ``escapes`` escaped balls' tables of
    ``per_escape`` springs, a compact table of ``carry`` springs."""
    return ListHistory(
        over_partner=np.full((1, escapes, per_escape), -1, dtype=np.int64),
        carry_start=np.zeros(n + 1, dtype=np.int64),
        carry_cursor=np.zeros(n, dtype=np.int64),
        carry_partner=np.zeros(carry, dtype=np.int64),
        carry_hist=np.zeros((carry, 3)),
        slot_ball=np.arange(n, dtype=np.int64),
        old_slot=np.arange(n, dtype=np.int64),
        shape_tmp=np.zeros((n, max(shapes, 1), 3)),
        stamp_tmp=np.zeros((n, max(shapes, 1)), dtype=np.int64),
        inertia_tmp=np.zeros(n),
        round_row=np.asarray(round_row, dtype=np.int64).reshape(-1),
        state=np.zeros(3, dtype=np.int64),
    )


@njit
def save_springs(lw, sp, over, lh):
    """Step 1 of the carry (the module docstring): every live spring of the list (``sp``) and of the
    escaped balls' tables (``over``) into the compact table, by the lower old slot. Returns how
    many there are; when more than the table holds, nothing is copied (the caller grows it)."""
    nbr, cnt = lw.nbr, lw.count
    n = cnt.shape[0]
    c = sp.clock[0]
    stamp, hist = sp.stamp, sp.hist
    cs = lh.carry_start
    cs[0] = 0
    for i in range(n):
        live = 0
        for m in range(cnt[i]):
            live += stamp[0, i, m] == c
        cs[i + 1] = live
    ne = min(lw.state[3], lw.escapes.shape[0], over.stamp.shape[1])
    K = over.stamp.shape[2]
    for e in range(ne):
        a = lw.escapes[e]
        for k in range(K):
            if over.stamp[0, e, k] == c:
                cs[min(a, lh.over_partner[0, e, k]) + 1] += 1
    for i in range(n):
        cs[i + 1] += cs[i]
    total = cs[n]
    if total > lh.carry_partner.shape[0]:
        return total
    cur = lh.carry_cursor
    for i in range(n):
        cur[i] = cs[i]
    for i in range(n):
        for m in range(cnt[i]):
            if stamp[0, i, m] == c:
                k = cur[i]
                lh.carry_partner[k] = nbr[i, m]
                for q in range(3):
                    lh.carry_hist[k, q] = hist[0, i, m, q]
                cur[i] = k + 1
    for e in range(ne):
        a = lw.escapes[e]
        for k in range(K):
            if over.stamp[0, e, k] == c:
                p = lh.over_partner[0, e, k]
                lo = min(a, p)
                q0 = cur[lo]
                lh.carry_partner[q0] = max(a, p)
                for q in range(3):  # (kept from the lower slot's side, as the list's)
                    lh.carry_hist[q0, q] = over.hist[0, e, k, q]
                cur[lo] = q0 + 1
    for s in range(n):
        lh.old_slot[lh.slot_ball[s]] = s
    return total


@njit(parallel=True)
def restore_springs(lw, sp, lh, threads):
    """Step 3 of the carry: each listed pair of the new list takes its saved spring (turned to the
    new lower slot's side), or starts at zero. Rows in parallel, each written by one thread."""
    nbr, cnt, perm = lw.nbr, lw.count, lw.perm
    n = cnt.shape[0]
    # (fields bound to locals: a store through ``tuple.field[...]`` in a prange loop is dropped)
    hist, stamp = sp.hist, sp.stamp
    old, cs, cp, ch = lh.old_slot, lh.carry_start, lh.carry_partner, lh.carry_hist
    c = sp.clock[0]
    threads = max(1, threads)
    for t in prange(threads):
        first = np.int64(t)
        for i in range(first, n, threads):
            a = old[perm[i]]
            for m in range(cnt[i]):
                b = old[perm[nbr[i, m]]]
                owner = min(a, b)
                other = max(a, b)
                found = -1
                for k in range(cs[owner], cs[owner + 1]):
                    if cp[k] == other:
                        found = k
                if found >= 0:
                    sign = 1.0 if owner == a else -1.0  # (exact: the law is antisymmetric to the bit)
                    for q in range(3):
                        hist[0, i, m, q] = sign * ch[found, q]
                    stamp[0, i, m] = c
                else:
                    stamp[0, i, m] = -1


@njit(hot=True)
def listed_slot(nbr, cnt, lo, hi):
    """The column of slot hi in slot lo's list row (lo < hi), or -1 when the pair is not listed."""
    for m in range(cnt[lo]):
        if nbr[lo, m] == hi:
            return m
    return -1


@njit(hot=True)
def overflow_slot(over, partner, e, j):
    """The column of the e-th escaped ball's spring with slot j: the live one (written in the last
    step), else a free one (written before that), claimed for j. The caller has made sure that one
    is free (the count before the escaped pass)."""
    c = over.clock[0]
    free = -1
    for k in range(partner.shape[2]):
        st = over.stamp[0, e, k]
        if st == c and partner[0, e, k] == j:
            return k
        if free < 0 and st < c:
            free = k
    partner[0, e, free] = j
    return free

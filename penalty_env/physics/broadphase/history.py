"""The tangential springs of a neighbour-list world: stored per list slot, carried through rebuilds.

On the scalar path a spring lives at ``Spin.hist[b, i, j]``, one slot per ball pair: O(n^2), which
a world of 10^5 balls cannot hold. The neighbour-list path (:mod:`..stepping.large_spin`) keeps:

* the listed pairs' springs packed in the list's own order, :attr:`ListHistory.pair_springs`: the
  spring of storage slot i and its m-th listed partner ``nbr[i, m]`` at ``pair_first[i] + m``
  (``pair_first`` the running sum of the list's counts at the build), kept from i's side (the
  pair's lower slot). A step reads and writes them in the order it walks the list, one contiguous
  stream. Every listed pair of a ball that has not escaped is met at every step, and the step
  writes the spring of a pair in contact and zero for one apart; so a spring that is zero is a new
  contact's (the law turns a zero spring into zero: a new contact and a continuing one whose spring
  is zero give the same force to the bit), and no stamp is needed;
* each ball's terrain springs in a :class:`~..model.Spin` of the list's own, rows the storage
  slots, ``hist[0, i, s]`` for terrain shape s, with stamps (the scalar path's rule: continuing
  when written in the step before), re-sorted with the balls;
* an escaped ball's pairs (met by the serial escaped pass, not the list's) in a table of that
  ball's own: a second Spin, ``over.hist[0, e, k]`` for the e-th escaped ball, keyed by the
  partner's slot (:attr:`ListHistory.over_partner`), with stamps. When a ball escapes, its listed
  springs move into its table (:func:`move_escaped_springs`: its row, and the rows of the balls
  that list it, found in the cells around where it was at the build) and their list slots are
  zeroed; the pair of two escaped balls is the earlier one's. A table is sized by a count before
  each escaped pass and grown when short; when a ball's listed springs do not fit its table as it
  escapes, the list is rebuilt instead.

Memory: ``n x cap x 24`` bytes for the listed springs (cap the list's width), ``n x shapes x 32``
for the terrain's: O(n x neighbours).

Carried through a rebuild as LAMMPS's ``fix neigh/history`` carries its partners' values:

1. before the storage is re-sorted, :func:`save_springs` copies every live spring of the list
   (not zero) and of the escaped balls' tables (written in the last step) into a compact table by
   the old lower slot (``carry_start`` / ``carry_partner`` / ``carry_hist``), and ``slot_ball``
   says which ball held each old slot (the storage order the list was built in);
2. the storage is re-sorted and the list rebuilt; each ball's terrain springs move with it;
3. :func:`restore_springs`, for each new listed pair, maps both new slots to their balls and
   those to their old slots, looks the pair up in the compact table (a few entries per ball) and
   takes its spring, negated when the pair's lower slot is now the other ball (every pair is
   evaluated from its lower slot's side and the law is antisymmetric to the bit). A listed pair
   without a saved spring starts at zero, as a new contact.

A contact that persists keeps its spring whatever the rebuilds and re-sorts; one that has ended
is not carried, exactly as the scalar path forgets it. Should the list be too small for the new
build, the saved springs wait (``state[PENDING]``) while the caller grows it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..._jit import njit, prange
from .partners import cell_partners

__all__ = [
    "ListHistory",
    "new_list_history",
    "save_springs",
    "restore_springs",
    "move_escaped_springs",
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
    listed pairs' springs, the escaped balls' tables' keys, the compact table of a rebuild, and
    which ball each slot held."""

    pair_first: np.ndarray  # (n + 1,) int64: where slot i's listed springs begin in pair_springs
    pair_springs: np.ndarray  # (n x cap, 3): the listed pairs' springs, from the lower slot's side
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
    blocks: np.ndarray  # (threads, SPIN_ROWS x SPIN_BLOCK) per thread: the spinning pass's block of pairs
    state: np.ndarray  # (3,) int64: see PENDING, CARRY_NEEDED, OVERFLOW_NEEDED


def new_list_history(
    n: int, cap: int, shapes: int, escapes: int, per_escape: int, carry: int, round_row, threads: int, block: int
) -> ListHistory:
    """The buffers of one world: n balls, a list ``cap`` wide, ``shapes`` terrain rows, ``escapes``
    escaped balls' tables of ``per_escape`` springs, a compact table of ``carry`` springs, a block
    of ``block`` numbers per thread."""
    return ListHistory(
        pair_first=np.zeros(n + 1, dtype=np.int64),
        pair_springs=np.zeros((n * cap, 3)),
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
        blocks=np.zeros((max(threads, 1), block)),
        state=np.zeros(3, dtype=np.int64),
    )


@njit(hot=True)
def _live(springs, k):
    """A listed spring is live (its pair touched in the last step) unless it is zero."""
    return springs[k, 0] != 0.0 or springs[k, 1] != 0.0 or springs[k, 2] != 0.0


@njit
def save_springs(lw, over, lh):
    """Step 1 of the carry (the module docstring): every live spring of the list and of the
    escaped balls' tables (``over``) into the compact table, by the lower old slot. Returns how
    many there are; when more than the table holds, nothing is copied (the caller grows it)."""
    nbr, cnt = lw.nbr, lw.count
    n = cnt.shape[0]
    c = over.clock[0]
    first, springs = lh.pair_first, lh.pair_springs
    cs = lh.carry_start
    cs[0] = 0
    for i in range(n):
        live = 0
        for m in range(cnt[i]):
            live += _live(springs, first[i] + m)
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
            s = first[i] + m
            if _live(springs, s):
                k = cur[i]
                lh.carry_partner[k] = nbr[i, m]
                for q in range(3):
                    lh.carry_hist[k, q] = springs[s, q]
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
def restore_springs(lw, lh, threads):
    """Step 3 of the carry: each listed pair of the new list takes its saved spring (turned to the
    new lower slot's side), or zero (a new contact). Rows in parallel, each written by one thread.
    Sets the new list's ``pair_first``."""
    nbr, cnt, perm = lw.nbr, lw.count, lw.perm
    n = cnt.shape[0]
    # (fields bound to locals: a store through ``tuple.field[...]`` in a prange loop is dropped)
    first, springs = lh.pair_first, lh.pair_springs
    old, cs, cp, ch = lh.old_slot, lh.carry_start, lh.carry_partner, lh.carry_hist
    first[0] = 0
    for i in range(n):
        first[i + 1] = first[i] + cnt[i]
    threads = max(1, threads)
    for t in prange(threads):
        start = np.int64(t)
        for i in range(start, n, threads):
            a = old[perm[i]]
            for m in range(cnt[i]):
                s = first[i] + m
                b = old[perm[nbr[i, m]]]
                owner = min(a, b)
                other = max(a, b)
                found = -1
                for k in range(cs[owner], cs[owner + 1]):
                    if cp[k] == other:
                        found = k
                sign = 1.0 if owner == a else -1.0  # (exact: the law is antisymmetric to the bit)
                for q in range(3):
                    springs[s, q] = sign * ch[found, q] if found >= 0 else 0.0


@njit
def move_escaped_springs(lw, over, lh, e0, e1, cand, D):
    """The balls that escaped in the step just taken (escapes e0..e1-1): each one's live listed
    springs (its own row's, and those of the rows that list it, found through the build's grid
    around the position it was listed at) move into its table, their list slots zeroed (the list
    pass no longer meets them; the pair of two escaped balls stays the earlier one's). False,
    leaving everything as it was, when a ball's springs do not fit its table (the caller then
    rebuilds the list instead)."""
    nbr, cnt, grid = lw.nbr, lw.count, lw.grid
    first, springs = lh.pair_first, lh.pair_springs
    K = over.stamp.shape[2]
    xref = lw.xref.reshape((1,) + lw.xref.shape)
    for pass_ in range(2):  # (0: count, 1: move)
        for e in range(e0, e1):
            i = lw.escapes[e]
            k = 0
            for m in range(cnt[i]):
                s = first[i] + m
                if _live(springs, s):
                    if pass_ == 1:
                        _move(over, lh, e, k, nbr[i, m], s)
                    k += 1
            found = cell_partners(0, i, xref, grid, False, cand, D)
            for t in range(found):
                j = cand[t]
                if j < i:
                    for m in range(cnt[j]):
                        s = first[j] + m
                        if nbr[j, m] == i and _live(springs, s):
                            if pass_ == 1:
                                _move(over, lh, e, k, j, s)
                            k += 1
            if k > K:
                return False
    return True


@njit(hot=True)
def _move(over, lh, e, k, partner, s):
    """List spring s into entry k of the e-th escaped ball's table (live: stamped with the clock),
    its list slot zeroed."""
    lh.over_partner[0, e, k] = partner
    for q in range(3):
        over.hist[0, e, k, q] = lh.pair_springs[s, q]
        lh.pair_springs[s, q] = 0.0
    over.stamp[0, e, k] = over.clock[0]


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

"""Settled beds of grains, made once per configuration and kept (per process, and on disk for
later processes): the PenaltyBalls sand and the level task's heap settle through here."""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np

from .._results import cached

__all__ = ["settle", "remembered_bed"]


def settle(world: Any, dt: float, times: tuple[float, float], speed: float) -> tuple[np.ndarray, float, float]:
    """Step ``world`` (one world of grains, stepping ``dt``) a quarter second at a time, for at least
    ``times[0]`` and until no ball moves faster than ``speed`` (at most ``times[1]``): (its positions,
    read-only; the time it settled; its fastest ball's last speed)."""
    chunk = max(1, int(round(0.25 / dt)))
    t, fastest = 0.0, math.inf
    while t < times[1]:
        world.step(chunk)
        t += chunk * dt
        fastest = float(np.sqrt(np.max(np.sum(world.velocities**2, axis=-1))))
        if t >= times[0] and fastest < speed:
            break
    bed = np.array(world.positions)
    bed.flags.writeable = False
    return bed, t, fastest


def remembered_bed(
    store: dict, name: str, key: tuple, make: Any, what: str, speed: float
) -> tuple[np.ndarray, float, float]:
    """A settled bed ``make()`` (see :func:`settle`) made once per configuration ``key``: per
    process in ``store``, and on disk for later processes (:func:`penalty_env._results.cached`,
    under ``name``). A bed whose fastest grain still moves at ``speed`` or more warns, naming
    ``what``."""
    known = store.get(key)
    if known is None:
        known = store[key] = cached(name, key, make)
        if not known[2] < speed:
            warnings.warn(
                f"{what} still moves at {known[2]:.3g} m/s after {known[1]:.3g} s of settling (the limit is "
                f"{speed:g} m/s): episodes start from a bed that has not come to rest",
                RuntimeWarning,
                stacklevel=4,
            )
    return known

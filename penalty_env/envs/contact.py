"""The tasks' contact model, derived once: from the bodies' masses and radii and the task's
tolerances to the springs, dashpots, friction slope and substep of a world.

Every task derives its physics here, and only here: the PenaltyBalls scene at make (one world's
values), its randomisation guard at the corners of the ranges, each randomised reset for its
worlds' draws (one Numba call for all of them, :mod:`.randomize`), and the level scene for its
grains. The rule (docs/physics.md, "Closed forms"):

* **the pair spring** (:func:`pair_springs`): ``ks`` keeps a head-on impact of the task's pair at
  ``speed`` and a steady ``force`` pressing it (the motor's stall force, a column of grains) under
  the penetration tolerance ``delta = tol min(r_a, r_b)``: ``ks >= m_eff v^2 / delta^2`` and
  ``ks >= F / delta`` (``physics.configure``'s rule, times a ``stiffness`` factor, then its
  ``stiffening``: configure's further stiffening for the exact peak overlap, the square of its
  penetration scale); ``kd`` gives the impact the target restitution exactly (the no-tension closed
  form's damping ratio ``zeta``);
* **the terrain** (:func:`terrain_springs`): the same spring, stiffened where a body would rest
  deeper than the tolerance (``ks_t >= m g / (tol r)`` for every body), its dashpot the pair's
  ``zeta`` on the ``m_ref`` body;
* **sliding friction** (:func:`sliding_kf`): the largest viscous slope that brings the lightest
  contact's sliding to rest in one substep (``kf dt / m_eff = 1``);
* **the substep** (:func:`substeps_for`): the control period split into the fewest equal
  substeps that are at most the step the accuracy and the stability limit allow.

The three rules are Numba functions: a reset kernel calls them compiled, and Python (one world at
make, the guard's corners) runs the same source in Python (``python_twin``): no compile at make.
:func:`configure_task` is the one call of ``physics.configure`` the tasks make.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from .._jit import njit, python_twin
from ..physics.configure import ContactConfig, configure

__all__ = [
    "ContactRule",
    "Springs",
    "configure_task",
    "pair_springs",
    "terrain_springs",
    "sliding_kf",
    "derive",
    "substeps_for",
]


class ContactRule(NamedTuple):
    """A task's contact tolerances (SI units)."""

    speed: float  # the largest normal speed at which the pair meets, m/s
    penetration: float  # the largest overlap, a fraction of the smaller radius
    restitution: float  # of the pair's impact
    accuracy: float  # the restitution's largest relative error (worst case): sets the accuracy step
    force: float  # the largest steady force pressing the pair together, N
    gravity: float  # m/s^2 (a body resting on the terrain)
    control_period: float  # s: the substep is at most this


class Springs(NamedTuple):
    """One world's derived contact model."""

    ks: float  # the pair spring, N/m
    kd: float  # the pair dashpot, N s/m
    ks_terrain: float
    kd_terrain: float


def configure_task(rule: ContactRule, masses: Any, radii: Any) -> ContactConfig:
    """``physics.configure`` for a task's pair (``masses``, ``radii``: its two bodies): the no-tension
    dashpot, symplectic Euler without events, the pair alone (the terrain's springs follow from it,
    :func:`terrain_springs`), the substep at most the control period, no energy budget (the rule the
    PenaltyBalls ids were made with)."""
    return configure(
        masses,
        radii,
        max_impact_speed=rule.speed,
        penetration=rule.penetration,
        restitution=rule.restitution,
        accuracy=rule.accuracy,
        damping="no_tension",
        terrain=False,
        integrators=("symplectic_euler",),
        events=False,
        max_dt=rule.control_period,
        max_force=rule.force,
        energy_budget=None,
    )


@njit
def pair_springs(m_a, m_b, r_a, r_b, speed, tol, force, stiffness, stiffening, zeta):
    """(ks, kd) of the pair (a, b): configure's rule (module docstring). ``stiffening`` is
    configure's penetration scale (1 but for nearly elastic or loosely resolved impacts)."""
    m_eff = m_a * m_b / (m_a + m_b)
    delta = tol * min(r_a, r_b)
    ks = max(m_eff * speed**2 / delta**2, force / delta) * stiffness
    kd = 2.0 * zeta * math.sqrt(ks * m_eff)
    return ks * stiffening**2, kd * stiffening


@njit
def terrain_springs(ks, zeta, masses, radii, tol, gravity, m_ref):
    """(ks_terrain, kd_terrain): the pair spring ``ks``, stiffened so that no body of ``masses`` and
    ``radii`` rests deeper than ``tol`` of its radius (m g / ks_t <= tol r), and the dashpot of
    damping ratio ``zeta`` on the body of mass ``m_ref``."""
    rest = 0.0
    for i in range(masses.shape[0]):
        rest = max(rest, masses[i] * gravity / (tol * radii[i]))
    kt = max(ks, rest)
    return kt, 2.0 * zeta * math.sqrt(kt * m_ref)


@njit
def sliding_kf(masses, dt):
    """The regularised Coulomb friction's viscous slope for balls that slide: the lightest pair's
    m_eff / dt (its sliding stops in one substep without overshoot)."""
    s0, s1 = math.inf, math.inf  # the two lightest
    for i in range(masses.shape[0]):
        m = masses[i]
        if m < s0:
            s0, s1 = m, s0
        elif m < s1:
            s1 = m
    return s0 * s1 / (s0 + s1) / dt


def derive(
    rule: ContactRule,
    masses: np.ndarray,
    radii: np.ndarray,
    pair: tuple[int, int],
    m_ref: float,
    zeta: float,
    stiffening: float = 1.0,
    stiffness: float = 1.0,
    force: float | None = None,
) -> Springs:
    """One world's :class:`Springs` (Python: the scene at make, the guard's corners): the pair
    ``pair`` of ``masses``/``radii`` sets the pair spring; every body rests on the terrain within
    the tolerance. ``force``: the rule's by default."""
    a, b = pair
    ks, kd = python_twin(pair_springs)(
        masses[a],
        masses[b],
        radii[a],
        radii[b],
        rule.speed,
        rule.penetration,
        rule.force if force is None else force,
        stiffness,
        stiffening,
        zeta,
    )
    kt, kdt = python_twin(terrain_springs)(ks, zeta, masses, radii, rule.penetration, rule.gravity, m_ref)
    return Springs(float(ks), float(kd), float(kt), float(kdt))


def substeps_for(control_period: float, dt_max: float, slack: float = 0.0) -> int:
    """The fewest equal substeps of ``control_period`` that are each at most ``dt_max`` (grown by a
    relative ``slack``, for the round-off of a limit recomputed from its own parameters)."""
    dt_max *= 1.0 + slack
    substeps = max(1, math.ceil(control_period / dt_max))
    if control_period / substeps > dt_max:  # rounding
        substeps += 1
    return substeps

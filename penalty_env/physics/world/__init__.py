"""The public ``World`` and its parts.

=================  ============================================================================
module             holds
=================  ============================================================================
``world``          :class:`World`: the arguments, the model, the state and the runner built from
                   them, stepping; its public methods are its parts'
``checks``         the arguments checked and shaped (state, balls, terrain, gravity, motors)
``guard``          :class:`StabilityGuard` (the step limits of a scene) and :class:`StartCheck`
``state``          :class:`StateView` (views of the state, writing it, energy, momenta)
``terrain``        :class:`TerrainView` (each shape's pose and heights per world, distances)
``parameters``     :class:`Parameters` (each world's physics parameters; ``per_world``)
=================  ============================================================================
"""

from .checks import Motor
from .guard import STABILITY_SAFETY, EnergyDriftWarning, StabilityGuard, StartCheck, StartOverlapWarning
from .parameters import Parameters
from .state import StateView
from .terrain import TerrainView
from .world import (
    BROADPHASES,
    DAMPING_MODES,
    GRID_MIN_BALLS,
    LANES_MAX_BALLS,
    LANES_MIN_WORLDS,
    LARGE_SPIN_MIN_BALLS,
    LARGE_WORLD_MIN_BALLS,
    NEIGHBOUR_SKIN,
    STEPPING,
    TANGENTIAL,
    World,
)

__all__ = [
    "World",
    "Motor",
    "StabilityGuard",
    "StartCheck",
    "StateView",
    "TerrainView",
    "Parameters",
    "EnergyDriftWarning",
    "StartOverlapWarning",
    "GRID_MIN_BALLS",
    "LANES_MAX_BALLS",
    "LANES_MIN_WORLDS",
    "LARGE_WORLD_MIN_BALLS",
    "LARGE_SPIN_MIN_BALLS",
    "NEIGHBOUR_SKIN",
    "STABILITY_SAFETY",
    "DAMPING_MODES",
    "BROADPHASES",
    "STEPPING",
    "TANGENTIAL",
]

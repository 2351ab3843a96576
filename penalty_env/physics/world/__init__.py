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
``paths``          :class:`Options`: which options go together, and the stepping path
=================  ============================================================================
"""

from ..broadphase.grid import GRID_MIN_BALLS
from ..model import TANGENTIAL
from ..stepping.lanes import LANES_MAX_BALLS, LANES_MIN_WORLDS
from ..stepping.large import LARGE_WORLD_MIN_BALLS, NEIGHBOUR_SKIN
from ..stepping.large_spin import LARGE_SPIN_MIN_BALLS
from .checks import Motor
from .guard import STABILITY_SAFETY, EnergyDriftWarning, StabilityGuard, StartCheck, StartOverlapWarning
from .parameters import Parameters
from .paths import Options
from .state import StateView
from .terrain import TerrainView
from .world import BROADPHASES, DAMPING_MODES, STEPPING, World

__all__ = [
    "World",
    "Motor",
    "StabilityGuard",
    "StartCheck",
    "StateView",
    "TerrainView",
    "Parameters",
    "Options",
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

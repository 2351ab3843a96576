"""The penalty-contact particle core: spheres and implicit terrain, answered by penalty forces.

Knows nothing of Gymnasium. ``World`` steps B worlds of n balls; ``theory`` holds the closed forms
the tests check against; ``configure`` turns tolerances into contact parameters and a time step.

Layout (each folder one concern; an import never points up this table):

=======================  ===========================================================================
``geometry/``            terrain shapes as signed distance functions: the Python shapes, the shape
                         table the kernels read, the kernels that evaluate it
``contact/``             the contact law (``law``, once) and where it is evaluated: a pair, the
                         terrain, spinning balls, SIMD lanes, neighbour-list blocks
``broadphase/``          which pairs can touch: the grid, the pair-visiting service, Verlet lists
``stepping/``            the integrators, the stepping paths (scalar, lanes, events, large worlds)
                         and the runner that owns the threads
``model``                the kernels' data: ``Model``, ``State``, ``Control``, ``Spin``
``world/``               the public ``World`` and its parts (checks, the stability guard, the
                         state, terrain and parameter views)
``diagnostics``          energy and penetration
``theory``, ``configure`` closed forms and stability limits; tolerance-driven configuration
=======================  ===========================================================================
"""

from . import theory
from .geometry import (
    SDF,
    Bowl,
    Box,
    Capsule,
    Cone,
    Cylinder,
    Difference,
    HeightField,
    Inside,
    Intersection,
    Plane,
    Shape,
    Sphere,
    Torus,
    Union,
    rotation_matrix,
)
from .geometry.implicit import ImplicitOverlap, implicit_overlap
from .model import Control, Model, State
from .stepping import events, lanes
from .world import EnergyDriftWarning, Motor, StartOverlapWarning, World

__all__ = [
    "World",
    "Motor",
    "EnergyDriftWarning",
    "StartOverlapWarning",
    "Model",
    "State",
    "Control",
    "Shape",
    "Sphere",
    "Bowl",
    "Plane",
    "Box",
    "Capsule",
    "Cylinder",
    "Cone",
    "Torus",
    "HeightField",
    "Union",
    "Intersection",
    "Difference",
    "Inside",
    "SDF",
    "rotation_matrix",
    "theory",
    "events",
    "lanes",
    "implicit_overlap",
    "ImplicitOverlap",
]

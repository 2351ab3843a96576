"""The penalty-contact particle core: spheres and implicit terrain, answered by penalty forces.

Knows nothing of Gymnasium. ``World`` steps B worlds of n balls; ``theory`` holds the closed forms
the tests check against; ``configure`` turns tolerances into contact parameters and a time step.

Layout (one module per concern):

========================  ==========================================================================
``world``                 the public ``World``: validation, the stability guard, state and stepping
``model``                 ``Model`` (the static scene, every contact parameter) and ``State``
``shapes``                terrain shapes (signed distance functions); ``implicit``: shape-shape overlap
``geometry``              the shapes' kernel side: phi per kind, CSG trees, poses, the terrain loop
``contact``               the contact laws and their shared helpers (the reference implementation)
``contact_lanes``         the laws' SIMD-across-worlds twin; ``lanes``: that stepping path
``contact_listed``        the pair law's neighbour-list twin; ``neighbour_list``: that path
``broadphase``            all pairs and the uniform grid
``integrators``           one step per method and the driver that runs any of them
``rotation``              spin: the rotating contact law, the tangential models, rolling resistance
``events``                event-located stepping (contact switches located and crossed)
``diagnostics``           energy and penetration
``runner``                the thread pool, the work threshold, the choice of stepping path
``theory``, ``configure`` closed forms and stability limits; tolerance-driven configuration
========================  ==========================================================================
"""

from . import theory
from .implicit import ImplicitOverlap, implicit_overlap
from .model import Model, State
from .shapes import (
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
from .world import EnergyDriftWarning, StartOverlapWarning, World

__all__ = [
    "World",
    "EnergyDriftWarning",
    "StartOverlapWarning",
    "Model",
    "State",
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
    "implicit_overlap",
    "ImplicitOverlap",
]

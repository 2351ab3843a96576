"""The penalty-contact particle core: spheres and implicit terrain, answered by penalty forces.

Knows nothing of Gymnasium. ``World`` steps B worlds of n balls; ``theory`` holds the closed forms
the tests check against.
"""

from . import theory
from .implicit import ImplicitOverlap, implicit_overlap
from .shapes import Bowl, Shape, Sphere
from .world import World

__all__ = ["World", "Bowl", "Sphere", "Shape", "theory", "implicit_overlap", "ImplicitOverlap"]

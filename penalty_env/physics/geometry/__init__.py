"""Implicit geometry: terrain shapes as signed distance functions, and their kernel side.

=================  ============================================================================
module             what it holds
=================  ============================================================================
``shapes``         the ``Shape`` base, spheres, bowls, planes (Python side)
``solids``         boxes, capsules, cylinders, cones, tori
``heightfield``    height fields
``csg``            unions, intersections, differences, complements
``user``           a user's own jitted SDF
``table``          the shape table: a scene's terrain as arrays the kernels read
``pack``           shapes into the table
``sdf``            the primitives' signed distances (kernels)
``evaluate``       any row of the table at a point, moving shapes, clearance (kernels)
``implicit``       the overlap of two shapes, by sampling
=================  ============================================================================
"""

from .csg import Difference, Inside, Intersection, Union
from .heightfield import HeightField
from .shapes import Bowl, Plane, Shape, Sphere, rotation_matrix
from .solids import Box, Capsule, Cone, Cylinder, Torus
from .user import SDF

__all__ = [
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
]

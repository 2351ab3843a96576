"""General implicit-vs-implicit detection (the course notes' section 1): sample points on one
boundary and test the other shape's phi there, both ways, so a shape lying wholly inside the other
is found whichever is passed first.

Boundaries are sampled parametrically for the primitives, by keeping the operands' samples that lie
on the boundary for CSG shapes, on the interpolated surface for height fields, and by projecting
points onto the zero level set (x <- x - phi grad phi) for user SDFs. An unbounded boundary (a
plane, a height field) is sampled within the other shape's bounding ball.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ... import _validate as V
from .shapes import Shape

__all__ = ["implicit_overlap", "ImplicitOverlap"]


class ImplicitOverlap(NamedTuple):
    overlapping: bool
    # deepest sampled penetration, max over samples of -phi_other: >= 0 when overlapping; when not,
    # minus the smallest sampled clearance (-distance between the shapes where phi is exact)
    depth: float
    point: np.ndarray  # the deepest sample

    def __bool__(self) -> bool:
        return self.overlapping


def _window(shape: Shape) -> tuple[np.ndarray, float] | None:
    """The bounding ball (centre, radius) of a bounded shape's solid, else None."""
    b = shape._bound()
    if shape.sign < 0.0 or not math.isfinite(b):
        return None
    return np.asarray(shape.center), 1.5 * b + 1e-9


def implicit_overlap(a: Shape, b: Shape, n_samples: int = 2048) -> ImplicitOverlap:
    """Do the solids of ``a`` and ``b`` intersect? Sampled test, exact as n_samples grows.

    A sample on a's boundary with phi_b < 0 lies inside b's solid (and vice versa). The depth is the
    largest such -phi, which converges to the deepest penetration of either boundary into the other
    solid; for separated shapes with exact phi it converges to minus their distance.
    """
    for name, s in (("a", a), ("b", b)):
        if not isinstance(s, Shape):
            raise V.ArgumentTypeError(f"{name} must be a Shape, got {V.describe(s)}")
    if a.dim != b.dim:
        raise ValueError(f"a and b must have the same dimension, got {a.dim}D and {b.dim}D")
    n = V.integer("n_samples", n_samples, 1)
    wa, wb = _window(a), _window(b)
    if wa is None and wb is None:
        raise ValueError(
            f"implicit_overlap needs one bounded solid to sample the other's boundary near it; "
            f"{type(a).__name__} and {type(b).__name__} are both unbounded"
        )
    pa = a.surface_points(n, window=wb)
    pb = b.surface_points(n, window=wa)
    pts = np.concatenate([pa, pb])
    phi = np.concatenate([b.phi(pa), a.phi(pb)])
    k = int(np.argmin(phi))
    return ImplicitOverlap(bool(phi[k] < 0.0), float(-phi[k]), pts[k])

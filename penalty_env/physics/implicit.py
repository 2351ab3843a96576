"""General implicit-vs-implicit detection (seed section 1): sample points on one boundary and test
the other shape's phi there. We sample both boundaries, so a shape lying wholly inside the other
is found whichever is passed first."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .shapes import Shape

__all__ = ["implicit_overlap", "ImplicitOverlap"]


class ImplicitOverlap(NamedTuple):
    overlapping: bool
    depth: float  # deepest sampled penetration, max over samples of -phi_other (>= 0 when overlapping)
    point: np.ndarray  # the deepest sample

    def __bool__(self) -> bool:
        return self.overlapping


def implicit_overlap(a: Shape, b: Shape, n_samples: int = 2048) -> ImplicitOverlap:
    """Do the solids of ``a`` and ``b`` intersect? Sampled test, exact as n_samples grows.

    A sample on a's boundary with phi_b < 0 lies inside b's solid (and vice versa). The depth is
    the largest such -phi, which converges to the true penetration depth for spheres.
    """
    for name, s in (("a", a), ("b", b)):
        if not isinstance(s, Shape) or s.kind < 0:
            raise ValueError(f"{name} must be a Sphere or Bowl, got {type(s).__name__}")
    if a.dim != b.dim:
        raise ValueError(f"a and b must have the same dimension, got {a.dim}D and {b.dim}D")
    if int(n_samples) < 1:
        raise ValueError(f"n_samples must be >= 1, got {n_samples!r}")
    pa = a.surface_points(n_samples)
    pb = b.surface_points(n_samples)
    pts = np.concatenate([pa, pb])
    phi = np.concatenate([b.phi(pa), a.phi(pb)])
    k = int(np.argmin(phi))
    return ImplicitOverlap(bool(phi[k] < 0.0), float(-phi[k]), pts[k])

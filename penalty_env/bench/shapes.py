"""Pictures of every terrain shape as the renderer draws it: ``python -m penalty_env.bench shapes``.

Writes ``docs/shapes_3d.png`` (top views, as ``PenaltyBalls-v0`` draws its terrain) and
``docs/shapes_2d.png`` (side views, as ``PenaltyBalls2D-v0`` does), one panel per shape of
docs/physics.md section 1, each drawn from the World's own ``terrain_distance`` (the kernels' phi).
"""

from __future__ import annotations

import argparse
import math
import os
import warnings

import numba
import numpy as np

from ..envs.render import VIEW_HALF_WIDTH, terrain_image
from ..physics import (
    SDF,
    Bowl,
    Box,
    Capsule,
    Cone,
    Cylinder,
    Difference,
    HeightField,
    Inside,
    Plane,
    Sphere,
    Torus,
    Union,
    World,
    rotation_matrix,
)


@numba.njit
def _ripples(p):
    """A user's SDF: ripples on a plane (a bound of the distance: slope at most 0.36)."""
    return (p[-1] - 0.12 * math.sin(3.0 * p[0]) * math.cos(3.0 * p[1] if len(p) == 3 else 0.0)) / 1.06


def shapes(d: int) -> list[tuple[str, object]]:
    """(label, shape) of every kind, placed to fill the renderer's view."""
    z = np.zeros(d)
    up = np.eye(d)[-1]
    x = np.eye(d)[0]
    R = rotation_matrix((0.0, 0.0, 1.0), 0.5) if d == 3 else rotation_matrix(0.5)
    hf_axes = np.linspace(-2.0, 2.0, 41)
    grids = np.meshgrid(*([hf_axes] * (d - 1)), indexing="ij")
    bumps = 0.25 * np.exp(-sum((g - 0.5) ** 2 for g in grids) / 0.3) + 0.15 * np.exp(
        -sum((g + 0.7) ** 2 for g in grids) / 0.2
    )
    return [
        ("Sphere", Sphere(tuple(-0.6 * up), 1.2)),
        ("Bowl", Bowl(tuple(2.0 * up), 2.0)),
        ("Plane (tilted)", Plane(tuple(z), tuple(up + 0.25 * x))),
        ("Box (rotated)", Box(tuple(z), (0.9, 0.5, 0.3)[:d], R)),
        ("Capsule", Capsule(tuple(-0.9 * x - 0.2 * up), tuple(0.9 * x + 0.3 * up), 0.4)),
        ("Cylinder", Cylinder(tuple(z), 0.8, 0.4)),
        ("Cone (frustum)", Cone(tuple(z), 1.0, 0.3, 0.5)),
        ("Torus", Torus(tuple(z), 0.9, 0.35)),
        ("HeightField", HeightField(bumps, 0.1, origin=(-2.0,) * (d - 1))),
        ("Difference(Box, Sphere)", Difference(Box(tuple(z), (1.2,) * d), Sphere(tuple(0.9 * up), 1.1))),
        (
            "Union(Box, Cylinder)",
            Union(Box(tuple(-0.6 * x), (0.5, 0.5, 0.2)[:d]), Cylinder(tuple(0.5 * x), 0.45, 0.5)),
        ),
        ("Inside(Box)", Inside(Box(tuple(z + 0.5 * up), (1.4,) * (d - 1) + (1.0,)))),
        ("SDF (user)", SDF(_ripples, dim=d)),
    ]


def draw(d: int, width: int = 192) -> list[tuple[str, np.ndarray]]:
    out = []
    for label, shape in shapes(d):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            w = World(np.full((1, d), 50.0), [0.1], [1.0], terrain=shape, ks=1e4, dt=1e-3, gravity=np.zeros(d))
        out.append((label, terrain_image(w, 0, width, width)))
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(prog="python -m penalty_env.bench shapes", description=__doc__)
    ap.add_argument("--out", default=None, help="folder for the PNGs (default: docs/ of the repository)")
    args = ap.parse_args(argv)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = args.out or os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "docs")
    for d in (3, 2):
        panels = draw(d)
        cols = 5
        rows = -(-len(panels) // cols)
        fig, axes = plt.subplots(rows, cols, figsize=(2.2 * cols, 2.45 * rows))
        for ax in axes.ravel():
            ax.axis("off")
        for ax, (label, img) in zip(axes.ravel(), panels):
            ax.imshow(img)
            ax.set_title(label, fontsize=9)
        view = "top views" if d == 3 else "side views"
        fig.suptitle(f"Terrain shapes in {d}D as the renderer draws them ({view}, {2 * VIEW_HALF_WIDTH:g} m across)")
        fig.tight_layout()
        path = os.path.join(out, f"shapes_{d}d.png")
        fig.savefig(path, dpi=90)
        plt.close(fig)
        print("wrote", path)


if __name__ == "__main__":
    main()

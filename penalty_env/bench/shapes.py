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

from ..envs.views.raster import CONTOUR_STEP, LIGHT, VIEW_HALF_WIDTH
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


# ------------------------------------------------------------------ any terrain, by sphere tracing
# (the gallery draws the World's own shapes, any of them, through their distance: the task terrains' pictures,
# penalty_env.envs.terrains, are closed forms the raster reads)
def _shade_3d(
    Z: np.ndarray, nx: np.ndarray, ny: np.ndarray, nz: np.ndarray, scale: float, sky: np.ndarray
) -> np.ndarray:
    """A top view of a height map ``Z`` with normals n: sand lit by the normal (its slope read at a
    glance), contour rings every CONTOUR_STEP of height, steep faces (walls) darker; ``sky`` marks
    columns without ground."""
    lx, ly, lz = np.array(LIGHT) / np.linalg.norm(LIGHT)
    lambert = np.clip(nx * lx - ny * ly + nz * lz, 0.0, 1.0)  # image y is flipped
    span = max(float(np.ptp(Z[~sky])) if np.any(~sky) else 0.0, 1e-9)
    shade = 0.78 + 2.5 * (lambert - lz) + 0.06 * (1.0 - (Z - Z[~sky].min() if np.any(~sky) else Z) / span)
    sand = np.array([0.90, 0.84, 0.70])
    img = sand[None, None, :] * np.clip(shade, 0.45, 1.1)[..., None]
    wall = np.clip((0.5 - nz) * 2.0, 0.0, 1.0)[..., None]  # faces steeper than 60 degrees
    img = img * (1.0 - wall) + np.array([0.52, 0.50, 0.48]) * wall
    gy, gx = np.gradient(Z * scale)
    slope = np.maximum(np.hypot(gx, gy) / max(CONTOUR_STEP * scale, 1e-9), 1e-3)
    phase = Z / CONTOUR_STEP
    frac = np.abs(phase - np.round(phase)) / slope  # pixel distance to the nearest contour
    line = np.clip(1.0 - frac, 0.0, 1.0) * (nz > 0.5)
    img *= (1.0 - 0.18 * line)[..., None]
    img[sky] = np.array([0.80, 0.88, 0.97])
    return np.clip(255.0 * img + 0.5, 0, 255).astype(np.uint8)


def terrain_heightmap(distance, xs: np.ndarray, ys: np.ndarray, top: float, bottom: float):
    """The terrain seen from above, for any shapes: each column (x, y) is marched down from z = top
    by sphere tracing (z <- z - phi, a safe step for a distance or a bound of it) until phi is
    about 0. ``distance(points) -> (phi, normal)``. Returns the height Z, the normal at the hit
    (nx, ny, nz) and where no ground was met above ``bottom``."""
    X, Y = np.meshgrid(xs, ys)
    z = np.full(X.shape, float(top))
    eps = 1e-3
    # first through any solid at the top (a container's lid, the rock around a cavity): the view
    # is a cut-away, the first surface below free space; a column solid all the way down is a wall
    phi, _ = distance(np.stack([X, Y, z], -1))
    lid = phi <= 0.0
    for _ in range(400):
        inside = (phi < 0.0) & (z > bottom)
        if not np.any(inside):
            break
        z = np.where(inside, z - np.maximum(-phi, eps), z)
        phi, _ = distance(np.stack([X, Y, z], -1))
    wall = z <= bottom
    z = np.where(wall, top, np.where(lid, z - eps, z))  # just below the lid's underside
    for _ in range(400):
        phi, _ = distance(np.stack([X, Y, z], -1))
        step = np.where((phi > 1e-4) & ~wall, phi, 0.0)
        if not np.any(step > 0.0):
            break
        z = np.maximum(z - step, bottom - 1.0)
    phi, n = distance(np.stack([X, Y, z], -1))
    sky = (z <= bottom) | ~np.isfinite(phi)
    n = np.where(wall[..., None], np.array([0.0, 0.0, 0.0]), n)  # a wall is drawn as a steep face
    return z, n[..., 0], n[..., 1], n[..., 2], sky


def _background_generic_3d(W: int, H: int, scale: float, distance, top: float) -> tuple[np.ndarray, np.ndarray]:
    """A top view of any terrain (``distance``): the image and its height map (for the shadows)."""
    xs = (np.arange(W) + 0.5 - 0.5 * W) / scale
    ys = -(np.arange(H) + 0.5 - 0.5 * H) / scale
    Z, nx, ny, nz, sky = terrain_heightmap(distance, xs, ys, top, -top)
    return _shade_3d(Z, nx, ny, nz, scale, sky), Z


def _background_generic_2d(W: int, H: int, scale: float, ground_px: float, distance) -> np.ndarray:
    """A side view of any terrain: sky where phi > 0, earth inside the solid, a surface line."""
    xs = (np.arange(W) + 0.5 - 0.5 * W) / scale
    zs = (ground_px - (np.arange(H) + 0.5)) / scale
    X, Z = np.meshgrid(xs, zs)
    phi, _ = distance(np.stack([X, Z], -1))
    depth = -phi * scale  # pixels into the solid (> 0) or the free space (< 0)
    return _side_image(Z, depth)


def _side_image(Z: np.ndarray, depth: np.ndarray) -> np.ndarray:
    sky_top, sky_low = np.array([0.80, 0.88, 0.97]), np.array([0.96, 0.97, 0.99])
    t = np.clip((Z - Z.min()) / max(float(Z.max() - Z.min()), 1e-9), 0.0, 1.0)[..., None]
    sky = sky_low + (sky_top - sky_low) * t
    earth = np.array([0.60, 0.47, 0.32]) * np.clip(1.0 - 0.004 * depth, 0.6, 1.0)[..., None]
    solid = np.clip(depth + 0.5, 0.0, 1.0)[..., None]
    img = sky * (1.0 - solid) + earth * solid
    line = np.clip(1.5 - np.abs(depth), 0.0, 1.0)[..., None]
    img = img * (1.0 - line) + np.array([0.35, 0.25, 0.15]) * line
    return np.clip(255.0 * img + 0.5, 0, 255).astype(np.uint8)


def terrain_image(world, b: int, width: int, height: int) -> np.ndarray:
    """The terrain of world ``b`` of any ``World`` as the renderer draws it: a top view in 3D, a side
    view in 2D, ``2 VIEW_HALF_WIDTH`` metres across (``python -m penalty_env.bench shapes`` draws
    every shape with it)."""
    scale = width / (2.0 * VIEW_HALF_WIDTH)

    def distance(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return world.terrain_distance(points, world=b)

    if world.dim == 3:
        return _background_generic_3d(width, height, scale, distance, top=2.5)[0]
    return _background_generic_2d(width, height, scale, 0.8 * height, distance)


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

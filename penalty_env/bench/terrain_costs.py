"""Section (f) of ``bench core``: the cost of one ball-terrain contact per kind of shape, on every
stepping path, against a sphere's.

``python -m penalty_env.bench core`` prints it; alone:
``python -c "from penalty_env.bench.terrain_costs import main; main()"``.

On each path a scene of balls resting on one shape is stepped, and the step's cost per ball less
the same scene's without terrain (the balls then fall freely: no contact) is the contact's:

* ``scalar``: 1,024 worlds of one ball resting on the shape's top, one world per thread at a time;
* ``lanes``: the same worlds, 64 to a SIMD block;
* ``neighbour_list``: one world of 1,024 small balls (radius 0.01) on a 32 x 32 lattice 0.03 apart
  over the shape's top, each set down overlapping the shape's surface by a tenth of its radius
  (from the World's own signed distance), without gravity and so heavy that they stay there
  while they are timed; found through the grid and its Verlet list.

The targets: a plane, box or height-field contact at most 2x a sphere's on every path; the other
primitives within 2x and a CSG of four primitives within 3x on the scalar path.
"""

from __future__ import annotations

import numba
import numpy as np

from ..physics import (
    SDF,
    Bowl,
    Box,
    Capsule,
    Cone,
    Cylinder,
    HeightField,
    Plane,
    Sphere,
    Torus,
    Union,
    World,
)
from .core import _rate

__all__ = ["terrain_costs", "terrain_kinds", "main", "PATHS"]

PATHS = ("scalar", "lanes", "neighbour_list")
TARGET_SHAPES = ("Plane", "Box", "HeightField")  # at most 2x a sphere's on every path


@numba.njit
def _user_plane(p):
    """A user's SDF: the plane z = 0."""
    return p[2]


def terrain_kinds(path: str = "scalar") -> list[tuple[str, object]]:
    """(label, shape) for ``path``: each shape's top is at height 0 around the origin (over the
    neighbour-list lattice's square, for the kinds it takes)."""
    axes = np.linspace(-2.0, 2.0, 41)
    X, Y = np.meshgrid(axes, axes, indexing="ij")
    bumps = 0.05 * np.sin(3.0 * X) * np.cos(2.0 * Y)
    four = Union(
        Box((0.0, 0.0, -0.5), (0.5, 0.5, 0.5)),
        Box((2.0, 0.0, -0.5), (0.3, 0.3, 0.5)),
        Cylinder((-2.0, 0.0, -0.5), 0.4, 0.5),
        Sphere((0.0, 2.0, -1.0), 1.0),
    )
    kinds = [
        ("Sphere", Sphere((0.0, 0.0, -1.0), 1.0)),
        ("Bowl", Bowl((0.0, 0.0, 1.0), 1.0)),
        ("Plane", Plane((0.0, 0.0, 0.0), (0.0, 0.0, 1.0))),
        ("Box", Box((0.0, 0.0, -0.5), (0.5, 0.5, 0.5))),
        ("Capsule", Capsule((-0.5, 0.0, -0.3), (0.5, 0.0, -0.3), 0.3)),
        ("Cylinder", Cylinder((0.0, 0.0, -0.5), 0.5, 0.5)),
        ("Cone", Cone((0.0, 0.0, -0.5), 0.8, 0.4, 0.5)),
        ("Torus", Torus((0.1, 0.0, -0.2), 0.1, 0.2)),
        ("HeightField", HeightField(bumps, 0.1, origin=(-2.0, -2.0))),
        ("Union of 4", four),
        ("SDF (user)", SDF(_user_plane, dim=3)),
    ]
    if path == "neighbour_list":  # the kinds whose top covers the lattice's square
        keep = ("Sphere", "Bowl", "Plane", "Box", "HeightField", "Union of 4", "SDF (user)")
        kinds = [k for k in kinds if k[0] in keep]
    return kinds


def _rest_heights(shape: object, xy: np.ndarray, radius: float, overlap: float) -> np.ndarray:
    """Heights at which balls at ``xy`` (N, 2) overlap the shape's top surface by ``overlap``
    (bisection on the World's own signed distance, from above)."""
    probe = World(np.zeros((1, 3)), [radius], [1.0], terrain=(shape,), ks=1.0, kd=0.0, dt=1e-3, start_check=False)
    lo, hi = np.full(len(xy), -1.5), np.full(len(xy), 1.5)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        phi, _ = probe.terrain_distance(np.column_stack([xy, mid]))
        above = phi > radius - overlap
        hi = np.where(above, mid, hi)
        lo = np.where(above, lo, mid)
    return hi


def _scene(path: str, shape: object | None, n_worlds: int) -> World:
    terrain = () if shape is None else (shape,)
    if path != "neighbour_list":
        mass, radius, ks = 1.0, 0.1, 1e4
        kd = 2.0 * np.sqrt(ks * mass)
        x = np.zeros((n_worlds, 1, 3))
        x[:, 0, 2] = radius - mass * 9.81 / ks  # every ball on the shape's top, where it rests
        return World(x, [radius], [mass], terrain=terrain, ks=ks, kd=kd, dt=1e-3, stepping=path)
    mass, radius, ks = 1e6, 0.01, 10.0  # (pushed out at 1e-9 m/s^2: in contact while timed)
    side = 32
    axis = (np.arange(side) - 0.5 * (side - 1)) * 0.03
    xy = np.stack(np.meshgrid(axis, axis, indexing="ij"), axis=-1).reshape(-1, 2)
    z = np.full(len(xy), radius) if shape is None else _rest_heights(shape, xy, radius, 0.1 * radius)
    x = np.column_stack([xy, z])
    n = len(x)
    kw = dict(ks=ks, kd=0.0, dt=1e-3, gravity=(0.0, 0.0, 0.0), stepping=path)
    return World(x, np.full(n, radius), np.full(n, mass), terrain=terrain, **kw)


def terrain_costs(path: str = "scalar", n_worlds: int = 1024, target_s: float = 0.3) -> tuple[list, float]:
    """Rows (label, ns per ball-step, contact ns, x a sphere's, fraction of balls in contact) on
    ``path``, and the ns per ball-step without terrain."""
    base = 1e9 / _rate(_scene(path, None, n_worlds), target_s)
    out = []
    for label, shape in terrain_kinds(path):
        w = _scene(path, shape, n_worlds)
        ns = 1e9 / _rate(w, target_s)
        pen = np.atleast_1d(w.max_penetration())
        in_contact = float(np.mean(pen > 0.0)) if path != "neighbour_list" else _touching(w)
        out.append((label, ns, ns - base, in_contact))
    sphere = out[0][2]
    return [(label, ns, contact, contact / sphere, frac) for label, ns, contact, frac in out], base


def _touching(world: World) -> float:
    """The fraction of a world's balls that touch the terrain."""
    phi, _ = world.terrain_distance(world.positions)
    return float(np.mean(phi < world.radii))


def report(quick: bool = False, paths: tuple[str, ...] = PATHS) -> None:
    """Print section (f)."""
    print("(f) one ball-terrain contact per kind of shape, on each stepping path (contact = step less the step")
    print("    without terrain); targets: a plane, box or height field within 2x a sphere's on every path")
    for path in paths:
        rows, base = terrain_costs(path, 256 if quick else 1024, 0.1 if quick else 0.3)
        print(f"  {path}: {base:.1f} ns per ball-step without terrain")
        print("    shape          ns/ball-step   contact ns   x a sphere's   balls in contact")
        for label, ns, contact, ratio, frac in rows:
            mark = " (target 2x)" if label in TARGET_SHAPES else ""
            print(f"    {label:<14} {ns:10.1f}   {contact:10.1f}   {ratio:10.2f}x   {100 * frac:8.0f}%{mark}")


def main() -> None:
    report()


if __name__ == "__main__":
    main()

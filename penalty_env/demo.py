"""The course's 2D starter scene ("Particle Sand (DEM)", docs/physics.md section 1) settling in its bowl.

Run: ``python -m penalty_env.demo``
"""

from __future__ import annotations

import numpy as np

from .physics import Bowl, World


def starter_scene(**overrides) -> World:
    """Four unit-mass particles in a 2D bowl (centre (0, 8), radius 8), gravity (0, -1),
    ks = 200, kd = 5, dt = 0.02, symplectic Euler: the course's starter code."""
    kwargs = dict(
        terrain=(Bowl((0.0, 8.0), 8.0),),
        gravity=(0.0, -1.0),
        ks=2e2,
        kd=5.0,
        dt=0.02,
        integrator="symplectic_euler",
    )
    kwargs.update(overrides)
    positions = np.array([[0.0, 1.0], [0.0, 2.0], [0.2, 2.5], [-0.2, 2.5]])
    return World(positions, [0.4, 0.2, 0.1, 0.3], [1.0, 1.0, 1.0, 1.0], **kwargs)


def main() -> None:
    world = starter_scene()
    e0 = world.energy()
    print(f"{'t':>6} {'energy':>10} {'max overlap/r':>14}   positions")
    for k in range(11):
        if k:
            world.step(100)
        pos = " ".join(f"({x:+.3f},{y:+.3f})" for x, y in world.positions)
        print(f"{k * 100 * world.dt:6.1f} {world.energy():10.5f} {world.max_penetration():14.4f}   {pos}")
    print(f"energy fell from {e0:.4f} to {world.energy():.4f}: the particles settled in the bowl")


if __name__ == "__main__":
    main()

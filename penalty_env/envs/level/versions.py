"""The level task's versions: what each fixes (its grains, their default count, the contact budget
its springs and substep are derived from, its defaults), and the grains of v0."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["LevelPhysics", "LEVEL_VERSIONS", "GRAIN_RADIUS", "GRAIN_MASS", "HEAP_SLOPE"]

GRAIN_RADIUS = 0.06  # m
GRAIN_MASS = 0.5  # kg (PenaltyBallsSand-v1's grains)
HEAP_SLOPE = 35.0  # the grains start on a lattice cone of this slope (degrees), then settle


@dataclass(frozen=True)
class LevelPhysics:
    """What a version of the task fixes: its grains, their default count, the contact budget the
    springs and the substep are derived from, and the default target.

    The springs come from ``configure`` (:meth:`SandLevelScene._contact_model`): a grain struck at
    ``impact`` x the blade's top speed (per axis, times sqrt(d - 1) for a diagonal move) overlaps
    at most ``overlap`` x its radius, and so does a grain under a column of grains as tall as the
    heap's start (the heap's static load, which fixes the spring's omega whatever the mass:
    docs/level.md, "The spring the task needs")."""

    version: int
    grain_radius: float  # m
    grain_mass: float  # kg
    grains: tuple[int, int]  # the default count (3D, 2D)
    impact: float  # the springs' impact speed, x the blade's top speed (x sqrt(d - 1))
    overlap: float  # the overlap budget, x the grain radius
    target: str  # the default target
    heap_slope: float = HEAP_SLOPE  # the start lattice's cone, degrees
    floor_stiffening: float = 1.0  # ks_terrain = this x the derived one (kd_terrain x its root: the same zeta)
    step_margin: float = 1.0  # the substep at most this fraction of the core's stability limit
    stepping: str = "scalar"  # the World's stepping path (a randomised scene's per-world physics: "scalar")
    success_fraction: float | None = None  # the default success threshold (None: LEVEL_PARAMETERS' by dim)

    @property
    def blade_floor(self) -> float:
        """The blade's bottom never goes below one grain layer plus 1 cm, m."""
        return 2.0 * self.grain_radius + 0.01


# v0: 250 grains of 0.06 m; springs from twice the blade's top speed at 10% of a radius.
# v1: 2,000 grains of 0.04 m (the same density: a flattened bed 2.8 grains deep), random targets,
# a lower start cone (25 degrees: the mound fits the arena); springs from the blade's top speed at
# 20% of a radius, the budget a bed's height map still reads (docs/level.md). Two more terms:
# - the terrain's spring (floor, walls and blade) twice the pairs': a grain on a shape has m_eff = m, twice a pair's
#   m / 2, so 2 ks gives the pairs' omega (no shorter substep) and halves the floor's overlap under
#   a column (measured on the settled bed: the largest 0.23 r at 1 x, 0.13 r at 2 x);
# - the substep at 0.8 of the stability limit, not at it: there the symplectic step's eigenvalue is
#   -1, a period-two mode that neither grows nor decays, and a bed never comes to rest (measured:
#   500 of 2,000 grains jitter in place above 2 mm/s after 40 s at the limit; 3 at 0.8 of it);
# - the neighbour-list path (2.7x the scalar path on the settled bed, one thread: bench level
#   --lammps), but for a randomised scene (per-world physics: the scalar path);
# - success at 0.75 of the initial error: the raster sweep ends at 0.63-0.82 of it (random
#   targets) and 0.74-0.77 (flat), a random policy at about 0.97 (docs/level.md, section 8).
LEVEL_VERSIONS: dict[int, LevelPhysics] = {
    0: LevelPhysics(0, GRAIN_RADIUS, GRAIN_MASS, (250, 24), 2.0, 0.1, "flat"),
    1: LevelPhysics(
        version=1,
        grain_radius=0.04,
        grain_mass=GRAIN_MASS * (0.04 / GRAIN_RADIUS) ** 3,
        grains=(2000, 80),
        impact=1.0,
        overlap=0.2,
        target="random",
        heap_slope=25.0,
        floor_stiffening=2.0,
        step_margin=0.8,
        stepping="neighbour_list",
        success_fraction=0.75,
    ),
}

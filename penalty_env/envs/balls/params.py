"""The PenaltyBalls task's parameters: every keyword argument with its default, range and meaning
(the env docstrings print this table), their check, and the task's constants (start distribution,
sand, terrains, rewards).

Units are SI (metres, kilograms, seconds, newtons). The last axis is up.
"""

from __future__ import annotations

import math
from typing import Any

from ... import _validate as V
from ..terrains import TERRAINS, make_terrain

__all__ = [
    "PARAMETERS",
    "INT_PARAMETERS",
    "CHOICE_PARAMETERS",
    "check_parameters",
    "max_grains",
    "BALL_START_RADIUS",
    "GOAL_DISTANCE",
    "PUSHER_GAP",
    "OBSTACLE_REGION",
    "OBSTACLE_GAP",
    "OBSTACLE_DENSITY",
    "OBSTACLE_TRIES",
    "SAND_MAX_DEPTH",
    "SAND_PACKING",
    "SAND_SETTLE_TIME",
    "SAND_SETTLE_SPEED",
    "SAND_LATTICE",
    "SAND_V1_GRAIN_MASS",
    "MAX_EPISODE_STEPS",
    "SAND_V1_EPISODE_STEPS",
    "HEIGHTMAP_CELLS",
    "HEIGHTMAP_CELL",
    "W_GOAL",
    "W_REACH",
    "SUCCESS_BONUS",
]

# ----------------------------------------------------------------------------------------------
# Keyword arguments: default, allowed range, meaning. The env docstrings print this table.
# ----------------------------------------------------------------------------------------------
PARAMETERS: dict[str, tuple[Any, Any, Any, str]] = {
    "n_obstacles": (0, 0, 8, "passive obstacle balls"),
    "pusher_radius": (0.15, 0.05, 0.3, "pusher radius, m"),
    "ball_radius": (0.15, 0.05, 0.3, "ball radius, m"),
    "obstacle_radius": (0.15, 0.05, 0.3, "obstacle radius, m"),
    "pusher_mass": (1.0, 0.1, 10.0, "pusher mass, kg"),
    "ball_mass": (0.5, 0.05, 10.0, "ball mass, kg"),
    "obstacle_mass": (1.0, 0.05, 10.0, "obstacle mass, kg"),
    "friction": (0.3, 0.0, 1.5, "Coulomb friction coefficient mu of every contact"),
    "restitution": (0.3, 0.22, 1.0, "coefficient of restitution of a pusher-ball impact"),
    "penetration_tolerance": (0.1, 0.01, 0.5, "overlap / radius of a pusher-ball impact at max_speed"),
    "restitution_accuracy": (
        0.3,
        0.05,
        0.5,
        "largest relative error of the pusher-ball restitution (worst case); sets the substep",
    ),
    "max_speed": (1.0, 0.1, 5.0, "pusher motor's no-load speed, m/s"),
    "max_force": (20.0, 0.5, 500.0, "pusher motor's stall force, N"),
    "goal_tolerance": (0.1, 0.02, 0.3, "success radius around the goal, m"),
    "control_period": (0.04, 0.005, 0.25, "simulated seconds per env step"),
    "bowl_radius": (8.0, 3.0, 100.0, "radius of the spherical terrain, m"),
    "gravity": (9.81, 0.1, 50.0, "gravitational acceleration, m/s^2"),
    "render_width": (256, 16, 4096, "rgb_array frame width, pixels"),
    "render_height": (256, 16, 4096, "rgb_array frame height, pixels"),
    "roughness": (0.05, 0.0, 0.15, "terrain='bumpy': the largest bump height, m"),
    "rolling_resistance": (0.02, 0.0, 0.5, "physics='rolling': rolling resistance coefficient mu_r"),
    "grains": (0, 0, 10_000, "sand grains settled in the bowl (PenaltyBallsSand: 300 in 3D, 40 in 2D)"),
    "grain_radius": (0.06, 0.02, 0.15, "grain radius, m"),
    "grain_mass": (0.15, 0.01, 1.0, "grain mass, kg"),
}
INT_PARAMETERS = ("n_obstacles", "render_width", "render_height", "grains")
# keyword arguments that choose among names: default, allowed, meaning
CHOICE_PARAMETERS: dict[str, tuple[str, tuple[str, ...], str]] = {
    "terrain": (
        "bowl",
        tuple(TERRAINS),
        "the ground: the spherical bowl (v0's), a flat arena walled by planes, the bowl as a height "
        "field with random bumps redrawn at every reset, or a walled floor sloping along x (the Terrain table)",
    ),
    "physics": (
        "sliding",
        ("sliding", "rolling"),
        "the balls slide without spinning (v0's), or spin and roll (v1's default: friction exerts a torque, "
        "rolling resistance rolling_resistance)",
    ),
}

# Start distribution (the env docstring's "Starting State" table)
BALL_START_RADIUS = 0.5  # the ball starts within this horizontal distance of the bowl's bottom
GOAL_DISTANCE = (0.4, 0.8)  # goal: this far from the ball's start, uniform
PUSHER_GAP = (0.1, 0.4)  # pusher: this surface gap from the ball, uniform
OBSTACLE_REGION = {3: 1.2, 2: 1.5}  # obstacles: disc radius (3D) / half-length (2D) around the bottom
OBSTACLE_GAP = 0.05  # minimum surface gap of an obstacle to any other ball at the start
OBSTACLE_DENSITY = 0.25  # obstacle footprints may cover at most this share of their region
OBSTACLE_TRIES = 10_000

# Sand (grains > 0; the env docstring's "Sand" section)
SAND_MAX_DEPTH = 0.5  # the settled bed may be at most this deep at the bowl's bottom, m (check_parameters)
SAND_PACKING = 0.58  # solid fraction assumed for that check (a loose random packing, 3D; 2D: 0.8)
SAND_SETTLE_TIME = (2.0, 20.0)  # a bed settles for at least / at most this much simulated time, s
SAND_SETTLE_SPEED = 0.02  # ... until no grain moves faster than this, m/s
SAND_LATTICE = 2.2  # the grains start on a square lattice of this many radii (jittered by 10% of a radius)
SAND_V1_GRAIN_MASS = 0.5  # the Sand-v1 ids' grain mass, kg (registered; the env docstring's version history)
MAX_EPISODE_STEPS = 150  # the registered ids' episode length: 6 s of simulated time at the default 0.04 s
SAND_V1_EPISODE_STEPS = 300  # registered for the Sand-v1 ids: 12 s (the docstring's version history)
HEIGHTMAP_CELLS = 5  # the observation's sand height map: this many cells per horizontal axis
HEIGHTMAP_CELL = 0.2  # ... each this wide, m, centred on the ball

# Reward (the env docstring's "Rewards" table)
W_GOAL = 10.0  # per metre the ball gets closer to the goal
W_REACH = 1.0  # per metre the pusher gets closer to the push point behind the ball
SUCCESS_BONUS = 10.0


def check_parameters(dim: int, params: dict[str, Any], owner: str = "PenaltyBallsEnv.__init__") -> dict[str, Any]:
    """Validated keyword arguments, defaults filled in. Raises ValueError naming the bad argument,
    its value and its allowed range, and TypeError in Python's own wording for an unknown one
    (``owner() got an unexpected keyword argument 'x'``: wrappers such as TorchRL's ``GymEnv`` read
    it to retry without the argument)."""
    if dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3, got {dim!r}")
    for name in params:
        if name not in PARAMETERS and name not in CHOICE_PARAMETERS:
            raise TypeError(
                f"{owner}() got an unexpected keyword argument {name!r} (allowed: "
                f"{', '.join([*PARAMETERS, *CHOICE_PARAMETERS])})"
            )
    out: dict[str, Any] = {}
    for name, (choice_default, allowed, _) in CHOICE_PARAMETERS.items():
        out[name] = V.choice(name, params.get(name, choice_default), allowed)
    for name, (default, lo, hi, meaning) in PARAMETERS.items():
        value = params.get(name, default)
        if name in INT_PARAMETERS:
            out[name] = V.integer(name, value, lo, hi, meaning)
        else:
            out[name] = V.in_range(name, value, lo, hi, meaning)
    n_grains = out["grains"]
    if n_grains:
        sand_terrains = [name for name, cls in TERRAINS.items() if cls.holds_sand]
        if out["terrain"] not in sand_terrains:
            raise ValueError(
                f"terrain={out['terrain']!r} cannot hold grains (grains={n_grains}); sand needs one of "
                f"{', '.join(map(repr, sand_terrains))} (a floor with a closed-form height for the height map)"
            )
        most = max_grains(dim, out["grain_radius"], out["bowl_radius"], out["terrain"])
        if n_grains > most:
            raise ValueError(
                f"grains={n_grains} grains of radius {out['grain_radius']:g} m would fill the {dim}D "
                f"{out['terrain']} deeper than {SAND_MAX_DEPTH:g} m; at most {most} fit (use fewer or smaller grains)"
            )
    n_obs = out["n_obstacles"]
    if n_obs:
        region = OBSTACLE_REGION[dim]
        reach = out["obstacle_radius"] + OBSTACLE_GAP
        used = n_obs * (math.pi * reach**2 if dim == 3 else 2.0 * reach)
        room = math.pi * region**2 if dim == 3 else 2.0 * region
        if used > OBSTACLE_DENSITY * room:
            fit = int(OBSTACLE_DENSITY * room / (used / n_obs))
            raise ValueError(
                f"n_obstacles={n_obs} obstacles of radius {out['obstacle_radius']:g} do not fit the "
                f"{dim}D start region (at most {fit}); use fewer or smaller obstacles"
            )
    return out


def max_grains(dim: int, grain_radius: float, bowl_radius: float, terrain: str) -> int:
    """The most grains whose bed, at ``SAND_PACKING`` (0.8 in 2D), is at most ``SAND_MAX_DEPTH`` deep
    on ``terrain`` (its room for a bed that deep: the bowl's cap, the arena's floor times the depth)."""
    room = make_terrain(terrain, dim, bowl_radius, 0.0).sand_room(SAND_MAX_DEPTH)
    grain = 4.0 / 3.0 * math.pi * grain_radius**3 if dim == 3 else math.pi * grain_radius**2
    return int(room * (SAND_PACKING if dim == 3 else 0.8) / grain)

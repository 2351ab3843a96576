"""The PenaltyBalls task's parameters: every keyword argument with its default, range and meaning
(the env docstrings print this table), their check, and the task's constants (start distribution,
sand, terrains, rewards).

Units are SI (metres, kilograms, seconds, newtons). The last axis is up.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from .. import _validate as V

__all__ = [
    "RANDOMIZE",
    "STIFFNESS_FACTOR",
    "check_randomize",
    "check_randomize_override",
    "check_options",
    "check_seed",
    "PARAMETERS",
    "INT_PARAMETERS",
    "CHOICE_PARAMETERS",
    "check_parameters",
    "coerce_action",
    "render_fps",
    "max_grains",
    "BALL_START_RADIUS",
    "GOAL_DISTANCE",
    "PUSHER_GAP",
    "OBSTACLE_REGION",
    "OBSTACLE_GAP",
    "OBSTACLE_DENSITY",
    "OBSTACLE_TRIES",
    "SAND_TERRAINS",
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
    "ARENA_HALF_WIDTH",
    "BUMPY_HALF_WIDTH",
    "BUMPY_CELL",
    "BUMPY_COUNT",
    "BUMPY_WIDTH",
    "BUMPY_TAPER",
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
        ("bowl", "arena", "bumpy"),
        "the ground: the spherical bowl (v0's), a flat arena walled by planes, or the bowl as a height "
        "field with random bumps redrawn at every reset",
    ),
    "physics": (
        "sliding",
        ("sliding", "rolling"),
        "the balls slide without spinning (v0's), or spin and roll (v1's default: friction exerts a torque, "
        "rolling resistance rolling_resistance)",
    ),
}

# Domain randomisation (``randomize=``; the env docstring's "Domain randomisation" section): the
# names a range may be given for, in the order a reset draws them, each with the keyword argument
# of PARAMETERS whose allowed range bounds it (None: its own bounds below) and its meaning
RANDOMIZE: dict[str, tuple[str | None, str]] = {
    "pusher_mass": ("pusher_mass", "the pusher's mass, kg"),
    "ball_mass": ("ball_mass", "the ball's mass, kg"),
    "obstacle_mass": ("obstacle_mass", "every obstacle's mass, kg"),
    "pusher_radius": ("pusher_radius", "the pusher's radius, m"),
    "ball_radius": ("ball_radius", "the ball's radius, m"),
    "obstacle_radius": ("obstacle_radius", "every obstacle's radius, m"),
    "friction": ("friction", "Coulomb friction coefficient mu of every contact"),
    "restitution": ("restitution", "restitution of a pusher-ball impact (sets the dashpots)"),
    "stiffness": (None, "a factor on the derived contact stiffness ks (and the terrain's)"),
    "max_force": ("max_force", "the pusher motor's stall force, N"),
    "roughness": ("roughness", "terrain='bumpy': the largest bump height, m"),
}
STIFFNESS_FACTOR = (0.25, 4.0)  # the allowed range of the ``stiffness`` factor


# Start distribution (the env docstring's "Starting State" table)
BALL_START_RADIUS = 0.5  # the ball starts within this horizontal distance of the bowl's bottom
GOAL_DISTANCE = (0.4, 0.8)  # goal: this far from the ball's start, uniform
PUSHER_GAP = (0.1, 0.4)  # pusher: this surface gap from the ball, uniform
OBSTACLE_REGION = {3: 1.2, 2: 1.5}  # obstacles: disc radius (3D) / half-length (2D) around the bottom
OBSTACLE_GAP = 0.05  # minimum surface gap of an obstacle to any other ball at the start
OBSTACLE_DENSITY = 0.25  # obstacle footprints may cover at most this share of their region
OBSTACLE_TRIES = 10_000

# Sand (grains > 0; the env docstring's "Sand" section)
SAND_TERRAINS = ("bowl", "arena")  # terrains with an analytic floor (the height map's reference)
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

# Terrains other than the bowl (the env docstring's "Terrain" table)
ARENA_HALF_WIDTH = 2.0  # terrain="arena": the walls stand this far from the centre, m
BUMPY_HALF_WIDTH = 2.5  # terrain="bumpy": the height field covers the square of this half width, m
BUMPY_CELL = 0.1  # ... with nodes this far apart, m
BUMPY_COUNT = {3: 40, 2: 12}  # Gaussian bumps per draw
BUMPY_WIDTH = (0.15, 0.35)  # their standard deviation, m, uniform
BUMPY_TAPER = 0.5  # bumps fade out over this distance to the field's edge, m (the bowl beyond is smooth)

# Reward (the env docstring's "Rewards" table)
W_GOAL = 10.0  # per metre the ball gets closer to the goal
W_REACH = 1.0  # per metre the pusher gets closer to the push point behind the ball
SUCCESS_BONUS = 10.0


def render_fps(control_period: float) -> int:
    """Frames per second of a video of the env: one frame per control period."""
    return max(1, round(1.0 / control_period))


def coerce_action(action: Any, shape: tuple[int, ...]) -> np.ndarray:
    """An action as a float array of ``shape``, or a ValueError that says what was wrong."""
    try:
        a = np.asarray(action, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"action must be an array of numbers with shape {shape}, got {action!r}") from None
    if a.shape != shape:
        raise ValueError(f"action must have shape {shape} (one throttle per horizontal axis), got shape {a.shape}")
    return a


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
        if out["terrain"] not in SAND_TERRAINS:
            raise ValueError(
                f"terrain={out['terrain']!r} cannot hold grains (grains={n_grains}); sand needs one of "
                f"{', '.join(map(repr, SAND_TERRAINS))} (a floor with a closed-form height for the height map)"
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
    """The most grains whose bed, at ``SAND_PACKING`` (0.8 in 2D), is at most ``SAND_MAX_DEPTH`` deep:
    the bowl's cap of that depth (3D: pi h^2 (3R - h) / 3; 2D: the circular segment), or the arena's
    floor (its walls' square, or line, times the depth)."""
    h, R = SAND_MAX_DEPTH, bowl_radius
    if terrain == "arena":
        room = (2.0 * ARENA_HALF_WIDTH) ** (dim - 1) * h
    elif dim == 3:
        room = math.pi * h * h * (3.0 * R - h) / 3.0
    else:
        room = R * R * math.acos((R - h) / R) - (R - h) * math.sqrt(2.0 * R * h - h * h)
    grain = 4.0 / 3.0 * math.pi * grain_radius**3 if dim == 3 else math.pi * grain_radius**2
    return int(room * (SAND_PACKING if dim == 3 else 0.8) / grain)


def check_options(options: Any, allowed: tuple[str, ...] = (), owner: str = "PenaltyBalls") -> dict[str, Any]:
    """``options`` as a dict: None or a mapping with string keys, each one of ``allowed`` (``owner``:
    the env named in the error)."""
    if options is None:
        return {}
    if not isinstance(options, Mapping):
        raise V.ArgumentTypeError(
            f"options must be None or a dict, got {V.describe(options)} ({type(options).__name__})"
        )
    unknown = [k for k in options if k not in allowed]
    if unknown:
        raise ValueError(
            f"options has unknown key(s) {', '.join(map(repr, unknown))}; {owner} accepts "
            f"{', '.join(map(repr, allowed)) or 'none'}"
        )
    return dict(options)


def check_seed(seed: Any) -> int | None:
    """A seed: None or an int >= 0 (numpy ints too, bools not)."""
    if seed is None:
        return None
    return V.integer("seed", seed, 0, None)


def check_randomize(randomize: Any, params: dict[str, Any], dim: int = 3) -> dict[str, tuple[float, float]]:
    """``randomize`` (None or a mapping from :data:`RANDOMIZE` names to ``(low, high)`` pairs of
    finite floats, low <= high, each within its parameter's allowed range) as a dict in the draw
    order; {} for None. ``params``: the checked keyword arguments (``roughness`` needs
    ``terrain="bumpy"``; sand refuses randomisation). Raises ValueError naming the bad entry."""
    if randomize is None:
        return {}
    if not isinstance(randomize, Mapping):
        raise V.ArgumentTypeError(
            f"randomize must be None or a dict of (low, high) ranges, got {V.describe(randomize)} "
            f"({type(randomize).__name__})"
        )
    unknown = [k for k in randomize if k not in RANDOMIZE]
    if unknown:
        raise ValueError(
            f"randomize has unknown name(s) {', '.join(map(repr, unknown))}; allowed: {', '.join(RANDOMIZE)}"
        )
    if randomize and params["grains"]:
        raise ValueError(
            f"randomize is not supported with sand yet (grains={params['grains']}): the settled bed is made "
            "once for the scene's fixed grains and bodies; use a PenaltyBalls id (grains=0)"
        )
    if "roughness" in randomize and params["terrain"] != "bumpy":
        raise ValueError(f"randomize['roughness'] needs terrain='bumpy' (got terrain={params['terrain']!r})")
    out: dict[str, tuple[float, float]] = {}
    for name, (param, meaning) in RANDOMIZE.items():
        if name not in randomize:
            continue
        lo_allowed, hi_allowed = STIFFNESS_FACTOR if param is None else PARAMETERS[param][1:3]
        out[name] = _range(f"randomize[{name!r}]", randomize[name], lo_allowed, hi_allowed, meaning)
    if "obstacle_radius" in out and params["n_obstacles"]:  # every draw's obstacles must fit their region
        try:
            check_parameters(dim, dict(params, obstacle_radius=out["obstacle_radius"][1]))
        except ValueError as exc:
            raise ValueError(
                f"randomize['obstacle_radius'] = {out['obstacle_radius']}: at its largest, {exc}"
            ) from None
    return out


def _range(label: str, value: Any, lo_allowed: float, hi_allowed: float, meaning: str) -> tuple[float, float]:
    """A (low, high) pair of finite floats with lo_allowed <= low <= high <= hi_allowed."""
    pair = value.tolist() if isinstance(value, np.ndarray) else value
    ok = isinstance(pair, (tuple, list)) and len(pair) == 2
    ok = ok and all(isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) for v in pair)
    if not ok or not all(math.isfinite(float(v)) for v in pair):
        raise ValueError(f"{label} must be a (low, high) pair of finite floats ({meaning}), got {value!r}")
    lo, hi = float(pair[0]), float(pair[1])
    if lo > hi:
        raise ValueError(f"{label} = {value!r}: low must be <= high")
    if lo < lo_allowed or hi > hi_allowed:
        raise ValueError(f"{label} = ({lo:g}, {hi:g}) must lie within [{lo_allowed:g}, {hi_allowed:g}] ({meaning})")
    return lo, hi


def check_randomize_override(override: Any, ranges: dict[str, tuple[float, float]]) -> dict[str, tuple[float, float]]:
    """The ranges of one reset: ``ranges`` (the make-time ones) with those of ``override`` (reset
    option ``randomize``: a mapping of some of their names to pairs within them) replaced. Raises
    ValueError for a name not randomised at make or a range outside the make-time one (the
    stability guard and the substep cover only those)."""
    if override is None:
        return ranges
    if not ranges:
        raise ValueError(
            "options['randomize'] needs an env made with randomize=... (the guard checks the ranges at make)"
        )
    if not isinstance(override, Mapping):
        raise V.ArgumentTypeError(
            f"options['randomize'] must be a dict of (low, high) ranges, got {V.describe(override)}"
        )
    out = dict(ranges)
    for name, value in override.items():
        if name not in ranges:
            raise ValueError(
                f"options['randomize'] names {name!r}, which the env was not made to randomise "
                f"(randomize={{...}} at make: {', '.join(ranges)})"
            )
        lo, hi = ranges[name]
        out[name] = _range(f"options['randomize'][{name!r}]", value, lo, hi, f"within the make-time range of {name}")
    return out

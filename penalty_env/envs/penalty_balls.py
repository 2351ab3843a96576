"""PenaltyBalls: push a ball to a goal in a spherical bowl, on the penalty-contact physics core.

``PenaltyBallsEnv`` is the Gymnasium env; ``PenaltyBallsVectorEnv`` is its native
vector twin (all worlds stepped in one Numba call). Both drive one
:class:`~penalty_env.envs.scene.PenaltyBallsScene`, as does the SB3 adapter (:mod:`penalty_env.sb3`),
so all three produce the same episodes.
"""

from __future__ import annotations

from typing import Any

from gymnasium.vector import AutoresetMode

from .. import _validate as V
from .balls.params import CHOICE_PARAMETERS, MAX_EPISODE_STEPS, PARAMETERS, SAND_V1_EPISODE_STEPS
from .balls.scene import PenaltyBallsScene
from .checks import render_fps
from .faces import TaskEnv, TaskVectorEnv, check_autoreset_mode, check_episode_steps, check_render_mode
from .terrains import terrain_table
from .views import OBS_MODES, Views, pop_view_kwargs

__all__ = ["PenaltyBallsEnv", "PenaltyBallsVectorEnv", "MAX_EPISODE_STEPS", "SAND_V1_EPISODE_STEPS"]


def _parameters_table() -> str:
    rows = ["    | Parameter | Default | Allowed | Description |", "    |---|---|---|---|"]
    for name, (choice, allowed, meaning) in CHOICE_PARAMETERS.items():
        rows.append(f"    | `{name}` | `{choice!r}` | {', '.join(f'`{a!r}`' for a in allowed)} | {meaning} |")
    for name, (default, lo, hi, meaning) in PARAMETERS.items():
        rows.append(f"    | `{name}` | {default} | [{lo}, {hi}] | {meaning} |")
    return "\n".join(rows)


class PenaltyBallsEnv(TaskEnv):
    """
    ## Description

    A pusher sphere and a ball rest in a spherical bowl (the course's terrain: the inside of a
    sphere of radius 8 m, gravity down). The agent drives the pusher with a horizontal motor and
    must push the ball onto a goal marked on the terrain. Every contact (pusher, ball, optional
    obstacle balls, terrain) is a penalty spring-dashpot with regularised Coulomb friction, stepped
    by the project's Numba core (``penalty_env.physics``). In `-v0` the balls slide without
    spinning; in `-v1` they spin and roll (`physics="rolling"`: friction acts at the contact point
    and exerts a torque, and a small rolling resistance `rolling_resistance` slows a rolling ball).

    `PenaltyBalls-v0` and `-v1` are 3D. `PenaltyBalls2D-v0` and `-v1` are the same task in the
    bowl's vertical slice (circles on a curve, the 2D kernels): there the pusher cannot pass the
    ball, so it starts on the far side of the ball from the goal. In `-v1` the pusher's motor still
    pushes at its centre (an action means what it means in `-v0`, and the same observation serves),
    and friction at the ground makes the pusher roll as it drives; a pushed ball rolls on instead of
    stopping like a puck, so the agent must push more gently or stop it on the goal.

    ## Action Space

    `Box(-1, 1, (d - 1,), float32)`: one motor throttle `a_k` per horizontal axis (x, y in 3D; x
    in 2D). The pusher feels the force `max_force * (a_k - v_k / max_speed)` along axis k, with
    its velocity v_k updated every physics substep: a DC motor's linear force-speed law (full force
    at rest, none at the top speed), so the pusher's self-driven speed stays below `max_speed`.
    Ground friction takes `mu m g` of it: throttles below about 0.15 do not start a resting
    pusher (a dead zone, as with any real motor). No vertical force: the
    pusher stays on the terrain. Finite values outside [-1, 1] are clipped, and a throttle vector
    longer than 1 is scaled to length 1 (so the pusher's speed, not just each component, stays
    below `max_speed`); an action of the wrong
    shape, or with NaN or inf, raises `ValueError`.

    ## Observation Space

    `obs_mode=` picks the observation (the keyword of `gymnasium.make`, `gymnasium.make_vec` and
    `penalty_env.sb3.make_vec_env`): `"state"` (the default), `"heightmap"`, `"rgb"`, or a tuple
    or list of them, e.g. `("state", "rgb")`, for a `spaces.Dict` keyed by mode name. Any other
    value raises `ValueError` naming the allowed ones. Every mode is computed for every terrain,
    in 2D and 3D, with and without sand; the vector and SB3 envs give the same observations as
    single envs seeded the same.

    | Keyword | Default | Allowed | Description |
    |---|---|---|---|
    | `obs_mode` | `"state"` | `"state"`, `"heightmap"`, `"rgb"`, a tuple or list of them | the observation |
    | `heightmap_cells` | 16 | [2, 64] | `"heightmap"`: cells per horizontal axis |
    | `heightmap_cell` | 0.1 | [0.01, 1.0] | `"heightmap"`: cell edge, m |
    | `rgb_size` | 64 | [16, 256] | `"rgb"`: image width and height, pixels |

    ### `obs_mode="state"`

    `Box(float32)` of size `7 d + 2 d n_obstacles` (21 in 3D, 14 in 2D without obstacles). Each
    entry is clipped to its bounds, which no physical state reaches. Positions are relative to the
    bowl's lowest point (the origin); the last axis is up; R is `bowl_radius`.

    | Index | Observation | Min | Max |
    |---|---|---|---|
    | 0 : d | pusher position | -R (up: 0) | R (up: 2R) |
    | d : 2d | pusher velocity, m/s | -v_bound | v_bound |
    | 2d : 3d | ball position | -R (up: 0) | R (up: 2R) |
    | 3d : 4d | ball velocity | -v_bound | v_bound |
    | 4d : 5d | goal position (a resting ball's centre at the goal) | -R (up: 0) | R (up: 2R) |
    | 5d : 6d | ball - pusher | -2R | 2R |
    | 6d : 7d | goal - ball | -2R | 2R |
    | 7d + 2dj : 7d + 2dj + d | obstacle j position | -R (up: 0) | R (up: 2R) |
    | 7d + 2dj + d : 7d + 2d(j+1) | obstacle j velocity | -v_bound | v_bound |

    `v_bound = max(10 max_speed, sqrt(4 g R))` (the speed of a fall through the bowl's height).

    With sand (`grains > 0`, the `PenaltyBallsSand` ids) the grains are not observed one by one:
    after these fields comes the sand's height map around the ball, `5^(d-1)` entries (25 in 3D,
    5 in 2D; see "Sand"), so the size stays fixed whatever the grain count.

    ### `obs_mode="heightmap"`

    `Box(0, 2R, (cells, cells), float32)` in 3D, `(cells,)` in 2D: a grid of `heightmap_cells`
    cells of `heightmap_cell` metres (16 x 16 cells of 0.1 m: 1.6 m square) centred on the
    pusher; entry `[i, j]` is at x = pusher x + (i - (cells - 1) / 2) cell (y likewise with j).
    Each entry is the height above the bowl's lowest point of whatever is highest over the cell's
    centre: the terrain there, or the top of a ball (pusher, ball, obstacles, grains) over it,
    z + sqrt(r^2 - rho^2) at horizontal distance rho < r from its centre. The terrain's height is
    the bowl's closed form R - sqrt(R^2 - rho^2) (solid beyond its rim: 2R), the arena's floor 0
    (its walls: 2R), or on the bumpy ground the height field's nodes, bilinear, the bowl beyond.
    Clipped to [0, 2R]. The goal is not in the map: combine the mode with `"state"` (a `Dict`)
    for a policy that must find it.

    ### `obs_mode="rgb"`

    `Box(0, 255, (size, size, 3), uint8)` (`rgb_size`, 64 by default), channel-last as SB3's
    `CnnPolicy` expects: a top view in 3D (x right, y up), a side view in 2D (x right, z up),
    3.5 m across and centred on the bowl's bottom like `render()`'s frames: the terrain's image
    (slope shading and height contours; grey walls; per world on the bumpy ground, redrawn when
    its bumps change), the goal as a green disc of radius `goal_tolerance`, and each ball as a
    flat disc of its colour (grains, obstacles grey, the pusher blue, the ball orange on top). A
    ball outside the view is drawn small at the border. About 130,000 images per second at
    1,024 worlds on 2 cores (`python -m penalty_env.bench views`).

    ## Rewards

    Dense, potential-based shaping plus a success bonus. `distance` is the ball-goal distance;
    `pusher_distance` is the pusher's distance to the *push point*, one contact distance behind the
    ball on the goal-ball line (where a pusher moving toward the goal pushes the ball at it).

    | Term (`info` key) | Value per step |
    |---|---|
    | `reward_goal` | 10 x (previous `distance` - `distance`): +10 per metre the ball gains |
    | `reward_reach` | 1 x (previous `pusher_distance` - `pusher_distance`) |
    | `reward_success` | +10 on the step the ball reaches the goal |

    The reward is their sum (a Python float); an episode's shaping adds up to the progress made,
    so a successful episode earns about 13 to 19 (3 to 8 for the ball's progress, up to ~1 for
    the pusher's, 10 for the success). `info` also holds `distance`,
    `pusher_distance`, `is_success` (bool; SB3's `EvalCallback` reads it) and `max_overlap`, the
    physics diagnostic: the largest contact overlap as a fraction of the smaller radius. Info
    values are numpy float64 scalars; `is_success` is a Python bool (Gymnasium's own vector envs
    batch a numpy bool into an object array).

    ## Starting State

    Every body starts at rest on the terrain (sunk by its resting overlap m g / ks). All draws
    come from the env's `np_random`, in this order:

    | Body | 3D | 2D |
    |---|---|---|
    | ball | uniform in the disc of radius 0.5 m around the bottom | uniform in [-0.5, 0.5] m |
    | goal | 0.4 to 0.8 m from the ball (uniform), uniform direction | same distance, random side |
    | pusher | surface gap 0.1 to 0.4 m from the ball (uniform), uniform direction | same gap, on the far side from the goal |
    | obstacles | uniform in the disc of radius 1.2 m, >= 0.05 m from every other ball and clear of the goal circle | uniform in [-1.5, 1.5] m, same clearances |

    ## Episode End

    1. Termination (success): the ball's centre is within `goal_tolerance` (0.1 m) of the goal
       (with sand: horizontally, see "Sand").
    2. Truncation: 150 steps (6 s of simulated time; the Sand-v1 ids: 300 steps, 12 s), from the
       registered `max_episode_steps`.

    `terminated` and `truncated` are Python bools. A uniformly random policy almost never
    succeeds (0 of 1,024 episodes in 3D, 0.3% in 2D); the scripted pusher in
    `penalty_env.envs.scripted` always does (1,024 of 1,024, in about 83 steps on average in 3D).

    ## Physics

    Derived from the scene's tolerances by `penalty_env.physics.configure` (the same function a
    user of the core calls) for the task's contact, the pusher-ball impact (defaults in brackets),
    not set by hand:
    - the contact stiffness `ks` keeps both a head-on impact at `max_speed` (ks >= m_eff v^2 /
      delta^2) and the motor pressing the pusher into a blocked ball at full force (ks >=
      max_force / delta) under delta = `penetration_tolerance` x the smaller radius [1481 N/m];
    - the dashpot gives the impact exactly the chosen `restitution` (normal force clipped at
      zero: no pull at separation); the terrain uses the same spring, stiffened where that spring
      would let a body rest deeper than `penetration_tolerance` x its radius (ks_terrain >=
      m g / (tolerance r) for every body), with the ball's bounce off it at the same restitution.
      Obstacles share the spring and dashpot: a pair heavier than pusher and ball rebounds more
      and overlaps deeper at the same speed, a lighter one less;
    - the substep `dt` is the largest symplectic-Euler step whose worst-case restitution error
      (over where a contact starts within the step), by the error models measured in
      `python -m penalty_env.bench accuracy`, stays within `restitution_accuracy` [30%: 9
      substeps of 4.4 ms per 0.04 s step], and within the core's stability limit for every
      contact the scene can form. Tighten it for physics studies (5%: 49 substeps); a looser
      bounce buys speed (50%: 7 substeps);
    - friction is regularised Coulomb with the largest viscous slope `kf` that brings the
      lightest contact's sliding to rest in one substep without overshoot [75 N s/m].
    A ball pushed to 1 m/s slides about 17 cm before friction stops it.
    `env.unwrapped.scene.describe()` prints the derived values and `scene.config` holds
    configure's full answer (predicted errors, cost, the alternatives it weighed).

    ## Arguments

    `gymnasium.make("PenaltyBalls-v0", render_mode=None, **kwargs)`; each keyword is checked, and
    a value outside its range raises `ValueError` naming the range. `max_episode_steps` sets the
    episode length (the `TimeLimit`).

    {parameters}

    Also: `max_force / max_speed * dt / pusher_mass` must be <= 1 (the motor's speed feedback,
    explicit per substep, must not overshoot), and the obstacles must fit their start region (at
    most 8 of the default size in 3D, 1 in 2D).

    ## Domain randomisation

    `randomize=` (default None: the fixed scene, its episodes unchanged bit for bit) gives ranges,
    `{name: (low, high)}`, from which every reset draws each world's physics, e.g.
    `gymnasium.make("PenaltyBalls-v0", randomize={"ball_mass": (0.5, 2.0), "friction": (0.2, 0.8),
    "restitution": (0.3, 0.6)})` (also `gymnasium.make_vec`, `PenaltyBallsVectorEnv` and
    `penalty_env.sb3.make_vec_env`). Names, in the order a reset draws them: `pusher_mass`,
    `ball_mass`, `obstacle_mass`, `pusher_radius`, `ball_radius`, `obstacle_radius`, `friction`,
    `restitution`, `stiffness` (a factor on the derived contact stiffness `ks` and the terrain's,
    allowed [0.25, 4]), `max_force` (the motor's strength) and `roughness` (`terrain="bumpy"`
    only). Each range must lie within its keyword argument's allowed range (the table above); an
    unknown name, a malformed pair or a range outside raises `ValueError` naming it. Sand
    (`grains > 0`) refuses randomisation for now.

    - **Draws.** At each reset a world draws one uniform `u` per given name, in the order above,
      from its own generator (the env's `np_random`; in a vector env world i's, seeded `seed + i`)
      *before* the start's draws, and takes `low + (high - low) u`; the start then uses the drawn
      radii. Same seed, same draws and episodes, in the single env, the vector env and SB3 alike.
    - **What a draw sets**, derived as the fixed scene derives it from its keyword arguments: `ks`
      from the pusher-ball impact at `max_speed` and the motor's stall force under the penetration
      tolerance (`physics.configure`'s rule; its further stiffening for a peak-overlap error, 1 at
      the defaults, is not redone per draw), times `stiffness`; `kd` from the restitution by the
      no-tension closed form; the terrain's spring stiffened where a body would rest deeper than
      the tolerance, and its dashpot; `kf` from the lightest pair; the resting overlap `m g / ks`
      at the start, the push point's offset and the obstacles' clearance from the radii.
    - **The substep** is fixed at make and covers every draw: the fixed scene's rule (the
      accuracy step of `configure` and the stability guard) and the motor's feedback bound, taken
      at every corner of the ranges. Ranges that need a smaller step than the fixed scene's make
      the scene take more substeps (slower) with a `RandomizationWarning` naming the ranges and
      the step they need; ranges that would need more than 1,000 substeps per step are refused.
    - **`reset(options={"randomize": {...}})`** replaces some ranges for that reset only (single
      env; the vector env's reset too), each within its make-time range (the guard covers only
      those), else `ValueError`.
    - **`info["randomization"]`**: the world's drawn values, `{name: float}` (the vector env
      batches them per name with `_name` masks, as Gymnasium batches a dict-valued info; the SB3
      `VecEnv` gives each world's dict).
    - **Cost**: each world's parameters are arrays the kernels read per world (one compile for a
      randomised scene, none per reset); `python -m penalty_env.bench randomize` measures the
      env-steps/s against the fixed scene's.

    ## Terrain

    `terrain=` picks the ground (every choice in 2D too, where planes are lines and the height
    field is a curve); the start distribution, goals and rewards are the same on each:

    {terrains}

    A height field's phi is the vertical gap times the local normal's z component, exact on a
    tilted plane; on the bumps its error is within the curvature bound in `docs/physics.md`
    section 1. The shapes themselves are
    `penalty_env.physics` shapes; `World` takes any of them (see `docs/physics.md`).

    ## Sand

    `PenaltyBallsSand-v0` (3D, 300 grains) and `PenaltyBallsSand2D-v0` (40 grains) are v1 (the
    balls roll) with the bowl's bottom filled by a bed of grains (`grains`, up to 10,000;
    `grain_radius` 0.06 m, `grain_mass` 0.15 kg) that the pusher and the ball plough through.
    The grains are balls of the same contact model (spring, dashpot, friction at the contact
    point, rolling resistance): the scene's `ks` and `kd` serve every pair, so a grain contact is
    overdamped (a grain barely bounces, as sand) and the dashpot sets the substep (25 per step
    at the defaults; lighter grains need more: the stability limit is `kd`-bound).
    `PenaltyBallsSand-v1` and `PenaltyBallsSand2D-v1` are the same task with grains of 0.5 kg
    (`grain_mass=0.5`: the grains no longer set the substep, 9 per step as in v1) and episodes
    of 300 steps (12 s: through Sand-v0's bed the scripted pusher needs a median of 100 steps
    and reaches the goal within 150 steps in only 70% of episodes); see the version history.
    PPO learns Sand-v1 as a curriculum, from a policy trained on v1 (`train/train_ppo.py
    --init-from`; docs/granular.md section 5); from scratch it did not learn in 30 minutes.

    - **The bed** is settled once per configuration and process: the grains drop from a lattice
      around the bottom and are stepped with the scene's own physics (grains alone) until none
      moves faster than 2 cm/s (at least 2 s, at most 20 s of simulated time; a bed still moving
      then warns). Every reset starts from that bed turned about the vertical by a uniform angle
      (the arena: a quarter turn; 2D: mirrored or not), drawn from the env's `np_random` after the
      start's draws, grains at rest: `reset` costs about a millisecond (`python -m
      penalty_env.bench env`).
    - **The bodies** start at the usual horizontal positions, lifted onto the sand (touching the
      highest grain under them) or resting on the floor where there is none.
    - **The goal** is reached horizontally: `distance`, `pusher_distance`, the rewards and
      success use the horizontal axes only (the sand's surface moves; a ball on the bed rides
      above the floor). The observed goal position is a resting ball's centre there on the bare
      floor, as without sand.
    - **The height map** in the observation: `5^(d-1)` cells of 0.2 m centred on the ball (x then
      y, row-major), each the sand's depth there: the highest grain top (z + r) in the cell above
      the bare floor under that grain, 0 where there is none.
    - **Terrains:** `"bowl"` and `"arena"` (a floor with a closed-form height); a bed deeper than
      0.5 m is refused, naming the most grains that fit.
    - **Stepping:** each world by the core's scalar step through a grid of the grains' size; the
      pusher, the ball and the obstacles stay out of the grid and meet every ball directly
      (`penalty_env.physics.broadphase.new_grid(lead=...)`).

    ## Rendering

    `render_mode="rgb_array"` returns a uint8 `(render_height, render_width, 3)` frame (3D: top
    view with shaded spheres, drop shadows and terrain contour lines; 2D: side view);
    `"human"` shows it in a pygame window at `metadata["render_fps"]` (1 / `control_period`);
    pygame comes with the `render` extra: `pip install -e ".[render]"` from the repository's root
    (the package is installed from a clone; it is not on PyPI).

    ## Vectorized environment

    `gymnasium.make_vec("PenaltyBalls-v0", num_envs=N)` returns :class:`PenaltyBallsVectorEnv`:
    all N worlds stepped in one Numba call, with the same episodes as N single envs seeded
    `seed + i`. `penalty_env.sb3.make_vec_env` gives the same worlds as an SB3 `VecEnv`.

    ## Version History

    * v0: Initial version. Its episodes stay bit for bit what they were, with two documented
      exceptions that only touch argument combinations which did not work: where the
      pusher-ball spring would rest a body deeper than its penetration tolerance (about 1 in 5 of
      random in-range combinations, some burying a ball by more than its radius), the terrain
      spring is stiffened to hold it there; and a combination whose nearly elastic contacts gain
      energy at v0's substep warns (`EnergyDriftWarning`) instead of heating silently.
      The `terrain` and `roughness` keywords were added later: their defaults (`"bowl"`) are
      v0's episodes, unchanged; so were `physics` and `rolling_resistance` (default `"sliding"`:
      v0's episodes).
    * v1: the balls roll (`physics="rolling"`, `rolling_resistance=0.02`): the World's rotation
      with regularised Coulomb friction at the contact point (docs/physics.md section 8). Each
      world is stepped by the core's scalar step (the SIMD-lanes twin does not rotate), about 5x
      the cost of a v0 step. Same observation, action, reward and start distribution.
    * Sand-v0 (`PenaltyBallsSand-v0`, `PenaltyBallsSand2D-v0`): v1 with a settled bed of grains
      (`grains=300` in 3D, 40 in 2D; "Sand"). The keywords `grains`, `grain_radius` and
      `grain_mass` were added for it; their default (`grains=0`) leaves v0 and v1 unchanged.
    * Sand-v1 (`PenaltyBallsSand-v1`, `PenaltyBallsSand2D-v1`): Sand-v0 with `grain_mass=0.5`
      (0.15 in Sand-v0) and `max_episode_steps=300` (150), registered as such: the episodes of
      `gymnasium.make("PenaltyBallsSand-v0", grain_mass=0.5, max_episode_steps=300)`. Heavier
      grains make a step 2.8x cheaper (9 substeps, not 25: a grain's dashpot `kd dt / m` bounded
      the step) and the longer episodes leave room to plough through (the scripted pusher, 64
      episodes: 70% success on Sand-v0, 97% on Sand-v1, median 126 steps). Sand-v0 stays as it
      was, bit for bit.
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": render_fps(PARAMETERS["control_period"][0])}
    OBS_MODES: tuple[str, ...] = OBS_MODES  # obs_mode's values (the env pages list each one's space)

    def __init__(self, dim: int = 3, render_mode: str | None = None, **kwargs: Any) -> None:
        check_render_mode(render_mode, self.metadata["render_modes"])
        view_kwargs = pop_view_kwargs(kwargs)
        scene = PenaltyBallsScene(1, dim=dim, **kwargs)
        self.views = Views(scene, **view_kwargs)
        self._attach(scene, self.views, render_mode)


class PenaltyBallsVectorEnv(TaskVectorEnv):
    """N PenaltyBalls worlds stepped together: one Numba call per step (threads for large N).

    The same task, spaces and keyword arguments as :class:`PenaltyBallsEnv`, plus
    ``num_envs``, ``max_episode_steps`` (the vector env truncates episodes itself) and
    ``autoreset_mode`` (default ``NEXT_STEP``, Gymnasium's default; ``SAME_STEP`` and
    ``DISABLED`` are supported as Gymnasium's ``SyncVectorEnv`` implements them). World i draws
    its starts from its own generator, seeded ``seed + i`` by ``reset(seed=seed)``, so the
    episodes are exactly those of N single envs seeded ``seed + i`` (and of a ``SyncVectorEnv``
    of them, infos included). ``render()`` returns one frame per world.

    ``obs_mode`` (``"state"``, ``"heightmap"``, ``"rgb"`` or a tuple of them, with
    ``heightmap_cells``, ``heightmap_cell``, ``rgb_size``: :class:`PenaltyBallsEnv`'s "Observation
    Space") is observed for the whole batch in one Numba call per mode after each step
    (:class:`~.views.Views`); a ``Dict`` mode's batch is a dict of arrays with a leading world
    axis, and ``SAME_STEP``'s ``final_obs`` holds each ended world's last observation in the
    same mode.
    """

    metadata = {
        "render_modes": ["rgb_array"],
        "render_fps": render_fps(PARAMETERS["control_period"][0]),
        "autoreset_mode": AutoresetMode.NEXT_STEP,
    }

    def __init__(
        self,
        num_envs: int = 1,
        dim: int = 3,
        max_episode_steps: int = MAX_EPISODE_STEPS,
        render_mode: str | None = None,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        **kwargs: Any,
    ) -> None:
        max_episode_steps = check_episode_steps(max_episode_steps)
        check_render_mode(render_mode, self.metadata["render_modes"])
        mode = check_autoreset_mode(autoreset_mode)
        scene, self.views = self.parts(num_envs, dim, "PenaltyBallsVectorEnv.__init__", **kwargs)
        self._attach(scene, self.views, max_episode_steps, render_mode, mode)

    @staticmethod
    def parts(n_worlds: int, dim: int, owner: str, **kwargs: Any) -> tuple[PenaltyBallsScene, Views]:
        """The scene of ``n_worlds`` worlds and its view (``obs_mode`` and its keywords), from the
        env's keyword arguments (the SB3 ``VecEnv`` builds its worlds with this too)."""
        view_kwargs = pop_view_kwargs(kwargs)
        scene = PenaltyBallsScene(V.integer("num_envs", n_worlds, 1), dim=dim, owner=owner, **kwargs)
        return scene, Views(scene, **view_kwargs)


PenaltyBallsEnv.__doc__ = (
    (PenaltyBallsEnv.__doc__ or "")
    .replace("{parameters}", _parameters_table().strip())
    .replace("{terrains}", terrain_table().strip())
)

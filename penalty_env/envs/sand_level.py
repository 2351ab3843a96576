"""PenaltySandLevel: shape a heaped bed of grains to a target surface with a kinematic blade.

:class:`.level.scene.SandLevelScene` holds B worlds of the task over one batched physics ``World``; the single env
(:class:`PenaltySandLevelEnv`, B = 1) and the native vector env (:class:`PenaltySandLevelVectorEnv`)
both drive it, so they produce the same episodes. The grains are the penalty core's balls (spring,
dashpot, Coulomb friction at the contact point, rolling resistance); the floor and the four walls
are planes, and the blade is a kinematic ``Box`` whose velocity the action sets for each control
period (it moves with every physics step).

Units are SI (metres, kilograms, seconds). The last axis is up.
"""

from __future__ import annotations

from typing import Any

from gymnasium.vector import AutoresetMode

from .. import _validate as V
from .faces import TaskEnv, TaskVectorEnv, check_autoreset_mode, check_episode_steps, check_render_mode
from .level.scene import LEVEL_EPISODE_STEPS, LEVEL_PARAMETERS, SandLevelScene
from .views import Views, pop_view_kwargs


# ----------------------------------------------------------------------------------------------
# The environments
# ----------------------------------------------------------------------------------------------
class PenaltySandLevelEnv(TaskEnv):
    """
    ## Description

    A heap of grains lies in a walled square arena 2 m wide (in 2D its vertical slice, a trough
    2 m long). `PenaltySandLevel-v1` is the task at a size that matters: 2,000 grains of radius
    0.04 m (a flattened bed 2.8 grains deep, against v0's 250 grains that spread thinner than one
    grain), random targets by default, the springs from a softer budget, and a picture of the
    grains in `render()`; see Version History. The agent drives a kinematic blade, a box 0.06 m thick, 0.5 m wide and 0.5 m tall
    (2D: a rectangle 0.06 x 0.5 m), through the grains and must shape the bed to a target surface:
    flat by default (the level surface holding the grains' volume), a slope or a mound drawn per
    episode (`target="random"`), or any height map given at reset. The grains are the penalty
    core's balls (radius 0.06 m, mass 0.5 kg; v1 0.04 m, 0.148 kg; friction 0.5 with a tangential spring, so static
    friction holds, rolling resistance 0.1: the grains of docs/granular.md's 3D piles); the floor
    and the walls are planes; the blade is a `Box` terrain shape whose velocity the action sets
    for each control period, so it moves with every physics step and the grains feel its motion
    (the dashpot and friction act on the velocity relative to its surface).

    The blade's bottom follows the target surface under the blade's centre (bilinear between the
    target's cells) a grain radius above it (a bed's grain tops stand about a radius above its
    depth), and never below one grain layer plus 1 cm (0.13 m: lower, it would bulldoze every
    grain on the floor), as a grader's automatic blade control holds a design surface: the agent
    steers, the blade cuts what stands above the target and carries it on to where the bed lies
    below it. The blade's face is across the x axis, so it pushes along x (in 3D a move along y
    slides it sideways, edge first).

    ## Action Space

    `Box(-1, 1, (d - 1,), float32)`: the blade's horizontal velocity command, `blade_speed` (0.5
    m/s) per unit on each axis. Finite values outside [-1, 1] are clipped; the move is cut short
    where the blade would leave its range (its faces 0.1 m from the walls: the centre within
    0.87 m of the arena's centre along x, and 0.65 m along y in 3D). The blade's vertical speed
    towards its target height is at most `blade_speed`. NaN or inf, or a wrong shape, raises
    `ValueError`.

    ## Observation Space

    `Box(float32)` of size `2 C + 2 (d - 1)`, C = `cells`^(d-1) (10 x 10 = 100 in 3D, 20 in 2D:
    204 and 42 entries):

    | Index | Observation | Min | Max |
    |---|---|---|---|
    | 0 : C | the bed's height map, m | 0 | 1 |
    | C : 2C | the target height map, m | 0 | 1 |
    | 2C : 2C + d - 1 | the blade's horizontal position (its centre), m | -1 | 1 |
    | 2C + d - 1 : | the blade's horizontal velocity, m/s | -blade_speed | blade_speed |

    The maps cover the arena ([-1, 1] m along each horizontal axis) with `cells` cells per axis,
    row-major (x, then y). The height map is the depth of sand over each cell: the volume of the
    grains over it divided by the cell's area and a nominal solid fraction (0.6 in 3D, 0.82 in
    2D), so that a bed packed at that fraction reads its thickness. Each grain's volume is shared
    between the cells around its centre by bilinear (cloud-in-cell) weights, so the map changes
    continuously as grains move and its sum is the grains' volume exactly (a conserved quantity:
    tested). Values are clipped to 1 m (no heap reaches it). A map of the highest grain top per
    cell was the first design; it does not work with a few hundred grains: a heap of 250 grains
    holds a bed only 0.09 m deep (less than a grain) once spread over the arena, so a level bed
    reads 0 or a grain's height cell by cell (docs/level.md).

    ### Observation modes

    `obs_mode=` takes the PenaltyBalls envs' values and keywords (`"state"`, the default: the Box
    above; `"heightmap"`: the grains' and floor's surface height on a square grid centred on the
    blade, `heightmap_cells` x `heightmap_cells` cells of `heightmap_cell` m in 3D, a profile in
    2D; `"rgb"`: a picture of the grains from above, `rgb_size` pixels square; a tuple of them: a
    `Dict`). They are the same views, drawn by the same kernels, as PenaltyBalls' (one raster).

    ## Rewards

    `error` is the RMS over the cells of (height map - target), in metres. The reward is
    `100 x (previous error - error)`: +1 per centimetre of decrease. An episode's rewards add up
    to 100 x (initial error - final error) exactly. `info` holds `error`, `initial_error`,
    `is_success` and `grains_lost` (grains whose position is not finite or whose centre has left
    the arena: 0 in every episode measured).

    ## Starting State

    The heap is settled once per configuration and process (grains dropped from a lattice cone of
    35 degrees in the centre, v1 25, stepped with the scene's own physics for at least 15 s and until no
    grain moves faster than 5 mm/s) and cached; each reset starts from it, at rest, turned by a
    uniform quarter turn (3D) or mirrored with probability 1/2 (2D). The blade starts at rest at
    one of the two x ends of its range (the side uniform), in 3D at a uniform y within its range,
    its bottom at its target height or 5 mm above the grains under it, whichever is higher. The
    draws, from the env's `np_random`, in order: the turn, the side, for `target="random"` the
    target's five, then (3D) y.

    The flat target is the grains' volume over the arena's area at the map's solid fraction (0.094
    m in 3D, 0.166 m in 2D at the defaults; v1 0.223 m), which is also the mean of every height map with all
    grains inside. `target="random"` adds to it a relief of zero mean whose largest |value| is
    0.25 to 0.5 x the level: a plane sloping along a uniform direction, or a Gaussian mound or pit
    of standard deviation 0.4 m, each with probability 1/2. `reset(options={"target": map})` sets
    a map for that episode (C values, or (cells, cells) in 3D, within [0, 1] m; else `ValueError`
    naming `options['target']`).

    ## Episode End

    1. Termination (success): the error falls below `success_fraction` x the episode's initial
       error (0.5 in 3D, 0.7 in 2D, 0.75 in v1: the raster sweep in `penalty_env.envs.scripted`
       reaches it, in v1 in about half the episodes, a random policy does not; docs/level.md).
    2. Truncation: the registered `max_episode_steps` (300 steps, 30 s, in 3D; 150, 15 s, in 2D).

    ## Arguments

    `gymnasium.make("PenaltySandLevel-v0", **kwargs)`; `target` is `"flat"` (v0's default) or
    `"random"` (v1's); `version` (registered: 0, or 1 for `PenaltySandLevel-v1`) selects the
    grains, contact budget and defaults of `penalty_env.envs.level.scene.LEVEL_VERSIONS`; the
    others:

    {parameters}

    `grains` is refused beyond a flat level of 0.4 m.

    ## Domain randomisation

    `randomize={name: (low, high)}` (default None: the fixed scene, bit for bit) draws each world's
    physics at every reset, one uniform per name in this order, from the world's own generator
    before the heap's turn and the blade's side: `friction` (Coulomb mu of every contact, within
    [0, 1.5]), `grain_mass` (every grain's mass, kg, within [0.05, 2]) and `blade_speed` (within
    its argument's range). The springs and the substep are fixed at make and cover every draw: the
    stiffness and damping are derived for the heaviest grains and the fastest blade of the ranges
    (so lighter grains rebound less than restitution 0.3), the substep for the lightest grains'
    stability limit. The heap starts from the same settled bed for every draw (heavier or lighter
    grains sink or rise by their resting overlap, < 1% of a radius, in the first steps). The
    observation's velocity bounds are the fastest blade's. `reset(options={"randomize": {...}})`
    narrows ranges for one reset; `info["randomization"]` holds the drawn values. An unknown name
    or a range outside its allowed one raises `ValueError` naming it.

    ## Physics

    By `penalty_env.physics.configure`, as in the PenaltyBalls scene: a grain-grain impact at twice
    the blade's top speed overlaps at most 10% of a radius, also under the weight of a column of
    grains as tall as the heap's start lattice, and rebounds at restitution 0.3; the substep keeps
    the restitution's worst-case error within 30% and the core's stability limit, the tangential
    spring's included (89 substeps of 1.1 ms per 0.1 s step in 3D, 55 of 1.8 ms in 2D). Each world
    is stepped by the core's scalar step through a grid of the grains' size.
    `env.unwrapped.scene.describe()` prints the values.

    v1's budget (`penalty_env.envs.level.scene.LEVEL_VERSIONS`): an impact at the blade's top speed
    and the start column's weight overlap at most 20% of a radius; the terrain's spring (floor,
    walls and blade) is twice the pairs' (a grain on a shape has twice a pair's effective mass: the
    same omega, half the overlap); the substep is at most 0.8 of the stability limit (at the limit a settled bed
    jitters in place and never comes to rest). 70 substeps of 1.4 ms per 0.1 s step; the settled
    bed's largest overlap 0.17 r (docs/level.md). v1 steps on the core's neighbour-list path
    (randomised: the scalar path, whose parameters are per world).

    ## Rendering

    `render_mode="rgb_array"`: the height map and the target as grey levels (3D) or bars (2D),
    the blade's cell marked red. v1 draws the grains themselves on their left: from above, each
    grain a disc shaded by its height (dark on the floor, light at twice the flat level), the
    highest on top, the blade's footprint a red outline.

    ## Version History

    * v1 (3D): 2,000 grains of radius 0.04 m and mass 0.148 kg (v0's density), `target="random"`
      by default, a start cone of 25 degrees (the mound fits the arena), the springs from the
      budget above (ks 1,635 N/m, 70 substeps per step; v0's rule would need 133 for these
      grains), success at 0.75 of the initial error, the grains drawn by `render()`. v0
      unchanged, bit for bit.
    * v0: Initial version.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(self, dim: int = 3, render_mode: str | None = None, **kwargs: Any) -> None:
        check_render_mode(render_mode, self.metadata["render_modes"])
        scene, view = PenaltySandLevelVectorEnv.parts(1, dim, "PenaltySandLevelEnv.__init__", **kwargs)
        self._attach(scene, view, render_mode)


def _parameters_table() -> str:
    rows = ["    | Parameter | Default (3D, 2D) | Allowed | Description |", "    |---|---|---|---|"]
    for name, (default, lo, hi, meaning) in LEVEL_PARAMETERS.items():
        shown = f"{default[0]}, {default[1]}" if isinstance(default, tuple) else f"{default}"
        rows.append(f"    | `{name}` | {shown} | [{lo}, {hi}] | {meaning} |")
    return "\n".join(rows)


PenaltySandLevelEnv.__doc__ = (PenaltySandLevelEnv.__doc__ or "").replace("{parameters}", _parameters_table().strip())


class PenaltySandLevelVectorEnv(TaskVectorEnv):
    """N PenaltySandLevel worlds stepped together on one batched ``World``: the same task, spaces
    and keyword arguments as :class:`PenaltySandLevelEnv`, plus ``num_envs``,
    ``max_episode_steps`` (the vector env truncates episodes itself) and ``autoreset_mode``
    (Gymnasium's three modes; default ``NEXT_STEP``: the step after an episode ends resets that
    world: its observation, reward 0, not stepped). World i draws from its own generator, seeded
    ``seed + i`` by ``reset(seed=seed)``, so its episodes are those of a single env seeded
    ``seed + i``. ``reset(options={"target": map})`` gives every reset world that target (this
    reset only)."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10, "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(
        self,
        num_envs: int = 1,
        dim: int = 3,
        max_episode_steps: int | None = None,
        render_mode: str | None = None,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        **kwargs: Any,
    ) -> None:
        check_render_mode(render_mode, self.metadata["render_modes"])
        mode = check_autoreset_mode(autoreset_mode)
        scene, view = self.parts(num_envs, dim, "PenaltySandLevelVectorEnv.__init__", **kwargs)
        steps = check_episode_steps(LEVEL_EPISODE_STEPS[scene.dim] if max_episode_steps is None else max_episode_steps)
        self._attach(scene, view, steps, render_mode, mode)

    @staticmethod
    def parts(n_worlds: int, dim: int, owner: str, **kwargs: Any) -> tuple[SandLevelScene, Views]:
        """The scene of ``n_worlds`` worlds and its view (``obs_mode`` and its keywords), from the
        env's keyword arguments (the SB3 ``VecEnv`` builds its worlds with this too)."""
        view_kwargs = pop_view_kwargs(kwargs)
        scene = SandLevelScene(V.integer("num_envs", n_worlds, 1), dim=dim, owner=owner, **kwargs)
        return scene, Views(scene, **view_kwargs)

"""penalty_env: a Numba penalty-contact particle core and the PenaltyBalls Gymnasium environments.

Importing the package registers ``PenaltyBalls-v0`` (3D) and ``PenaltyBalls2D-v0`` with
Gymnasium, their ``-v1`` (the balls roll), and ``PenaltyBallsSand-v0`` / ``PenaltyBallsSand2D-v0``
(v1 with a bed of sand grains in the bowl) and their ``-v1`` (heavier grains, longer episodes),
and ``PenaltySandLevel-v0`` / ``PenaltySandLevel2D-v0`` (a blade levels a heap of grains), all
with a native vector entry point. Registration stores import paths only, so this
import stays cheap: the environments (and Numba) load when an env is first made.
"""

import re
import warnings

from gymnasium import logger as _gym_logger
from gymnasium.envs.registration import register, registry

__version__ = "0.1.0"

_ENVS = "penalty_env.envs.penalty_balls"
_MAX_EPISODE_STEPS = 150  # penalty_env.envs.balls.params.MAX_EPISODE_STEPS (kept literal: no import)
_SAND_V1_EPISODE_STEPS = 300  # penalty_env.envs.balls.params.SAND_V1_EPISODE_STEPS (kept literal: no import)
_SAND_V1_GRAIN_MASS = 0.5  # penalty_env.envs.balls.params.SAND_V1_GRAIN_MASS, kg (kept literal: no import)

# v0: balls that slide; v1: balls that roll (physics="rolling"; the docstring's version history).
# v1 is a sibling task, not v0's replacement (v0 stays the main id, bit for bit): Gymnasium's
# "PenaltyBalls-v0 is out of date, consider upgrading to v1" on every make of v0 would mislead.
# Likewise Sand-v0 (its makes stay silent as they were; the docs point sand users to Sand-v1) and
# Goal-v0 (below), and SandLevel-v0 (v1 is a larger task beside it). Two guards, for these ids' note only:
#  - a warnings filter. It holds until something resets the process's filters after this import:
#    pytest does for every test (its "always" for DeprecationWarning goes first), and so does
#    unittest's runner (simplefilter("default")), so a user's own tests would show the note;
#  - hence Gymnasium's logger.deprecation (the note's only caller, in gymnasium.envs.registration)
#    is wrapped to drop the note of these ids; every other message goes on as before, through
#    gymnasium.logger.warn with the same category and stack level (the warning names the caller).
_SIBLING_V0 = re.compile(r"The environment Penalty(Balls(Sand|Goal)?|SandLevel)(2D)?-v0 is out of date")
warnings.filterwarnings("ignore", message=".*" + _SIBLING_V0.pattern, category=DeprecationWarning)


def _without_sibling_v0_note(deprecation):
    """Gymnasium's ``logger.deprecation`` without the "out of date" note of the ids above."""
    if getattr(deprecation, "_penalty_env_v0", False):  # already wrapped (the package imported again)
        return deprecation

    def quiet_deprecation(msg: str, *args: object) -> None:
        if isinstance(msg, str) and _SIBLING_V0.search(msg):
            return
        # as gymnasium.logger.deprecation does: the warning is attributed to our caller's caller
        _gym_logger.warn(msg, *args, category=DeprecationWarning, stacklevel=2)

    quiet_deprecation.__doc__ = deprecation.__doc__
    quiet_deprecation._penalty_env_v0 = True  # type: ignore[attr-defined]
    return quiet_deprecation


_gym_logger.deprecation = _without_sibling_v0_note(_gym_logger.deprecation)
# Sand: v1's rolling physics with a settled bed of grains in the bowl (the `grains` parameter of
# penalty_env.envs.balls.params, registered here: 300 in 3D, 40 in 2D). Sand-v1: grains of 0.5 kg
# (no longer setting the substep: 9 per step as in v1, against Sand-v0's 25) and 300-step episodes
# (the env docstring's history).
for _id, _dim, _physics, _grains, _extra, _steps in (
    ("PenaltyBalls-v0", 3, "sliding", 0, {}, _MAX_EPISODE_STEPS),
    ("PenaltyBalls2D-v0", 2, "sliding", 0, {}, _MAX_EPISODE_STEPS),
    ("PenaltyBalls-v1", 3, "rolling", 0, {}, _MAX_EPISODE_STEPS),
    ("PenaltyBalls2D-v1", 2, "rolling", 0, {}, _MAX_EPISODE_STEPS),
    ("PenaltyBallsSand-v0", 3, "rolling", 300, {}, _MAX_EPISODE_STEPS),
    ("PenaltyBallsSand2D-v0", 2, "rolling", 40, {}, _MAX_EPISODE_STEPS),
    ("PenaltyBallsSand-v1", 3, "rolling", 300, {"grain_mass": _SAND_V1_GRAIN_MASS}, _SAND_V1_EPISODE_STEPS),
    ("PenaltyBallsSand2D-v1", 2, "rolling", 40, {"grain_mass": _SAND_V1_GRAIN_MASS}, _SAND_V1_EPISODE_STEPS),
):
    if _id not in registry:
        _kwargs: dict = {"dim": _dim}
        if _physics != "sliding":
            _kwargs["physics"] = _physics
        if _grains:
            _kwargs["grains"] = _grains
        _kwargs.update(_extra)
        register(
            id=_id,
            entry_point=f"{_ENVS}:PenaltyBallsEnv",
            vector_entry_point=f"{_ENVS}:PenaltyBallsVectorEnv",
            max_episode_steps=_steps,
            kwargs=_kwargs,
        )

# The sand-shaping task (penalty_env.envs.sand_level): a kinematic blade levels a heap of grains
# in a walled arena; 300-step episodes in 3D, 150 in 2D (penalty_env.envs.level.scene.LEVEL_EPISODE_STEPS,
# kept literal).
# v1 (3D): 2,000 smaller grains, random targets, springs from a softer budget
# (penalty_env.envs.level.scene.LEVEL_VERSIONS); a larger task beside v0, not its replacement.
for _id, _dim, _steps, _version in (
    ("PenaltySandLevel-v0", 3, 300, 0),
    ("PenaltySandLevel2D-v0", 2, 150, 0),
    ("PenaltySandLevel-v1", 3, 300, 1),
):
    if _id not in registry:
        register(
            id=_id,
            entry_point="penalty_env.envs.sand_level:PenaltySandLevelEnv",
            vector_entry_point="penalty_env.envs.sand_level:PenaltySandLevelVectorEnv",
            max_episode_steps=_steps,
            kwargs={"dim": _dim} if _version == 0 else {"dim": _dim, "version": _version},
        )

# Goal-conditioned variants of v0 and v1 (penalty_env.envs.goal): a Dict observation with
# observation / achieved_goal / desired_goal, a sparse reward by default, compute_reward for HER.
_GOAL_ENVS = "penalty_env.envs.goal"
for _id, _dim, _physics in (
    ("PenaltyBallsGoal-v0", 3, "sliding"),
    ("PenaltyBallsGoal2D-v0", 2, "sliding"),
    ("PenaltyBallsGoal-v1", 3, "rolling"),
    ("PenaltyBallsGoal2D-v1", 2, "rolling"),
):
    if _id not in registry:
        register(
            id=_id,
            entry_point=f"{_GOAL_ENVS}:PenaltyBallsGoalEnv",
            vector_entry_point=f"{_GOAL_ENVS}:PenaltyBallsGoalVectorEnv",
            max_episode_steps=_MAX_EPISODE_STEPS,
            kwargs={"dim": _dim} if _physics == "sliding" else {"dim": _dim, "physics": _physics},
        )

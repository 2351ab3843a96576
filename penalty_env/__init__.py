"""penalty_env: a Numba penalty-contact particle core and the PenaltyBalls Gymnasium environments.

Importing the package registers ``PenaltyBalls-v0`` (3D) and ``PenaltyBalls2D-v0`` with
Gymnasium, and their ``-v1`` (the balls roll), all with a native vector entry point. Registration stores import paths only, so this
import stays cheap: the environments (and Numba) load when an env is first made.
"""

import warnings

from gymnasium.envs.registration import register, registry

__version__ = "0.1.0"

_ENVS = "penalty_env.envs.penalty_balls"
_MAX_EPISODE_STEPS = 150  # penalty_env.envs.penalty_balls.MAX_EPISODE_STEPS (kept literal: no import)

# v0: balls that slide; v1: balls that roll (physics="rolling"; the docstring's version history).
# v1 is a sibling task, not v0's replacement (v0 stays the main id, bit for bit): Gymnasium's
# "PenaltyBalls-v0 is out of date, consider upgrading to v1" on every make of v0 would mislead.
warnings.filterwarnings(
    "ignore", message=r".*The environment PenaltyBalls(2D)?-v0 is out of date", category=DeprecationWarning
)
for _id, _dim, _physics in (
    ("PenaltyBalls-v0", 3, "sliding"),
    ("PenaltyBalls2D-v0", 2, "sliding"),
    ("PenaltyBalls-v1", 3, "rolling"),
    ("PenaltyBalls2D-v1", 2, "rolling"),
):
    if _id not in registry:
        register(
            id=_id,
            entry_point=f"{_ENVS}:PenaltyBallsEnv",
            vector_entry_point=f"{_ENVS}:PenaltyBallsVectorEnv",
            max_episode_steps=_MAX_EPISODE_STEPS,
            kwargs={"dim": _dim} if _physics == "sliding" else {"dim": _dim, "physics": _physics},
        )

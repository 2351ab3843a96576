"""penalty_env: a Numba penalty-contact particle core and the PenaltyBalls Gymnasium environments.

Importing the package registers ``PenaltyBalls-v0`` (3D) and ``PenaltyBalls2D-v0`` with
Gymnasium, both with a native vector entry point. Registration stores import paths only, so this
import stays cheap: the environments (and Numba) load when an env is first made.
"""

from gymnasium.envs.registration import register, registry

__version__ = "0.1.0"

_ENVS = "penalty_env.envs.penalty_balls"
_MAX_EPISODE_STEPS = 150  # penalty_env.envs.penalty_balls.MAX_EPISODE_STEPS (kept literal: no import)

for _id, _dim in (("PenaltyBalls-v0", 3), ("PenaltyBalls2D-v0", 2)):
    if _id not in registry:
        register(
            id=_id,
            entry_point=f"{_ENVS}:PenaltyBallsEnv",
            vector_entry_point=f"{_ENVS}:PenaltyBallsVectorEnv",
            max_episode_steps=_MAX_EPISODE_STEPS,
            kwargs={"dim": _dim},
        )

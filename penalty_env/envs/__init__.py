"""The PenaltyBalls Gymnasium environments (single, native vector) on the physics core."""

from .penalty_balls import MAX_EPISODE_STEPS, PenaltyBallsEnv, PenaltyBallsVectorEnv
from .balls.scene import PARAMETERS, PenaltyBallsScene

__all__ = ["PenaltyBallsEnv", "PenaltyBallsVectorEnv", "PenaltyBallsScene", "PARAMETERS", "MAX_EPISODE_STEPS"]

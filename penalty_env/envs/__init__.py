"""The PenaltyBalls Gymnasium environments (single, native vector) on the physics core."""

from .balls.scene import PARAMETERS, PenaltyBallsScene
from .penalty_balls import MAX_EPISODE_STEPS, PenaltyBallsEnv, PenaltyBallsVectorEnv

__all__ = ["PenaltyBallsEnv", "PenaltyBallsVectorEnv", "PenaltyBallsScene", "PARAMETERS", "MAX_EPISODE_STEPS"]

"""penalty_env: a Numba penalty-contact particle core and the PenaltyBalls Gymnasium environments."""

__version__ = "0.1.0"

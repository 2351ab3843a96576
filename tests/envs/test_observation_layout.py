"""The fused kernel writes the observation in ObservationLayout's order (it does not read the table
per entry, for speed): check it against a NumPy reading of the table."""

import gymnasium as gym
import numpy as np
import pytest

import penalty_env  # noqa: F401
from penalty_env.envs.balls.layout import DIFFERENCE, GOAL, POSITION, VELOCITY


def _reference(scene):
    x, v = scene.world.state.positions, scene.world.state.velocities
    lay = scene.layout
    d = lay.dim

    def body(who):
        return scene.goal if who == GOAL else x[:, who]

    cols = []
    for kind, a, b in lay.table:
        if kind == POSITION:
            cols.append(body(a))
        elif kind == VELOCITY:
            cols.append(v[:, a])
        else:
            assert kind == DIFFERENCE
            cols.append(body(a) - body(b))
    raw = np.concatenate(cols, axis=1)
    assert raw.shape[1] == lay.size == len(lay.table) * d
    return np.minimum(np.maximum(raw, lay.low), lay.high).astype(np.float32)


@pytest.mark.parametrize("env_id", ["PenaltyBalls-v0", "PenaltyBalls2D-v0", "PenaltyBalls-v1"])
@pytest.mark.parametrize("n_obstacles", [0, 1])
def test_kernel_observation_follows_the_layout_table(env_id, n_obstacles):
    venv = gym.make_vec(env_id, num_envs=32, n_obstacles=n_obstacles)
    obs, _ = venv.reset(seed=3)
    scene = venv.unwrapped.scene
    rng = np.random.default_rng(0)
    for _ in range(40):
        # large actions drive the pusher into the clipping bounds too
        obs, *_ = venv.step(rng.uniform(-3, 3, (32,) + venv.single_action_space.shape).astype(np.float32))
        np.testing.assert_array_equal(obs, _reference(scene))
    venv.close()

"""PenaltyBalls-v0 / PenaltyBalls2D-v0 as single Gymnasium envs: API, checkers, seeding, bad
input, and the physics the task is built from."""

from __future__ import annotations

import os
import subprocess
import sys
import warnings

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")  # check_env opens a "human" window too
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.error import ResetNeeded

import penalty_env  # noqa: F401  (registers the ids)
from penalty_env.envs import PARAMETERS, PenaltyBallsEnv
from penalty_env.envs.scripted import ScriptedPusher
from penalty_env.physics.world import EnergyDriftWarning

IDS = ("PenaltyBalls-v0", "PenaltyBalls2D-v0")
DIM = {"PenaltyBalls-v0": 3, "PenaltyBalls2D-v0": 2}


def rollout(env, actions, seed):
    """(obs, reward, terminated, truncated, info) of every step of one seeded episode."""
    obs, info = env.reset(seed=seed)
    out = [(obs, info)]
    for a in actions:
        step = env.step(a)
        out.append(step)
        if step[2] or step[3]:
            break
    return out


# ------------------------------------------------------------------------------ registration


def test_import_registers_both_ids_with_a_vector_entry_point():
    for env_id in IDS:
        spec = gym.spec(env_id)
        assert spec.entry_point == "penalty_env.envs.penalty_balls:PenaltyBallsEnv"
        assert spec.vector_entry_point == "penalty_env.envs.penalty_balls:PenaltyBallsVectorEnv"
        assert spec.max_episode_steps == 150
        assert spec.kwargs == {"dim": DIM[env_id]}


def test_import_is_cheap_and_make_needs_no_prior_import():
    code = (
        "import sys, penalty_env\n"
        "heavy = [m for m in ('numba', 'torch', 'stable_baselines3', 'pygame') if m in sys.modules]\n"
        "assert not heavy, heavy\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
    code = (
        "import gymnasium as gym\n"
        "env = gym.make('penalty_env:PenaltyBalls-v0')\n"
        "obs, info = env.reset(seed=0)\n"
        "assert obs.shape == (21,)\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


# ------------------------------------------------------------------------------ checkers


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("n_obstacles", [0, 1])
def test_gymnasium_env_checker_passes_without_warnings(env_id, n_obstacles):
    from gymnasium.utils.env_checker import check_env

    env = gym.make(env_id, render_mode="rgb_array", n_obstacles=n_obstacles)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped, skip_render_check=False)
    env.close()


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("n_obstacles", [0, 1])
def test_sb3_env_checker_passes_without_warnings(env_id, n_obstacles):
    from stable_baselines3.common.env_checker import check_env

    single = gym.make(env_id, n_obstacles=n_obstacles).unwrapped
    wrapped = gym.make(env_id, n_obstacles=n_obstacles)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(single, warn=True)
        check_env(wrapped, warn=True)


# ------------------------------------------------------------------------------ API and types


@pytest.mark.parametrize("env_id", IDS)
def test_step_returns_python_scalars_and_documented_info(env_id):
    env = gym.make(env_id, n_obstacles=1)
    d = DIM[env_id]
    obs, info = env.reset(seed=3)
    assert env.action_space.shape == (d - 1,) and env.action_space.dtype == np.float32
    assert obs.dtype == np.float32 and obs.shape == (7 * d + 2 * d,)
    assert np.all(np.isfinite(env.observation_space.low)) and np.all(np.isfinite(env.observation_space.high))
    keys = {"reward_goal", "reward_reach", "reward_success", "distance", "pusher_distance", "max_overlap", "is_success"}
    assert set(info) == keys and info["is_success"] is False
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
    assert type(reward) is float and type(terminated) is bool and type(truncated) is bool
    assert set(info) == keys and type(info["is_success"]) is bool
    assert reward == pytest.approx(info["reward_goal"] + info["reward_reach"] + info["reward_success"])
    assert obs in env.observation_space
    assert 0.0 < info["max_overlap"] < 0.1  # resting on the terrain: m g / ks, a few % of r


@pytest.mark.parametrize("env_id", IDS)
def test_reset_with_a_seed_replays_the_episode_bit_for_bit(env_id):
    env = gym.make(env_id, n_obstacles=1)
    actions = np.random.default_rng(1).uniform(-1.5, 1.5, (60, DIM[env_id] - 1)).astype(np.float32)
    first = rollout(env, actions, seed=7)
    rollout(env, actions, seed=8)  # something else in between
    again = rollout(env, actions, seed=7)
    assert len(first) == len(again)
    for a, b in zip(first, again):
        for x, y in zip(a, b):
            if isinstance(x, np.ndarray):
                assert np.array_equal(x, y)
            else:
                assert x == y
    other = rollout(env, actions, seed=8)
    assert not np.array_equal(first[0][0], other[0][0])


def test_every_draw_comes_from_np_random():
    env = gym.make("PenaltyBalls-v0", n_obstacles=2)
    np.random.seed(0)
    state = np.random.get_state()[1].copy()
    env.reset(seed=5)
    assert np.array_equal(np.random.get_state()[1], state)  # the global generator is untouched
    env.unwrapped.np_random = np.random.default_rng(123)
    a, _ = env.reset()
    env.unwrapped.np_random = np.random.default_rng(123)
    b, _ = env.reset()
    assert np.array_equal(a, b)


def test_truncates_at_max_episode_steps():
    env = gym.make("PenaltyBalls-v0", max_episode_steps=7)
    env.reset(seed=0)
    for k in range(7):
        _, _, terminated, truncated, _ = env.step(np.zeros(2, np.float32))
        assert not terminated and truncated == (k == 6)


# ------------------------------------------------------------------------------ bad input


@pytest.mark.parametrize(
    "action, words",
    [
        (np.zeros(3, np.float32), "shape (2,)"),
        (np.zeros((1, 2), np.float32), "shape (2,)"),
        (0.5, "shape (2,)"),
        (np.array([np.nan, 0.0], np.float32), "NaN or inf"),
        (np.array([0.0, np.inf]), "NaN or inf"),
        (["a", "b"], "array of real numbers"),
    ],
)
def test_a_bad_action_is_refused_and_nothing_moves(action, words):
    env = gym.make("PenaltyBalls-v0")
    env.reset(seed=0)
    before = env.unwrapped.scene.world.positions.copy()
    with pytest.raises(ValueError, match="action") as exc:
        env.step(action)
    assert words in str(exc.value)
    assert np.array_equal(env.unwrapped.scene.world.positions, before)


def test_out_of_range_actions_are_clipped():
    a, b = gym.make("PenaltyBalls-v0"), gym.make("PenaltyBalls-v0")
    a.reset(seed=4)
    b.reset(seed=4)
    for _ in range(5):
        oa = a.step(np.array([7.0, -3.0], np.float32))[0]
        ob = b.step(np.array([1.0, -1.0], np.float32))[0]
        assert np.array_equal(oa, ob)
    assert a.step([0.2, 0.1])[0] is not None  # lists and float64 work too


def test_step_before_reset_fails_clearly():
    env = PenaltyBallsEnv()
    with pytest.raises(ResetNeeded, match="before reset"):
        env.step(np.zeros(2, np.float32))


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"ball_radius": 3.0}, "ball_radius (ball radius, m) must be a number in [0.05, 0.3]"),
        ({"friction": -0.1}, "friction"),
        ({"n_obstacles": -1}, "n_obstacles (passive obstacle balls) must be an int in [0, 8]"),
        ({"n_obstacles": 1.5}, "n_obstacles"),
        ({"control_period": float("nan")}, "control_period"),
        ({"goal_tolerance": "wide"}, "goal_tolerance"),
        ({"max_force": 500.0, "max_speed": 0.1}, "must be <= 1"),
        ({"n_obstacles": 8, "obstacle_radius": 0.3}, "do not fit"),
        ({"dim": 4}, "dim must be 2 or 3"),
        ({"render_mode": "video"}, "render_mode"),
    ],
)
def test_bad_keyword_arguments_are_refused_with_the_allowed_range(kwargs, words):
    with pytest.raises(ValueError) as exc:
        PenaltyBallsEnv(**kwargs)
    assert words in str(exc.value)


def test_unknown_keyword_is_refused():
    with pytest.raises(TypeError, match="ball_size"):
        PenaltyBallsEnv(ball_size=0.2)


# ------------------------------------------------------------------------------ the physics


def test_substeps_and_stiffness_follow_from_the_scene():
    for kwargs in ({}, {"control_period": 0.1}, {"penetration_tolerance": 0.03}, {"max_speed": 2.0, "max_force": 60.0}):
        scene = PenaltyBallsEnv(**kwargs).scene
        p = scene.params
        assert scene.substeps * scene.dt == pytest.approx(p["control_period"])
        assert scene.dt <= scene.world.stability_limit()  # the core's guard accepts it
        assert scene.dt <= scene.config.dt * (1 + 1e-12)  # and configure's accuracy step
        # the fewest substeps that satisfy both
        limit = min(scene.world.stability_limit(), scene.config.dt)
        assert scene.control_period / (scene.substeps - 1) > limit or scene.substeps == 1
        m_eff = p["pusher_mass"] * p["ball_mass"] / (p["pusher_mass"] + p["ball_mass"])
        delta = p["penetration_tolerance"] * min(p["pusher_radius"], p["ball_radius"])
        assert scene.ks == pytest.approx(max(m_eff * p["max_speed"] ** 2 / delta**2, p["max_force"] / delta))


def _head_on(scene, speed):
    """Pusher sliding at ``speed`` straight into the resting ball; returns the largest overlap / r."""
    x = scene.world.positions[0].copy()
    z = x[1, -1]
    x[0] = [-0.4, 0.0, z]
    x[1] = [0.0, 0.0, z]
    v = np.zeros_like(x)
    v[0, 0] = speed
    scene.world.set_state(positions=x[None], velocities=v[None], worlds=[0])
    scene.actions[0] = [1.0, 0.0]  # at v = max_speed the motor's force is zero: the pusher coasts
    worst = 0.0
    for _ in range(int(0.4 / scene.control_period)):
        scene.step()
        r = min(scene.radii[0], scene.radii[1])
        gap = np.linalg.norm(scene.world.positions[0, 1] - scene.world.positions[0, 0])
        worst = max(worst, (scene.radii[0] + scene.radii[1] - gap) / r)
    return worst


def test_a_head_on_impact_at_top_speed_overlaps_by_the_penetration_tolerance():
    for tol in (0.1, 0.05):
        # undamped (e = 1), frictionless, a coasting pusher, sampled every 5 ms: the closed form
        # says the peak overlap is v / omega0, which configure sets to tol x r less the margin it
        # keeps for the integrator's predicted overshoot of the peak (the motor's residual push
        # and the terrain add a little)
        with pytest.warns(EnergyDriftWarning):  # undamped (e = 1): collisions would gain energy
            env = PenaltyBallsEnv(
                penetration_tolerance=tol, friction=0.0, max_force=0.5, restitution=1.0, control_period=0.005
            )
        env.reset(seed=0)
        worst = _head_on(env.scene, env.scene.params["max_speed"])
        margin = env.scene.config.predicted_error["peak_overlap"]
        assert worst == pytest.approx(tol / (1.0 + margin), rel=0.05)
    env = PenaltyBallsEnv(friction=0.0, max_force=0.5, control_period=0.005)  # e = 0.3: lower
    env.reset(seed=0)
    assert 0.5 * 0.1 < _head_on(env.scene, 1.0) < 0.1


def test_a_pushed_ball_slides_to_rest_as_coulomb_friction_says():
    env = PenaltyBallsEnv()
    env.reset(seed=0)
    scene = env.scene
    x = scene.world.positions[0].copy()
    x[:] = scene.on_terrain(np.array([[-1.0, 1.0], [0.0, 0.0], [0.0, 0.0]]))[:2]  # pusher away, ball at rest
    v = np.zeros_like(x)
    v[1, 0] = 1.0
    scene.world.set_state(positions=x[None], velocities=v[None], worlds=[0])
    for _ in range(25):  # 1 s
        scene.step()
    mu, g = scene.params["friction"], scene.params["gravity"]
    assert np.linalg.norm(scene.world.velocities[0, 1]) < 0.02  # at rest (up to the regularised creep)
    slide = scene.world.positions[0, 1, 0]
    assert slide == pytest.approx(1.0 / (2.0 * mu * g), rel=0.15)  # v^2 / (2 mu g) = 0.17 m


def test_the_motor_holds_the_pusher_below_its_top_speed():
    env = PenaltyBallsEnv()
    env.reset(seed=2)
    speeds = []
    for _ in range(40):
        obs = env.step(np.array([1.0, 0.0], np.float32))[0]
        speeds.append(float(np.hypot(obs[3], obs[4])))
    p = env.scene.params
    assert max(speeds) < p["max_speed"]
    # steady state on the flat: F (1 - v / v_max) = mu m g
    expected = p["max_speed"] * (1.0 - p["friction"] * p["pusher_mass"] * p["gravity"] / p["max_force"])
    assert speeds[15] == pytest.approx(expected, rel=0.1)


@pytest.mark.parametrize("env_id", IDS)
def test_the_scripted_pusher_succeeds_and_a_random_policy_rarely_does(env_id):
    env = gym.make(env_id)
    policy = ScriptedPusher.for_env(env)
    rng = np.random.default_rng(0)
    wins_scripted = wins_random = 0
    for ep in range(20):
        obs, _ = env.reset(seed=ep)
        while True:
            obs, reward, terminated, truncated, info = env.step(policy(obs))
            if terminated or truncated:
                wins_scripted += info["is_success"]
                assert terminated == info["is_success"]
                break
    for ep in range(60):
        env.reset(seed=1000 + ep)
        while True:
            _, _, terminated, truncated, info = env.step(rng.uniform(-1, 1, DIM[env_id] - 1).astype(np.float32))
            if terminated or truncated:
                wins_random += info["is_success"]
                break
    assert wins_scripted >= 19
    assert wins_random <= 3


def test_observations_stay_inside_their_bounds_even_when_pushed_hard():
    env = gym.make("PenaltyBalls-v0", n_obstacles=3, max_episode_steps=400)
    rng = np.random.default_rng(0)
    env.reset(seed=0)
    for _ in range(400):
        obs, *_ = env.step(np.sign(rng.uniform(-1, 1, 2)).astype(np.float32))
        assert obs in env.observation_space


def test_docstring_documents_the_task_in_tables():
    doc = PenaltyBallsEnv.__doc__
    for section in (
        "## Action Space",
        "## Observation Space",
        "## Rewards",
        "## Starting State",
        "## Episode End",
        "## Arguments",
        "## Version History",
    ):
        assert section in doc
    for name, (default, lo, hi, _) in PARAMETERS.items():  # the Arguments table is the checked ranges
        assert f"| `{name}` | {default} | [{lo}, {hi}] |" in doc, name

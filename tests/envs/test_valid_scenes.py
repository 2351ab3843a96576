"""Every documented argument combination gives a valid scene, or is refused with a message that
names the arguments and the limit (property tests over the whole documented parameter box).

Valid: every body starts at rest on the terrain within its penetration tolerance (the resting
overlap m g / ks_terrain is at most ``penetration_tolerance`` x its radius: the terrain is stiffened
where the pusher-ball spring would not hold a heavy body), no two bodies overlap, and the scene then
steps with observations inside the observation space, finite rewards, no ball leaving the bowl,
and a scene let go by its motor loses energy.
"""

from __future__ import annotations

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import penalty_env  # noqa: F401
from penalty_env.envs.balls.params import INT_PARAMETERS, PARAMETERS
from penalty_env.physics.world import EnergyDriftWarning

# the sand keywords (grains > 0 changes what "rests on the terrain" means): test_sand.py's own property test
SKIP = ("render_width", "render_height", "grains", "grain_radius", "grain_mass")


@st.composite
def kwargs_in_the_box(draw):
    """Each documented keyword argument drawn over its whole allowed range (floats log-uniform on
    a positive range so both ends are reached)."""
    out = {}
    for name, (_, lo, hi, _) in PARAMETERS.items():
        if name in SKIP:
            continue
        if name in INT_PARAMETERS:
            out[name] = draw(st.integers(lo, hi))
        elif lo > 0:
            out[name] = float(math.exp(draw(st.floats(math.log(lo), math.log(hi)))))
        else:
            out[name] = draw(st.floats(lo, hi))
    return out


def _resting_fractions(scene) -> np.ndarray:
    """Each body's overlap with the terrain / its radius, in world 0."""
    x = np.asarray(scene.world.positions)[0]
    c = np.zeros(scene.dim)
    c[-1] = scene.bowl_radius
    return (scene.radii - (scene.bowl_radius - np.linalg.norm(x - c, axis=-1))) / scene.radii


def _make_or_refusal(env_id, kwargs, seed):
    """The env made and reset, or None when it was refused naming an argument and its limit. The
    only warning a documented combination may raise is the energy guard's, for a nearly undamped
    contact (restitution near 1), and it names its remedy; a start never overlaps."""
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            env = gym.make(env_id, **kwargs)
            env.reset(seed=seed)
        for w in caught:
            if issubclass(w.category, DeprecationWarning) and "out of date" in str(w.message):
                continue  # (Gymnasium's note that the v0 id has a v1)
            assert issubclass(w.category, EnergyDriftWarning), f"{w.category.__name__}: {w.message}"
            assert "substeps" in str(w.message)
    except ValueError as exc:
        message = str(exc)
        named = [k for k in kwargs if k in message]
        assert named, f"the refusal must name an argument: {message}"
        assert any(ch.isdigit() for ch in message), f"and the limit: {message}"
        return None
    return env


@pytest.mark.slow
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(kwargs=kwargs_in_the_box(), dim=st.sampled_from([2, 3]), seed=st.integers(0, 2**31 - 1))
def test_every_documented_combination_starts_valid_or_is_refused(kwargs, dim, seed):
    if dim == 2:
        kwargs["n_obstacles"] = min(kwargs["n_obstacles"], 2)
    env = _make_or_refusal("PenaltyBalls-v0" if dim == 3 else "PenaltyBalls2D-v0", kwargs, seed)
    if env is None:
        return
    scene = env.unwrapped.scene
    tol = kwargs["penetration_tolerance"]
    frac = _resting_fractions(scene)
    assert np.all(frac <= tol * (1 + 1e-9)), (frac, tol)
    assert np.all(frac > 0.0), "every body rests on the terrain"
    # the terrain spring is what holds the heaviest body at the tolerance
    assert scene.ks_terrain >= np.max(scene.masses * scene.gravity / (tol * scene.radii)) * (1 - 1e-12)
    x = np.asarray(scene.world.positions)[0]
    d = np.linalg.norm(x[:, None] - x[None], axis=-1) + np.eye(len(x)) * 1e9
    assert np.all(d >= scene.radii[:, None] + scene.radii[None]), "no two bodies overlap at the start"
    assert scene.world.max_penetration() <= tol * (1 + 1e-9)


def test_the_reported_combination_now_rests_within_its_tolerance():
    """ball_mass=10, max_force=5, penetration_tolerance=0.3 (each in range) used to start the ball
    sunk 1.46 radii into the floor: the terrain spring was the pusher-ball spring, 97 N/m."""
    env = gym.make("PenaltyBalls-v0", ball_mass=10.0, max_force=5.0, penetration_tolerance=0.3)
    env.reset(seed=0)
    frac = _resting_fractions(env.unwrapped.scene)
    assert frac[1] == pytest.approx(0.3, rel=1e-9)  # the heaviest body sets the terrain's stiffness
    assert np.all(frac <= 0.3 * (1 + 1e-12))


@pytest.mark.parametrize("env_id", ["PenaltyBalls-v0", "PenaltyBalls2D-v0"])
def test_the_default_scene_keeps_the_pusher_ball_spring_for_the_terrain(env_id):
    """Where the pusher-ball spring already holds every body within its tolerance (the default
    and every combination that was valid before), the terrain keeps it: those episodes are
    unchanged."""
    scene = gym.make(env_id).unwrapped.scene
    assert scene.ks_terrain == scene.ks
    assert scene.ks >= scene.ks_rest


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    kwargs=kwargs_in_the_box(),
    dim=st.sampled_from([2, 3]),
    seed=st.integers(0, 2**31 - 1),
    actions=st.lists(st.tuples(st.floats(-3, 3), st.floats(-3, 3)), min_size=5, max_size=40),
)
def test_random_scenes_and_actions_stay_finite_bounded_and_in_the_bowl(kwargs, dim, seed, actions):
    if dim == 2:
        kwargs["n_obstacles"] = min(kwargs["n_obstacles"], 2)
    env = _make_or_refusal("PenaltyBalls-v0" if dim == 3 else "PenaltyBalls2D-v0", kwargs, seed)
    if env is None:
        return
    scene = env.unwrapped.scene
    space = env.observation_space
    R = scene.bowl_radius
    c = np.zeros(dim)
    c[-1] = R
    for a in actions:
        obs, reward, terminated, truncated, info = env.step(np.array(a[: dim - 1], dtype=np.float32))
        assert space.contains(obs), obs
        assert math.isfinite(reward)
        x = np.asarray(scene.world.positions)[0]
        assert np.all(np.linalg.norm(x - c, axis=-1) < R), "a ball left the bowl"
        if terminated or truncated:
            env.reset()


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(kwargs=kwargs_in_the_box(), dim=st.sampled_from([2, 3]), seed=st.integers(0, 2**31 - 1))
def test_a_scene_let_go_by_its_motor_loses_energy(kwargs, dim, seed):
    """Pushed, then let go: with the motor off (throttle 0 still brakes the pusher: F = -F_max v /
    v_max) friction, the dashpots and the brake only dissipate, so the scene ends the release with
    less energy than it began it. (From step to step a body sliding along the curved terrain,
    which its dashpot does not damp, exchanges a little energy with its contact spring at the
    integrator's error, docs/physics.md section 6; between contacts no step may gain any:
    ``tests/physics/test_conservation.py``.) Damped: restitution up to 0.9."""
    kwargs["restitution"] = min(kwargs["restitution"], 0.9)
    if dim == 2:
        kwargs["n_obstacles"] = min(kwargs["n_obstacles"], 2)
    env = _make_or_refusal("PenaltyBalls-v0" if dim == 3 else "PenaltyBalls2D-v0", kwargs, seed)
    if env is None:
        return
    scene = env.unwrapped.scene
    for _ in range(5):
        env.step(np.ones(dim - 1, dtype=np.float32))
    e0 = float(scene.world.energy()[0])
    for _ in range(30):
        env.step(np.zeros(dim - 1, dtype=np.float32))
    assert float(scene.world.energy()[0]) < e0

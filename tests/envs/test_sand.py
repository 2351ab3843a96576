"""PenaltyBallsSand-v0 / PenaltyBallsSand2D-v0 (and their -v1): the pushing task through a settled
bed of grains (v1's rolling physics): registration, both env checkers, seeded replay, the native vector env
against single envs, the settled bed and its reuse, the height map against its definition, the
renderer's grains, and the arguments refused."""

from __future__ import annotations

import os
import warnings

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env, data_equivalence
from gymnasium.vector import SyncVectorEnv
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import penalty_env  # noqa: F401
from penalty_env.envs.balls import params as S
from penalty_env.envs.balls.sand import grain_lattice
from penalty_env.envs.terrains import make_terrain
from penalty_env.envs.terrains.arena import HALF_WIDTH as ARENA_HALF_WIDTH
from penalty_env.envs.views.raster import GRAIN_COLOR

SAND = {"PenaltyBallsSand-v0": (3, 300), "PenaltyBallsSand2D-v0": (2, 40)}
# the 2D id compiles its own kernels (about 40 s cold): kept for the slow run
SAND_IDS = ["PenaltyBallsSand-v0", pytest.param("PenaltyBallsSand2D-v0", marks=pytest.mark.slow)]


def test_sand_is_registered_on_v1_physics_with_grains():
    from penalty_env.envs.penalty_balls import MAX_EPISODE_STEPS, SAND_V1_EPISODE_STEPS

    for env_id, (d, grains) in SAND.items():
        spec = gym.spec(env_id)
        assert spec.kwargs == {"dim": d, "physics": "rolling", "grains": grains}
        assert spec.vector_entry_point == "penalty_env.envs.penalty_balls:PenaltyBallsVectorEnv"
        assert spec.max_episode_steps == MAX_EPISODE_STEPS
        # Sand-v1: the same with heavier grains and longer episodes
        spec1 = gym.spec(env_id.replace("-v0", "-v1"))
        assert spec1.kwargs == {"dim": d, "physics": "rolling", "grains": grains, "grain_mass": S.SAND_V1_GRAIN_MASS}
        assert spec1.max_episode_steps == SAND_V1_EPISODE_STEPS == 2 * MAX_EPISODE_STEPS
        assert spec1.vector_entry_point == spec.vector_entry_point
    scene = gym.make("PenaltyBallsSand-v0").unwrapped.scene
    assert scene.world.rotation is True
    assert scene.n_balls == 2 + 300 and scene.n_bodies == 2
    # the observation: v1's 21 entries and a 5 x 5 height map
    assert scene.observation_space.shape == (21 + 25,)
    assert gym.make("PenaltyBallsSand-v0", grains=1000).observation_space.shape == (46,)


def test_sand_v1_is_sand_v0_with_heavier_grains_and_longer_episodes_at_a_third_of_the_substeps():
    """Sand-v1's episodes are Sand-v0's made with its two registered keywords, bit for bit (the
    single env through its TimeLimit, and the native vector env), and its step takes 9 substeps
    (v1's: the grains' dashpot no longer bounds the step) where Sand-v0's takes 25."""
    v0 = gym.make("PenaltyBallsSand-v0").unwrapped.scene
    v1 = gym.make("PenaltyBallsSand-v1").unwrapped.scene
    assert (v0.substeps, v1.substeps) == (25, gym.make("PenaltyBalls-v1").unwrapped.scene.substeps) == (25, 9)
    assert float(v1.masses[-1]) == S.SAND_V1_GRAIN_MASS and v1.n_grains == v0.n_grains
    twin = gym.make("PenaltyBallsSand-v0", grain_mass=S.SAND_V1_GRAIN_MASS, max_episode_steps=300)
    env = gym.make("PenaltyBallsSand-v1")
    rng = np.random.default_rng(5)
    assert data_equivalence(env.reset(seed=11), twin.reset(seed=11), exact=True)
    for t in range(300):
        a = rng.uniform(-1.0, 1.0, env.action_space.shape).astype(np.float32)
        out = env.step(a)
        assert data_equivalence(out, twin.step(a), exact=True), t
        if out[2] or out[3]:
            break
    assert t == 299 and out[3] and not out[2]  # truncated at 300 steps, not 150
    n = 2
    native = gym.make_vec("PenaltyBallsSand-v1", num_envs=n)
    native0 = gym.make_vec("PenaltyBallsSand-v0", num_envs=n, grain_mass=S.SAND_V1_GRAIN_MASS, max_episode_steps=300)
    assert data_equivalence(native.reset(seed=4), native0.reset(seed=4), exact=True)
    for t in range(20):
        acts = rng.uniform(-1.0, 1.0, (n, 2)).astype(np.float32)
        assert data_equivalence(native.step(acts), native0.step(acts), exact=True), t


@pytest.mark.parametrize("env_id", [*SAND_IDS, "PenaltyBallsSand-v1"])
def test_both_env_checkers_pass_on_sand(env_id):
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    envs = gym.make(env_id).unwrapped, gym.make(env_id).unwrapped
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the checkers' warnings (making Sand-v0 is silent, as v0: __init__)
        check_env(envs[0])
        sb3_check_env(envs[1])


@pytest.mark.parametrize("env_id", SAND_IDS)
def test_sand_replays_a_seeded_episode_bit_for_bit(env_id):
    env = gym.make(env_id, max_episode_steps=40)
    rng = np.random.default_rng(2)
    actions = rng.uniform(-1.0, 1.0, (40,) + env.action_space.shape).astype(np.float32)
    runs = []
    for _ in range(2):
        obs, _ = env.reset(seed=7)
        trace = [obs]
        for a in actions:
            obs, reward, terminated, truncated, info = env.step(a)
            trace.append(obs)
            assert np.isfinite(reward) and info["max_overlap"] < 0.5
            if terminated or truncated:
                break
        runs.append(np.array(trace))
    assert np.array_equal(runs[0], runs[1])


@pytest.mark.parametrize("env_id", SAND_IDS)
def test_sand_native_vector_env_equals_single_envs(env_id):
    n, k = 3, SAND[env_id][0] - 1
    native = gym.make_vec(env_id, num_envs=n, max_episode_steps=25)
    twin = SyncVectorEnv([lambda: gym.make(env_id, max_episode_steps=25) for _ in range(n)])
    rng = np.random.default_rng(0)
    assert data_equivalence(native.reset(seed=3), twin.reset(seed=3), exact=True)
    for t in range(55):  # through two autoresets
        acts = rng.uniform(-1.0, 1.0, (n, k)).astype(np.float32)
        assert data_equivalence(native.step(acts), twin.step(acts), exact=True), t


def test_the_bed_is_settled_once_and_each_reset_turns_it_about_the_vertical():
    env = gym.make("PenaltyBallsSand-v0").unwrapped
    scene = env.scene
    bed = scene.bed
    assert scene.sand.settle_speed < S.SAND_SETTLE_SPEED and scene.sand.settle_time >= S.SAND_SETTLE_TIME[0]
    # a second scene of the same configuration reuses the bed (no second settling)
    assert gym.make_vec("PenaltyBallsSand-v0", num_envs=2).scene.bed is bed
    # a different grain count is a different bed
    assert gym.make("PenaltyBallsSand-v0", grains=200).unwrapped.scene.bed.shape == (200, 3)
    # the settled grains rest in the bowl: none below the floor by more than a small overlap, none flying
    rho = np.hypot(bed[:, 0], bed[:, 1])
    gap = bed[:, 2] - scene.floor(bed[:, :2]) - scene.radii[-1]
    assert gap.min() > -0.05 * scene.radii[-1]
    assert bed[:, 2].max() < 10 * scene.radii[-1]
    env.reset(seed=1)
    grains = scene.world.positions[0, scene.n_bodies :]
    # turned about the vertical through the bottom: heights and distances from the axis kept, in order
    np.testing.assert_allclose(grains[:, 2], bed[:, 2], rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.hypot(grains[:, 0], grains[:, 1]), rho, rtol=1e-12, atol=1e-12)
    angle = np.arctan2(grains[:, 1], grains[:, 0]) - np.arctan2(bed[:, 1], bed[:, 0])
    assert np.ptp(np.mod(angle[rho > 0.1] + np.pi, 2 * np.pi)) < 1e-9
    # the bodies start on the sand or the floor, touching no grain
    for i in range(scene.n_bodies):
        p = scene.world.positions[0, i]
        dist = np.linalg.norm(grains - p, axis=1) - scene.radii[i] - scene.radii[-1]
        assert dist.min() >= -1e-9
        assert p[2] >= scene.floor(p[:2]) + scene.radii[i] - 0.1 * scene.radii[i]
    # at rest: every velocity and spin zero
    assert not scene.world.velocities[0].any() and not scene.world.angular_velocities[0].any()


def _height_map(scene, b=0):
    """The height map as the observation table documents it, in numpy."""
    d = scene.dim
    x = scene.world.positions[b]
    hm = scene.heightmap
    H, c = hm.cells, hm.cell
    out = np.zeros(H ** (d - 1))
    ball = x[1]
    for i in range(scene.n_bodies, scene.n_balls):
        u = (x[i, : d - 1] - ball[: d - 1] + 0.5 * H * c) / c
        if np.any(u < 0) or np.any(u >= H):
            continue
        cell = int(u[0]) if d == 2 else int(u[0]) * H + int(u[1])
        depth = x[i, d - 1] + scene.radii[i] - scene.floor(x[i, : d - 1])
        out[cell] = max(out[cell], min(depth, hm.top))
    return out


def test_the_height_map_is_the_sand_depth_around_the_ball():
    env = gym.make("PenaltyBallsSand-v0")
    obs, _ = env.reset(seed=4)
    scene = env.unwrapped.scene
    off = scene.layout.heightmap_offset
    rng = np.random.default_rng(0)
    for _ in range(30):
        np.testing.assert_allclose(obs[off:], _height_map(scene), rtol=1e-6, atol=1e-6)
        obs, *_ = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
    # the bed is two to three grains deep at the bottom: the map sees sand there
    assert 0.0 < obs[off:].max() < 10 * scene.radii[-1]
    assert scene.observation_space.contains(obs)


def test_the_renderer_draws_the_grains():
    """Every grain covers the bowl's own image at its centre (3D top view), in the grains' colour
    family (more red than blue, as GRAIN_COLOR), in both render modes' frame."""
    env = gym.make("PenaltyBallsSand-v0", render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render().astype(int)
    renderer = env.unwrapped._renderer
    background = renderer._background(0).astype(int)
    scene = env.unwrapped.scene
    grains = scene.world.positions[0, scene.n_bodies :]
    px = (0.5 * renderer.width + grains[:, 0] * renderer.scale).astype(int)
    py = (0.5 * renderer.height - grains[:, 1] * renderer.scale).astype(int)
    covered = np.abs(frame[py, px] - background[py, px]).max(axis=-1) > 10
    assert covered.all()
    assert GRAIN_COLOR[0] > GRAIN_COLOR[2]
    hidden = np.zeros(len(grains), dtype=bool)  # under the pusher or the ball (blue / orange drawn over)
    for i in range(scene.n_bodies):
        hidden |= np.hypot(*(grains[:, :2] - scene.world.positions[0, i, :2]).T) < scene.radii[i]
    rgb = frame[py[~hidden], px[~hidden]]
    assert np.mean(rgb[:, 0] > rgb[:, 2] + 20) > 0.95


def test_grains_are_refused_where_they_cannot_go():
    with pytest.raises(ValueError, match=r"grains=.*at most \d+ fit"):
        gym.make("PenaltyBallsSand-v0", grains=10_000, grain_radius=0.15)
    with pytest.raises(ValueError, match=r"terrain='bumpy' cannot hold grains"):
        gym.make("PenaltyBallsSand-v0", terrain="bumpy")
    with pytest.raises(ValueError, match=r"grains .* must be an int in \[0, 10000\], got 10001"):
        gym.make("PenaltyBallsSand-v0", grains=10_001)
    with pytest.raises(ValueError, match=r"grain_radius"):
        gym.make("PenaltyBallsSand-v0", grain_radius=0.5)


def test_the_goal_is_reached_horizontally():
    """With sand the ball rides on the bed: success and the shaping use the horizontal distance."""
    env = gym.make("PenaltyBallsSand-v0")
    env.reset(seed=3)
    scene = env.unwrapped.scene
    _, _, _, _, info = env.step(np.zeros(2, dtype=np.float32))
    ball, goal = scene.world.positions[0, 1], scene.goal[0]
    assert info["distance"] == pytest.approx(np.hypot(*(goal[:2] - ball[:2])), rel=1e-12)
    assert abs(goal[2] - ball[2]) > 1e-3  # the heights differ: the 3D distance would not be this


@pytest.mark.slow  # compiles the arena's kernels
def test_sand_in_the_arena_stays_within_its_walls_and_turns_by_quarter_turns():
    env = gym.make("PenaltyBallsSand-v0", terrain="arena", grains=500)
    scene = env.unwrapped.scene
    bed = scene.bed
    assert np.abs(bed[:, :2]).max() < ARENA_HALF_WIDTH - 0.9 * scene.radii[-1]
    for seed in range(4):
        env.reset(seed=seed)
        grains = scene.world.positions[0, scene.n_bodies :]
        turned = [
            np.stack([c * bed[:, 0] - s * bed[:, 1], s * bed[:, 0] + c * bed[:, 1]], axis=-1)
            for c, s in ((1, 0), (0, 1), (-1, 0), (0, -1))
        ]
        assert any(np.array_equal(grains[:, :2], t) for t in turned)
        for _ in range(10):
            env.step(np.ones(2, dtype=np.float32))
        assert np.abs(scene.world.positions[0, :, :2]).max() < ARENA_HALF_WIDTH


@pytest.mark.slow  # each grain count settles its own bed
@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    grains=st.integers(1, 600),
    radius=st.floats(0.02, 0.15),
    mass=st.floats(0.01, 1.0),
    friction=st.floats(0.0, 1.5),
    dim=st.sampled_from([2, 3]),
    seed=st.integers(0, 2**31 - 1),
)
def test_every_sand_combination_starts_valid_or_is_refused(grains, radius, mass, friction, dim, seed):
    kwargs = dict(grains=grains, grain_radius=radius, grain_mass=mass, friction=friction)
    env_id = "PenaltyBallsSand-v0" if dim == 3 else "PenaltyBallsSand2D-v0"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # a bed still creeping after 20 s warns
            env = gym.make(env_id, **kwargs)
    except ValueError as exc:
        assert any(k in str(exc) for k in kwargs) and any(ch.isdigit() for ch in str(exc)), str(exc)
        return
    obs, _ = env.reset(seed=seed)
    scene = env.unwrapped.scene
    x = scene.world.positions[0]
    r = scene.radii
    gap = np.linalg.norm(x[:, None] - x[None], axis=-1) - r[:, None] - r[None] + np.eye(len(x)) * 1e9
    nb = scene.n_bodies
    assert gap[:nb].min() >= -1e-9, "no body starts overlapping a grain or a body"
    assert gap.min() > -0.2 * radius, "the settled grains overlap little"
    rng = np.random.default_rng(seed)
    for _ in range(20):
        obs, reward, *_ = env.step(rng.uniform(-1, 1, dim - 1).astype(np.float32))
        assert env.observation_space.contains(obs) and np.isfinite(reward)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("terrain", ["bowl", "arena"])
def test_the_start_lattice_stays_inside_the_terrain_up_to_the_largest_grain_count(dim, terrain):
    """Where the grains start before settling: inside the bowl (or the arena's walls, above its
    floor) for every grain size, up to the most grains the arguments allow (``max_grains``, at most
    10,000), without overlap (the lattice's pitch 2.2 r, jittered by 0.1 r either way)."""
    R = 8.0
    for r in (0.02, 0.06, 0.15):
        n = min(S.max_grains(dim, r, R, terrain), 10_000)
        x = grain_lattice(dim, make_terrain(terrain, dim, R, 0.0), n, r)
        assert x.shape == (n, dim)
        if terrain == "bowl":
            centre = np.zeros(dim)
            centre[-1] = R
            assert np.all(R - np.linalg.norm(x - centre, axis=-1) >= r), (r, n)
        else:
            assert np.all(np.abs(x[:, :-1]) <= ARENA_HALF_WIDTH - r) and np.all(x[:, -1] >= r), (r, n)
        # the jittered lattice: neighbours on a layer at least 2.2 r - 0.2 r apart
        layer = x[np.abs(x[:, -1] - x[:, -1].min()) < 0.5 * r] if terrain == "arena" else x[: min(n, 400)]
        d = np.linalg.norm(layer[:, None] - layer[None], axis=-1) + np.eye(len(layer)) * 1e9
        assert d.min() >= 2.0 * r - 1e-12, (r, n)

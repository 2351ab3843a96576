"""Observation modes (``obs_mode``): the state vector unchanged, height maps against closed forms
and the physics' own terrain, images that show the bodies where they are, the same observations
in the single, vector and SB3 envs, and bad input refused."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env, data_equivalence
from gymnasium.vector import AutoresetMode, SyncVectorEnv

import penalty_env  # noqa: F401
from penalty_env.envs.randomize import RandomizationWarning
from penalty_env.envs.views import OBS_MODES
from penalty_env.envs.views import raster as R

ALL = ("state", "heightmap", "rgb")


def place(env, positions):
    """Put world 0's bodies at ``positions`` (at rest) and return the env's views."""
    scene = env.unwrapped.scene
    scene.world.set_state(positions=np.asarray(positions, dtype=float)[None], worlds=[0])
    return env.unwrapped.views


def cell_centres(views, pusher):
    """The horizontal centres of the height map's cells (x, and y in 3D), as documented."""
    H, c = views.heightmap_cells, views.heightmap_cell
    offsets = (np.arange(H) - 0.5 * (H - 1)) * c
    if views.scene.dim == 2:
        return (pusher[0] + offsets,)
    return np.meshgrid(pusher[0] + offsets, pusher[1] + offsets, indexing="ij")


def body_tops(scene, cells, heights):
    """``heights`` raised to the top of each body over the cells: z + sqrt(r^2 - rho^2)."""
    out = heights.copy()
    d = scene.dim
    for p, r in zip(scene.world.positions[0], scene.radii):
        rho2 = sum((c - p[k]) ** 2 for k, c in enumerate(cells))
        top = np.where(rho2 < r * r, p[d - 1] + np.sqrt(np.maximum(r * r - rho2, 0.0)), -np.inf)
        out = np.maximum(out, top)
    return out


def test_state_mode_is_the_default_path_and_the_dict_state_entry_equals_it():
    plain = gym.make("PenaltyBalls-v0")
    assert plain.unwrapped.batch.state_view and plain.observation_space == plain.unwrapped.scene.observation_space
    both = gym.make("PenaltyBalls-v0", obs_mode=("state", "rgb"))
    a, _ = plain.reset(seed=5)
    b, _ = both.reset(seed=5)
    assert np.array_equal(a, b["state"])
    rng = np.random.default_rng(0)
    for _ in range(20):
        act = rng.uniform(-1, 1, 2).astype(np.float32)
        a = plain.step(act)[0]
        b = both.step(act)[0]
        assert np.array_equal(a, b["state"]) and a.dtype == b["state"].dtype


@pytest.mark.parametrize("dim", [3, 2])
def test_heightmap_of_a_ball_on_the_flat_arena_is_its_top(dim):
    # cells of 0.11 m: no cell centre lies exactly one radius (0.15 m) from the pusher's centre
    env = gym.make(
        "PenaltyBalls-v0" if dim == 3 else "PenaltyBalls2D-v0",
        terrain="arena",
        obs_mode="heightmap",
        heightmap_cell=0.11,
    )
    env.reset(seed=0)
    r_ball = 0.15
    # the ball on a cell centre 0.3 m from the pusher, at rest height on the floor; the pusher lower
    if dim == 3:
        pos = [[0.0, 0.0, 0.1], [0.3, -0.2, r_ball]]
    else:
        pos = [[0.0, 0.1], [0.3, r_ball]]
    views = place(env, pos)
    hm = views.single(0)
    assert hm.shape == ((16, 16) if dim == 3 else (16,)) and hm.dtype == np.float32
    expected = body_tops(env.unwrapped.scene, cell_centres(views, pos[0][:-1]), np.zeros(hm.shape))
    np.testing.assert_allclose(hm, expected, rtol=1e-6, atol=1e-6)
    # a ball exactly under a cell centre: the peak is its top, z + r
    centre = cell_centres(views, pos[0][:-1])
    on_cell = [float(centre[0][10, 3]), float(centre[1][10, 3])] if dim == 3 else [float(centre[0][10])]
    pos[1] = on_cell + [r_ball]
    hm = place(env, pos).single(0)
    assert hm.max() == np.float32(2 * r_ball)


def test_height_map_and_image_draw_each_worlds_drawn_radii():
    """A randomised scene's balls are drawn at their world's drawn radius (not the make-time one)."""
    with pytest.warns(RandomizationWarning):  # (small radii need a shorter step: more substeps)
        venv = gym.make_vec(
            "PenaltyBalls-v0",
            num_envs=3,
            terrain="arena",
            obs_mode=("heightmap", "rgb"),
            heightmap_cell=0.05,
            randomize={"ball_radius": (0.08, 0.28), "pusher_radius": (0.08, 0.28)},
        )
    venv.reset(seed=3)
    scene = venv.unwrapped.scene
    radii = scene.world.model.radii  # (B, n): each world's draw
    assert np.ptp(radii[:, 1]) > 0.02  # the worlds differ
    views = venv.unwrapped.views
    obs = views.observe()
    for b in range(3):
        x = scene.world.positions[b]
        cells = cell_centres(views, x[0][:-1])
        expected = np.zeros(views.heightmap_shape)
        for p, r in zip(x, radii[b]):
            rho2 = sum((c - p[k]) ** 2 for k, c in enumerate(cells))
            expected = np.maximum(expected, np.where(rho2 < r * r, p[2] + np.sqrt(np.maximum(r * r - rho2, 0.0)), 0.0))
        np.testing.assert_allclose(obs["heightmap"][b], expected, rtol=1e-6, atol=1e-6)
        ball = np.all(obs["rgb"][b] == rgb_of(R.BALL_COLOR), axis=-1)
        area = ball.sum() / views.scale**2  # the ball's disc in m^2 (the pusher may cover a little of it)
        assert area <= np.pi * radii[b, 1] ** 2 * 1.15 and (area >= np.pi * radii[b, 1] ** 2 * 0.5)


@pytest.mark.parametrize("dim", [3, 2])
def test_heightmap_on_the_bowl_is_its_closed_form_and_the_bodies_tops(dim):
    env = gym.make("PenaltyBalls-v0" if dim == 3 else "PenaltyBalls2D-v0", obs_mode="heightmap", heightmap_cell=0.25)
    env.reset(seed=3)
    scene = env.unwrapped.scene
    R_ = scene.bowl_radius
    views = env.unwrapped.views
    pusher = scene.world.positions[0, 0]
    cells = cell_centres(views, pusher[:-1])
    rho2 = sum(c * c for c in cells)
    bowl = R_ - np.sqrt(R_ * R_ - rho2)
    hm = views.single(0)
    np.testing.assert_allclose(hm, body_tops(scene, cells, bowl), rtol=1e-6, atol=1e-7)
    # at the rim and beyond it the bowl is solid: the cap, 2R (the space's high)
    pos = scene.world.positions[0].copy()
    pos[0, 0] = R_ - 0.2
    hm = place(env, pos).single(0)
    assert hm.max() == np.float32(2 * R_) == views.space.high.max()


@pytest.mark.parametrize("dim", [3, 2])
def test_heightmap_on_bumps_lies_on_the_physics_terrain(dim):
    """Away from the bodies, each cell's height is where the World's own terrain distance is 0."""
    env = gym.make(
        "PenaltyBalls-v0" if dim == 3 else "PenaltyBalls2D-v0",
        terrain="bumpy",
        obs_mode="heightmap",
        heightmap_cell=0.11,
    )
    env.reset(seed=7)
    scene = env.unwrapped.scene
    views = env.unwrapped.views
    for pusher_at in (None, 2.45):  # where the start put it; near the field's edge (the bowl beyond)
        pos = scene.world.positions[0].copy()
        if pusher_at is not None:
            pos[0, 0] = pusher_at
        hm = place(env, pos).single(0).astype(np.float64)
        cells = cell_centres(views, pos[0][:-1])
        free = body_tops(scene, cells, np.full(hm.shape, -np.inf)) == -np.inf
        points = np.stack([*(c[free] for c in cells), hm[free]], axis=-1)
        phi, _ = scene.world.terrain_distance(points)
        assert free.sum() > hm.size // 2
        assert np.abs(phi).max() < 1e-6  # float32 heights of about 0.3 m


def rgb_of(color):
    """A palette colour (0..1) as the kernels write it: 255 c rounded half up."""
    return np.floor(255.0 * np.asarray(color) + 0.5)


def pixel(views, point, dim):
    """(row, col) of a world point in the rgb image (the module docstring's projection)."""
    S = views.rgb_size
    col = int(S / 2 + point[0] * views.scale)
    row = int((S / 2 if dim == 3 else views.ground) - point[1] * views.scale)
    return row, col


@pytest.mark.parametrize("dim", [3, 2])
@pytest.mark.parametrize("terrain", ["bowl", "bumpy"])
def test_rgb_draws_the_ball_and_the_goal_where_they_are(dim, terrain):
    env = gym.make(
        "PenaltyBalls-v0" if dim == 3 else "PenaltyBalls2D-v0", obs_mode="rgb", terrain=terrain, n_obstacles=1
    )
    env.reset(seed=2)
    scene = env.unwrapped.scene
    views = env.unwrapped.views
    for _ in range(3):
        img = env.step(env.action_space.sample())[0]
        assert img.shape == (64, 64, 3) and img.dtype == np.uint8
        for body, color in ((1, R.BALL_COLOR), (0, R.PUSHER_COLOR), (2, R.OBSTACLE_COLOR)):
            row, col = pixel(views, scene.world.positions[0, body], dim)
            assert np.array_equal(img[row, col], rgb_of(color)), (body, img[row, col])
        goal = scene.goal[0]
        row, col = pixel(views, goal, dim)
        covered = np.linalg.norm(scene.world.positions[0, :, :] - goal, axis=-1) < scene.radii + 0.1
        if not covered.any():
            assert np.array_equal(img[row, col], rgb_of(R.GOAL_COLOR))


def test_rgb_size_and_a_body_out_of_view_stays_in_the_frame():
    env = gym.make("PenaltyBalls-v0", obs_mode="rgb", rgb_size=40, terrain="arena")
    env.reset(seed=0)
    pos = env.unwrapped.scene.world.positions[0].copy()
    pos[1, :2] = (1.95, 0.0)  # the ball by the wall, outside the 1.75 m half view
    img = place(env, pos).single(0)
    assert img.shape == (40, 40, 3)
    ball = np.all(img == rgb_of(R.BALL_COLOR), axis=-1)
    assert ball.any() and np.flatnonzero(ball.any(axis=0)).min() >= 36  # a marker at the right border


@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_vector_env_worlds_equal_single_envs_seeded_the_same(mode):
    """Every mode at once, on bumps redrawn at each reset (each world's terrain image too)."""
    kwargs = dict(terrain="bumpy", obs_mode=ALL, max_episode_steps=8)
    native = gym.make_vec("PenaltyBalls-v0", num_envs=3, autoreset_mode=mode, **kwargs)
    twin = SyncVectorEnv([lambda: gym.make("PenaltyBalls-v0", **kwargs) for _ in range(3)], autoreset_mode=mode)
    assert native.observation_space == twin.observation_space
    a, _ = native.reset(seed=4)
    b, _ = twin.reset(seed=4)
    assert data_equivalence(a, b, exact=True)
    rng = np.random.default_rng(1)
    ends = 0
    for t in range(20):
        acts = rng.uniform(-1, 1, (3, 2)).astype(np.float32)
        x, y = native.step(acts), twin.step(acts)
        assert data_equivalence(x[0], y[0], exact=True), f"obs at step {t}"
        if mode == AutoresetMode.SAME_STEP and "final_obs" in x[4]:
            assert data_equivalence(x[4]["final_obs"], y[4]["final_obs"], exact=True)
            ends += 1
        assert native.observation_space.contains(x[0])
    assert mode == AutoresetMode.NEXT_STEP or ends == 2


@pytest.mark.parametrize("mode", [*OBS_MODES, ("state", "heightmap", "rgb")])
def test_every_mode_passes_gymnasiums_env_checker(mode):
    env = gym.make("PenaltyBalls-v0", obs_mode=mode).unwrapped
    check_env(env, skip_render_check=True)
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs)


def test_heightmap_2d_passes_the_env_checker():
    env = gym.make("PenaltyBalls2D-v0", obs_mode="heightmap", heightmap_cells=9).unwrapped
    check_env(env, skip_render_check=True)
    assert env.observation_space.shape == (9,)


def test_sb3_vec_env_returns_dict_and_image_observations_and_terminal_observation():
    pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.preprocessing import is_image_space

    from penalty_env.sb3 import make_vec_env

    venv = make_vec_env("PenaltyBalls-v0", n_envs=3, seed=0, obs_mode="rgb", max_episode_steps=4)
    assert is_image_space(venv.observation_space)
    venv = make_vec_env("PenaltyBalls-v0", n_envs=3, seed=0, obs_mode=ALL, max_episode_steps=4)
    obs = venv.reset()
    shapes = {"state": (3, 21), "heightmap": (3, 16, 16), "rgb": (3, 64, 64, 3)}
    assert {k: v.shape for k, v in obs.items()} == shapes
    single = gym.make("PenaltyBalls-v0", obs_mode=ALL, max_episode_steps=4)
    s_obs, _ = single.reset(seed=1)  # world 1's twin
    assert data_equivalence({k: v[1] for k, v in obs.items()}, s_obs, exact=True)
    acts = np.zeros((3, 2), dtype=np.float32)
    for _ in range(4):
        obs, _, dones, infos = venv.step(acts)
        s_obs = single.step(acts[1])[0]
    assert dones.all()
    last = infos[1]["terminal_observation"]
    assert data_equivalence(last, s_obs, exact=True)
    assert venv.observation_space.contains({k: v[0] for k, v in obs.items()})


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(obs_mode="pixels"), r"obs_mode must be one of \('state', 'heightmap', 'rgb'\).*'pixels'"),
        (dict(obs_mode=("rgb", "rgb")), "obs_mode.*repeated"),
        (dict(obs_mode=()), "obs_mode.*empty"),
        (dict(obs_mode=("state", "depth")), "obs_mode.*'depth'"),
        (dict(obs_mode=3), "obs_mode.*got 3"),
        (dict(heightmap_cells=1), r"heightmap_cells.*\[2, 64\].*got 1"),
        (dict(heightmap_cells=2.5), r"heightmap_cells.*\[2, 64\]"),
        (dict(heightmap_cell=0.0), r"heightmap_cell .*\[0.01, 1.0\].*got 0.0"),
        (dict(rgb_size=8), r"rgb_size.*\[16, 256\].*got 8"),
    ],
)
def test_bad_view_arguments_are_refused_naming_them(kwargs, match):
    from penalty_env.envs import PenaltyBallsEnv, PenaltyBallsVectorEnv

    with pytest.raises(ValueError, match=match):
        PenaltyBallsEnv(**kwargs)
    with pytest.raises(ValueError, match=match):
        PenaltyBallsVectorEnv(2, **kwargs)


@pytest.mark.slow
def test_sand_grains_are_in_the_height_map_and_the_image():
    env = gym.make("PenaltyBallsSand2D-v0", obs_mode=("heightmap", "rgb"), heightmap_cells=32, heightmap_cell=0.11)
    obs, _ = env.reset(seed=0)
    scene = env.unwrapped.scene
    views = env.unwrapped.views
    cells = cell_centres(views, scene.world.positions[0, 0][:-1])
    R_ = scene.bowl_radius
    expected = body_tops(scene, cells, R_ - np.sqrt(R_ * R_ - cells[0] ** 2))
    np.testing.assert_allclose(obs["heightmap"], expected, rtol=1e-6, atol=1e-6)
    grain = np.all(obs["rgb"] == rgb_of(R.GRAIN_COLOR), axis=-1)
    assert grain.sum() > 20


def test_docstring_documents_every_mode_and_keyword():
    from penalty_env.envs import PenaltyBallsEnv
    from penalty_env.envs.views import VIEW_PARAMETERS

    doc = PenaltyBallsEnv.__doc__ or ""
    for mode in OBS_MODES:
        assert f'### `obs_mode="{mode}"`' in doc
    for name, (default, lo, hi, _) in VIEW_PARAMETERS.items():
        assert f"| `{name}` | {default} | [{lo}, {hi}] |" in doc, name


def test_a_pickled_env_observes_on_alike():
    import pickle

    env = gym.make("PenaltyBalls-v0", obs_mode=("heightmap", "rgb"), terrain="bumpy")
    env.reset(seed=0)
    env.step(np.zeros(2, dtype=np.float32))
    twin = pickle.loads(pickle.dumps(env))
    act = np.array([0.5, -0.3], dtype=np.float32)
    assert data_equivalence(env.step(act)[0], twin.step(act)[0], exact=True)

"""PenaltySandLevel-v0 / PenaltySandLevel2D-v0: the sand-shaping task. Registration, the env
checker, the height map against a brute-force numpy computation, the flat target's volume, grains
and volume conserved under an aggressive blade, rewards that telescope, seeded replay and the
native vector env against single envs, the settled heap's slope against the repose angle of
docs/granular.md, targets drawn or given, and the arguments refused.

The default run uses the 2D id (its kernels compile once, about 20 s cold); the 3D id's tests are
slow (its own compile and a 250-grain heap)."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import penalty_env  # noqa: F401
from penalty_env.envs import sand_level as SL
from penalty_env.envs.level import kernel as LK
from penalty_env.envs.level import scene as LS
from penalty_env.envs.scripted import RasterSweep

IDS = ["PenaltySandLevel2D-v0", pytest.param("PenaltySandLevel-v0", marks=pytest.mark.slow)]


def _brute_force_map(x: np.ndarray, half: float, cells: int, unit: float) -> np.ndarray:
    """The height map's definition, cell by cell: each grain inside the arena gives each cell
    unit x the product over the horizontal axes of the hat weight max(0, 1 - |f - i|), f the
    grain's position in cell-centre units clamped to [0, cells - 1]."""
    d = x.shape[1]
    out = np.zeros((cells,) * (d - 1))
    idx = np.arange(cells)
    for p in x:
        if not np.all(np.isfinite(p)) or np.any(np.abs(p[:-1]) > half):
            continue
        f = np.clip((p[:-1] + half) * cells / (2 * half) - 0.5, 0.0, cells - 1.0)
        w = [np.maximum(0.0, 1.0 - np.abs(f[k] - idx)) for k in range(d - 1)]
        out += unit * (w[0] if d == 2 else np.outer(w[0], w[1]))
    return np.minimum(out.reshape(-1), 1.0)


@pytest.mark.parametrize("d", [2, 3])
def test_height_map_matches_brute_force(d):
    rng = np.random.default_rng(d)
    n, cells, half, unit = 300, 7, 1.0, 0.013
    x = rng.uniform(-1.2, 1.2, (2, n, d))  # some grains outside the arena (skipped)
    x[..., -1] = rng.uniform(0.0, 0.5, (2, n))
    x[0, 3] = np.nan  # a lost grain: skipped, no NaN in the map
    x[1, :5, :-1] = 1.0  # on the far walls: the edge cells
    out = np.full((2, cells ** (d - 1)), -1.0)
    LK.height_maps(x, np.arange(2, dtype=np.int64), half, cells, unit, 1.0, out)
    for b in range(2):
        np.testing.assert_allclose(out[b], _brute_force_map(x[b], half, cells, unit), rtol=1e-12, atol=1e-15)
    assert np.all(np.isfinite(out))


def test_registered_with_vector_entry_point():
    for env_id, d, steps in (("PenaltySandLevel-v0", 3, 300), ("PenaltySandLevel2D-v0", 2, 150)):
        spec = gym.spec(env_id)
        assert spec.kwargs == {"dim": d}
        assert spec.max_episode_steps == steps == SL.LEVEL_EPISODE_STEPS[d]
        assert spec.vector_entry_point == "penalty_env.envs.sand_level:PenaltySandLevelVectorEnv"


@pytest.mark.parametrize("env_id", IDS)
def test_check_env(env_id):
    env = gym.make(env_id)
    check_env(env.unwrapped, skip_render_check=True)
    frame = gym.make(env_id, render_mode="rgb_array")
    frame.reset(seed=0)
    img = frame.render()
    assert img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 3


@pytest.mark.parametrize("env_id", IDS)
def test_flat_target_holds_the_beds_volume(env_id):
    """The flat level is the grains' volume over the arena's area at the map's nominal packing; the
    settled heap's map holds exactly that volume (every grain inside, none clipped)."""
    env = gym.make(env_id)
    obs, info = env.reset(seed=0)
    scene = env.unwrapped.scene
    d, n = scene.dim, scene.n_grains
    volume = 4.0 / 3.0 * math.pi * LS.GRAIN_RADIUS**3 if d == 3 else math.pi * LS.GRAIN_RADIUS**2
    area = (2.0 * LS.HALF_WIDTH) ** (d - 1)
    assert scene.flat_level == pytest.approx(n * volume / (LS.PACKING[d] * area), rel=1e-12)
    C = scene.n_cells
    np.testing.assert_array_equal(obs[C : 2 * C], np.float32(scene.flat_level))
    assert scene.maps[0].max() < LS.MAP_TOP  # (no clipping)
    assert scene.maps[0].mean() == pytest.approx(scene.flat_level, rel=1e-12)
    assert info["error"] == pytest.approx(np.sqrt(np.mean((scene.maps[0] - scene.flat_level) ** 2)), rel=1e-12)


def _aggressive(k: int, d: int) -> np.ndarray:
    """Full speed into the walls and corners, reversing every 10 steps, a diagonal in 3D."""
    s = 1.0 if (k // 10) % 2 == 0 else -1.0
    return np.array([s, -s] if d == 3 else [s], dtype=np.float32)


@pytest.mark.parametrize("env_id", IDS)
def test_grains_and_volume_conserved_under_an_aggressive_blade(env_id):
    env = gym.make(env_id, target="random")
    obs, info = env.reset(seed=3)
    scene = env.unwrapped.scene
    d, n = scene.dim, scene.n_grains
    masses = scene.world.masses.copy()
    volume = scene.maps[0].sum()
    steps = 80 if d == 2 else 60
    for k in range(steps):
        obs, r, term, trunc, info = env.step(_aggressive(k, d))
        x = np.asarray(scene.world.positions).reshape(-1, n, d)[0]
        assert info["grains_lost"] == 0
        assert np.all(np.isfinite(x)) and np.all(np.isfinite(obs))
        assert np.all(np.abs(x[:, :-1]) < LS.HALF_WIDTH) and np.all(x[:, -1] > 0.0)
        # the map's sum is the grains' volume: conserved while no cell reaches the clip
        assert scene.maps[0].sum() == pytest.approx(volume, rel=1e-9)
        assert env.observation_space.contains(obs)
    np.testing.assert_array_equal(scene.world.masses, masses)
    # the blade stayed within its range, its faces clear of the walls
    assert np.all(np.abs(scene.blade[0, :-1]) <= scene.blade_range + 1e-12)


@pytest.mark.parametrize("env_id", IDS)
def test_rewards_telescope_to_the_error_decrease(env_id):
    env = gym.make(env_id)
    obs, info = env.reset(seed=1)
    policy = RasterSweep(env)
    e0, total, done = info["initial_error"], 0.0, False
    assert e0 == info["error"] > 0.0
    while not done:
        obs, r, term, trunc, info = env.step(policy(obs))
        total += r
        done = term or trunc
    assert total == pytest.approx(LS.REWARD_SCALE * (e0 - info["error"]), rel=1e-9, abs=1e-9)
    # terminated exactly when the error fell below the documented fraction of the initial error
    fraction = env.unwrapped.scene.success_fraction
    assert term == info["is_success"] == (info["error"] < fraction * e0)


def _episode(env, seed: int, actions: np.ndarray) -> list:
    out = [env.reset(seed=seed)[0]]
    for a in actions:
        o, r, term, trunc, info = env.step(a)
        out += [o, r, term, info["error"]]
    return out


@pytest.mark.parametrize("env_id", IDS)
def test_same_seed_same_episode_single_and_vector(env_id):
    n_worlds, steps = 3, 12
    env = gym.make(env_id, target="random")
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1.0, 1.0, (steps, n_worlds) + env.action_space.shape).astype(np.float32)
    first = _episode(env, 7, actions[:, 0])
    again = _episode(gym.make(env_id, target="random"), 7, actions[:, 0])
    for a, b in zip(first, again):
        np.testing.assert_array_equal(a, b)
    venv = gym.make_vec(env_id, num_envs=n_worlds, vectorization_mode="vector_entry_point", target="random")
    obs, _ = venv.reset(seed=7)
    vectors = [obs]
    for a in actions:
        o, r, term, trunc, info = venv.step(a)
        vectors.append((o, r, term, info["error"]))
    for w in range(n_worlds):
        single = _episode(gym.make(env_id, target="random"), 7 + w, actions[:, w])
        np.testing.assert_array_equal(single[0], vectors[0][w])
        for k in range(steps):
            o, r, term, err = vectors[k + 1]
            np.testing.assert_array_equal(single[1 + 4 * k], o[w])
            assert single[2 + 4 * k] == r[w] and single[3 + 4 * k] == term[w] and single[4 + 4 * k] == err[w]


def test_vector_env_autoresets_on_the_next_step():
    venv = gym.make_vec(
        "PenaltySandLevel2D-v0", num_envs=2, vectorization_mode="vector_entry_point", max_episode_steps=3
    )
    venv.reset(seed=0)
    zeros = np.zeros((2, 1), dtype=np.float32)
    for _ in range(2):
        _, _, _, trunc, _ = venv.step(zeros)
        assert not trunc.any()
    _, _, _, trunc, _ = venv.step(zeros)
    assert trunc.all()
    obs, reward, term, trunc, info = venv.step(zeros)  # the reset step: no reward, a fresh error
    assert not (term.any() or trunc.any()) and np.all(reward == 0.0)
    np.testing.assert_array_equal(info["error"], info["initial_error"])


def test_a_masked_reset_reports_only_the_worlds_it_reset():
    """As Gymnasium's SyncVectorEnv: after reset(options={"reset_mask": m}) the info keys' masks
    are m (the other worlds' entries zero); a numpy array of seeds is taken like a list."""
    venv = gym.make_vec("PenaltySandLevel2D-v0", num_envs=3, vectorization_mode="vector_entry_point")
    obs, info = venv.reset(seed=np.array([4, 5, 6]))
    assert info["_error"].all()
    first = obs.copy()
    mask = np.array([False, True, False])
    obs, info = venv.reset(seed=[None, 5, None], options={"reset_mask": mask})
    for key in ("error", "initial_error", "grains_lost", "is_success"):
        np.testing.assert_array_equal(info["_" + key], mask)
        assert not np.any(info[key][~mask])
    assert info["error"][1] > 0.0
    np.testing.assert_array_equal(obs[1], first[1])  # the same seed, the same start


def test_random_targets_keep_the_volume_and_a_given_target_is_used():
    env = gym.make("PenaltySandLevel2D-v0", target="random")
    scene = env.unwrapped.scene
    drawn = []
    for seed in range(6):
        obs, info = env.reset(seed=seed)
        t = scene.targets[0].copy()
        assert t.mean() == pytest.approx(scene.flat_level, rel=1e-12)
        spread = (np.abs(t - scene.flat_level).max()) / scene.flat_level
        assert LS.TARGET_AMPLITUDE[0] - 1e-12 <= spread <= LS.TARGET_AMPLITUDE[1] + 1e-12
        drawn.append(t)
    assert len({tuple(np.round(t, 12)) for t in drawn}) == len(drawn)
    given = np.linspace(0.05, 0.3, scene.n_cells)
    obs, info = env.reset(seed=0, options={"target": given})
    C = scene.n_cells
    np.testing.assert_allclose(obs[C : 2 * C], given.astype(np.float32))
    assert info["error"] == pytest.approx(np.sqrt(np.mean((scene.maps[0] - given) ** 2)), rel=1e-12)


@pytest.mark.slow
def test_settled_heap_is_no_steeper_than_the_repose_angle():
    """The 3D heap's slope, fitted by the pile benchmark's ``profile_angle`` (bins of one grain
    diameter), does not exceed the repose angle docs/granular.md reports for these grains (mu =
    0.5, mu_r = 0.1, the same tangential spring: 26.1 degrees, the mean of two fills that differ
    by 1.1) plus 1.5 degrees (the allowance of the granular tests)."""
    from penalty_env.bench.granular.pile import profile_angle

    scene = SL.SandLevelScene(1, dim=3)
    assert (LS.GRAIN_FRICTION, LS.GRAIN_ROLLING) == (0.5, 0.1)
    assert scene.settle_speed < LS.SETTLE_SPEED
    d = 2.0 * LS.GRAIN_RADIUS
    x = np.asarray(scene.bed) / d
    angle, (rho, h), _ = profile_angle(x, np.full(len(x), 0.5), np.zeros(2), 3, 1.0)
    assert angle <= 26.1 + 1.5
    assert h.max() >= 1.5  # a heap: at least a layer and a half of grains at its crest


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match="grains"):
        gym.make("PenaltySandLevel2D-v0", grains=0)
    with pytest.raises(ValueError, match="cells"):
        gym.make("PenaltySandLevel2D-v0", cells=1)
    with pytest.raises(ValueError, match="blade_speed"):
        gym.make("PenaltySandLevel2D-v0", blade_speed=5.0)
    with pytest.raises(ValueError, match="target"):
        gym.make("PenaltySandLevel2D-v0", target="bumpy")
    with pytest.raises(ValueError, match="at most"):
        gym.make("PenaltySandLevel2D-v0", grains=2000)
    with pytest.raises(TypeError, match="unexpected keyword argument 'colour'"):
        gym.make("PenaltySandLevel2D-v0", colour=1)
    env = gym.make("PenaltySandLevel2D-v0")
    with pytest.raises(gym.error.ResetNeeded):
        env.unwrapped.step(np.zeros(1, dtype=np.float32))
    env.reset(seed=0)
    C = env.unwrapped.scene.n_cells
    for bad, words in (
        (np.zeros(3), "shape"),
        (np.full(C, np.nan), "finite"),
        (np.full(C, 2.0), "within"),
        (np.full(C, -0.1), "within"),
        ("flat", "real numbers"),
    ):
        with pytest.raises(ValueError, match=words) as exc:
            env.reset(options={"target": bad})
        assert "options['target']" in str(exc.value)
    with pytest.raises(ValueError, match="unknown key"):
        env.reset(options={"goal": 1})
    with pytest.raises(ValueError, match="NaN"):
        env.step(np.array([np.nan], dtype=np.float32))
    with pytest.raises(ValueError, match="shape"):
        env.step(np.zeros(2, dtype=np.float32))


# ------------------------------------------------------------------ domain randomisation
LEVEL_RANGES = {"friction": (0.3, 0.8), "grain_mass": (0.3, 1.0), "blade_speed": (0.3, 0.6)}


def test_randomised_level_draws_within_ranges_and_sets_the_worlds_physics():
    vec = gym.make_vec(
        "PenaltySandLevel2D-v0", num_envs=3, vectorization_mode="vector_entry_point", randomize=LEVEL_RANGES
    )
    _, info = vec.reset(seed=4)
    drawn = info["randomization"]
    scene = vec.unwrapped.scene
    for name, (lo, hi) in LEVEL_RANGES.items():
        assert np.all((drawn[name] >= lo) & (drawn[name] <= hi)), name
    np.testing.assert_array_equal(scene.blade_speeds, drawn["blade_speed"])
    # the World holds each world's drawn mass for every grain, and its friction
    for b in range(3):
        params = scene.world.parameters(b)
        np.testing.assert_allclose(params["masses"], drawn["grain_mass"][b], rtol=1e-15)  # (1 / (1 / m))
        assert params["mu"] == drawn["friction"][b]
    # a blade at full throttle towards the centre (it starts at an end) moves its drawn top speed
    # per control period
    before = scene.blade[:, 0].copy()
    vec.step(-np.sign(before)[:, None].astype(np.float32))
    moved = np.abs(scene.blade[:, 0] - before)
    np.testing.assert_allclose(moved, drawn["blade_speed"] * scene.control_period, rtol=1e-12)


def test_randomised_level_single_and_vector_envs_agree_bit_for_bit():
    single = gym.make("PenaltySandLevel2D-v0", randomize=LEVEL_RANGES)
    vec = gym.make_vec(
        "PenaltySandLevel2D-v0", num_envs=2, vectorization_mode="vector_entry_point", randomize=LEVEL_RANGES
    )
    vobs, vinfo = vec.reset(seed=7)
    obs, info = single.reset(seed=8)  # world 1 of the vector env is seeded 7 + 1
    np.testing.assert_array_equal(obs, vobs[1])
    assert info["randomization"]["friction"] == vinfo["randomization"]["friction"][1]
    rng = np.random.default_rng(0)
    for _ in range(5):
        a = rng.uniform(-1, 1, (2, 1)).astype(np.float32)
        vobs, vr, *_ = vec.step(a)
        obs, r, *_ = single.step(a[1])
        np.testing.assert_array_equal(obs, vobs[1])
        assert r == vr[1]


def test_level_randomize_refuses_unknown_names_and_out_of_range_pairs():
    with pytest.raises(ValueError, match="stiffness"):
        gym.make("PenaltySandLevel2D-v0", randomize={"stiffness": (1, 2)})
    with pytest.raises(ValueError, match="grain_mass"):
        gym.make("PenaltySandLevel2D-v0", randomize={"grain_mass": (0.01, 1.0)})
    env = gym.make("PenaltySandLevel2D-v0", randomize={"friction": (0.3, 0.5)})
    with pytest.raises(ValueError, match="friction"):
        env.reset(seed=0, options={"randomize": {"friction": (0.1, 0.5)}})


def test_level_observation_modes_come_from_the_shared_views():
    """obs_mode on the level task: the views' spaces, the state part equal to the state env's,
    the picture of the grains not blank, the height map centred on the blade."""
    state = gym.make("PenaltySandLevel2D-v0")
    env = gym.make("PenaltySandLevel2D-v0", obs_mode=("state", "heightmap", "rgb"))
    assert set(env.observation_space.spaces) == {"state", "heightmap", "rgb"}
    s, _ = state.reset(seed=3)
    o, _ = env.reset(seed=3)
    np.testing.assert_array_equal(o["state"], s)
    for key, space in env.observation_space.spaces.items():
        assert space.contains(o[key]), key
    assert o["rgb"].std() > 0  # grains and floor drawn, not a blank frame
    assert o["heightmap"].max() > 0  # sand under the blade's window

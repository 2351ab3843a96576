"""Per-world domain randomisation (``randomize=``): the fixed scene is untouched (the fingerprint
test), a randomised one is deterministic per seed in every env kind, its draws lie in their ranges
and set each world's physics, the physics follows the draw (resting overlap m g / ks_terrain, the
closed-form rebound of the drawn restitution), the make-time guard covers the ranges' worst corner,
bad input is refused, and nothing compiles per reset."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from numba.core import event as numba_event

import penalty_env  # noqa: F401 (registers the ids)
from penalty_env.envs.balls.scene import PenaltyBallsScene
from penalty_env.envs.penalty_balls import PenaltyBallsVectorEnv
from penalty_env.envs.randomize import RandomizationWarning
from penalty_env.physics import theory
from penalty_env.sb3 import make_vec_env

RANGES = {
    "ball_mass": (0.5, 2.0),
    "pusher_radius": (0.14, 0.16),
    "friction": (0.2, 0.8),
    "restitution": (0.3, 0.6),
    "max_force": (15.0, 20.0),
}


def _episode(env: gym.Env, seed: int, steps: int) -> tuple[np.ndarray, list]:
    rng = np.random.default_rng(seed)
    obs, info = env.reset(seed=seed)
    rows, draws = [obs], [info["randomization"]]
    for _ in range(steps):
        obs, *_, info = env.step(rng.uniform(-1, 1, env.action_space.shape))
        rows.append(obs)
    return np.array(rows), draws


def test_single_vector_and_sb3_agree_bit_for_bit():
    """Same seed -> the same randomised episode in the single env, the native vector env and the
    SB3 VecEnv; world i of a batch is the single env seeded seed + i; the draws are in range and
    differ across worlds and resets."""
    n, steps, seed = 3, 20, 7
    single = [gym.make("PenaltyBalls-v0", randomize=RANGES) for _ in range(n)]
    actions = np.random.default_rng(0).uniform(-1, 1, (steps, n, 2))
    want, want_draws = [], []
    for i, env in enumerate(single):
        obs, info = env.reset(seed=seed + i)
        rows = [obs]
        want_draws.append(info["randomization"])
        for t in range(steps):
            rows.append(env.step(actions[t, i])[0])
        want.append(rows)
    want = np.array(want).transpose(1, 0, 2)  # (steps + 1, n, obs)

    vec = PenaltyBallsVectorEnv(n, randomize=RANGES)
    obs, infos = vec.reset(seed=seed)
    got = [obs]
    for t in range(steps):
        got.append(vec.step(actions[t])[0])
    assert np.array_equal(np.array(got), want)
    for name in RANGES:
        assert np.array_equal(infos["randomization"][name], [d[name] for d in want_draws])
        assert infos["randomization"]["_" + name].all()

    sb3 = make_vec_env("PenaltyBalls-v0", n_envs=n, seed=seed, randomize=RANGES)
    got = [sb3.reset()]
    for t in range(steps):
        obs, _, _, step_infos = sb3.step(actions[t])
        got.append(obs)
    assert np.array_equal(np.array(got), want)
    assert [i["randomization"] for i in step_infos] == want_draws

    # the draws: within their ranges, different across worlds and across resets
    draws = np.array([[d[k] for k in RANGES] for d in want_draws])
    lo, hi = np.array(list(RANGES.values())).T
    assert np.all((draws >= lo) & (draws <= hi))
    assert np.all(np.ptp(draws, axis=0) > 0.0)
    again = single[0].reset()[1]["randomization"]
    assert all(again[k] != want_draws[0][k] for k in RANGES)


def test_draws_set_the_worlds_physics_as_the_fixed_scene_derives_it():
    """A draw derives what the fixed scene derives from its keyword arguments: a randomised world
    whose ranges are single points equals the fixed scene made with those values (ks, kd, the
    terrain's, kf, masses, radii, the motor), and a world's values follow its draw."""
    point = {"ball_mass": 0.8, "pusher_radius": 0.12, "friction": 0.5, "restitution": 0.45, "max_force": 25.0}
    fixed = PenaltyBallsScene(1, **point)
    with pytest.warns(RandomizationWarning):  # (the point's step is shorter than the defaults')
        rand = PenaltyBallsScene(2, randomize={k: (v, v) for k, v in point.items()})
    assert rand.dt == fixed.dt and rand.substeps == fixed.substeps
    rand.reset_worlds([0, 1], [np.random.default_rng(1), np.random.default_rng(2)])
    p = rand.world.parameters(1)
    assert p["masses"].tolist() == fixed.masses.tolist() and p["radii"].tolist() == fixed.radii.tolist()
    assert p["mu"] == fixed.mu and p["max_force"].tolist() == [fixed.params["max_force"]]
    for name in ("ks", "ks_terrain", "kf"):
        assert p[name] == pytest.approx(getattr(fixed, name), rel=1e-13)
    # kd from the restitution: the closed-form inversion against the numerical one (rel 1e-9)
    assert p["kd"] == pytest.approx(fixed.kd, rel=1e-9)
    assert p["kd_terrain"] == pytest.approx(fixed.kd_terrain, rel=1e-9)
    assert rand.task.push_offset[1] == pytest.approx(fixed.task.push_offset, rel=1e-15)


@pytest.mark.parametrize("physics", ["sliding", pytest.param("rolling", marks=pytest.mark.slow)])
def test_the_reset_kernel_and_its_python_twin_derive_the_same_bits(physics):
    """The one derivation runs compiled at a reset and in Python at make (``python_twin``, the
    guard's corners): on the same draws the two write the same World and scene rows, bit for bit
    (every world's ks, kd, terrain spring, kf, masses, radii, motor; rolling: inertia and kr; rest
    radii, push offset)."""
    import copy

    from penalty_env._jit import python_twin
    from penalty_env.envs.balls.randomize import derive_worlds

    ranges = dict(RANGES, pusher_mass=(0.5, 3.0), obstacle_radius=(0.1, 0.2), stiffness=(0.5, 1.5))
    with pytest.warns(RandomizationWarning):  # (these ranges need more substeps)
        a = PenaltyBallsScene(6, randomize=ranges, physics=physics, n_obstacles=2)
    idx = np.arange(6)
    a.reset_worlds(idx, [np.random.default_rng(s) for s in range(6)], observe=False)  # the kernel
    r = a.randomizer
    d = r.draws({n: r.drawn[:, j] for j, n in enumerate(r.names)}, 6)
    arrays = copy.deepcopy((r.world_arrays, r.rows))
    for field in arrays[0] + arrays[1]:
        field[...] = np.nan  # (every value the twin leaves unwritten would show)
    python_twin(derive_worlds)(idx, d, r.derive_rule, r._grid, r._zetas, *arrays)
    for name, want, got in zip(
        arrays[0]._fields + arrays[1]._fields[:-1], r.world_arrays + r.rows[:-1], arrays[0] + arrays[1][:-1]
    ):
        if physics == "sliding" and name in ("inv_inertia", "kr"):
            continue  # (placeholders: the sliding scene has none)
        assert want.tobytes() == got.tobytes(), name


def test_closed_form_restitution_matches_the_numerical_inverse():
    e = np.array([0.22, 0.3, 0.47, 0.8, 0.99])
    fast = theory.zeta_for_restitution_no_tension(e)
    slow = [theory.zeta_for_restitution(float(x), "no_tension") for x in e]
    assert np.allclose(fast, slow, rtol=1e-9, atol=0.0)
    assert np.allclose(theory.restitution_no_tension(fast), e, rtol=1e-9)


def _drop(env: gym.Env, height: float, steps: int) -> tuple[float, float, np.ndarray]:
    """Drop the ball from ``height`` (its lowest point above the bowl's bottom) with the pusher
    parked far away; returns (its mass, ks_terrain, the ball's centre heights per step)."""
    scene = env.unwrapped.scene
    p = scene.world.parameters(0)
    r = p["radii"][1]
    x = scene.world.state.positions
    pos = x[0].copy()
    pos[1] = (0.0, 0.0, r + height)
    pos[0] = (2.0, 0.0, 8.0 - math.sqrt((8.0 - p["radii"][0]) ** 2 - 4.0))  # on the bowl, 2 m out
    scene.world.set_state(positions=pos[None], velocities=np.zeros_like(pos)[None], worlds=[0])
    z = [pos[1, 2]]
    for _ in range(steps):
        env.step(np.zeros(2))
        z.append(x[0, 1, 2])
    return p, np.array(z)


def test_physics_follows_the_draw():
    """Per world: a dropped ball rebounds to the closed-form height of its drawn restitution (the
    no-tension law with gravity, within the model's declared error, restitution_accuracy), and then
    rests at the overlap m g / ks_terrain of its drawn mass."""
    env = gym.make(
        "PenaltyBalls-v0", randomize={"ball_mass": (0.5, 2.0), "restitution": (0.45, 0.7)}, control_period=0.005
    )
    accuracy = env.unwrapped.scene.params["restitution_accuracy"]
    g = env.unwrapped.scene.gravity
    seen = []
    for seed in range(3):
        env.reset(seed=seed)
        h0 = 0.3
        p, z = _drop(env, h0, 1200)
        r, m = p["radii"][1], p["masses"][1]
        omega = math.sqrt(p["ks_terrain"] / m)
        zeta = p["kd_terrain"] / (2.0 * math.sqrt(p["ks_terrain"] * m))
        v = math.sqrt(2.0 * g * h0)
        exact = theory.contact_response(zeta, "no_tension", g / (omega * v)).restitution
        first = int(np.argmax(z < r))  # in contact
        h1 = z[first + int(np.argmax(z[first:] > r)) :].max() - r  # the rebound's apex
        assert math.sqrt(h1 / h0) == pytest.approx(exact, rel=accuracy)
        assert h1 < h0  # passive
        # at rest: the overlap m g / ks_terrain (the bowl is flat at its bottom)
        assert r - z[-1] == pytest.approx(m * g / p["ks_terrain"], rel=1e-3)
        seen.append(m)
    assert np.ptp(seen) > 0.1


def test_guard_covers_the_worst_corner():
    """Ranges that need a smaller step than the fixed scene's get more substeps and a warning naming
    the range; a draw at the worst corner (small radius, stiff, strong motor) stays stable and
    passive: a dropped ball rebounds lower."""
    ranges = {"pusher_radius": (0.05, 0.3), "ball_radius": (0.05, 0.3), "stiffness": (0.25, 4.0)}
    with pytest.warns(RandomizationWarning, match=r"randomize\['stiffness'\]"):
        env = gym.make("PenaltyBalls-v0", randomize=ranges, control_period=0.005)
    fixed = PenaltyBallsScene(1, control_period=0.005)
    assert env.unwrapped.scene.dt < fixed.dt
    corner = {"pusher_radius": (0.05, 0.05), "ball_radius": (0.05, 0.05), "stiffness": (4.0, 4.0)}
    env.reset(seed=0, options={"randomize": corner})
    p, z = _drop(env, 0.05, 300)
    assert p["radii"][1] == 0.05 and p["ks"] == pytest.approx(
        4.0 * PenaltyBallsScene(1, pusher_radius=0.05, ball_radius=0.05).ks
    )
    assert np.all(np.isfinite(z))
    first = int(np.argmax(z < 0.05))
    assert z[first + int(np.argmax(z[first:] > 0.05)) :].max() - 0.05 < 0.05


def test_reset_options_override_within_the_make_time_ranges():
    env = gym.make("PenaltyBalls-v0", randomize=RANGES)
    _, info = env.reset(seed=0, options={"randomize": {"ball_mass": (1.5, 1.5)}})
    assert info["randomization"]["ball_mass"] == 1.5
    assert env.unwrapped.scene.world.parameters(0)["masses"][1] == 1.5
    _, info = env.reset()  # the override was for that reset only
    assert info["randomization"]["ball_mass"] != 1.5
    with pytest.raises(ValueError, match=r"options\['randomize'\]\['ball_mass'\].*within"):
        env.reset(options={"randomize": {"ball_mass": (0.1, 1.0)}})
    with pytest.raises(ValueError, match="not made to randomise"):
        env.reset(options={"randomize": {"obstacle_mass": (1.0, 1.0)}})
    with pytest.raises(ValueError, match="made with randomize"):
        gym.make("PenaltyBalls-v0").reset(options={"randomize": {"ball_mass": (1.0, 1.0)}})
    vec = PenaltyBallsVectorEnv(2, randomize=RANGES)
    _, infos = vec.reset(seed=0, options={"randomize": {"friction": (0.25, 0.25)}})
    assert infos["randomization"]["friction"].tolist() == [0.25, 0.25]


@pytest.mark.parametrize(
    ("randomize", "kwargs", "match"),
    [
        ({"mass": (1.0, 2.0)}, {}, "unknown name"),
        ({"ball_mass": (2.0, 1.0)}, {}, "low must be <= high"),
        ({"ball_mass": (1.0,)}, {}, r"\(low, high\) pair"),
        ({"ball_mass": (1.0, float("nan"))}, {}, r"\(low, high\) pair of finite"),
        ({"ball_mass": ("a", "b")}, {}, r"\(low, high\) pair"),
        ({"ball_mass": (0.01, 1.0)}, {}, r"randomize\['ball_mass'\] = \(0.01, 1\) must lie within \[0.05, 10\]"),
        ({"stiffness": (0.1, 1.0)}, {}, r"within \[0.25, 4\]"),
        ({"obstacle_radius": (0.1, 0.3)}, {"n_obstacles": 8}, r"obstacle_radius.*at its largest.*do not fit"),
        ({"roughness": (0.0, 0.1)}, {}, "needs terrain='bumpy'"),
        ({"ball_mass": (1.0, 2.0)}, {"grains": 10}, "not supported with sand"),
        ([("ball_mass", (1.0, 2.0))], {}, "randomize must be None or a dict"),
        (  # a motor strong enough to need more than MAX_SUBSTEPS at the corner (F / v_max dt / m <= 1)
            {"max_force": (20.0, 500.0), "pusher_mass": (0.1, 1.0)},
            {"control_period": 0.25},
            r"worst corner \(pusher_mass=0.1, max_force=500\).*more than 1000",
        ),
    ],
)
def test_bad_randomize_is_refused(randomize, kwargs, match):
    with pytest.raises((ValueError, TypeError), match=match):
        PenaltyBallsScene(1, randomize=randomize, **kwargs)


def test_pickled_randomised_env_continues_bit_for_bit():
    import pickle

    env = PenaltyBallsVectorEnv(3, randomize=RANGES, max_episode_steps=15)
    env.reset(seed=4)
    actions = np.random.default_rng(2).uniform(-1, 1, (40, 3, 2))
    for a in actions[:10]:
        env.step(a)
    copy = pickle.loads(pickle.dumps(env))
    for a in actions[10:]:  # (episodes end and reset within these steps: new draws in both)
        want, got = env.step(a), copy.step(a)
        assert np.array_equal(want[0], got[0])
    assert copy.scene.world.model.radii is copy.scene.randomizer.world_arrays.radii  # its own arrays, still shared
    assert copy.scene.task.push_offset is copy.scene.randomizer.rows.push


def test_no_compile_per_reset():
    """After the first reset and step, many resets (each drawing new masses, radii, stiffness) and
    steps compile nothing."""
    with pytest.warns(RandomizationWarning):  # (these ranges need more substeps)
        vec = PenaltyBallsVectorEnv(16, randomize=dict(RANGES, stiffness=(0.5, 1.0), ball_radius=(0.1, 0.2)))
    vec.reset(seed=0)
    vec.step(np.zeros((16, 2)))
    with numba_event.install_recorder("numba:compile") as rec:
        for k in range(20):
            vec.reset(seed=k)
            for _ in range(3):
                vec.step(np.random.default_rng(k).uniform(-1, 1, (16, 2)))
    assert rec.buffer == []

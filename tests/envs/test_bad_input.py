"""Bad input, table-driven: every refusal is a ValueError or TypeError that names the argument, repeats
the value it got and states what is allowed, and leaves the object usable.

The table covers ``World`` (construction, ``step``, ``set_state``), the shapes, ``configure``, every
env keyword argument (below, above and beside its range), ``reset``, ``step`` and the vector sizes.
"""

from __future__ import annotations

import re

import gymnasium as gym
import numpy as np
import pytest

import penalty_env  # noqa: F401
from penalty_env.envs import PenaltyBallsVectorEnv
from penalty_env.envs.balls.params import INT_PARAMETERS, PARAMETERS
from penalty_env.physics import Bowl, Sphere, World
from penalty_env.physics.configure import configure

X = np.array([[0.0, 0.0, 0.5], [0.5, 0.0, 0.5]])
WORLD = dict(
    positions=X, radii=[0.1, 0.1], masses=[1.0, 1.0], terrain=Bowl((0.0, 0.0, 8.0), 8.0), ks=1e3, kd=1.0, dt=1e-3
)


def _world(**change):
    kw = dict(WORLD, **change)
    return World(kw.pop("positions"), kw.pop("radii"), kw.pop("masses"), **kw)


def _value_text(value):
    """What the message must repeat of the value."""
    if isinstance(value, float) and value != value:
        return "nan"
    if isinstance(value, (list, tuple, np.ndarray)):
        return None  # arrays: the shape or a part is enough
    return str(value) if isinstance(value, str) else repr(value)


# (id, callable, argument named, value, words of the allowed range)
WORLD_CASES = [
    ("positions string", lambda: _world(positions="abc"), "positions", "abc", "real numbers"),
    ("positions ragged", lambda: _world(positions=[[0, 0, 1], [0, 1]]), "positions", None, "rectangular"),
    ("positions NaN", lambda: _world(positions=[[0, 0, np.nan], [1, 0, 1]]), "positions", None, "finite"),
    ("positions 1-d", lambda: _world(positions=[0.0, 1.0, 2.0]), "positions", None, "2 or 3 dimensions"),
    ("positions d=4", lambda: _world(positions=np.zeros((2, 4))), "positions", "4", "d = 2 or 3"),
    ("radii negative", lambda: _world(radii=[0.1, -0.1]), "radii", "-0.1", "> 0"),
    ("radii shape", lambda: _world(radii=[0.1]), "radii", "(1,)", "(2,)"),
    ("radii string", lambda: _world(radii="big"), "radii", "big", "real numbers"),
    ("masses zero", lambda: _world(masses=[1.0, 0.0]), "masses", "0.0", "> 0"),
    ("masses inf", lambda: _world(masses=[1.0, np.inf]), "masses", None, "finite"),
    ("velocities shape", lambda: _world(velocities=np.zeros((3, 3))), "velocities", "(3, 3)", "shape of positions"),
    ("terrain string", lambda: _world(terrain="bowl"), "terrain", "bowl", "Sphere"),
    ("terrain 2D shape", lambda: _world(terrain=[Bowl((0.0, 8.0), 8.0)]), "terrain[0]", "2D", "3D"),
    ("gravity length", lambda: _world(gravity=(0.0, -9.81)), "gravity", "2", "d = 3"),
    ("gravity string", lambda: _world(gravity="down"), "gravity", "down", "real numbers"),
    ("ks zero", lambda: _world(ks=0.0), "ks", "0.0", "> 0"),
    ("ks nan", lambda: _world(ks=float("nan")), "ks", "nan", "> 0"),
    ("ks string", lambda: _world(ks="1e3"), "ks", "1e3", "> 0"),
    ("ks bool", lambda: _world(ks=True), "ks", "True", "> 0"),
    ("kd negative", lambda: _world(kd=-1.0), "kd", "-1.0", ">= 0"),
    ("ks_terrain negative", lambda: _world(ks_terrain=-5.0), "ks_terrain", "-5.0", "> 0"),
    ("kd_terrain nan", lambda: _world(kd_terrain=float("nan")), "kd_terrain", "nan", ">= 0"),
    ("damping unknown", lambda: _world(damping="quadratic"), "damping", "quadratic", "linear"),
    ("mu negative", lambda: _world(mu=-0.1), "mu", "-0.1", ">= 0"),
    ("kf zero", lambda: _world(mu=0.3, kf=0.0), "kf", "0.0", "> 0"),
    ("integrator unknown", lambda: _world(integrator="leapfrog"), "integrator", "leapfrog", "symplectic_euler"),
    ("integrator None", lambda: _world(integrator=None), "integrator", "None", "symplectic_euler"),
    ("dt zero", lambda: _world(dt=0.0), "dt", "0.0", "> 0"),
    ("dt inf", lambda: _world(dt=float("inf")), "dt", "inf", "> 0"),
    ("broadphase unknown", lambda: _world(broadphase="octree"), "broadphase", "octree", "grid"),
    ("stepping unknown", lambda: _world(stepping="gpu"), "stepping", "gpu", "lanes"),
    ("allow_unstable string", lambda: _world(allow_unstable="yes"), "allow_unstable", "yes", "True or False"),
    ("events int", lambda: _world(events=1), "events", "1", "True or False"),
]

SHAPE_CASES = [
    ("Sphere centre 1-d", lambda: Sphere((1.0,), 1.0), "center", "1", "2 or 3"),
    ("Sphere centre NaN", lambda: Sphere((0.0, np.nan), 1.0), "center", "nan", "finite"),
    ("Sphere radius zero", lambda: Sphere((0.0, 0.0), 0.0), "radius", "0.0", "> 0"),
    ("Bowl radius negative", lambda: Bowl((0.0, 0.0, 0.0), -2.0), "radius", "-2.0", "> 0"),
    ("Bowl radius string", lambda: Bowl((0.0, 0.0), "r"), "radius", "r", "> 0"),
]

CONFIGURE = dict(masses=[1.0, 1.0], radii=[0.1, 0.1], max_impact_speed=1.0)


def _configure(**change):
    return configure(**dict(CONFIGURE, **change))


CONFIGURE_CASES = [
    ("masses negative", lambda: _configure(masses=[1.0, -1.0]), "masses", "-1.0", "> 0"),
    ("radii mismatched", lambda: _configure(radii=[0.1]), "radii", "1 radii", "equal-length"),
    ("max_impact_speed zero", lambda: _configure(max_impact_speed=0.0), "max_impact_speed", "0.0", "> 0"),
    ("penetration nan", lambda: _configure(penetration=float("nan")), "penetration", "nan", "> 0"),
    ("restitution zero", lambda: _configure(restitution=0.0), "restitution", "0.0", "(0, 1]"),
    ("restitution 1.5", lambda: _configure(restitution=1.5), "restitution", "1.5", "(0, 1]"),
    ("accuracy negative", lambda: _configure(accuracy=-0.01), "accuracy", "-0.01", "> 0"),
    ("damping unknown", lambda: _configure(damping="x"), "damping", "x", "no_tension"),
    ("integrators unknown", lambda: _configure(integrators=("leapfrog",)), "integrators", "leapfrog", "rk4"),
    ("max_dt zero", lambda: _configure(max_dt=0.0), "max_dt", "0.0", "> 0"),
    ("max_force negative", lambda: _configure(max_force=-1.0), "max_force", "-1.0", ">= 0"),
    ("gravity string", lambda: _configure(gravity="g"), "gravity", "g", "real number"),
    ("energy_budget zero", lambda: _configure(energy_budget=0.0), "energy_budget", "0.0", "> 0"),
]


def _make_with_unknown_render_mode():
    """Gymnasium warns of a render mode the metadata does not list before the env refuses it."""
    with pytest.warns(UserWarning, match="render_mode='rgb'"):
        return gym.make("PenaltyBalls-v0", render_mode="rgb")


def _env_kwarg_cases():
    out = []
    for name, (_, lo, hi, _) in PARAMETERS.items():
        if name in INT_PARAMETERS:
            bad = [lo - 1, hi + 1, 1.5]
        else:
            bad = [hi * 2 + 1, "0.5", True] + ([lo / 2] if lo > 0 else [lo - 1])
        for value in bad:
            out.append(
                (
                    f"{name}={value!r}",
                    (lambda n=name, v=value: gym.make("PenaltyBalls-v0", **{n: v})),
                    name,
                    value,
                    f"[{lo}, {hi}]",
                )
            )
    return out


ENV_CASES = _env_kwarg_cases() + [
    ("render_mode unknown", lambda: _make_with_unknown_render_mode(), "render_mode", "rgb", "rgb_array"),
    ("num_envs zero", lambda: PenaltyBallsVectorEnv(num_envs=0), "num_envs", "0", "[1, inf]"),
    ("num_envs float", lambda: PenaltyBallsVectorEnv(num_envs=2.5), "num_envs", "2.5", "int"),
    (
        "max_episode_steps zero",
        lambda: PenaltyBallsVectorEnv(num_envs=2, max_episode_steps=0),
        "max_episode_steps",
        "0",
        "[1, inf]",
    ),
    (
        "autoreset_mode unknown",
        lambda: PenaltyBallsVectorEnv(num_envs=2, autoreset_mode="sometimes"),
        "autoreset_mode",
        "sometimes",
        "NextStep",
    ),
]

ALL_CASES = WORLD_CASES + SHAPE_CASES + CONFIGURE_CASES + ENV_CASES


def _check(exc_info, name, value, allowed):
    message = str(exc_info.value)
    assert re.search(rf"(?<![\w.]){re.escape(name)}(?!\w)", message), f"the argument {name!r} is not named: {message}"
    text = None if value is None else (value if isinstance(value, str) and value in message else _value_text(value))
    if text is not None:
        assert text in message, f"the value {text!r} is not repeated: {message}"
    assert allowed in message, f"the allowed range {allowed!r} is not stated: {message}"


def test_the_table_is_large():
    assert len(ALL_CASES) + len(LIVE_CASES) >= 60


@pytest.mark.parametrize("make, name, value, allowed", [c[1:] for c in ALL_CASES], ids=[c[0] for c in ALL_CASES])
def test_construction_refusals_name_the_argument_the_value_and_the_range(make, name, value, allowed):
    with pytest.raises((ValueError, TypeError)) as exc_info:
        make()
    _check(exc_info, name, value, allowed)


# calls on live objects: (id, object factory, call, argument, value, allowed); after the refusal the
# object must still work
LIVE_CASES = [
    ("World.step n negative", lambda: _world(), lambda w: w.step(-1), "n", "-1", "[0,"),
    ("World.step n float", lambda: _world(), lambda w: w.step(1.5), "n", "1.5", "int"),
    ("World.step n huge", lambda: _world(), lambda w: w.step(2**63), "n", str(2**63), "int"),
    ("World.step forces string", lambda: _world(), lambda w: w.step(1, forces="x"), "forces", "x", "real numbers"),
    (
        "World.step forces shape",
        lambda: _world(),
        lambda w: w.step(1, forces=np.zeros((3, 3))),
        "forces",
        "(3, 3)",
        "(2, 3)",
    ),
    (
        "World.step forces NaN",
        lambda: _world(),
        lambda w: w.step(1, forces=np.full((2, 3), np.nan)),
        "forces",
        None,
        "finite",
    ),
    (
        "World.set_state shape",
        lambda: _world(),
        lambda w: w.set_state(positions=np.zeros((3, 3))),
        "positions",
        "(3, 3)",
        "(2, 3)",
    ),
    (
        "World.set_state worlds float",
        lambda: _world(positions=np.stack([X, X])),
        lambda w: w.set_state(positions=X[None], worlds=[0.5]),
        "worlds",
        "float",
        "integer",
    ),
    (
        "World.set_state worlds range",
        lambda: _world(positions=np.stack([X, X])),
        lambda w: w.set_state(positions=X[None], worlds=[5]),
        "worlds",
        "5",
        "0..1",
    ),
    ("reset options int", lambda: _env(), lambda e: e.reset(options=5), "options", "5", "dict"),
    (
        "reset options mixed keys",
        lambda: _env(),
        lambda e: e.reset(options={"a": 1, 2: 3}),
        "options",
        "'a'",
        "accepts",
    ),
    (
        "reset options unknown",
        lambda: _env(),
        lambda e: e.reset(options={"difficulty": 1}),
        "options",
        "difficulty",
        "accepts",
    ),
    ("reset seed float", lambda: _env(), lambda e: e.reset(seed=1.5), "seed", "1.5", "int"),
    ("reset seed negative", lambda: _env(), lambda e: e.reset(seed=-1), "seed", "-1", "[0, inf]"),
    ("reset seed string", lambda: _env(), lambda e: e.reset(seed="x"), "seed", "x", "int"),
    ("step action string", lambda: _env(), lambda e: e.step("x"), "action", "x", "shape (2,)"),
    ("step action shape", lambda: _env(), lambda e: e.step(np.zeros(3)), "action", "(3,)", "shape (2,)"),
    ("step action NaN", lambda: _env(), lambda e: e.step(np.array([np.nan, 0.0])), "action", "nan", "NaN or inf"),
    (
        "vector reset options string",
        lambda: _venv(),
        lambda e: e.reset(options="garbage"),
        "options",
        "garbage",
        "dict",
    ),
    ("vector reset seed list", lambda: _venv(), lambda e: e.reset(seed=[1, 2]), "seed", "2", "list of 3"),
    ("vector reset seed float", lambda: _venv(), lambda e: e.reset(seed=0.5), "seed", "0.5", "int"),
    (
        "vector reset_mask",
        lambda: _venv(),
        lambda e: e.reset(options={"reset_mask": [True]}),
        "reset_mask",
        "[True]",
        "bool array",
    ),
    ("vector step shape", lambda: _venv(), lambda e: e.step(np.zeros((2, 2))), "action", "(2, 2)", "(3, 2)"),
]


def _env():
    env = gym.make("PenaltyBalls-v0")
    env.reset(seed=0)
    return env


def _venv():
    venv = gym.make_vec("PenaltyBalls-v0", num_envs=3)
    venv.reset(seed=0)
    return venv


def _still_works(obj):
    if isinstance(obj, World):
        obj.step(2)
        assert np.all(np.isfinite(obj.positions))
    elif hasattr(obj, "num_envs"):
        obs, *_ = obj.step(np.zeros((obj.num_envs, 2), np.float32))
        assert np.all(np.isfinite(obs))
    else:
        obs, *_ = obj.step(np.zeros(2, np.float32))
        assert np.all(np.isfinite(obs))


@pytest.mark.parametrize(
    "factory, call, name, value, allowed", [c[1:] for c in LIVE_CASES], ids=[c[0] for c in LIVE_CASES]
)
def test_call_refusals_name_the_argument_and_leave_the_object_usable(factory, call, name, value, allowed):
    obj = factory()
    with pytest.raises((ValueError, TypeError)) as exc_info:
        call(obj)
    _check(exc_info, name, value, allowed)
    _still_works(obj)


def test_an_unknown_keyword_raises_type_error_in_pythons_own_words():
    """TorchRL's GymEnv retries without ``frameskip`` when the TypeError says exactly this."""
    with pytest.raises(TypeError, match=r"__init__\(\) got an unexpected keyword argument 'frameskip'"):
        gym.make("PenaltyBalls-v0", frameskip=4)
    with pytest.raises(TypeError, match=r"got an unexpected keyword argument 'frameskip'"):
        gym.make_vec("PenaltyBalls-v0", num_envs=2, frameskip=4)

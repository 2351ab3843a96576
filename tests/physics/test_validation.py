"""Bad arguments raise ValueError naming the argument; the stability guard explains itself."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from penalty_env.physics import Bowl, Sphere, World, theory

NAN = float("nan")


def _good(**over):
    kw = dict(
        positions=np.array([[0.0, 0.0, 0.3], [0.5, 0.0, 0.3]]),
        radii=[0.2, 0.2],
        masses=[1.0, 2.0],
        terrain=(Bowl((0, 0, 2.0), 2.0),),
        ks=1e4,
        kd=10.0,
        dt=1e-3,
    )
    kw.update(over)
    return kw


def _make(**over):
    kw = _good(**over)
    return World(kw.pop("positions"), kw.pop("radii"), kw.pop("masses"), **kw)


def test_the_reference_arguments_are_accepted():
    w = _make()
    assert (w.n_worlds, w.n_balls, w.dim) == (1, 2, 3)


@pytest.mark.parametrize(
    "name,over",
    [
        ("positions", dict(positions=np.zeros(3))),  # one dimension
        ("positions", dict(positions=np.zeros((1, 1, 1, 3)))),  # four dimensions
        ("positions", dict(positions=np.zeros((2, 4)))),  # d = 4
        ("positions", dict(positions=np.zeros((2, 1)), gravity=(-9.81,))),  # d = 1
        ("positions", dict(positions=np.array([[0.0, 0.0, NAN], [0.5, 0, 0.3]]))),
        ("positions", dict(positions=np.array([[0.0, 0.0, math.inf], [0.5, 0, 0.3]]))),
        ("positions", dict(positions=[["a", 0, 0], [0, 0, 0]])),
        ("velocities", dict(velocities=np.zeros((3, 3)))),
        ("velocities", dict(velocities=np.array([[0.0, NAN, 0.0], [0.0, 0.0, 0.0]]))),
        ("radii", dict(radii=[0.2])),
        ("radii", dict(radii=[0.2, 0.0])),
        ("radii", dict(radii=[0.2, -0.1])),
        ("radii", dict(radii=[0.2, NAN])),
        ("masses", dict(masses=[1.0, 2.0, 3.0])),
        ("masses", dict(masses=[1.0, 0.0])),
        ("masses", dict(masses=[-1.0, 2.0])),
        ("masses", dict(masses=[1.0, NAN])),
        ("gravity", dict(gravity=(0.0, -9.81))),
        ("gravity", dict(gravity=(0.0, 0.0, NAN))),
        ("ks", dict(ks=0.0)),
        ("ks", dict(ks=-1.0)),
        ("ks", dict(ks=NAN)),
        ("ks", dict(ks="stiff")),
        ("kd", dict(kd=-0.1)),
        ("kd", dict(kd=NAN)),
        ("ks_terrain", dict(ks_terrain=0.0)),
        ("kd_terrain", dict(kd_terrain=-1.0)),
        ("dt", dict(dt=0.0)),
        ("dt", dict(dt=-1e-3)),
        ("dt", dict(dt=NAN)),
        ("mu", dict(mu=-0.1)),
        ("kf", dict(mu=0.5, kf=0.0)),
        ("integrator", dict(integrator="leapfrog")),
        ("damping", dict(damping="quadratic")),
        ("broadphase", dict(broadphase="octree")),
        ("terrain", dict(terrain=(Bowl((0, 2.0), 2.0),))),  # 2D shape in a 3D world
        ("terrain", dict(terrain=("bowl",))),
    ],
)
def test_bad_arguments_raise_value_error_naming_the_argument(name, over):
    with pytest.raises(ValueError, match=re.escape(name)):
        _make(**over)


def test_bad_step_and_state_arguments_raise_value_error_naming_the_argument():
    w = _make()
    for bad in (
        np.zeros((3, 3)),
        np.zeros(3),
        np.array([[0.0, 0.0, NAN], [0.0, 0.0, 0.0]]),
        np.array([[0.0, 0.0, math.inf], [0.0, 0.0, 0.0]]),
    ):
        with pytest.raises(ValueError, match="forces"):
            w.step(1, forces=bad)
    for bad_n in (-1, 1.5, True, "3"):
        with pytest.raises(ValueError, match=r"\bn\b"):
            w.step(bad_n)
    with pytest.raises(ValueError, match="positions"):
        w.set_state(positions=np.zeros((3, 3)))
    with pytest.raises(ValueError, match="velocities"):
        w.set_state(velocities=np.array([[NAN, 0, 0], [0, 0, 0]]))
    with pytest.raises(ValueError, match="worlds"):
        w.set_state(positions=np.zeros((1, 2, 3)), worlds=[1])
    # nothing above touched the state
    np.testing.assert_array_equal(w.positions, _good()["positions"])


def test_shapes_validate_their_arguments():
    for bad in (dict(center=(0, 0), radius=0.0), dict(center=(0, 0), radius=-2.0), dict(center=(0, 0), radius=NAN)):
        with pytest.raises(ValueError, match="radius"):
            Sphere(**bad)
    with pytest.raises(ValueError, match="center"):
        Bowl(center=(0.0,), radius=1.0)


def test_stability_guard_refuses_dt_above_the_dense_pile_limit_and_gives_limit_and_substeps():
    # the stiffest contact: the two lightest balls, m_eff = 1 * 2 / 3; symplectic Euler, kd = 10
    ks, kd = 1e4, 10.0
    m_eff = 2.0 / 3.0
    crit = theory.critical_dt("symplectic_euler", ks, kd, m_eff)
    zeta = kd / (2 * math.sqrt(ks * m_eff))
    omega = math.sqrt(ks / m_eff)
    assert crit == pytest.approx(2 * (math.sqrt(1 + zeta**2) - zeta) / omega, rel=1e-12)
    # half the critical dt, or the dense-pile mode's limit (2 omega, 2 zeta) if smaller: damped, it is
    pile = 2 * (math.sqrt(1 + 4 * zeta**2) - 2 * zeta) / (2 * omega)
    assert pile < 0.5 * crit
    limit = min(0.5 * crit, pile)
    assert theory.guard_dt("symplectic_euler", ks, kd, m_eff) == pytest.approx(limit, rel=1e-12)
    assert _make(dt=limit).stability_limit() == pytest.approx(limit, rel=1e-12)
    dt = 0.1
    with pytest.raises(ValueError) as info:
        _make(dt=dt)
    msg = str(info.value)
    substeps = math.ceil(dt / limit)
    assert f"{limit:.6g}" in msg, msg
    assert f"{substeps} substeps" in msg, msg
    assert "allow_unstable" in msg
    # just above the limit is refused, and allow_unstable lets it through
    with pytest.raises(ValueError, match="stability limit"):
        _make(dt=limit * 1.001)
    assert _make(dt=dt, allow_unstable=True).dt == dt


def test_stability_guard_uses_the_terrain_contact_when_it_is_stiffest():
    # one ball of mass 1 on terrain: m_eff = 1 (no pair contact possible)
    kw = dict(positions=np.array([[0.0, 0.0, 0.3]]), radii=[0.2], masses=[1.0], kd=0.0, ks_terrain=4e4)
    limit = 0.5 * theory.critical_dt("velocity_verlet", 4e4, 0.0, 1.0)
    assert _make(integrator="velocity_verlet", dt=1e-4, **kw).stability_limit() == pytest.approx(limit, rel=1e-12)
    assert limit == pytest.approx(0.5 * 2.0 / 200.0, rel=1e-12)
    # no terrain, a single ball: no contact can form, any dt is allowed
    w = World(np.zeros((1, 3)), [0.2], [1.0], ks=1e4, dt=10.0)
    assert w.stability_limit() == math.inf


def test_explicit_euler_on_undamped_contacts_is_refused_unless_allow_unstable():
    with pytest.raises(ValueError) as info:
        _make(integrator="explicit_euler", kd=0.0, dt=1e-6)
    msg = str(info.value)
    assert "explicit" in msg.lower() and "allow_unstable" in msg
    assert _make(integrator="explicit_euler", kd=0.0, dt=1e-6, allow_unstable=True).stability_limit() == 0.0
    # with damping it is accepted up to half of omega dt = 2 zeta, i.e. dt <= kd / ks
    ok = _make(integrator="explicit_euler", kd=10.0, ks_terrain=1e4, dt=0.5 * 10.0 / 1e4)
    assert ok.stability_limit() == pytest.approx(0.5 * 10.0 / 1e4, rel=1e-12)


def test_implicit_euler_has_no_stability_limit():
    assert _make(integrator="implicit_euler", dt=1.0).stability_limit() == math.inf


def test_a_world_that_blows_up_raises_floating_point_error():
    w = _make(kd=0.0, dt=0.05, allow_unstable=True, positions=np.array([[0.0, 0.0, 0.1], [0.5, 0.0, 0.3]]))
    with pytest.raises(FloatingPointError):
        w.step(10_000)


def test_implicit_euler_refuses_no_tension_damping_which_its_linearised_solve_cannot_honour():
    """The frozen-contact Jacobian does not know the clip, so the solve would pull separating balls
    together: the combination is refused with a message naming both arguments."""
    with pytest.raises(ValueError, match="no_tension.*implicit_euler"):
        World(
            np.array([[0.0, 0.0, 0.1]]),
            [0.1],
            [1.0],
            ks=1e3,
            dt=1e-3,
            integrator="implicit_euler",
            damping="no_tension",
        )


@pytest.mark.parametrize(
    "kwargs,name",
    [
        (dict(terrain=None), "terrain"),
        (dict(terrain=5), "terrain"),
        (dict(damping=np.array(["linear"])), "damping"),
        (dict(allow_unstable=float("nan")), "allow_unstable"),
        (dict(ks=True), "ks"),
        (dict(positions=np.array([[True, False, True]])), "positions"),
    ],
)
def test_ill_typed_arguments_are_refused_naming_the_argument(kwargs, name):
    base = dict(positions=np.array([[0.0, 0.0, 0.1]]), radii=[0.1], masses=[1.0], ks=1e3, dt=1e-3)
    base.update(kwargs)
    with pytest.raises(ValueError, match=name):
        World(**base)


def test_set_state_refuses_a_boolean_mask_for_worlds():
    w = World(np.zeros((2, 1, 3)), [0.1], [1.0], ks=1e3, dt=1e-3)
    with pytest.raises(ValueError, match="worlds"):
        w.set_state(positions=np.zeros((1, 1, 3)), worlds=np.array([True, False]))


def test_a_stale_numba_cache_index_naming_a_vanished_class_is_a_cache_miss_not_a_crash(tmp_path):
    """An index written by an older version may pickle a class the package no longer has (the cache
    survives an upgrade); the first call must recompile, not raise."""
    import pickle
    import subprocess
    import sys
    import textwrap

    code = textwrap.dedent(
        """
        import numba, pickle, types, sys, os
        sys.path.insert(0, os.environ["MOD_DIR"])
        import penalty_env  # noqa: F401  (installs the tolerant index loader)
        import penalty_env._jit  # noqa: F401
        import stale_mod
        print(stale_mod.f(2.0))
        """
    )
    mod = tmp_path / "stale_mod.py"
    mod.write_text("import numba\n@numba.njit(cache=True)\ndef f(x):\n    return x + 1.0\n")
    env = dict(__import__("os").environ, MOD_DIR=str(tmp_path), NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    first = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert first.stdout.strip() == "3.0"
    # corrupt the index as an older version would leave it: a key naming a class that is gone
    (index,) = list((tmp_path / "cache").rglob("*.nbi"))
    with open(index, "rb") as f:
        version = pickle.load(f)
    gone = type("Gone", (), {"__module__": "penalty_env.physics.geometry.table"})
    gone.__qualname__ = "UnionNodeThatIsGone"
    import penalty_env.physics.geometry.table as geometry

    geometry.UnionNodeThatIsGone = gone  # type: ignore[attr-defined]
    try:
        payload = pickle.dumps((("stamp",), {gone(): "x"}))
    finally:
        delattr(geometry, "UnionNodeThatIsGone")
    with open(index, "wb") as f:
        pickle.dump(version, f)
        f.write(payload)
    again = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert again.returncode == 0, again.stderr[-2000:]
    assert again.stdout.strip() == "3.0"

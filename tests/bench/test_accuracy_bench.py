"""The speed-against-accuracy benchmark (penalty_env/bench/accuracy.py, stability.py) and the
measured error models it writes into penalty_env/physics/configure.py."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

from penalty_env.bench import accuracy as A
from penalty_env.bench import stability as S
from penalty_env.physics import configure as CF
from penalty_env.physics import theory


def test_fit_recovers_constant_and_order_and_never_under_predicts():
    spcs = np.array(A.SPCS, float)
    rng = np.random.default_rng(0)
    errs = 3.0 * spcs**-2.0 * rng.uniform(0.8, 1.2, spcs.size)
    errs[:2] = 1.5 * A.MODEL_MAX_ERROR  # points too far from the oracle are left out
    errs[-1] = 1e-13  # the round-off floor too
    fit = A.fit_power_law(spcs, errs)
    assert fit["p"] == pytest.approx(2.0, abs=0.15)
    used = (spcs >= fit["spc_min"]) & (errs > A.FLOOR)
    assert np.all(fit["C"] * spcs[used] ** -fit["p"] >= errs[used] * (1 - 1e-9))


def test_measured_models_cover_every_method_at_the_chart_zetas():
    assert CF.ERROR_MODELS, "run python -m penalty_env.bench accuracy --fit"
    for integ in theory.INTEGRATORS:
        for ev in (False, True):
            for damping in ("linear", "no_tension"):
                if integ == "implicit_euler" and damping == "no_tension":
                    continue  # World refuses it
                for zeta in (0.1, 0.3):
                    key = CF._model_key(integ, ev, damping, "restitution", zeta)
                    assert key in CF.ERROR_MODELS, key


def _order(integ, events, zeta=0.3, damping="linear"):
    return CF.ERROR_MODELS[CF._model_key(integ, events, damping, "restitution", zeta)]["p"]


@pytest.mark.parametrize("integ", theory.INTEGRATORS)
@pytest.mark.parametrize("zeta", [0.1, 0.3])
def test_fitted_orders_are_one_without_events_where_the_dashpot_jumps(integ, zeta):
    assert 0.8 < _order(integ, False, zeta) < 1.3


@pytest.mark.parametrize("zeta", [0.1, 0.3])
def test_fitted_orders_with_events_are_two_for_verlet_and_four_for_rk4(zeta):
    assert 1.7 < _order("velocity_verlet", True, zeta) < 2.4
    assert _order("rk4", True, zeta) >= 3.5
    # the first-order methods stay first order with events (their own order)
    for integ in ("explicit_euler", "symplectic_euler", "implicit_euler"):
        assert 0.8 < _order(integ, True, zeta) < 1.3


def test_costs_are_measured():
    assert CF.COST_PER_STEP["rk4"] > 2.0 * CF.COST_PER_STEP["symplectic_euler"]
    assert CF.EVENT_EXTRA_EVALS["rk4"] > 0


def test_the_chart_and_csv_cover_the_sweep():
    path = os.path.join(
        os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "docs", "accuracy.csv.gz"
    )
    if not os.path.exists(path):
        pytest.skip("docs/accuracy.csv.gz not generated")
    rows = A.read_csv(path)
    scen = {r["scenario"] for r in rows}
    assert scen == {"pair", "drop", "rest", "elastic_pile", "damped_pile"}
    assert {r["steps_per_contact"] for r in rows} == set(A.SPCS)
    assert {r["zeta"] for r in rows if r["scenario"] == "damped_pile"} == set(A.ZETAS) - {0.0}
    assert {r["zeta"] for r in rows if r["scenario"] == "pair"} == set(A.ZETAS) | set(A.FIT_EXTRA_ZETAS)
    assert {r["damping"] for r in rows if r["integrator"] == "implicit_euler"} == {"linear"}  # World refuses no_tension
    assert {(r["integrator"], r["events"]) for r in rows} == {(i, e) for i in theory.INTEGRATORS for e in (0, 1)}


@pytest.mark.slow
def test_quick_benchmark_runs_and_writes_its_outputs(tmp_path):
    A.main(["--quick", "--out", str(tmp_path)])
    assert (tmp_path / "accuracy.csv.gz").exists()
    assert (tmp_path / "accuracy_linear_zeta0.3.png").stat().st_size > 10_000


# --- the stability map's measurement ------------------------------------------------------------


@pytest.mark.parametrize(
    "integ, zeta",
    [
        ("symplectic_euler", 0.0),
        ("symplectic_euler", 0.3),
        ("velocity_verlet", 0.0),
        ("velocity_verlet", 0.3),
        ("rk4", 0.0),
        ("rk4", 0.3),
        ("explicit_euler", 0.3),
    ],
)
def test_stability_map_measures_the_theoretical_boundary(integ, zeta):
    crit = theory.critical_omega_dt(integ, zeta)
    assert S.floor_oscillator_growth(integ, 0.97 * crit, zeta) <= S.GROWING
    assert not S.floor_oscillator_growth(integ, 1.03 * crit, zeta) <= S.GROWING


def test_implicit_euler_and_explicit_euler_undamped_sit_at_the_extremes():
    assert S.floor_oscillator_growth("implicit_euler", 50.0, 0.0) <= S.GROWING
    assert not S.floor_oscillator_growth("explicit_euler", 0.05, 0.0) <= S.GROWING


def test_tunnelling_boundaries_are_where_the_theory_puts_them():
    omega = math.sqrt(S.TUN_KS / S.TUN_M)
    r = S.TUN_R
    dt = 0.01 / omega
    # v / omega0 ~ r: the spring cannot stop the ball within a radius
    assert S.tunnelling_outcome("symplectic_euler", 0.5 * omega * r, dt)[0] == 0
    assert S.tunnelling_outcome("symplectic_euler", 1.5 * omega * r, dt)[0] == 2
    # v dt ~ r: one step goes a radius deep before the contact is seen, however stiff the spring
    # (visible on its own for implicit Euler, stable at any dt; the explicit methods gain energy
    # there first, since v < omega0 r puts v dt = r beyond omega0 dt = 1)
    slow = 0.05 * omega * r
    assert S.tunnelling_outcome("implicit_euler", slow, 0.3 * r / slow)[0] == 0
    assert S.tunnelling_outcome("implicit_euler", slow, 3.0 * r / slow)[0] == 2
    assert S.tunnelling_outcome("rk4", slow, 3.0 * r / slow)[0] in (1, 2, 3)


# --- the sweep's cells as Ray tasks ---------------------------------------------------------------


def _csv_without_wall_times(rows, path):
    """The CSV as written, without its one measured time (wall_per_sim_s differs between any two runs)."""
    A.write_csv(rows, str(path))
    col = A.FIELDS.index("wall_per_sim_s")
    return [",".join(c for i, c in enumerate(line.split(",")) if i != col) for line in path.read_text().splitlines()]


@pytest.mark.slow
def test_ray_sweep_writes_the_serial_csv_on_the_quick_grid(tmp_path):
    ray = pytest.importorskip("ray")
    serial = A.sweep(quick=True, log=lambda *_: None)
    ray.init(address="local", num_cpus=2, object_store_memory=100 * 1024 * 1024, include_dashboard=False)
    try:
        tasks = A.sweep(quick=True, log=lambda *_: None, ray=True)
    finally:
        ray.shutdown()
    assert len(serial) == len(tasks) > 50
    assert _csv_without_wall_times(tasks, tmp_path / "ray.csv") == _csv_without_wall_times(
        serial, tmp_path / "serial.csv"
    )
    assert all(r["wall_per_sim_s"] > 0 for r in tasks if not r["diverged"])

"""The measurements of ``python -m penalty_env.bench stability`` (:mod:`penalty_env.bench.stability`,
whose docstring describes them): (a) the floor oscillator's growth on a grid of omega0 dt and
zeta, (b) the outcome of a ball hitting the terrain at speed v, (c) the environment driven at full
throttle.
"""

from __future__ import annotations

import math
import time

import numpy as np

from ..physics import Bowl, World, theory

INTEGRATORS = theory.INTEGRATORS
SHORT = {
    "explicit_euler": "explicit Euler",
    "symplectic_euler": "symplectic Euler",
    "velocity_verlet": "velocity Verlet",
    "rk4": "RK4",
    "implicit_euler": "implicit Euler",
}

# (a) the floor oscillator ----------------------------------------------------------------------
OSC_R, OSC_M, OSC_KS, OSC_G, OSC_BOWL_R = 0.25, 2.0, 2.0e4, 9.81, 4.0


def floor_oscillator_growth(
    integrator: str, omega_dt: float, zeta: float, n_steps: int = 4000, displacement: float = 1e-4, window: int = 200
) -> float:
    """Largest oscillation energy over the last ``window`` steps / over the first ``window`` steps;
    inf if the run blew up or its energy ever exceeded 1e4 x the start (amplitude x 100).

    The second test matters: the contact is linear only while the ball stays on the floor, and a
    fast-growing run saturates (RK4 just above its limit settles into a large bounded oscillation
    whose stages leave the contact) before the first window ends. Starting 1e-4 of the resting
    overlap away leaves a factor 5,000 in amplitude before that. A bounded neutral method
    (symplectic Euler or Verlet at zeta = 0) gives a ratio of about 1 even where its energy swings
    widely within a period; a damped one < 1.
    """
    kd = 2.0 * zeta * math.sqrt(OSC_KS * OSC_M)
    omega = math.sqrt(OSC_KS / OSC_M)
    rest = OSC_M * OSC_G / OSC_KS
    bowl = Bowl((0.0, 0.0, OSC_BOWL_R), OSC_BOWL_R)
    x = np.array([[0.0, 0.0, OSC_R - rest]])
    w = World(
        x,
        [OSC_R],
        [OSC_M],
        terrain=(bowl,),
        gravity=(0.0, 0.0, -OSC_G),
        ks=OSC_KS,
        kd=kd,
        integrator=integrator,
        dt=omega_dt / omega,
        allow_unstable=True,
    )
    e_rest = w.energy()
    x[0, 2] = OSC_R - rest * (1.0 + displacement)
    w.set_state(positions=x, velocities=np.zeros((1, 3)))
    limit = 1e4 * (w.energy() - e_rest)

    def window_max(steps):
        e = 0.0
        for _ in range(steps):
            w.step(1)
            e = max(e, w.energy() - e_rest)
        return e

    try:
        first = window_max(window)
        left = n_steps - 2 * window
        peak = first
        while left > 0 and peak <= limit:
            k = min(10, left)
            w.step(k)
            left -= k
            peak = max(peak, w.energy() - e_rest)
        last = window_max(window)
    except FloatingPointError:
        return math.inf
    if not (math.isfinite(last) and max(peak, last) <= limit):
        return math.inf
    return last / first


GROWING = 1.01  # last-window / first-window energy above this: growing


def stability_map(omega_dts, zetas, n_steps=4000, log=print):
    """rows (integrator, omega_dt, zeta, growth) and the measured boundary per integrator."""
    rows = []
    boundary = {}
    for integ in INTEGRATORS:
        t = time.perf_counter()
        bnd = []
        for z in zetas:
            first = math.inf
            for h in omega_dts:
                gr = floor_oscillator_growth(integ, h, z, n_steps)
                rows.append((integ, h, z, gr))
                if not gr <= GROWING and first == math.inf:
                    first = h
            bnd.append(first)
        boundary[integ] = np.array(bnd)
        log(f"(a) {SHORT[integ]:17s} map done in {time.perf_counter() - t:5.1f} s")
    return rows, boundary


# (b) tunnelling ----------------------------------------------------------------------------------
TUN_R, TUN_M, TUN_KS, TUN_ZETA = 0.1, 1.0, 1.0e4, 0.1
TUN_PHASES = 8


def tunnelling_outcome(integrator: str, speed: float, dt: float, phases: int = TUN_PHASES):
    """Worst outcome over phases: 0 fine, 1 launched with more energy, 2 passed through, 3 NaN.
    Also returns the largest overlap / r and the largest exit / impact kinetic energy."""
    omega = math.sqrt(TUN_KS / TUN_M)
    kd = 2.0 * TUN_ZETA * math.sqrt(TUN_KS * TUN_M)
    tc = theory.contact_time(TUN_KS, kd, TUN_M)
    bowl = Bowl((0.0, 0.0, 50.0), 50.0)  # a floor at z = 0, flat on the scale of the ball
    ph = (np.arange(phases) + 0.5) / phases
    x = np.zeros((phases, 1, 3))
    x[:, 0, 2] = TUN_R + speed * dt * ph
    v = np.zeros_like(x)
    v[:, 0, 2] = -speed
    w = World(
        x,
        [TUN_R],
        [TUN_M],
        v,
        terrain=(bowl,),
        gravity=(0.0, 0.0, 0.0),
        ks=TUN_KS,
        kd=kd,
        integrator=integrator,
        dt=dt,
        allow_unstable=True,
    )
    # long enough for a contact of several t_c, or for a deep pass at speed v
    t_end = 4.0 * tc + 4.0 * (TUN_R + speed / omega) / speed + 2 * dt
    n_total = int(math.ceil(t_end / dt))
    chunk = max(1, n_total // 400)
    worst_pen = 0.0
    done = 0
    try:
        while done < n_total:
            k = min(chunk, n_total - done)
            w.step(k)
            done += k
            z = w.positions[:, 0, 2]
            worst_pen = max(worst_pen, float(np.max((TUN_R - z) / TUN_R)))
            if np.all(z > TUN_R) and np.all(w.velocities[:, 0, 2] > 0):
                break
    except FloatingPointError:
        return 3, math.inf, math.inf
    vz = w.velocities[:, 0, 2]
    gain = float(np.max(vz**2 / speed**2))
    if not np.all(np.isfinite(w.positions)):
        return 3, worst_pen, gain
    if worst_pen > 1.0:
        return 2, worst_pen, gain
    if gain > 1.0:
        return 1, worst_pen, gain
    return 0, worst_pen, gain


def tunnelling_map(speeds, dts, log=print):
    rows = []
    for integ in INTEGRATORS:
        t = time.perf_counter()
        for dt in dts:
            for s in speeds:
                out, pen, gain = tunnelling_outcome(integ, s, dt)
                rows.append((integ, s, dt, out, pen, gain))
        log(f"(b) {SHORT[integ]:17s} tunnelling map done in {time.perf_counter() - t:5.1f} s")
    return rows


# (c) the environment -----------------------------------------------------------------------------


def env_stress(
    n_steps: int = 100_000, env_id: str = "PenaltyBalls-v0", seed: int = 0, release_steps: int = 3_000, log=print
):
    """Drive the pusher at full throttle toward the ball for n_steps env steps (no resets), then
    release the throttle for ``release_steps``.

    Checks (the env's own settings, through ``gymnasium.make`` and ``env.unwrapped.scene``):
    * no NaN;
    * no tunnelling: every overlap (``info["max_overlap"]``, a fraction of the smaller radius) < 1;
    * no energy from nowhere, at any run length: the total energy (``World.energy()``) never rises
      above its start by more than the motor's work. The motor's force F_max (a - v / v_max) does
      at most F_max a . dx_pusher per step (its speed feedback only takes energy out), and friction
      and the dashpots only dissipate, so E - E_0 - sum F_max a . dx may not exceed 1% of that
      work (a sampled bound, so a margin);
    * under the constant drive the energy settles (runs of 50,000 steps and more: the largest value
      over the last fifth exceeds the largest before it by < 1%; the motor only lifts the bodies to
      where it holds them);
    * with the throttle released every force left (the motor's speed feedback, friction, the
      dashpots) dissipates, so the energy must fall at every step.
    Returns a dict of the measurements.
    """
    import gymnasium as gym

    import penalty_env  # noqa: F401  (registers the ids)

    env = gym.make(env_id, max_episode_steps=None)
    scene = env.unwrapped.scene
    env.reset(seed=seed)
    p = scene.params
    t0 = time.perf_counter()
    k, worst_overlap, nan, energies, work, creation = _drive(env, scene, n_steps, p["max_force"], log)
    wall = time.perf_counter() - t0
    e = np.array(energies)
    cut = max(1, int(0.8 * e.size))
    drive_growth = float((e[cut:].max() - e[:cut].max()) / max(abs(e[:cut].max()), 1e-300)) if e.size > 1 else 0.0
    release = []
    if not nan:
        release, worst_overlap = _release(env, scene, release_steps, worst_overlap)
    rel = np.array(release)
    release_rise = float(np.max(np.diff(rel))) if rel.size > 1 else 0.0
    env.close()
    settles = e.size < 2 or n_steps < 50_000 or drive_growth <= 1e-2
    energy_gain = creation > 0.01 * max(work, 1.0) or not settles or release_rise > 0.0
    return {
        "steps": k + 1,
        "worst_overlap": worst_overlap,
        "penetration_tolerance": p["penetration_tolerance"],
        "drive_energy_final": float(e[-1]) if e.size else math.nan,
        "drive_energy_growth": drive_growth,
        "motor_work_bound": work,
        "energy_beyond_motor_work": creation,
        "release_energy_drop": float(rel[0] - rel[-1]) if rel.size else math.nan,
        "release_largest_rise": release_rise,
        "nan": nan,
        "tunnelled": worst_overlap >= 1.0,
        "energy_gain": energy_gain,
        "substeps": scene.substeps,
        "dt": scene.dt,
        "integrator": scene.world.integrator,
        "ok": not nan and worst_overlap < 1.0 and not energy_gain,
        "wall_s": wall,
    }


def _energy(scene) -> float:
    """The env's total energy (``World.energy()`` of its one world)."""
    return float(np.ravel(scene.world.energy())[0])


def _pusher_action(scene):
    """Full throttle from the pusher (body 0) toward the ball (body 1), along the action's d - 1
    axes, and the pusher's position along them before the step."""
    d = scene.dim
    x = scene.world.positions
    x = x[0] if x.ndim == 3 else x
    direction = x[1, : d - 1] - x[0, : d - 1]
    norm = float(np.linalg.norm(direction))
    action = (direction / norm if norm > 0 else np.ones(d - 1)).astype(np.float32)
    before = x[0, : d - 1].copy()
    return action, before


def _drive(env, scene, n_steps, fmax, log):
    """The drive of :func:`env_stress`: ``n_steps`` env steps at full throttle (stopped by a NaN).
    Returns the last step's index, the worst overlap, whether a NaN stopped it, the energy every
    100 steps, the bound of the motor's work, and the largest E - E_0 - work seen (every 10 steps)."""
    d = scene.dim
    worst_overlap = 0.0
    nan = False
    energies = []
    k = 0
    e0 = _energy(scene)
    work = 0.0  # an upper bound of the motor's work so far
    creation = 0.0  # the largest E - E_0 - work seen
    for k in range(n_steps):
        action, before = _pusher_action(scene)
        try:
            obs, _, _, _, info = env.step(action)
        except FloatingPointError:
            nan = True
            break
        after = np.asarray(scene.world.positions)
        after = (after[0] if after.ndim == 3 else after)[0, : d - 1]
        work += fmax * float(np.dot(action, after - before))
        if k % 10 == 0:
            creation = max(creation, _energy(scene) - e0 - work)
        worst_overlap = max(worst_overlap, float(info["max_overlap"]))
        if not np.all(np.isfinite(obs)):
            nan = True
            break
        if k % 100 == 0:
            energies.append(_energy(scene))
        if log and k and k % 25_000 == 0:
            log(f"(c) {k:,} steps: worst overlap {worst_overlap:.4f} r, energy {energies[-1]:.4f} J")
    return k, worst_overlap, nan, energies, work, creation


def _release(env, scene, release_steps, worst_overlap):
    """The throttle released for ``release_steps``: the energy after each step, and the worst
    overlap so far."""
    zero = np.zeros(scene.dim - 1, dtype=np.float32)
    release = []
    for _ in range(release_steps):
        _, _, _, _, info = env.step(zero)
        worst_overlap = max(worst_overlap, float(info["max_overlap"]))
        release.append(_energy(scene))
    return release, worst_overlap

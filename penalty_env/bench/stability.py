"""Where each integrator holds and where it fails: ``python -m penalty_env.bench stability [--quick]``.

(a) Stability map. A ball resting on the bowl's floor under gravity, displaced slightly from its
    resting overlap, is a linear oscillator of frequency omega0 = sqrt(ks / m) and damping ratio
    zeta while it stays in contact. For each integrator and each (omega0 dt, zeta) of a grid, the
    ball starts 1e-4 of the resting overlap off rest, and the run is *growing* if its largest
    oscillation energy (``World.energy()`` minus that of the ball at rest) over the last 200 of
    4,000 steps exceeds 1.01x that over the first 200, or its energy ever exceeds 1e4x the start,
    or the run produced NaN; else *bounded*. The
    measured boundary (the first growing omega0 dt at each zeta) is drawn against the theoretical
    curves of docs/physics.md section 4 (``theory.critical_omega_dt``, from each method's amplification
    matrix).
(b) Tunnelling. A ball (r = 0.1 m, m = 1 kg, ks = 1e4 N/m, zeta = 0.1) flies at speed v into the
    bowl's floor, gravity off, at 8 phases of the step grid. Outcomes: it *passes through* (its
    centre crosses the surface: overlap > r at some step), it is *launched with more energy* than
    it came with (exit kinetic energy > impact kinetic energy), or neither. Predicted boundaries:
    v / omega0 ~ r (the spring cannot stop the ball within a radius) and v dt ~ r (a single step
    goes a radius deep; LIGGGHTS warns when v_max dt > r_min), plus the stability limit.
(c) The environment. ``gymnasium.make("PenaltyBalls-v0")`` with its own settings; the pusher is
    driven at full throttle at the ball for 100,000 steps (it pushes the ball up the bowl's wall
    and holds it there, pressed between the pusher and the terrain), then the throttle is
    released: no NaN, no tunnelling (every overlap below the radius), no energy gain (the energy
    settles under the drive and falls at every step once released); the worst overlap is reported.

Output (``--out``, default ``docs/``; ``--quick`` writes to a temporary folder): ``stability_map.png``,
``tunnelling.png``, ``stability.csv.gz`` and ``tunnelling.csv.gz`` (every run).
"""

from __future__ import annotations

import argparse
import csv
import gzip
import math
import os
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
    d = scene.dim
    p = scene.params

    def energy():
        return float(np.ravel(scene.world.energy())[0])

    worst_overlap = 0.0
    nan = False
    energies = []
    t0 = time.perf_counter()
    k = 0
    fmax = p["max_force"]
    e0 = energy()
    work = 0.0  # an upper bound of the motor's work so far
    creation = 0.0  # the largest E - E_0 - work seen
    for k in range(n_steps):
        x = scene.world.positions
        x = x[0] if x.ndim == 3 else x
        direction = x[1, : d - 1] - x[0, : d - 1]
        norm = float(np.linalg.norm(direction))
        action = (direction / norm if norm > 0 else np.ones(d - 1)).astype(np.float32)
        before = x[0, : d - 1].copy()
        try:
            obs, _, _, _, info = env.step(action)
        except FloatingPointError:
            nan = True
            break
        after = np.asarray(scene.world.positions)
        after = (after[0] if after.ndim == 3 else after)[0, : d - 1]
        work += fmax * float(np.dot(action, after - before))
        if k % 10 == 0:
            creation = max(creation, energy() - e0 - work)
        worst_overlap = max(worst_overlap, float(info["max_overlap"]))
        if not np.all(np.isfinite(obs)):
            nan = True
            break
        if k % 100 == 0:
            energies.append(energy())
        if log and k and k % 25_000 == 0:
            log(f"(c) {k:,} steps: worst overlap {worst_overlap:.4f} r, energy {energies[-1]:.4f} J")
    wall = time.perf_counter() - t0
    e = np.array(energies)
    cut = max(1, int(0.8 * e.size))
    drive_growth = float((e[cut:].max() - e[:cut].max()) / max(abs(e[:cut].max()), 1e-300)) if e.size > 1 else 0.0
    release = []
    if not nan:
        zero = np.zeros(d - 1, dtype=np.float32)
        for _ in range(release_steps):
            _, _, _, _, info = env.step(zero)
            worst_overlap = max(worst_overlap, float(info["max_overlap"]))
            release.append(energy())
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


# charts ------------------------------------------------------------------------------------------


def _edges(centres, log=False):
    c = np.log10(centres) if log else np.asarray(centres, float)
    e = np.concatenate([[1.5 * c[0] - 0.5 * c[1]], 0.5 * (c[1:] + c[:-1]), [1.5 * c[-1] - 0.5 * c[-2]]])
    return 10**e if log else e


def plot_map(rows, boundary, omega_dts, zetas, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap

    fig, axes = plt.subplots(1, 5, figsize=(17, 3.7), sharey=True)
    zf = np.linspace(0.0, 1.0, 201)
    ix = {float(h): k for k, h in enumerate(omega_dts)}
    iz = {float(z): k for k, z in enumerate(zetas)}
    cmap = ListedColormap(["#b7e4b0", "#f4a6a0"])
    for ax, integ in zip(axes, INTEGRATORS):
        grid = np.zeros((len(zetas), len(omega_dts)))
        for i, h, z, g in rows:
            if i == integ:
                grid[iz[float(z)], ix[float(h)]] = 0.0 if g <= GROWING else 1.0
        ax.pcolormesh(_edges(omega_dts), _edges(zetas), grid, cmap=cmap, vmin=0, vmax=1)
        theo = np.array([theory.critical_omega_dt(integ, z) for z in zf])
        ax.plot(np.minimum(theo, omega_dts[-1] * 1.05), zf, color="k", lw=1.5)
        b = boundary[integ]
        fin = np.isfinite(b)
        if fin.any():
            ax.plot(b[fin], np.asarray(zetas)[fin], ls="none", marker="o", ms=3.5, color="gold", mec="k", mew=0.5)
        ax.set_xlim(_edges(omega_dts)[0], _edges(omega_dts)[-1])
        ax.set_ylim(0, 1)
        ax.set_title(SHORT[integ], fontsize=10)
        ax.set_xlabel("omega0 dt", fontsize=9)
    axes[0].set_ylabel("damping ratio zeta", fontsize=9)
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    fig.legend(
        [
            Patch(color="#b7e4b0"),
            Patch(color="#f4a6a0"),
            Line2D([], [], color="k", lw=1.5),
            Line2D([], [], ls="none", marker="o", color="gold", mec="k"),
        ],
        [
            "bounded",
            "growing",
            "theory (docs/physics.md section 4, amplification matrix)",
            "measured: first growing omega0 dt",
        ],
        loc="lower center",
        ncol=4,
        fontsize=8,
        frameon=False,
    )
    fig.suptitle(
        "Stability map: a ball oscillating on the floor (a linear oscillator while in contact); growing = energy "
        "over the last 200 of 4,000 steps > 1.01 x the first 200's, or > 1e4 x the start",
        fontsize=10,
    )
    fig.tight_layout(rect=(0, 0.07, 1, 0.93))
    fig.savefig(path, dpi=64)
    plt.close(fig)


def plot_tunnelling(rows, speeds, dts, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    omega = math.sqrt(TUN_KS / TUN_M)
    kd = 2.0 * TUN_ZETA * math.sqrt(TUN_KS * TUN_M)
    fig, axes = plt.subplots(1, 5, figsize=(17, 3.8), sharey=True)
    colors = {0: "tab:green", 1: "tab:orange", 2: "tab:red", 3: "k"}
    labels = {0: "fine", 1: "launched with more energy", 2: "passes through (overlap > r)", 3: "NaN"}
    from matplotlib.colors import BoundaryNorm, ListedColormap

    cmap = ListedColormap([colors[c] for c in (0, 1, 2, 3)])
    norm = BoundaryNorm([-0.5, 0.5, 1.5, 2.5, 3.5], 4)
    lx = np.log10(np.asarray(dts) * omega)
    ly = np.log10(np.asarray(speeds) / (omega * TUN_R))
    ex = 10 ** np.concatenate([[1.5 * lx[0] - 0.5 * lx[1]], 0.5 * (lx[1:] + lx[:-1]), [1.5 * lx[-1] - 0.5 * lx[-2]]])
    ey = 10 ** np.concatenate([[1.5 * ly[0] - 0.5 * ly[1]], 0.5 * (ly[1:] + ly[:-1]), [1.5 * ly[-1] - 0.5 * ly[-2]]])
    for ax, integ in zip(axes, INTEGRATORS):
        grid = np.zeros((len(speeds), len(dts)))
        index_s = {float(s): k for k, s in enumerate(speeds)}
        index_d = {float(d): k for k, d in enumerate(dts)}
        for i, s, dt, out, _, _ in rows:
            if i == integ:
                grid[index_s[float(s)], index_d[float(dt)]] = out
        ax.pcolormesh(ex, ey, grid, cmap=cmap, norm=norm, alpha=0.75)
        for code in (0, 1, 2, 3):
            ax.plot([], [], ls="none", marker="s", color=colors[code], label=labels[code])
        xs = np.array(dts) * omega
        ax.plot(xs, np.ones_like(xs), color="k", ls="--", lw=1, label="v / omega0 = r")
        ax.plot(xs, 1.0 / xs, color="k", ls=":", lw=1.2, label="v dt = r")
        crit = theory.critical_dt(integ, TUN_KS, kd, TUN_M) * omega
        if math.isfinite(crit) and crit > 0:
            ax.axvline(crit, color="tab:blue", lw=1, label="stability limit")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(ex[0], ex[-1])
        ax.set_ylim(ey[0], ey[-1])
        ax.set_title(SHORT[integ], fontsize=10)
        ax.set_xlabel("omega0 dt", fontsize=9)
    axes[0].set_ylabel("impact speed v / (omega0 r)", fontsize=9)
    handles, labs = [], []
    for ax in axes:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            if lab not in labs:
                handles.append(h)
                labs.append(lab)
    fig.legend(handles, labs, loc="lower center", ncol=7, fontsize=8, frameon=False, markerscale=1.5)
    fig.suptitle(
        f"Tunnelling: a ball (r = {TUN_R} m) hits the terrain at speed v, zeta = {TUN_ZETA}, "
        f"worst of {TUN_PHASES} phases",
        fontsize=10,
    )
    fig.tight_layout(rect=(0, 0.08, 1, 0.93))
    fig.savefig(path, dpi=64)
    plt.close(fig)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(
        prog="python -m penalty_env.bench stability",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--quick", action="store_true", help="coarser maps and 5,000 env steps (CI smoke run)")
    ap.add_argument("--out", default=None, help="folder for the PNGs and CSVs (default: docs/ of the repository)")
    ap.add_argument("--env-steps", type=int, default=None, help="env steps of part (c) (default 100,000)")
    ap.add_argument("--skip", default="", help="comma-separated parts to skip: map, tunnelling, env")
    args = ap.parse_args(argv)
    out = args.out or os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "docs")
    if args.quick and args.out is None:
        import tempfile

        out = os.path.join(tempfile.gettempdir(), "penalty_env_bench_quick")  # keep docs/ for the full run
    os.makedirs(out, exist_ok=True)
    skip = set(filter(None, args.skip.split(",")))
    t0 = time.perf_counter()
    failed = []
    if "map" not in skip:
        omega_dts = np.round(np.arange(0.1, 3.301, 0.1 if args.quick else 0.05), 4)
        zetas = np.round(np.arange(0.0, 1.0001, 0.1 if args.quick else 0.05), 4)
        rows, boundary = stability_map(omega_dts, zetas)
        with gzip.open(os.path.join(out, "stability.csv.gz"), "wt", newline="") as f:
            wr = csv.writer(f)
            wr.writerow(["integrator", "omega_dt", "zeta", "energy_growth"])
            wr.writerows((i, h, z, f"{g:.4g}") for i, h, z, g in rows)
        plot_map(rows, boundary, omega_dts, zetas, os.path.join(out, "stability_map.png"))
        print("(a) measured first growing omega0 dt vs theory (docs/physics.md section 4):")
        for integ in INTEGRATORS:
            parts = []
            for z in (0.0, 0.1, 0.3, 1.0):
                k = int(np.argmin(np.abs(zetas - z)))
                measured, expected = boundary[integ][k], theory.critical_omega_dt(integ, z)
                parts.append(f"zeta {z:g}: {measured:.3g} (theory {expected:.3g})")
                # the first growing omega0 dt of the grid sits within a grid step of the theory (or is
                # the grid's first point, where the theory lies below the grid: explicit Euler at zeta 0)
                step = omega_dts[1] - omega_dts[0]
                lowest = max(expected, float(omega_dts[0]))
                near = (measured == expected == math.inf) or (lowest - step <= measured <= lowest + 1.5 * step)
                if not near and expected < omega_dts[-1]:
                    failed.append(f"(a) {SHORT[integ]} at zeta {z:g}: {measured:.3g} against {expected:.3g}")
            print(f"    {SHORT[integ]:17s} " + "; ".join(parts))
    if "tunnelling" not in skip:
        omega = math.sqrt(TUN_KS / TUN_M)
        n = 12 if args.quick else 26
        dts = np.logspace(-3, 1, n) / omega
        speeds = np.logspace(-2, 2, n) * omega * TUN_R
        trows = tunnelling_map(speeds, dts)
        with gzip.open(os.path.join(out, "tunnelling.csv.gz"), "wt", newline="") as f:
            wr = csv.writer(f)
            wr.writerow(["integrator", "speed", "dt", "outcome", "max_overlap_over_r", "exit_energy_ratio"])
            wr.writerows((i, f"{s:.4g}", f"{dt:.4g}", o, f"{p:.4g}", f"{g:.4g}") for i, s, dt, o, p, g in trows)
        plot_tunnelling(trows, speeds, dts, os.path.join(out, "tunnelling.png"))
        print(
            "(b) tunnelling: smallest omega0 dt with an energy gain, at v / (omega0 r) = 0.1; "
            "smallest v / (omega0 r) passing through at omega0 dt = 0.01"
        )
        for integ in INTEGRATORS:
            gain = [
                dt * omega
                for i, s, dt, o, _, _ in trows
                if i == integ and o == 1 and abs(s / (omega * TUN_R) - 0.1) < 0.05
            ]
            thru = [s / (omega * TUN_R) for i, s, dt, o, _, _ in trows if i == integ and o == 2 and dt * omega < 0.012]
            print(
                f"    {SHORT[integ]:17s} energy gain from omega0 dt = {min(gain) if gain else float('nan'):.3g}; "
                f"passes through from v = {min(thru) if thru else float('nan'):.3g} omega0 r"
            )
    if "env" not in skip:
        n = args.env_steps or (5_000 if args.quick else 100_000)
        try:
            res = env_stress(n)
        except Exception as exc:  # the env is optional for the physics benchmarks
            print(f"(c) environment stress test could not run: {type(exc).__name__}: {exc}")
        else:
            print(
                f"(c) PenaltyBalls-v0, pusher at full throttle into the ball for {res['steps']:,} steps "
                f"({res['integrator']}, dt {res['dt']:.4g} s x {res['substeps']} substeps, {res['wall_s']:.1f} s): "
                f"worst overlap {res['worst_overlap']:.4f} r (tolerance {res['penetration_tolerance']:g} r); "
                f"energy {res['drive_energy_final']:.4f} J at the end of the drive (growth over the last fifth "
                f"{res['drive_energy_growth']:.2g}; checked from 50,000 steps), at most "
                f"{res['energy_beyond_motor_work']:.3g} J above the start plus the motor's work "
                f"({res['motor_work_bound']:.4g} J), then falls by {res['release_energy_drop']:.4f} J with the "
                f"throttle released (largest one-step rise {res['release_largest_rise']:.3g} J); NaN: {res['nan']}; "
                f"{'OK' if res['ok'] else 'FAILED'}"
            )
            if not res["ok"]:
                failed.append("(c) environment stress test")
    print(f"stability benchmark done in {time.perf_counter() - t0:.1f} s")
    if failed:
        print("FAILED: " + ", ".join(failed))
        raise SystemExit(1)


if __name__ == "__main__":
    main()

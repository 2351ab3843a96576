"""Case ``lammps_repose``: the 3D pile of ``repose3d`` filled and settled here, then lifted and
measured here and in LAMMPS from the same states. LAMMPS's input (``lammps_repose_script``, with
its ``rolling sds``), the settled state both codes start from (``PileState``, ``lammps_pile_fill``),
the lift in each code (``ours_pile``, ``lammps_pile``), one fill compared (``lammps_repose``), and
the case over the fills with its figure (``case_lammps_repose``, ``plot_lammps_repose``)."""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field

import numpy as np

from ...physics import World
from .grains import Contact, G
from .lammps_common import _frozen_type_2, _lammps, _run_lammps
from .output import _plt, _write_csv
from .pile import (
    REPOSE_3D_SETUP,
    Repose,
    ReposeFill,
    lift_steps,
    pile_top,
    profile_angle,
    repose_fill,
    repose_lift,
    repose_terrain,
    zhou_2002_model_a,
)

# ----------------------------------------------------------------------------------------------
# 5. LAMMPS on the same pile
# ----------------------------------------------------------------------------------------------

# The 3D pile of the table (REPOSE_3D_SETUP) at mu = 0.5, mu_r = 0.2, filled and settled here, then
# lifted and measured here and in LAMMPS from that same state; ``seeds`` the fills; ``more``: further
# (mu, mu_r, seeds).
LAMMPS_REPOSE = dict(mu=0.5, mu_r=0.2, seeds=(1, 2, 3, 4, 5, 6), settle_time=60.0, more=((0.5, 0.1, (1, 2)),))


def lammps_repose_script(
    ks: float,
    kd: float,
    kt: float,
    kd_t: float,
    mu: float,
    mu_r: float,
    m: float,
    R: float,
    z0: float,
    H: float,
    lift: float,
    t_lift: float,
    k_roll: float | None = None,
) -> str:
    """The LAMMPS input of the pile (after ``read_data``: the pile's grains of type 1, the base's of
    type 2; before ``neighbor``/``timestep``/``run``). The normal and tangential law as in
    ``lammps_silo_script`` (Hooke, ``damping mass_velocity``, ``tangential linear_history``: our ks,
    kd, kt, kd_t), the base's grains frozen as the silo's rim is (gamma_n = kd / m against them);
    rolling resistance LAMMPS's ``rolling sds``, a spring-dashpot-slider on the rolling displacement
    whose force, capped at mu_r |F_n|, acts with the lever R* (r_i r_j / (r_i + r_j), r at the
    floor; inside the tube LAMMPS takes the region's radius as -2R, so R* = r 2R / (2R - r), 4%
    above ours at R = 6 d): model A's torque mu_r R* |f_n|, as ours; below it the torque is elastic (a spring
    k_roll, kt by default, and a dashpot gamma_roll = kd_t), where ours is viscous (kr |w_r|,
    kr = I_eff / dt).

    The floor a ``zplane`` wall; the tube a cylinder region of radius ``R`` from ``z0`` to ``H``,
    side in, caps open, moved up at ``lift`` for ``t_lift`` (then at rest) by ``region move``
    (``fix wall/gran/region`` takes the region's velocity into the contact); both with the law
    against the walls (m_eff = m). Gravity and ``nve/sphere`` on the pile's grains only."""
    ks, kd, kt, kd_t, mu, mu_r, m, R, z0, H, lift, t_lift = (
        float(v) for v in (ks, kd, kt, kd_t, mu, mu_r, m, R, z0, H, lift, t_lift)
    )
    kr = kt if k_roll is None else float(k_roll)

    def law(gamma_n: float) -> str:
        return (
            f"hooke {ks!r} {gamma_n!r} damping mass_velocity tangential linear_history {kt!r} {kd_t / kd!r} {mu!r} "
            f"rolling sds {kr!r} {kd_t!r} {mu_r!r}"
        )

    return (
        "\n"
        + _frozen_type_2("base", law, kd, m)
        + f"""variable dz equal ternary(time<{t_lift!r},{lift!r}*time,{lift * t_lift!r})
region tube cylinder z 0.0 0.0 {R!r} {z0!r} {H!r} side in open 1 open 2 move NULL NULL v_dz units box
fix floor grains wall/gran granular {law(kd / m)} zplane 0.0 NULL
fix tube grains wall/gran/region granular {law(kd / m)} region tube
fix grav grains gravity {G!r} vector 0.0 0.0 -1.0
fix int grains nve/sphere
compute ke grains ke
thermo_style custom step time c_ke
"""
    )


@dataclass
class PileState:
    """A filled and settled tube (``repose_fill``), before the lift: what both codes need."""

    seed: int
    x: np.ndarray = field(repr=False)  # every grain, the pile's n first, then the base's
    v: np.ndarray = field(repr=False)
    w: np.ndarray = field(repr=False)
    radii: np.ndarray = field(repr=False)
    masses: np.ndarray = field(repr=False)
    n: int
    mu: float
    mu_r: float
    z0: float
    R: float
    half: float
    wall_t: float
    contact: Contact
    dt: float
    kt: float
    kd_t: float
    kr: float
    lift: float  # the lift speed, and its steps (until the rim is 1 d above the grains)
    lift_steps: int


def lammps_pile_fill(seed: int, mu: float, mu_r: float) -> PileState:
    """Fill and settle the table's tube (REPOSE_3D_SETUP) here (``repose_fill``)."""
    cfg = REPOSE_3D_SETUP
    f = repose_fill(3, mu, mu_r, int(cfg["n"]), float(cfg["tube_radius"]), seed, base=str(cfg["base"]))
    w, n = f.world, f.n
    top = pile_top(w, n)
    lift = float(cfg["lift_speed"])
    return PileState(
        seed,
        w.positions.copy(),
        w.velocities.copy(),
        w.angular_velocities.copy(),
        w.radii.copy(),
        w.masses.copy(),
        n,
        mu,
        mu_r,
        f.z0,
        f.R,
        f.half,
        f.wall_t,
        f.contact,
        w.dt,
        w.kt,
        w.kd_t,
        w.kr,
        lift,
        lift_steps(top, f.z0, lift, w.dt),
    )


def ours_pile(s: PileState, settle_time: float) -> tuple[Repose, str]:
    """Lift and measure ``s`` in a fresh World, with ``repose_lift``: ``repose``'s lift, but without
    the fill's contact history (as LAMMPS starts), so another realisation of ``repose``'s pile.
    Returns the pile and the World's stepping path (``auto``'s choice: the neighbour list for a
    pile of this size)."""
    tick = time.time()
    terrain = repose_terrain(3, s.R, s.half, s.wall_t, s.z0)
    spin = dict(rotation=True, tangential="history", mu=s.mu, mu_r=s.mu_r, kt=s.kt, kd_t=s.kd_t, kr=s.kr)
    common = dict(terrain=terrain, ks=s.contact.ks, kd=s.contact.kd, broadphase="grid", **spin)
    w = World(s.x, s.radii, s.masses, s.v, dt=s.dt, gravity=(0.0, 0.0, -G), **common)
    w.angular_velocities = s.w
    held = np.arange(len(s.x)) >= s.n
    fill = ReposeFill(w, s.n, s.mu, s.mu_r, held, s.z0, s.R, s.half, s.wall_t, s.contact)
    return repose_lift(fill, s.lift, settle_time, tick, "grains"), w.stepping


def lammps_pile(s: PileState, settle_time: float, lmp=None, k_roll: float | None = None) -> tuple:
    """Lift ``s``'s tube in LAMMPS (``lammps_repose_script``; the same state, no contact history,
    the same dt and lift), settle for chunks of 2 time units (733 steps; ``_settle_held`` takes 720)
    until the translational kinetic energy per grain is below 1e-6 m g d (``_settle_held``'s
    criterion; at most ``settle_time``). Returns (the pile's grains'
    positions, seconds, LAMMPS's version)."""
    import tempfile

    from ..peer_lammps import _data_file

    lmp = _lammps(lmp)
    m = float(s.masses[0])
    if not np.all(s.masses == m):
        raise ValueError("the LAMMPS pile takes grains of one mass (one gamma_n per type pair)")
    n, k = s.n, len(s.x) - s.n
    reach = float(np.abs(s.x[:, :2]).max()) + 30.0
    H = s.z0 + 2.0 * s.half
    chunk = int(round(2.0 / s.dt))
    tol = 1e-6 * n * m * G * 2.0 * float(s.radii[:n].mean())
    tick = time.time()
    with tempfile.TemporaryDirectory(prefix="penalty_env-pile-") as tmp:
        _data_file(
            os.path.join(tmp, "state.data"),
            s.x,
            s.v,
            s.radii,
            s.masses,
            [-reach, -reach, -2.0],
            [reach, reach, H + s.lift * s.lift_steps * s.dt + 10.0],
            s.w,
            types=[1] * n + [2] * k,
        )
        script = "units si\natom_style sphere\natom_modify map array\nboundary f f f\ncomm_modify vel yes\n"
        script += "read_data state.data\n"
        script += lammps_repose_script(
            s.contact.ks, s.contact.kd, s.kt, s.kd_t, s.mu, s.mu_r, m, s.R, s.z0, H, s.lift, s.lift_steps * s.dt, k_roll
        )
        script += f"neighbor {0.2!r} bin\nneigh_modify delay 0 every 1 check yes\ntimestep {s.dt!r}\n"
        script += f"thermo {chunk}\nrun {s.lift_steps}\n"
        script += f"variable b loop {int(settle_time / 2.0)}\nlabel block\n"
        script += f'run {chunk} pre no post no\nif "$(c_ke) < {tol!r}" then "jump SELF done"\n'
        script += "next b\njump SELF block\nlabel done\n"
        script += "write_dump grains custom final.txt id x y z modify sort id format float %.17g\n"
        _run_lammps(lmp, tmp, script)
        final = np.loadtxt(os.path.join(tmp, "final.txt"), skiprows=9, ndmin=2)
    return final[:, 1:4], time.time() - tick, lmp.version


def lammps_repose(seed: int, mu: float | None = None, mu_r: float | None = None, lmp=None, soft: bool = False) -> dict:
    """One fill of the table's pile, settled here, lifted and measured by a World and by LAMMPS from
    that same state: the two angles (``profile_angle``), heights and profiles. ``soft``: LAMMPS
    once more with a rolling spring ten times softer (k_roll = kt / 10), the sensitivity of the
    angle to the rolling law below its cap."""
    cfg = LAMMPS_REPOSE
    mu = float(cfg["mu"] if mu is None else mu)
    mu_r = float(cfg["mu_r"] if mu_r is None else mu_r)
    s = lammps_pile_fill(seed, mu, mu_r)
    ours, stepping = ours_pile(s, float(cfg["settle_time"]))
    radii = s.radii[: s.n]
    out = dict(seed=seed, mu=mu, mu_r=mu_r, n=s.n, base=len(s.x) - s.n, dt=s.dt, stepping=stepping)
    out.update(angle=ours.angle, height=ours.height, profile=ours.profile, seconds=ours.seconds, x=ours.x)
    for tag, k_roll in (("lammps", None), ("lammps_soft", s.kt / 10.0))[: 2 if soft else 1]:
        x, seconds, version = lammps_pile(s, float(cfg["settle_time"]), lmp, k_roll)
        angle, prof, _ = profile_angle(x, radii, np.zeros(2), 3)
        out.update({f"angle_{tag}": angle, f"height_{tag}": float(np.max(prof[1])) - s.z0})
        out.update({f"profile_{tag}": prof, f"seconds_{tag}": seconds, f"x_{tag}": x, "version": version})
    return out


def _lammps_repose_job(args: tuple) -> dict:
    seed, mu, mu_r, soft = args
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return lammps_repose(seed, mu, mu_r, soft=soft)


def case_lammps_repose(out: str) -> dict:
    """LAMMPS_REPOSE's fills, two at a time (each single-threaded: minutes): the angles of both
    codes as CSV (one row per pile) and their profiles' figure."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    cfg = LAMMPS_REPOSE
    jobs = [(seed, cfg["mu"], cfg["mu_r"], True) for seed in cfg["seeds"]]
    jobs += [(seed, mu, mu_r, False) for mu, mu_r, seeds in cfg["more"] for seed in seeds]
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as pool:
        runs = list(pool.map(_lammps_repose_job, jobs))
    _write_csv(
        os.path.join(out, "granular_lammps_repose.csv"),
        ["seed", "mu", "mu_r", "n", "base_grains", "dt", "angle_ours", "angle_lammps", "angle_lammps_soft_roll"]
        + ["height_ours", "height_lammps", "seconds_ours", "seconds_lammps", "zhou2002_deg_d10mm", "zhou2002_deg_d1mm"]
        + ["stepping_ours"],
        [
            (r["seed"], r["mu"], r["mu_r"], r["n"], r["base"], r["dt"], r["angle"], r["angle_lammps"])
            + (r.get("angle_lammps_soft", float("nan")), r["height"], r["height_lammps"], r["seconds"])
            + (
                r["seconds_lammps"],
                zhou_2002_model_a(r["mu"], r["mu_r"], 10.0),
                zhou_2002_model_a(r["mu"], r["mu_r"], 1.0),
                r["stepping"],
            )
            for r in runs
        ],
    )
    plot_lammps_repose(runs, out)
    summary: dict = {}
    for mu_r in sorted({r["mu_r"] for r in runs}, reverse=True):
        sel = [r for r in runs if r["mu_r"] == mu_r]
        ours = np.array([r["angle"] for r in sel])
        theirs = np.array([r["angle_lammps"] for r in sel])
        key = f"lammps_repose mu_r={mu_r}"
        summary[key + " angles ours"] = tuple(round(float(a), 2) for a in ours)
        summary[key + " angles LAMMPS"] = tuple(round(float(a), 2) for a in theirs)
        if "angle_lammps_soft" in sel[0]:
            soft = tuple(round(float(r["angle_lammps_soft"]), 2) for r in sel)
            summary[key + " angles LAMMPS, k_roll = kt / 10"] = soft
        summary[key + " means ours, LAMMPS"] = (round(float(ours.mean()), 2), round(float(theirs.mean()), 2))
        summary[key + " Zhou 2002 (d 10 mm, 1 mm)"] = (
            round(zhou_2002_model_a(sel[0]["mu"], mu_r, 10.0), 1),
            round(zhou_2002_model_a(sel[0]["mu"], mu_r, 1.0), 1),
        )
    summary["lammps_repose seconds ours, LAMMPS (mean)"] = (
        round(float(np.mean([r["seconds"] for r in runs]))),
        round(float(np.mean([r["seconds_lammps"] for r in runs]))),
    )
    summary["lammps_repose version"] = runs[0]["version"]
    summary["lammps_repose our stepping path"] = sorted({r["stepping"] for r in runs})
    return summary


def plot_lammps_repose(runs: list[dict], out: str) -> None:
    """Left: the first fill's surface profile in both codes (and LAMMPS with the softer rolling
    spring); right: every fill's angle in both codes against Zhou et al.'s range."""
    plt = _plt()
    fig, (ax, right) = plt.subplots(1, 2, figsize=(13, 4.8))
    cfg = LAMMPS_REPOSE
    first = next(r for r in runs if r["mu_r"] == cfg["mu_r"])
    for key, label in (
        ("profile", "penalty_env"),
        ("profile_lammps", "LAMMPS"),
        ("profile_lammps_soft", "LAMMPS, k_roll = kt/10"),
    ):
        if key in first:
            rho, h = first[key]
            angle = first["angle" + key[len("profile") :]]
            ax.plot(rho, h, "o-", ms=3, label=f"{label}: {angle:.1f} deg")
    ax.set_xlim(0.0, 20.0)
    ax.set_xlabel("distance from the axis / d")
    ax.set_ylabel("surface height / d")
    ax.set_title(f"fill {first['seed']}, mu = {first['mu']}, mu_r = {first['mu_r']}: profiles")
    ax.legend(fontsize=8)
    for mu_r, marker in ((cfg["mu_r"], "o"),) + tuple((m[1], "s") for m in cfg["more"]):
        sel = [r for r in runs if r["mu_r"] == mu_r]
        seeds = [r["seed"] for r in sel]
        right.plot(seeds, [r["angle"] for r in sel], marker, color="C0", label=f"penalty_env, mu_r = {mu_r}")
        right.plot(
            seeds, [r["angle_lammps"] for r in sel], marker, color="C1", mfc="none", label=f"LAMMPS, mu_r = {mu_r}"
        )
        lo, hi = zhou_2002_model_a(sel[0]["mu"], mu_r, 10.0), zhou_2002_model_a(sel[0]["mu"], mu_r, 1.0)
        right.axhspan(lo, hi, color="0.85", zorder=0)
        right.text(0.5, lo + 0.05, f"Zhou et al. 2002, mu_r = {mu_r}", fontsize=7, va="bottom")
    right.set_xlim(0.3, max(r["seed"] for r in runs) + 0.7)
    right.set_xlabel("fill (seed)")
    right.set_ylabel("angle of repose (degrees)")
    right.set_title("the same states in both codes; grey: Zhou et al.'s range (walled heaps)")
    right.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "granular_lammps_repose.png"), dpi=110)
    plt.close(fig)

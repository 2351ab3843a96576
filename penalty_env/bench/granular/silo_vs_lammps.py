"""Case ``lammps``: a 3D silo discharged here and in LAMMPS from the same settled states. Its
geometry (the floor plate, the orifice's rim of spheres: ``rim_centres``, ``lammps_silo_terrain``),
LAMMPS's input (``lammps_silo_script``), the fill (``lammps_silo_fill``), the discharge in each code
(``ours_silo_discharge``, ``lammps_silo_discharge``), the comparison over fills and replicas
(``lammps_silo``, ``lammps_compare``) and its figure and case (``plot_lammps``, ``case_lammps``)."""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, field, replace

import numpy as np

from ...physics import Box, Cylinder, Difference, Plane, Sphere, World
from .beverloo import discharge_rate, silo_scene
from .grains import Contact, G, make_world, settle, spin_kwargs
from .lammps_common import _frozen_type_2, _lammps, _run_lammps
from .output import _plt, _write_csv

# ----------------------------------------------------------------------------------------------
# 4. LAMMPS on the same silo
# ----------------------------------------------------------------------------------------------

# The silo of the cross-check: ``n`` grains before the round fill keeps those inside the wall (1106
# at seed 2), ``plate`` the floor plate's thickness, the rim ``rim_radius`` spheres at most
# ``rim_spacing`` apart, D the clear opening between them; ``seeds`` the fills run by case_lammps.
LAMMPS_SILO = dict(
    n=1500,
    width=10.0,
    D=5.0,
    mu=0.5,
    catch=20.0,
    sample=0.5,
    out_fraction=0.65,
    plate=0.2,
    rim_radius=0.5,
    rim_spacing=0.25,
    seeds=(2, 3, 4, 5),
)


def rim_centres(D: float, plate: float, rim_radius: float, spacing: float) -> np.ndarray:
    """The orifice's rim: spheres of ``rim_radius`` on a ring in the plate's mid-plane (z = -plate / 2)
    of radius a = D / 2 + rim_radius (the plate's hole), so that the clear opening between their
    inner surfaces is D; evenly spaced, at most ``spacing`` apart along the ring."""
    a = D / 2 + rim_radius
    k = int(math.ceil(2.0 * math.pi * a / spacing))
    phi = 2.0 * math.pi * np.arange(k) / k
    return np.stack([a * np.cos(phi), a * np.sin(phi), np.full(k, -plate / 2)], axis=-1)


def lammps_silo_terrain(
    width: float, D: float, height: float, catch: float, plate: float, rim_radius: float, rim: np.ndarray
) -> list:
    """Our side of the cross-check's silo (``lammps_silo_script`` is LAMMPS's): the floor plate, z in
    [-plate, 0] with a hole of radius a = D / 2 + rim_radius (Difference(Box, Cylinder)); the
    cylindrical shell of ``silo_terrain``; a plane closing the floor while the silo fills (index 2;
    left out to open it); the catch plane ``catch`` below; then the rim, a static ``Sphere`` of
    ``rim_radius`` at each of ``rim`` (rim_centres), which covers the hole's edges: the grains
    never reach the places where Difference is a bound (tests/bench/test_lammps_silo.py checks it).

    The hole's cylinder reaches 2 d past both faces of the plate. Difference is max(phi_plate,
    -phi_hole), and -phi_hole is the distance to the hole's nearest face, its caps included: with a
    cap less than a grain radius r past the plate's face (``silo_terrain``'s reaches 0.5 d past the
    top), a grain over the hole with its centre within r of the plate's plane touches a phantom
    plate (phi = its height, normal up) and stays there: measured with the cap 0.9 d above the
    plate, the discharge stopped after 33 grains."""
    R, a = width / 2, D / 2 + rim_radius
    half = height / 2
    c = [0.0, 0.0, half]
    up = [0.0, 0.0, 1.0]
    return [
        Difference(
            Box([0.0, 0.0, -plate / 2], [R + 2.0, R + 2.0, plate / 2]), Cylinder([0, 0, -plate / 2], a, plate / 2 + 2.0)
        ),
        Difference(Cylinder(c, R + 1.0, half), Cylinder(c, R, half + 1.0)),
        Plane([0.0, 0.0, 0.0], up),
        Plane([0.0, 0.0, -catch], up),
    ] + [Sphere(p, rim_radius) for p in rim]


def lammps_silo_script(
    ks: float,
    kd: float,
    kt: float,
    kd_t: float,
    mu: float,
    m: float,
    R: float,
    H: float,
    catch: float,
    plate: float,
    a: float,
    n: int,
) -> str:
    """The LAMMPS input of the silo of ``n`` grains (after ``read_data``: the grains of type 1, the
    rim's spheres of type 2; before ``neighbor``/``timestep``/``run``). Every contact is Hooke with damping
    m_eff gamma_n v_n (``damping mass_velocity``) and a linear tangential spring with history
    (``tangential linear_history``: Kt, the dashpot x_gamma,t m_eff gamma_n, the cap mu |F_n|), as
    our ``tangential="history"``; the grains turn (``fix nve/sphere``):

    - grain-grain: ``pair_style granular``, gamma_n = kd / (m / 2) (m_eff = m / 2: our kd),
      x_gamma,t = kd_t / kd (our kd_t);
    - grain-rim: the rim's spheres are atoms excluded from the time integration (``fix nve/sphere``
      on the grains only) and frozen (``fix freeze``: the granular pair styles then take m_eff = the
      mobile grain's mass), so gamma_n = kd / m and x_gamma,t = kd_t / kd give our ball-terrain
      dashpot kd_terrain = kd and tangential dashpot kd_t (a per-type ``pair_coeff``:
      ``gran/hooke/history`` has one gamma_n for all pairs, which would double both at the rim);
    - the plate: ``fix wall/gran/region`` (the same law in its granular form, m_eff = m) on the
      free space around it, the union of the half-spaces above (z > 0) and below (z < -plate) the
      plate and the hole (a closed cylinder of radius a reaching past both faces: LAMMPS's union
      drops a contact whose point lies inside another of its regions, so the hole's caps give none
      and the planes give none over the hole); LAMMPS's regions have faces but no edges, which is
      why the rim covers the hole's edges;
    - the silo's wall: a cylinder region of radius R from the floor to H, side in, caps open;
    - the catch floor: ``fix wall/gran ... zplane`` at -catch.

    Gravity acts on the grains only. Discharged grains that roll off the catch floor out of the
    box (60 d from the axis; they roll on without rolling resistance) are dropped (``thermo_modify
    lost ignore``): ``nout`` counts the grains 3 d below the floor, those included."""
    ks, kd, kt, kd_t, mu, m, R, H, catch, plate, a = (
        float(v) for v in (ks, kd, kt, kd_t, mu, m, R, H, catch, plate, a)
    )

    def law(gamma_n: float) -> str:
        return f"hooke {ks!r} {gamma_n!r} damping mass_velocity tangential linear_history {kt!r} {kd_t / kd!r} {mu!r}"

    return (
        "\n"
        + _frozen_type_2("rim", law, kd, m)
        + f"""region above plane 0.0 0.0 0.0 0.0 0.0 1.0 side in
region below plane 0.0 0.0 {-plate!r} 0.0 0.0 -1.0 side in
region hole cylinder z 0.0 0.0 {a!r} {-plate - 2.0!r} 2.0 side in
region free union 3 above below hole
region shell cylinder z 0.0 0.0 {R!r} 0.0 {H!r} side in open 1 open 2
fix floor grains wall/gran/region granular {law(kd / m)} region free
fix shell grains wall/gran/region granular {law(kd / m)} region shell
fix catch grains wall/gran granular {law(kd / m)} zplane {-catch!r} NULL
fix grav grains gravity {G!r} vector 0.0 0.0 -1.0
fix int grains nve/sphere
region gone block INF INF INF INF INF -3.0
variable nout equal count(grains,gone)+{n}-count(grains)
thermo_modify lost ignore
"""
    )


@dataclass
class SiloState:
    """The settled silo of the cross-check, closed, and what both codes need to discharge it."""

    seed: int
    x: np.ndarray = field(repr=False)  # (n, 3) grain positions, velocities, angular velocities
    v: np.ndarray = field(repr=False)
    w: np.ndarray = field(repr=False)
    radii: np.ndarray = field(repr=False)
    masses: np.ndarray = field(repr=False)
    contact: Contact
    dt: float
    H: float  # the wall's height
    rim: np.ndarray = field(repr=False)  # (k, 3) the rim's sphere centres
    kt: float = 0.0  # the World's tangential spring and dashpot (its defaults: 2/7 ks, kd / 2)
    kd_t: float = 0.0


def lammps_silo_fill(seed: int = 2) -> SiloState:
    """Fill the cross-check's silo (LAMMPS_SILO) with its orifice closed and settle it, here."""
    cfg = LAMMPS_SILO
    width, D, catch, plate, rr = cfg["width"], cfg["D"], cfg["catch"], cfg["plate"], cfg["rim_radius"]
    x, radii, masses, contact, h0 = silo_scene(3, int(cfg["n"]), width, seed)
    x[:, 2] += rr + plate  # clear of the rim, which stands rim_radius - plate / 2 above the plate
    h0 += rr + plate
    H = h0 + 4.0
    rim = rim_centres(D, plate, rr, cfg["rim_spacing"])
    terrain = lammps_silo_terrain(width, D, H, catch, plate, rr, rim)
    w = make_world(x, radii, masses, contact, terrain, **spin_kwargs(3, cfg["mu"]))
    w.step(int(round((2.0 * math.sqrt(2.0 * h0) + 5.0) / w.dt)))
    settle(w, 60.0, tol=1e-6, chunk=2.0, drag=0.02)
    return SiloState(
        seed,
        w.positions.copy(),
        w.velocities.copy(),
        w.angular_velocities.copy(),
        radii,
        masses,
        contact,
        w.dt,
        H,
        rim,
        w.kt,
        w.kd_t,
    )


def ours_silo_discharge(s: SiloState, verbose: bool = False) -> tuple:
    """Discharge ``s`` in a fresh World (no contact history, the closing plane left out): the
    discharged count every ``sample`` until ``out_fraction`` of the grains are out (or 400 time
    units, or none has left for 20: clogged). Returns (t, counts, seconds)."""
    cfg = LAMMPS_SILO
    n = len(s.x)
    ours = ours_silo_world(s)
    steps = int(round(cfg["sample"] / s.dt))
    counts = [0]
    gone = np.zeros(n, dtype=bool)
    tick = time.time()
    while counts[-1] < cfg["out_fraction"] * n and len(counts) * steps * s.dt < 400.0:
        ours.step(steps)
        gone |= ours.positions[:, 2] < -3.0
        counts.append(int(gone.sum()))
        clog = int(round(20.0 / (steps * s.dt)))  # nothing out for 20 time units: clogged
        if len(counts) > clog and counts[-1] == counts[-1 - clog]:
            break
        if verbose and len(counts) % 20 == 0:
            print(
                f"  ours t={len(counts) * steps * s.dt:.0f}: {counts[-1]} out ({time.time() - tick:.0f} s)", flush=True
            )
    t = np.arange(len(counts)) * steps * s.dt
    return t, np.array(counts), time.time() - tick


def _lammps_silo_input(s: SiloState, tmp: str) -> str:
    """Write ``s`` (the grains as type 1, the rim's spheres as type 2) to ``tmp``/state.data and
    return the input up to the time step (``lammps_silo_script`` and a neighbour skin of 0.2 d
    rebuilt on need)."""
    from ..peer_lammps import _data_file

    cfg = LAMMPS_SILO
    n, k = len(s.x), len(s.rim)
    width, catch, plate, rr = cfg["width"], cfg["catch"], cfg["plate"], cfg["rim_radius"]
    m = float(s.masses[0])
    if not np.all(s.masses == m):
        raise ValueError("the LAMMPS silo takes grains of one mass (one gamma_n per type pair)")
    x = np.concatenate([s.x, s.rim])
    v = np.concatenate([s.v, np.zeros((k, 3))])
    w = np.concatenate([s.w, np.zeros((k, 3))])
    radii = np.concatenate([s.radii, np.full(k, rr)])
    masses = np.concatenate([s.masses, np.full(k, m * (rr / float(s.radii[0])) ** 3)])
    lo = [-width / 2 - 60.0, -width / 2 - 60.0, -catch - 2.0]
    hi = [width / 2 + 60.0, width / 2 + 60.0, s.H + 10.0]
    _data_file(os.path.join(tmp, "state.data"), x, v, radii, masses, lo, hi, w, types=[1] * n + [2] * k)
    script = "units si\natom_style sphere\natom_modify map array\nboundary f f f\ncomm_modify vel yes\n"
    script += "read_data state.data\n"
    script += lammps_silo_script(
        s.contact.ks, s.contact.kd, s.kt, s.kd_t, cfg["mu"], m, width / 2, s.H, catch, plate, cfg["D"] / 2 + rr, n
    )
    return script + f"neighbor {0.2!r} bin\nneigh_modify delay 0 every 1 check yes\ntimestep {s.dt!r}\n"


def lammps_silo_discharge(s: SiloState, lmp=None) -> tuple:
    """Discharge ``s`` in LAMMPS (``lammps_silo_script``; the grains' positions, velocities and
    spins, no contact history; the same dt): the count every ``sample`` until ``out_fraction`` are
    out (or 400 time units). Returns (t, counts, seconds, LAMMPS's version)."""
    import tempfile

    cfg = LAMMPS_SILO
    lmp = _lammps(lmp)
    steps = int(round(cfg["sample"] / s.dt))
    target = int(math.ceil(cfg["out_fraction"] * len(s.x)))
    tick = time.time()
    with tempfile.TemporaryDirectory(prefix="penalty_env-silo-") as tmp:
        script = _lammps_silo_input(s, tmp)
        script += f"fix series all ave/time {steps} 1 {steps} v_nout file series.txt\nthermo {steps * 1000}\n"
        # blocks of ``sample`` until the target is out (at most 400 time units)
        script += f"run {steps}\nvariable b loop {int(400.0 / (steps * s.dt))}\nlabel block\n"
        script += f'run {steps} pre no post no\nif "${{nout}} >= {target}" then "jump SELF done"\n'
        script += "next b\njump SELF block\nlabel done\n"
        _run_lammps(lmp, tmp, script)
        rows = np.loadtxt(os.path.join(tmp, "series.txt"), comments="#", ndmin=2)
    t = np.concatenate([[0.0], rows[:, 0] * s.dt])
    counts = np.concatenate([[0], rows[:, 1]]).astype(int)
    return t, counts, time.time() - tick, lmp.version


def lammps_silo_final(s: SiloState, steps: int, lmp=None) -> tuple:
    """Run ``s`` ``steps`` steps in LAMMPS (``lammps_silo_script``): the grains' final positions,
    velocities and angular velocities."""
    import tempfile

    lmp = _lammps(lmp)
    with tempfile.TemporaryDirectory(prefix="penalty_env-silo-") as tmp:
        script = _lammps_silo_input(s, tmp) + f"thermo {int(steps)}\nrun {int(steps)}\n"
        script += "write_dump grains custom final.txt id x y z vx vy vz omegax omegay omegaz "
        script += "modify sort id format float %.17g\n"
        _run_lammps(lmp, tmp, script)
        final = np.loadtxt(os.path.join(tmp, "final.txt"), skiprows=9, ndmin=2)
    return final[:, 1:4], final[:, 4:7], final[:, 7:10]


def ours_silo_world(s: SiloState) -> World:
    """A fresh World of ``s`` (no contact history), the closing plane left out."""
    cfg = LAMMPS_SILO
    terrain = lammps_silo_terrain(cfg["width"], cfg["D"], s.H, cfg["catch"], cfg["plate"], cfg["rim_radius"], s.rim)
    terrain = [t for k, t in enumerate(terrain) if k != 2]
    spin = spin_kwargs(3, cfg["mu"]) | dict(kt=s.kt, kd_t=s.kd_t)
    common = dict(terrain=terrain, ks=s.contact.ks, kd=s.contact.kd, broadphase="grid", **spin)
    # gravity g = 1, as make_world gives it (the World's default is -9.81)
    ours = World(s.x, s.radii, s.masses, s.v, dt=s.dt, gravity=(0.0, 0.0, -G), **common)
    ours.angular_velocities = s.w
    return ours


def perturbed(s: SiloState, k: int, size: float = 1e-9) -> SiloState:
    """``s`` with every grain moved by a random displacement of about ``size`` d (k = 0: ``s``
    itself): a replica for the run-to-run scatter (the discharge is chaotic, so a change at
    round-off level gives another realisation of the same flow)."""
    if k == 0:
        return s
    shift = np.random.default_rng(1000 + k).normal(0.0, size, s.x.shape)
    return replace(s, x=s.x + shift)


def lammps_silo(seed: int = 2, replicas: int = 0, verbose: bool = True, lmp=None) -> dict:
    """One fill (``seed``) of the cross-check's silo, settled here, then discharged from that same
    state by a World and by LAMMPS (and from ``replicas`` more copies of it, each perturbed at
    1e-9 d, in both codes); the discharged counts every ``sample`` and the rates over the middle of
    the discharge (``discharge_rate``: 20% to 60% out), in grains per sqrt(d / g), one per run."""
    s0 = lammps_silo_fill(seed)
    n = len(s0.x)
    out: dict = dict(seed=seed, n=n, rim=len(s0.rim), dt=s0.dt, ks=s0.contact.ks, kd=s0.contact.kd)
    out.update(curves=[], curves_lammps=[], rates=[], rates_lammps=[], seconds=[], seconds_lammps=[])
    for k in range(replicas + 1):
        s = perturbed(s0, k)
        t, counts, t_ours = ours_silo_discharge(s, verbose)
        lt, lc, t_lammps, version = lammps_silo_discharge(s, lmp)
        rate = discharge_rate(t, counts.astype(float), float(n))[0]
        rate_lmp = discharge_rate(lt, lc.astype(float), float(n))[0]
        out["curves"].append((t, counts))
        out["curves_lammps"].append((lt, lc))
        out["rates"].append(rate)
        out["rates_lammps"].append(rate_lmp)
        out["seconds"].append(t_ours)
        out["seconds_lammps"].append(t_lammps)
        out["version"] = version
        if verbose:
            print(
                f"  seed {seed} replica {k}: {n} grains, W ours {rate:.3f}, LAMMPS {rate_lmp:.3f} grains / sqrt(d/g)"
                f" (ratio {rate / rate_lmp:.3f}); ours {t_ours:.0f} s, LAMMPS {t_lammps:.0f} s ({version})",
                flush=True,
            )
    return out


def lammps_compare(runs: list[dict]) -> dict:
    """The cross-check's numbers from ``lammps_silo`` runs: per fill the ratio ours / LAMMPS of the
    unperturbed runs; their mean and its standard error (the fills' ratios scatter by the two codes'
    run-to-run noise, which is the same whatever the model difference); the replicas' relative
    scatter per code (the noise of one run); and the ratio of all our runs' mean rate to all of
    LAMMPS's."""
    ratios = np.array([r["rates"][0] / r["rates_lammps"][0] for r in runs])
    ours = np.concatenate([r["rates"] for r in runs])
    theirs = np.concatenate([r["rates_lammps"] for r in runs])
    spread = [
        float(np.std(r[key], ddof=1) / np.mean(r[key]))
        for key in ("rates", "rates_lammps")
        for r in runs
        if len(r[key]) > 1
    ]
    se = float(np.std(ratios, ddof=1) / math.sqrt(len(ratios))) if len(ratios) > 1 else float("nan")
    return dict(
        ratios=ratios,
        mean_ratio=float(ratios.mean()),
        se_ratio=se,
        pooled_ratio=float(ours.mean() / theirs.mean()),
        replica_spread=float(np.sqrt(np.mean(np.square(spread)))) if spread else float("nan"),
    )


def plot_lammps(runs: list[dict], cmp: dict, out: str) -> None:
    """docs/granular_lammps.png: the discharge curves of every run, and the rates per fill."""
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    for i, r in enumerate(runs):
        color = f"C{i}"
        for k in range(len(r["curves"])):
            lw = 1.5 if k == 0 else 0.6
            (t, c), (lt, lc) = r["curves"][k], r["curves_lammps"][k]
            label = f"fill {r['seed']}: penalty_env (solid), LAMMPS (dashed)" if k == 0 else None
            axes[0].plot(t, c, "-", color=color, lw=lw, label=label)
            axes[0].plot(lt, lc, "--", color=color, lw=lw)
    n = runs[0]["n"]
    sizes = sorted({r["n"] for r in runs})
    axes[0].axhspan(0.2 * n, 0.6 * n, color="0.9", label="fitted span (20% to 60% out)")
    axes[0].set_xlabel("t / sqrt(d/g)")
    axes[0].set_ylabel("discharged grains")
    axes[0].legend(fontsize=7)
    axes[0].set_title("discharge from the same states (thin: replicas perturbed at 1e-9 d)")
    for i, r in enumerate(runs):
        k = np.arange(len(r["rates"]))
        axes[1].plot(i - 0.08 + 0.03 * k, r["rates"], "o", color="C0", ms=7, alpha=0.9)
        axes[1].plot(i + 0.08 + 0.03 * k, r["rates_lammps"], "s", color="C3", ms=7, alpha=0.9)
    axes[1].plot([], [], "o", color="C0", label="penalty_env")
    axes[1].plot([], [], "s", color="C3", label="LAMMPS")
    axes[1].set_xticks(range(len(runs)), [f"fill {r['seed']}" for r in runs])
    axes[1].set_ylabel("W / (grains / sqrt(d/g))")
    axes[1].set_title(
        f"ours / LAMMPS = {cmp['mean_ratio']:.3f} +- {cmp['se_ratio']:.3f} (mean of fills +- s.e.)", fontsize=10
    )
    axes[1].legend(fontsize=8)
    grains = f"{sizes[0]}" if len(sizes) == 1 else f"{sizes[0]} to {sizes[-1]}"
    fig.suptitle(
        f"3D silo ({grains} spheres, 10 d wide, clear orifice {LAMMPS_SILO['D']:g} d between frozen rim spheres, "
        f"mu = {LAMMPS_SILO['mu']}): penalty_env and LAMMPS",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(os.path.join(out, "granular_lammps.png"), dpi=110)
    plt.close(fig)


def case_lammps(out: str, seeds=None, replicas: int = 2) -> dict:
    seeds = tuple(LAMMPS_SILO["seeds"] if seeds is None else seeds)
    runs = [lammps_silo(seed, replicas=replicas if i == 0 else 0) for i, seed in enumerate(seeds)]
    cmp = lammps_compare(runs)
    rows = []
    for r in runs:
        for code, key, rates in (("penalty_env", "curves", "rates"), ("lammps", "curves_lammps", "rates_lammps")):
            for k, (t, c) in enumerate(r[key]):
                rows += [(code, r["seed"], k, r[rates][k], a, int(b)) for a, b in zip(t, c, strict=True)]
    _write_csv(
        os.path.join(out, "granular_lammps.csv"),
        ["code", "seed", "replica", "rate", "t", "discharged_grains"],
        rows,
    )
    plot_lammps(runs, cmp, out)
    summary = {
        f"lammps fill {r['seed']} W ours, LAMMPS": (round(r["rates"][0], 3), round(r["rates_lammps"][0], 3))
        for r in runs
    }
    if replicas:
        summary["lammps fill replicas W ours"] = tuple(round(v, 3) for v in runs[0]["rates"])
        summary["lammps fill replicas W LAMMPS"] = tuple(round(v, 3) for v in runs[0]["rates_lammps"])
    return summary | {
        "lammps ratios ours / LAMMPS": tuple(round(float(v), 4) for v in cmp["ratios"]),
        "lammps mean ratio +- s.e.": (round(cmp["mean_ratio"], 4), round(cmp["se_ratio"], 4)),
        "lammps pooled ratio (all runs)": round(cmp["pooled_ratio"], 4),
        "lammps replica spread (one run, relative)": round(cmp["replica_spread"], 4),
        "lammps seconds ours, LAMMPS (mean per run)": (
            round(float(np.mean([s for r in runs for s in r["seconds"]]))),
            round(float(np.mean([s for r in runs for s in r["seconds_lammps"]]))),
        ),
        "lammps grains, rim spheres, dt": (runs[0]["n"], runs[0]["rim"], round(runs[0]["dt"], 6)),
        "lammps version": runs[0]["version"],
    }

"""Cases ``repose2d``/``repose3d``: a pile released by lifting a tube, its angle of repose from the
surface profile (``profile_angle``); the fill and the lift (``repose_fill``, ``repose_lift``, which
the LAMMPS cross-check of the pile reuses), grains held at rest on the base, Zhou et al.'s (2002)
correlation the 3D piles are compared with, and the case that runs the table of friction
coefficients and draws the profiles (``case_repose``)."""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, field

import numpy as np

from ...physics import Box, Cylinder, Difference, Plane, World
from .grains import (
    RHO_S,
    STEPS_PER_CONTACT,
    Contact,
    G,
    grain_mass,
    make_world,
    random_sequential,
    settle,
)
from .output import _plt, _write_csv

# ----------------------------------------------------------------------------------------------
# 2. Angle of repose
# ----------------------------------------------------------------------------------------------


def profile_angle(x: np.ndarray, radii: np.ndarray, axis_xy, dim: int, bin_width: float = 1.0) -> tuple:
    """The pile's angle of repose (degrees) from its surface profile: the highest grain top in bins of
    width ``bin_width`` along the distance from the axis (2D: both flanks; 3D: the median over 12
    azimuthal sectors), fitted by a straight line where the profile lies between 20% and 80% of the
    pile's height (off the crest and the toe), from the crest (the highest bin) out to the first bin
    below 20%. Returns (angle, (rho, h) of the profile, the fit)."""
    rel = x[:, :-1] - np.asarray(axis_xy, float)
    top = x[:, -1] + radii
    rho = np.linalg.norm(rel, axis=1)
    nb = int(np.ceil(rho.max() / bin_width)) + 1
    bins = np.minimum((rho / bin_width).astype(int), nb - 1)
    if dim == 2:
        sectors = (rel[:, 0] > 0).astype(int)
        ns = 2
    else:
        ns = 12
        sectors = ((np.arctan2(rel[:, 1], rel[:, 0]) + np.pi) / (2 * np.pi) * ns).astype(int) % ns
    prof = np.zeros((ns, nb))
    np.maximum.at(prof, (sectors, bins), top)
    h = np.median(prof, axis=0)
    centres = (np.arange(nb) + 0.5) * bin_width
    # the crest: the highest bin (in 3D the bins at the axis hold too few grains for every sector)
    crest = int(np.argmax(h))
    hmax = float(h[crest])
    below = np.nonzero((np.arange(nb) > crest) & (h < 0.2 * hmax))[0]
    last = int(below[0]) if below.size else nb  # the flank ends at the first bin below 20%
    sel = (np.arange(nb) >= crest) & (np.arange(nb) < last) & (h > 0.2 * hmax) & (h < 0.8 * hmax)
    if sel.sum() < 2:
        return 0.0, (centres, h), (0.0, float(hmax))
    slope, icpt = np.polyfit(centres[sel], h[sel], 1)
    return float(np.degrees(np.arctan(max(-slope, 0.0)))), (centres, h), (float(slope), float(icpt))


@dataclass
class Repose:
    dim: int
    mu: float
    mu_r: float
    angle: float
    n: int
    profile: tuple = field(repr=False)
    fit: tuple = field(repr=False)
    x: np.ndarray = field(repr=False)
    radii: np.ndarray = field(repr=False)
    height: float = 0.0  # the pile's height (the crest's bin), in d
    base: str = "flat"
    lift_speed: float = 0.5
    seconds: float = 0.0


def rough_base(rng, radius: float, d: float = 1.0, fraction: float = 0.5) -> np.ndarray:
    """A layer of grains of diameter ``d`` lying on the floor (centres at height d / 2) over a disk
    of ``radius``: random non-overlapping positions (random sequential addition) covering an area
    fraction ``fraction`` of the floor (random sequential addition of disks jams at 0.547), so that
    the grains above find hollows of random depth, as on a layer of grains glued to a base."""
    n = int(fraction * (2.0 * radius) ** 2 / (math.pi * d**2 / 4.0))
    xy = random_sequential(rng, np.full(n, d / 2.0), [-radius] * 2, [radius] * 2, max_tries=20000)
    xy = xy[np.linalg.norm(xy, axis=1) < radius - d / 2.0]
    return np.concatenate([xy, np.full((len(xy), 1), d / 2.0)], 1)


def _step_held(world: World, steps: int, held: np.ndarray | None, every: int = 5) -> None:
    """Step ``steps`` times; the grains ``held`` (a mask) are set at rest (velocity and spin zero)
    every ``every`` steps: grains glued to the base (a velocity of at most ``every`` steps of
    acceleration, so they move by far less than their overlaps)."""
    if held is None or not held.any():
        world.step(steps)
        return
    done = 0
    while done < steps:
        k = min(every, steps - done)
        world.step(k)
        done += k
        v = world.velocities.copy()
        v[held] = 0.0
        world.velocities = v
        if world.rotation:
            w = world.angular_velocities.copy()
            w[held] = 0.0
            world.angular_velocities = w


def _settle_held(
    world: World, held: np.ndarray | None, time_max: float, tol: float, chunk: float, drag: float
) -> float:
    """``settle`` with the ``held`` grains kept at rest (the kinetic energy counted over the free
    grains)."""
    if held is None or not held.any():
        return settle(world, time_max, tol=tol, chunk=chunk, drag=drag)
    steps = max(1, int(round(chunk / world.dt)))
    sub = max(1, steps // 20)
    free = ~held
    m = world.masses[free]
    t = 0.0
    while t < time_max:
        for _ in range(steps // sub):
            _step_held(world, sub, held)
            if drag > 0.0:
                world.velocities = world.velocities * (1.0 - drag)
                if world.rotation:
                    world.angular_velocities = world.angular_velocities * (1.0 - drag)
        t += (steps // sub) * sub * world.dt
        v = world.velocities[free]
        ke = 0.5 * float(np.sum(m[:, None] * v**2)) / free.sum()
        if ke / (m.mean() * G * 2.0 * world.radii[free].mean()) < tol:
            break
    return t


@dataclass
class ReposeFill:
    """A filled tube whose grains have settled, before the lift (``repose_fill``): the World (the
    pile's ``n`` grains first, then the held base grains), the tube's geometry and what the lift
    needs."""

    world: World = field(repr=False)
    n: int
    mu: float
    mu_r: float
    held: np.ndarray | None = field(repr=False)
    z0: float  # the tube's rim and the fill's bottom
    R: float  # the tube's inner radius
    half: float  # the tube's half height (it reaches from z0 to z0 + 2 half)
    wall_t: float  # the tube's wall thickness
    contact: Contact


def repose(
    dim: int,
    mu: float,
    mu_r: float = 0.0,
    n: int | None = None,
    tube_radius: float | None = None,
    lift_speed: float = 0.5,
    seed: int = 1,
    steps_per_contact: float = STEPS_PER_CONTACT,
    settle_time: float = 60.0,
    base: str = "flat",
    spread: float = 0.0,
) -> Repose:
    """Fill a tube standing on a floor, let the grains settle, lift the tube at ``lift_speed``
    sqrt(g d) (a kinematic shape) until it clears the grains, and measure the angle of the pile that
    remains. 2D: disks of diameters uniform in [0.8, 1.2] (avoiding the hexagonal order of equal
    disks), the tube two thin walls; 3D: spheres of diameters uniform in [1 - spread, 1 + spread]
    (equal by default), the tube a cylindrical shell (``Difference`` of two cylinders). The floor
    has the grains' friction; 3D ``base="grains"``: a random layer of grains of diameter d held at
    rest on the floor (``rough_base``) out to three tube radii, the tube standing on it (its rim one
    d above the floor). Friction: ``tangential="history"`` (Cundall-Strack) with rotation and
    rolling resistance mu_r (Ai et al. 2011, model A)."""
    tick = time.time()
    fill = repose_fill(dim, mu, mu_r, n, tube_radius, seed, steps_per_contact, base, spread)
    return repose_lift(fill, lift_speed, settle_time, tick, base)


def repose_fill(
    dim: int,
    mu: float,
    mu_r: float = 0.0,
    n: int | None = None,
    tube_radius: float | None = None,
    seed: int = 1,
    steps_per_contact: float = STEPS_PER_CONTACT,
    base: str = "flat",
    spread: float = 0.0,
) -> ReposeFill:
    """``repose``'s first part: the tube filled and its grains settled."""
    rng = np.random.default_rng(seed)
    if dim == 2:
        n = n or 300
        R = tube_radius or 6.0
        radii = rng.uniform(0.4, 0.6, n)
    else:
        n = n or 1500
        R = tube_radius or 5.0
        radii = np.full(n, 0.5) if spread == 0.0 else rng.uniform(0.5 - spread / 2, 0.5 + spread / 2, n)
    z0 = 1.0 if (dim == 3 and base == "grains") else 0.0  # the tube's rim and the fill's bottom
    masses = grain_mass(radii, dim)
    vol = masses.sum() / RHO_S
    section = 2 * R if dim == 2 else math.pi * R**2
    fill_h = vol / 0.6 / section
    h0 = vol / 0.3 / section
    lo = [-R + 0.05] * (dim - 1) + [0.0]
    hi = [R - 0.05] * (dim - 1) + [h0]
    if dim == 3:  # random positions in a square prism, the n lowest of those inside the tube kept
        inside = math.pi * (R - 0.55) ** 2 / (4.0 * (R - 0.5) ** 2)  # the share of the square's centres
        m_sq = int(1.15 * n / inside) + 10
        r_sq = np.full(m_sq, 0.5) if spread == 0.0 else rng.uniform(0.5 - spread / 2, 0.5 + spread / 2, m_sq)
        h_sq = float(np.sum(grain_mass(r_sq, 3))) / RHO_S / 0.25 / (2.0 * R - 1.0) ** 2 + 1.0
        x = random_sequential(rng, r_sq, [-R, -R, z0], [R, R, z0 + h_sq])
        keep = np.nonzero(np.linalg.norm(x[:, :2], axis=1) < R - 0.55)[0]
        keep = keep[np.argsort(x[keep, 2], kind="stable")][:n]
        if keep.size < n:
            raise RuntimeError(f"repose: only {keep.size} of {n} grains placed in the tube")
        x, radii = x[keep], r_sq[keep]
        masses = grain_mass(radii, 3)
        h0 = float(x[:, 2].max()) - z0 + 1.0
    else:
        x = random_sequential(rng, radii, lo, hi)
    held = None
    if dim == 3 and base == "grains":
        layer = rough_base(rng, 3.0 * R + 4.0)
        # out of the tube's wall (R to R + 1, standing on the layer's top)
        rho = np.linalg.norm(layer[:, :2], axis=1)
        layer = layer[(rho < R - 0.55) | (rho > R + 1.55)]
        held = np.concatenate([np.zeros(n, bool), np.ones(len(layer), bool)])
        x = np.concatenate([x, layer])
        radii = np.concatenate([radii, np.full(len(layer), 0.5)])
        masses = np.concatenate([masses, grain_mass(np.full(len(layer), 0.5), 3)])
    elif base != "flat":
        raise ValueError(f"base must be 'flat' or (3D) 'grains', got {base!r}")
    half = 0.5 * h0 + 2.0
    wall_t = 1.0
    terrain = repose_terrain(dim, R, half, wall_t, z0)
    contact = Contact.for_grains(float(masses.mean()), float(radii.mean()), fill_h, steps_per_contact)
    # rotation and Cundall-Strack springs even without friction (where they change nothing), so that
    # every pile of a dimension compiles to the same kernels
    spin = dict(rotation=True, tangential="history", mu=mu, mu_r=mu_r)
    w = make_world(x, radii, masses, contact, terrain, **spin)
    _step_held(w, int(round((2.0 * math.sqrt(2.0 * h0) + 5.0) / w.dt)), held)
    _settle_held(w, held, 40.0, tol=1e-6, chunk=2.0, drag=0.02)
    return ReposeFill(w, n, mu, mu_r, held, z0, R, half, wall_t, contact)


def repose_terrain(dim: int, R: float, half: float, wall_t: float, z0: float) -> list:
    """The floor (a plane at 0) and the tube at rest, kinematic: 2D two walls ``wall_t`` thick at
    +-R, 3D a cylindrical shell (``Difference`` of two cylinders) of inner radius R; both reaching
    from ``z0`` to ``z0 + 2 half`` (2D: from 0)."""
    up = np.zeros(dim)
    if dim == 2:
        tube = [
            Box([-R - wall_t, half], [wall_t, half], velocity=up),
            Box([R + wall_t, half], [wall_t, half], velocity=up),
        ]
    else:
        c = [0.0, 0.0, z0 + half]
        tube = [Difference(Cylinder(c, R + wall_t, half), Cylinder(c, R, half + 1.0), velocity=up)]
    return [Plane(np.zeros(dim), np.eye(dim)[-1])] + tube


def pile_top(w: World, n: int) -> float:
    """The highest grain top of the pile's ``n`` grains (the first n of ``w``)."""
    return float((w.positions.reshape(-1, w.dim)[:n, -1] + w.radii[:n]).max())


def repose_lift(fill: ReposeFill, lift_speed: float, settle_time: float, tick: float, base: str) -> Repose:
    """``repose``'s second part: lift the tube at ``lift_speed`` until its lower rim is above the
    highest grain, let the pile settle, and measure it."""
    w, n, held, z0 = fill.world, fill.n, fill.held, fill.z0
    dim, radii = w.dim, w.radii
    free = slice(0, n)
    top = pile_top(w, n)
    vel = np.zeros(dim)
    vel[-1] = lift_speed
    shapes = range(1, len(w.terrain))  # the tube (the floor is shape 0)
    for k in shapes:
        w.set_shape_pose(k, velocity=vel)
    _step_held(w, lift_steps(top, z0, lift_speed, w.dt), held)
    for k in shapes:
        w.set_shape_pose(k, velocity=np.zeros(dim))
    _settle_held(w, held, settle_time, tol=1e-6, chunk=2.0, drag=0.0)
    x = w.positions.reshape(-1, dim)[free]
    angle, prof, fit = profile_angle(x, radii[free], np.zeros(dim - 1), dim)
    height = float(np.max(prof[1])) - z0
    seconds = time.time() - tick
    return Repose(dim, fill.mu, fill.mu_r, angle, n, prof, fit, x, radii[free], height, base, lift_speed, seconds)


def lift_steps(top: float, z0: float, lift_speed: float, dt: float) -> int:
    """The steps of the lift: until the tube's rim (at ``z0``) is 1 d above the grains' ``top``."""
    return int(round((top - z0 + 1.0) / lift_speed / dt))


def zhou_2002_angle(mu_pp: float, mu_pw: float, mu_r_pp_mm: float, mu_r_pw_mm: float, d_mm: float) -> float:
    """Zhou, Xu, Yu and Zulli's (Powder Technology 125 (2002) 45) correlation of the angle of repose
    (degrees) of mono-sized spheres, fitted to their simulations and measurements:
    theta = 68.61 mu_pp^0.27 mu_pw^0.22 mu_r,pp^0.06 mu_r,pw^0.12 d^-0.2, with the sliding
    friction coefficients between particles (pp) and with the walls and base (pw), their rolling
    friction coefficients (the lever of a constant torque mu_r |f_n|, a length in mm) and the
    diameter d in mm."""
    return 68.61 * mu_pp**0.27 * mu_pw**0.22 * mu_r_pp_mm**0.06 * mu_r_pw_mm**0.12 * d_mm**-0.2


def zhou_2002_model_a(mu: float, mu_r: float, d_mm: float) -> float:
    """``zhou_2002_angle`` for our coefficients: model A's torque mu_r R* |f_n| is Zhou et al.'s
    constant torque with the lever mu_r R*, R* = d / 4 between equal spheres and d / 2 against the
    floor (R* = r there); the same mu between grains and with the floor. The grain size enters only
    as d^-0.02 once the levers scale with d (1 to 10 mm: a factor 1 to 0.955)."""
    return zhou_2002_angle(mu, mu, mu_r * d_mm / 4.0, mu_r * d_mm / 2.0, d_mm)


# ----------------------------------------------------------------------------------------------
# The case
# ----------------------------------------------------------------------------------------------


REPOSE_2D = ((0.0, 0.0), (0.2, 0.0), (0.5, 0.0), (0.5, 0.2))
REPOSE_3D = ((0.0, 0.0), (0.5, 0.0), (0.5, 0.1), (0.5, 0.2))
# 3D: 2000 equal spheres in a tube 12 d wide, lifted slowly, on a base of grains held at rest (550
# spheres in an 8 d tube made heaps 3 to 4 d high, 2.5 to 3.9 degrees below Zhou et al.'s range)
REPOSE_3D_SETUP = dict(n=2000, tube_radius=6.0, lift_speed=0.1, base="grains")


def _repose_job(args: tuple) -> Repose:
    dim, mu, mu_r, kw = args
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return repose(dim, mu, mu_r, **kw)


def case_repose(dim: int, out: str) -> dict:
    size = dict(n=200) if dim == 2 else REPOSE_3D_SETUP
    cases = REPOSE_2D if dim == 2 else REPOSE_3D
    if dim == 2:
        runs = [repose(dim, mu, mu_r, **size) for mu, mu_r in cases]
    else:  # two at a time (each run is single-threaded: minutes)
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as pool:
            runs = list(pool.map(_repose_job, [(dim, mu, mu_r, size) for mu, mu_r in cases]))
    extra = (lambda r: ()) if dim == 2 else (lambda r: (r.height, zhou(r), zhou(r, 10.0)))
    _write_csv(
        os.path.join(out, f"granular_repose{dim}d.csv"),
        ["dim", "mu", "mu_r", "n", "angle_deg", "fit_slope", "fit_intercept", "profile_rho", "profile_h"]
        + ([] if dim == 2 else ["height", "zhou2002_deg_d1mm", "zhou2002_deg_d10mm"]),
        [
            (r.dim, r.mu, r.mu_r, r.n, r.angle, r.fit[0], r.fit[1], float(a), float(b)) + extra(r)
            for r in runs
            for a, b in zip(*r.profile, strict=True)
        ],
    )
    plt = _plt()
    if dim == 2:
        fig, ax = plt.subplots(figsize=(7, 4.5))
    else:
        fig, (ax, side) = plt.subplots(1, 2, figsize=(13, 4.8))
    reach = 5.0
    for r in runs:
        rho, h = r.profile
        label = f"mu={r.mu}, mu_r={r.mu_r}: {r.angle:.1f} deg"
        if dim == 3 and r.mu_r > 0:
            label += f" (Zhou et al. 2002: {zhou(r, 10.0):.0f}-{zhou(r):.0f})"
        (line,) = ax.plot(rho, h, "o-", ms=3, label=label)
        slope, icpt = r.fit
        if slope < 0:
            end = icpt / -slope
            reach = max(reach, 1.5 * end)
            ax.plot([0.0, end], [icpt, 0.0], "--", color=line.get_color(), lw=1)
        if dim == 3:  # a slab one d thick through the axis
            sel = np.abs(r.x[:, 1]) < 0.5
            off = 7.0 * runs.index(r)
            side.scatter(r.x[sel, 0], r.x[sel, 2] + off, s=4, color=line.get_color())
            side.text(-15.5, off + 5.0, f"mu={r.mu}, mu_r={r.mu_r}", fontsize=8)
    ax.set_xlim(0.0, reach)
    ax.set_xlabel("distance from the axis / d")
    ax.set_ylabel("surface height / d")
    ax.set_title(f"{dim}D pile after lifting the tube: profile and fitted flank")
    ax.legend(fontsize=8)
    if dim == 3:
        side.set_aspect("equal")
        side.set_xlim(-16.0, 16.0)
        side.set_xlabel("x / d (grains with |y| < d / 2)")
        side.set_yticks([])
        side.set_title("the heaps in section (stacked)")
    fig.tight_layout()
    fig.savefig(os.path.join(out, f"granular_repose{dim}d.png"), dpi=110)
    plt.close(fig)
    summary = {f"repose{dim}d mu={r.mu} mu_r={r.mu_r}": round(r.angle, 2) for r in runs}
    if dim == 3:
        for r in runs:
            key = f"repose3d mu={r.mu} mu_r={r.mu_r}"
            summary[key + " height"] = round(r.height, 2)
            summary[key + " seconds"] = round(r.seconds)
            summary[key + " Zhou 2002 (d 10 mm, 1 mm)"] = (round(zhou(r, 10.0), 1), round(zhou(r), 1))
    return summary


def zhou(r: Repose, d_mm: float = 1.0) -> float:
    """Zhou et al.'s correlation for a pile's coefficients (0 without rolling friction, where it
    does not apply: it vanishes with mu_r)."""
    return zhou_2002_model_a(r.mu, r.mu_r, d_mm) if r.mu > 0 and r.mu_r > 0 else 0.0

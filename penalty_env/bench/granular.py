"""``python -m penalty_env.bench granular [case ...]``: granular physics against experiments and laws.

Cases (all by default; docs/granular.md has the figures and the numbers):

- ``packing3d``: monodisperse frictionless spheres poured into a box and settled: interior solid
  fraction against random close packing, 0.64 (Scott and Kilgour 1969; Berryman 1983); and the same
  pour with mu = 0.5 (lower).
- ``packing2d``: bidisperse disks (50:50, radius ratio 1.4), frictionless: 0.84 (O'Hern et al. 2003);
  and with mu = 0.5.
- ``repose2d``, ``repose3d``: a pile released by lifting a tube (a kinematic shape moving up): its
  angle from a fit of the surface profile, against sliding friction mu and rolling friction mu_r
  (3D: slowly lifted, on a base of grains held at rest; against Zhou et al. 2002's correlation).
- ``beverloo2d``, ``beverloo3d``: a flat-bottomed silo discharging through a slot (2D) or a round
  orifice (3D): the rate W against the orifice D, fitted to W = C rho_b sqrt(g) (D - k d)^b
  (Beverloo et al. 1961: b = 5/2 in 3D; 3/2 in 2D).
- ``lammps``: a 3D silo discharged here and in LAMMPS from the same settled states (the same
  Hooke contact with Cundall-Strack history, nve/sphere; the same walls, the orifice's edges
  covered by a rim of spheres, frozen atoms in LAMMPS, static Sphere terrain here), over four
  fills and replicas: the ratio of the discharge rates and its run-to-run scatter.
- ``lammps_repose``: the 3D pile of ``repose3d`` filled and settled here, then lifted and measured
  here and in LAMMPS from the same states (the same normal and tangential laws, the rolling
  torque's cap; LAMMPS's ``rolling sds``), over six fills at mu_r = 0.2 and two at 0.1.

Units: the grain diameter d (the mean one), the solid density rho_s = 1 (3D: per volume, 2D: per
area) and g = 1; time in sqrt(d / g). The contact spring is chosen so that a grain under
``layers`` grains overlaps its neighbour by about 1% of its radius, ks = m g layers / (0.01 r); the
dashpot gives a normal restitution of 0.5 between two grains; the time step is t_c / ``STEPS_PER_CONTACT``
(t_c the pair's contact duration), never above ``World.stability_limit()``.

Writes docs/granular_*.png and docs/granular_*.csv (``--out`` to put them elsewhere).
"""

from __future__ import annotations

import argparse
import math
import os
import time
from dataclasses import dataclass, field, replace

import numpy as np

from ..physics import World, theory
from ..physics import Box, Cylinder, Difference, Plane, Sphere

CASES = ("packing3d", "packing2d", "repose2d", "repose3d", "beverloo2d", "beverloo3d", "lammps", "lammps_repose")
G = 1.0  # gravity
RHO_S = 1.0  # solid density
RESTITUTION = 0.5
STEPS_PER_CONTACT = 15  # dt = t_c / this (DEM practice: t_c / 10 to t_c / 50)
DOCS = os.path.join(os.path.dirname(__file__), "..", "..", "docs")

# Published values the figures are compared with (docs/granular.md names the sources).
RCP_3D = 0.64  # Scott and Kilgour 1969; Berryman 1983
JAMMING_2D = 0.84  # O'Hern, Silbert, Liu and Nagel 2003, bidisperse disks 1:1.4


# ----------------------------------------------------------------------------------------------
# Grains, contact parameters, pouring and settling
# ----------------------------------------------------------------------------------------------


def grain_mass(radii: np.ndarray, dim: int) -> np.ndarray:
    """Masses from the solid density: rho_s 4/3 pi r^3 (spheres) or rho_s pi r^2 (disks)."""
    r = np.asarray(radii, dtype=np.float64)
    return RHO_S * (4.0 / 3.0 * np.pi * r**3 if dim == 3 else np.pi * r**2)


@dataclass
class Contact:
    """The contact law's numbers for grains of mass ``m`` and radius ``r`` under ``layers`` layers."""

    ks: float
    kd: float
    dt: float
    t_c: float

    @classmethod
    def for_grains(cls, m: float, r: float, layers: float, steps_per_contact: float = STEPS_PER_CONTACT) -> Contact:
        ks = m * G * layers / (0.01 * r)
        m_eff = m / 2.0
        lne = math.log(RESTITUTION)
        zeta = -lne / math.sqrt(math.pi**2 + lne**2)
        kd = 2.0 * zeta * math.sqrt(ks * m_eff)
        t_c = math.pi / (theory.natural_frequency(ks, m_eff) * math.sqrt(1.0 - zeta**2))
        return cls(float(ks), float(kd), float(t_c / steps_per_contact), float(t_c))


def make_world(x, radii, masses, contact: Contact, terrain, **kw) -> World:
    """A World with ``contact``'s spring and dashpot, dt = min(t_c / STEPS_PER_CONTACT, the guard's limit)."""
    common = dict(terrain=terrain, ks=contact.ks, kd=contact.kd, broadphase="grid", **kw)
    dim = np.shape(x)[-1]
    common.setdefault("gravity", (0.0,) * (dim - 1) + (-G,))
    probe = World(x, radii, masses, dt=1e-9, allow_unstable=True, **common)
    dt = min(contact.dt, 0.95 * probe.stability_limit())
    return World(x, radii, masses, dt=dt, **common)


def random_sequential(rng, radii: np.ndarray, lo, hi, max_tries: int = 2000) -> np.ndarray:
    """Random non-overlapping positions (random sequential addition, largest grains first) with
    centres in the box [lo + r, hi - r]; raises if a grain finds no place."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    dim = lo.size
    cell = 2.0 * float(np.max(radii))
    grid: dict[tuple, list[int]] = {}
    x = np.zeros((len(radii), dim))
    order = np.argsort(-radii, kind="stable")
    offsets = np.stack(np.meshgrid(*[np.arange(-1, 2)] * dim, indexing="ij"), -1).reshape(-1, dim)
    for i in order:
        r = radii[i]
        for _ in range(max_tries):
            p = rng.uniform(lo + r, hi - r)
            key = tuple(np.floor(p / cell).astype(int))
            ok = True
            for off in offsets:
                for j in grid.get(tuple(np.add(key, off)), ()):
                    if np.sum((x[j] - p) ** 2) < (r + radii[j]) ** 2:
                        ok = False
                        break
                if not ok:
                    break
            if ok:
                x[i] = p
                grid.setdefault(key, []).append(int(i))
                break
        else:
            raise RuntimeError(f"random_sequential: no room for grain {i} after {max_tries} tries")
    return x


def kinetic_per_grain(world: World) -> float:
    """Mean translational kinetic energy per grain, in m g d of the mean grain."""
    v = world.velocities.reshape(-1, world.n_balls, world.dim)
    m = world.masses
    ke = 0.5 * np.einsum("i,bij->b", m, v**2) / world.n_balls
    return float(ke.max() / (m.mean() * G * 2.0 * world.radii.mean()))


def settle(world: World, time_max: float, tol: float = 1e-6, chunk: float = 1.0, drag: float = 0.0) -> float:
    """Step until the kinetic energy per grain is below ``tol`` m g d (checked every ``chunk`` time
    units) or ``time_max`` passes; ``drag`` > 0 multiplies the velocities by (1 - drag) every
    chunk / 20 (a global damping for settling). Returns the time stepped."""
    steps = max(1, int(round(chunk / world.dt)))
    sub = max(1, steps // 20) if drag > 0.0 else steps
    t = 0.0
    while t < time_max:
        for _ in range(steps // sub):
            world.step(sub)
            if drag > 0.0:
                world.velocities = world.velocities * (1.0 - drag)
                if world.rotation:
                    world.angular_velocities = world.angular_velocities * (1.0 - drag)
        t += (steps // sub) * sub * world.dt
        if kinetic_per_grain(world) < tol:
            break
    return t


def mean_overlap(x: np.ndarray, radii: np.ndarray) -> float:
    """Mean overlap of touching pairs, in units of the mean radius."""
    from scipy.spatial import cKDTree

    tree = cKDTree(x)
    pairs = tree.query_pairs(2.0 * float(radii.max()), output_type="ndarray")
    if len(pairs) == 0:
        return 0.0
    gap = np.linalg.norm(x[pairs[:, 0]] - x[pairs[:, 1]], axis=1) - radii[pairs[:, 0]] - radii[pairs[:, 1]]
    ov = -gap[gap < 0.0]
    return float(ov.mean() / radii.mean()) if ov.size else 0.0


def spin_kwargs(dim: int, mu: float, mu_r: float = 0.0) -> dict:
    """The friction arguments: Cundall-Strack springs with history (static friction: a contact below
    the cap sticks; the regularised law would creep and let a frictional bed compact as a frictionless
    one does) and rotation. In 2D always with rotation (even frictionless, where it changes nothing),
    so that every 2D scene compiles to the same kernels (compiling one set takes about a minute)."""
    if mu > 0.0 or mu_r > 0.0 or dim == 2:
        return dict(rotation=True, tangential="history", mu=mu, mu_r=mu_r)
    return {}


def box_terrain(dim: int, width: float, height: float) -> list:
    """A floor plane at 0 and side walls at 0 and ``width``: in 3D planes; in 2D kinematic boxes (at
    rest), so that the 2D scenes share their shape kinds (Plane, kinematic Box) and so their kernels."""
    if dim == 3:
        terrain = [Plane(np.zeros(3), np.eye(3)[2])]
        for k in range(2):
            e = np.eye(3)[k]
            terrain += [Plane(np.zeros(3), e), Plane(width * e, -e)]
        return terrain
    half = height / 2.0
    return [
        Plane([0.0, 0.0], [0.0, 1.0]),
        Box([-1.0, half], [1.0, half], velocity=(0.0, 0.0)),
        Box([width + 1.0, half], [1.0, half], velocity=(0.0, 0.0)),
    ]


# ----------------------------------------------------------------------------------------------
# 1. Packing
# ----------------------------------------------------------------------------------------------


def solid_fraction(x: np.ndarray, radii: np.ndarray, lo, hi, spacing: float = 0.05) -> float:
    """The fraction of the box [lo, hi] covered by the grains (the volume of the sphere parts inside
    the box, or in 2D their area, over the box's): stratified Monte Carlo, one random point in each
    cell of a lattice ``spacing`` apart, counted inside if it lies within a grain (the union: where
    two grains overlap, the overlap counts once). Unbiased (a regular lattice is not: it can line up
    with the grains' surfaces), and its error is far below the plain Monte Carlo sqrt(p (1 - p) / N)."""
    from scipy.spatial import cKDTree

    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    counts = np.maximum(np.round((hi - lo) / spacing).astype(int), 1)
    step = (hi - lo) / counts
    axes = [a + (np.arange(c) + 0.5) * h for a, c, h in zip(lo, counts, step, strict=True)]
    pts = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, lo.size)
    pts += np.random.default_rng(12345).uniform(-0.5, 0.5, pts.shape) * step  # one random point per cell
    near = (x > lo - 2 * radii.max()).all(1) & (x < hi + 2 * radii.max()).all(1)
    xs, rs = x[near], radii[near]
    tree = cKDTree(xs)
    covered = np.zeros(len(pts), dtype=bool)
    for r in np.unique(rs):
        sub = cKDTree(xs[rs == r]) if len(np.unique(rs)) > 1 else tree
        dist, _ = sub.query(pts, k=1, distance_upper_bound=r)
        covered |= dist <= r
    return float(covered.mean())


@dataclass
class Packing:
    dim: int
    mu: float
    n: int
    fraction: float
    region: tuple
    overlap: float  # mean overlap / r
    settle_time: float
    ke: float
    x: np.ndarray = field(repr=False)
    radii: np.ndarray = field(repr=False)


def pour_bed(
    dim: int,
    mu: float = 0.0,
    n: int | None = None,
    width: float | None = None,
    seed: int = 0,
    pour_fraction: float | None = None,
    time_max: float = 400.0,
) -> Packing:
    """Pour grains into a box of ``width`` (square in 3D) from random non-overlapping positions at a
    solid fraction ``pour_fraction``, let them fall and settle (a light global drag once the bed has
    landed) until the kinetic energy per grain is below 1e-7 m g d; measure the solid fraction in the
    interior (3 mean diameters from the walls, the floor and the free surface).

    3D: monodisperse spheres (d = 1). 2D: 50:50 disks of diameters 1 and 1.4 (O'Hern et al.)."""
    rng = np.random.default_rng(seed)
    if dim == 3:
        n = n or 2000
        width = width or 10.0
        radii = np.full(n, 0.5)
        pour_fraction = pour_fraction or 0.25
    else:
        n = n or 1200
        width = width or 40.0
        radii = np.where(np.arange(n) % 2 == 0, 0.5, 0.7)
        pour_fraction = pour_fraction or 0.45
    masses = grain_mass(radii, dim)
    vol = np.sum(masses) / RHO_S
    height0 = vol / pour_fraction / width ** (dim - 1)
    rho_bed = 0.84 if dim == 2 else 0.64
    bed_h = vol / rho_bed / width ** (dim - 1)
    x = random_sequential(rng, radii, [0.0] * dim, [width] * (dim - 1) + [height0])
    terrain = box_terrain(dim, width, height0 + 5.0)
    contact = Contact.for_grains(float(masses.mean()), float(radii.mean()), bed_h / (2 * radii.mean()))
    kw = spin_kwargs(dim, mu)
    w = make_world(x, radii, masses, contact, terrain, **kw)
    # fall: free fall of the top grains onto the bed takes sqrt(2 height0 / g)
    w.step(int(round((2.0 * math.sqrt(2.0 * height0 / G) + 10.0) / w.dt)))
    t = settle(w, time_max, tol=1e-7, chunk=2.0, drag=0.02)
    x = w.positions.reshape(n, dim)
    top = np.sort(x[:, -1] + radii)[-max(10, n // 50)]  # the free surface (the highest grains' tops)
    dmean = 2.0 * radii.mean()
    margin = 3.0 * dmean
    lo = [margin] * (dim - 1) + [margin]
    hi = [width - margin] * (dim - 1) + [top - margin]
    frac = solid_fraction(x, radii, lo, hi)
    return Packing(dim, mu, n, frac, (tuple(lo), tuple(hi)), mean_overlap(x, radii), t, kinetic_per_grain(w), x, radii)


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
# 3. Silo discharge, Beverloo's law
# ----------------------------------------------------------------------------------------------


@dataclass
class Discharge:
    dim: int
    D: float  # orifice diameter (2D: slot width), in d
    t: np.ndarray = field(repr=False)  # sample times
    out: np.ndarray = field(repr=False)  # discharged mass at those times
    fill: np.ndarray = field(repr=False)  # fill height (mean top of the grains still in the silo)
    rate: float = 0.0  # the mass rate over the middle of the discharge
    rate_windows: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    bulk_density: float = 0.0
    n: int = 0
    wall: float = 0.0  # silo width (2D) or diameter (3D)
    seed: int = 0  # the fill's random seed
    total: float = 0.0  # the mass in the silo at the start


def silo_terrain(dim: int, width: float, D: float, height: float, catch: float) -> list:
    """The silo, its floor at height 0. 2D: the floor two plates (exact boxes, kinematic so that each
    world of a batch can place them: their inner edges D apart), the side walls two boxes, all
    kinematic at rest. 3D: the floor a plate one d thick with a round hole of diameter D,
    Difference(Box, Cylinder) (exact except along the rim's edges, where max(phi_a, -phi_b) bounds
    the distance from below), the wall a cylindrical shell (Difference of two cylinders), and a plane
    that closes the floor while the silo fills (index 2, moved away to open it). Last: a catch
    plane ``catch`` below the floor, wide open, where the discharged grains heap up."""
    if dim == 2:
        big = width
        half = height / 2.0
        return [
            Box([-D / 2 - big, -0.5], [big, 0.5], velocity=(0.0, 0.0)),
            Box([D / 2 + big, -0.5], [big, 0.5], velocity=(0.0, 0.0)),
            Box([-width / 2 - 1.0, half], [1.0, half], velocity=(0.0, 0.0)),
            Box([width / 2 + 1.0, half], [1.0, half], velocity=(0.0, 0.0)),
            Plane([0.0, -catch], [0.0, 1.0]),
        ]
    R = width / 2
    half = height / 2
    c = [0.0, 0.0, half]
    up = [0.0, 0.0, 1.0]
    # The cutters reach far past the plate and the shell (to below the catch plane): max(phi_a, -phi_b)
    # is the distance only where -phi_b measures the cut's side. A cutter that ends just past the
    # plate leaves, over the hole, phi = max(distance to the plate's face, distance to the cutter's
    # cap), a phantom face across the hole; and the shell's inner cylinder, ended 1 d below the
    # floor, left its outer cylinder's bottom cap as a phantom floor across the whole silo (measured:
    # grains rested over a hole of 8 d).
    reach = height + catch + 10.0
    return [
        Difference(Box([0.0, 0.0, -0.5], [R + 2.0, R + 2.0, 0.5]), Cylinder([0, 0, -0.5], D / 2, reach)),
        Difference(Cylinder(c, R + 1.0, half), Cylinder(c, R, reach)),
        Plane([0.0, 0.0, 0.0], up, velocity=(0.0, 0.0, 0.0)),
        Plane([0.0, 0.0, -catch], up),
    ]


def discharge_rate(t: np.ndarray, out: np.ndarray, total: float, lo: float = 0.2, hi: float = 0.6) -> tuple:
    """The mass rate over the middle of the discharge: a straight-line fit of the discharged mass
    against time between ``lo`` and ``hi`` of ``total`` (the start's transient and the end, where
    the silo empties, left out); and the rates over the two halves of that span (the first at the
    higher fill height)."""
    sel = (out >= lo * total) & (out <= hi * total)
    if sel.sum() < 4:
        return float("nan"), np.full(2, np.nan)
    rate = float(np.polyfit(t[sel], out[sel], 1)[0])
    edges = np.linspace(lo * total, hi * total, 3)
    wins = []
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        s = (out >= a) & (out <= b)
        wins.append(np.polyfit(t[s], out[s], 1)[0] if s.sum() >= 3 else np.nan)
    return rate, np.array(wins)


def silo_scene(dim: int, n: int, width: float, seed: int = 2, layers: float | None = None) -> tuple:
    """Random non-overlapping grains over the closed floor of a silo of ``width`` (2D: diameters
    uniform in [0.8, 1.2]; 3D: equal spheres): (x, radii, masses, contact, height of the cloud)."""
    rng = np.random.default_rng(seed)
    radii = rng.uniform(0.4, 0.6, n) if dim == 2 else np.full(n, 0.5)
    masses = grain_mass(radii, dim)
    vol = masses.sum() / RHO_S
    section = width if dim == 2 else math.pi * width**2 / 4
    h0 = vol / (0.45 if dim == 2 else 0.25) / section
    if dim == 2:
        x = random_sequential(rng, radii, [-width / 2, 0.0], [width / 2, h0])
    else:
        R = width / 2
        x = random_sequential(rng, radii, [-R, -R, 0.0], [R, R, h0 * 4 / math.pi])
        keep = np.linalg.norm(x[:, :2], axis=1) < R - 0.55
        x, radii, masses = x[keep], radii[keep], masses[keep]
        h0 = float(x[:, 2].max()) + 1.0
    fill_h = vol / 0.6 / section
    layers = layers or min(fill_h, 2.0 * width)  # the pressure saturates (Janssen) from about a width
    contact = Contact.for_grains(float(masses.mean()), float(radii.mean()), layers)
    return x, radii, masses, contact, h0


def discharge(
    dim: int,
    orifices,
    n: int,
    width: float,
    mu: float = 0.5,
    mu_r: float = 0.0,
    seed: int = 2,
    sample: float = 0.5,
    out_fraction: float = 0.65,
    time_max: float = 400.0,
    catch: float | None = None,
    verbose: bool = False,
    done=None,
    stall: float = 30.0,
) -> list[Discharge]:
    """Fill the silo with its orifice closed (2D: the plates meet; 3D: a plane over the floor) and
    settle it once; then, for each orifice, a World of its own starts from that settled state (at
    rest, no contact history), opens the orifice and records the discharged mass (grains 3 d below
    the floor) every ``sample`` until ``out_fraction`` of it has left (or ``time_max``). A World per
    orifice rather than a batch: a batch steps every world until the slowest one has drained.
    ``done``, if given, is called with each orifice's Discharge as it finishes. An orifice through
    which nothing has left for ``stall`` time units has clogged (or never started to flow): its run
    stops there (its rate is then that of the span before, or nan)."""
    orifices = list(orifices)
    x, radii, masses, contact, h0 = silo_scene(dim, n, width, seed)
    n = len(x)
    catch = catch or (25.0 if dim == 2 else 20.0)
    kw = spin_kwargs(dim, mu, mu_r)
    big = width
    w = make_world(x, radii, masses, contact, silo_terrain(dim, width, orifices[0], h0 + 4.0, catch), **kw)
    if dim == 2:  # closed: the plates meet at the centre
        w.set_shape_pose(0, position=[-big, -0.5])
        w.set_shape_pose(1, position=[big, -0.5])
    tick = time.time()
    w.step(int(round((2.0 * math.sqrt(2.0 * h0) + 5.0) / w.dt)))
    settle(w, 60.0, tol=1e-6, chunk=2.0, drag=0.02)
    settled = w.positions.reshape(n, dim).copy()
    rho_b = bulk_density(settled, radii, dim, width)
    if verbose:
        print(f"  settled {n} grains, rho_b = {rho_b:.4f} ({time.time() - tick:.0f} s)", flush=True)
    results = []
    for D in orifices:
        w = make_world(settled, radii, masses, contact, silo_terrain(dim, width, D, h0 + 4.0, catch), **kw)
        if dim == 3:
            w.set_shape_pose(2, position=[0.0, 0.0, -1e4])  # the closing plane out of the way
        gone = np.zeros(n, dtype=bool)
        ts, outs, fills = [0.0], [0.0], [_fill_height(settled, gone)]
        steps = max(1, int(round(sample / w.dt)))
        t = moved = 0.0
        tick = time.time()
        while t < time_max:
            w.step(steps)
            t += steps * w.dt
            xs = w.positions.reshape(n, dim)
            gone |= xs[:, -1] < -3.0
            outs.append(float(masses[gone].sum()))
            ts.append(t)
            fills.append(_fill_height(xs, gone))
            if verbose and len(ts) % 40 == 0:
                print(f"  D={D:g} t={t:.0f} out={outs[-1] / masses.sum():.2f} ({time.time() - tick:.0f} s)", flush=True)
            if outs[-1] >= out_fraction * masses.sum():
                break
            if outs[-1] > outs[-2]:
                moved = t
            elif t - moved > stall:
                if verbose:
                    print(f"  D={D:g}: clogged at t={moved:.0f} ({outs[-1] / masses.sum():.2f} out)", flush=True)
                break
        times, mass_out, fill = np.array(ts), np.array(outs), np.array(fills)
        rate, wins = discharge_rate(times, mass_out, masses.sum())
        results.append(Discharge(dim, D, times, mass_out, fill, rate, wins, rho_b, n, width, seed, float(masses.sum())))
        if done is not None:
            done(results[-1])
    return results


def _fill_height(x: np.ndarray, gone: np.ndarray) -> float:
    """The fill height: the mean height of the highest 2% of the grains still in the silo."""
    z = np.sort(x[~gone, -1])
    return float(z[-max(5, len(z) // 50) :].mean()) if len(z) else 0.0


def beverloo_fit(D, W, dim: int, rho_b: float, exponent: float | None = None, sigma=None, resamples: int = 400) -> dict:
    """Fit W = C rho_b sqrt(g) (D - k d)^b: with b free (a least-squares fit of log W over C, k, b,
    each point weighted by 1 / ``sigma``, its relative error, if given) and with b fixed at
    ``exponent`` (default Beverloo's: 5/2 in 3D, 3/2 in 2D; then W^(1/b) is linear in D).

    With ``sigma`` (the rates' relative standard errors, one per point or one for all), the 68%
    intervals of b and k (free fit) and of C and k (fixed exponent) from ``resamples`` refits of
    log W + N(0, sigma): keys b_lo, b_hi, k_lo, k_hi, C_fixed_lo, ... ."""
    from scipy.optimize import least_squares

    D, W = np.asarray(D, float), np.asarray(W, float)
    b0 = exponent if exponent is not None else (2.5 if dim == 3 else 1.5)
    weight = 1.0 / np.broadcast_to(np.asarray(sigma if sigma is not None else 1.0, float), D.shape)

    def fits(y: np.ndarray) -> tuple:
        # fixed exponent: y^(1/b) = C^(1/b) (D - k), weighted as log y (d y^(1/b) = y^(1/b) d log y / b)
        s, c0 = np.polyfit(D, y ** (1.0 / b0), 1, w=weight / y ** (1.0 / b0))
        k_fixed, C_fixed = -c0 / s, s**b0
        res = least_squares(
            lambda p: weight * (np.log(p[0]) + p[2] * np.log(np.maximum(D - p[1], 1e-9)) - np.log(y)),
            x0=[C_fixed, min(k_fixed, float(D.min()) - 0.1), b0],
            bounds=([1e-6, -5.0, 0.5], [1e3, float(D.min()) - 0.05, 5.0]),
        )
        return (*res.x, C_fixed, k_fixed)

    y = W / (rho_b * math.sqrt(G))
    C, k, b, C_fixed, k_fixed = fits(y)
    out = dict(C=float(C), k=float(k), b=float(b), C_fixed=float(C_fixed), k_fixed=float(k_fixed), b_fixed=b0)
    if sigma is not None:
        rng = np.random.default_rng(0)
        draws = np.array([fits(y * np.exp(rng.normal(0.0, 1.0 / weight))) for _ in range(resamples)])
        for j, key in enumerate(("C", "k", "b", "C_fixed", "k_fixed")):
            lo, hi = np.percentile(draws[:, j], [16.0, 84.0])
            out[f"{key}_lo"], out[f"{key}_hi"] = float(lo), float(hi)
    return out


def bulk_density(x: np.ndarray, radii: np.ndarray, dim: int, width: float) -> float:
    """The bulk density rho_b = rho_s x the solid fraction, measured in the settled silo away from its
    walls, floor and free surface (3D: a box inside the cylinder)."""
    top = np.sort(x[:, -1])[-max(5, len(x) // 50)]
    if dim == 2:
        lo, hi = [-width / 2 + 3.0, 3.0], [width / 2 - 3.0, top - 3.0]
    else:
        a = (width / 2 - 3.0) / math.sqrt(2.0)
        lo, hi = [-a, -a, 3.0], [a, a, top - 3.0]
    return RHO_S * solid_fraction(x, radii, lo, hi)


# ----------------------------------------------------------------------------------------------
# 4. LAMMPS
# ----------------------------------------------------------------------------------------------


# ----------------------------------------------------------------------------------------------
# The cases: each writes docs/granular_<case>.csv and .png and returns its summary
# ----------------------------------------------------------------------------------------------


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _write_csv(path: str, header: list[str], rows) -> None:
    with open(path, "w") as f:
        f.write(",".join(header) + "\n")
        for row in rows:
            f.write(",".join(f"{v:.6g}" if isinstance(v, float) else str(v) for v in row) + "\n")


def case_packing(dim: int, out: str) -> dict:
    size = dict(n=400, width=20.0) if dim == 2 else {}
    runs = [pour_bed(dim, mu=mu, **size) for mu in (0.0, 0.5)]
    target = RCP_3D if dim == 3 else JAMMING_2D
    rows = [(p.dim, p.mu, p.n, p.fraction, p.overlap, p.settle_time, p.ke) for p in runs]
    _write_csv(
        os.path.join(out, f"granular_packing{dim}d.csv"),
        ["dim", "mu", "n", "solid_fraction", "mean_overlap_over_r", "settle_time", "ke_per_grain"],
        rows,
    )
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(9, 4.5))
    for ax, p in zip(axes, runs, strict=True):
        x = p.x
        if dim == 3:  # a slab through the middle
            mid = x[:, 1].mean()
            sel = np.abs(x[:, 1] - mid) < 0.5
            xx, zz, rr = x[sel, 0], x[sel, 2], np.sqrt(np.maximum(p.radii[sel] ** 2 - (x[sel, 1] - mid) ** 2, 0))
        else:
            xx, zz, rr = x[:, 0], x[:, 1], p.radii
        for a, b, r in zip(xx, zz, rr, strict=True):
            ax.add_patch(plt.Circle((a, b), r, color="tab:blue" if p.mu == 0 else "tab:orange", alpha=0.6, lw=0))
        (lo, hi) = p.region
        ax.add_patch(plt.Rectangle((lo[0], lo[-1]), hi[0] - lo[0], hi[-1] - lo[-1], fill=False, color="k", lw=1.5))
        ax.set_aspect("equal")
        ax.autoscale_view()
        ax.set_title(f"mu = {p.mu}: solid fraction {p.fraction:.3f} (box)")
    fig.suptitle(
        f"{dim}D poured bed ({'monodisperse spheres' if dim == 3 else 'bidisperse disks 1:1.4'}); "
        f"published frictionless: {target}"
    )
    fig.tight_layout()
    fig.savefig(os.path.join(out, f"granular_packing{dim}d.png"), dpi=110)
    plt.close(fig)
    return {f"packing{dim}d mu={p.mu}": round(p.fraction, 4) for p in runs} | {
        f"packing{dim}d mu={p.mu} overlap/r": round(p.overlap, 4) for p in runs
    }


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


BEVERLOO_2D = dict(
    orifices=(12.0, 10.0, 8.5, 7.0, 6.0, 5.0), n=1100, width=32.0, seeds=tuple(range(2, 12)), time_max=300.0
)
BEVERLOO_3D = dict(orifices=(9.0, 8.0, 7.0, 6.0, 5.5, 5.0), n=4700, width=16.0, seeds=(2, 3), time_max=400.0)
BEVERLOO_CSV = ["seed", "D", "t", "discharged_mass", "fill_height", "total_mass", "rho_b", "n", "width"]


def read_beverloo_csv(path: str, dim: int) -> list[Discharge]:
    """The runs of a ``granular_beverloo<dim>d.csv`` (as ``case_beverloo`` writes it), their rates
    measured again."""
    data = np.genfromtxt(path, delimiter=",", names=True)
    runs = []
    for seed in np.unique(data["seed"]):
        for D in np.unique(data["D"][data["seed"] == seed]):
            r = data[(data["seed"] == seed) & (data["D"] == D)]
            total = float(r["total_mass"][0])
            rate, wins = discharge_rate(r["t"], r["discharged_mass"], total)
            runs.append(
                Discharge(
                    dim, float(D), r["t"], r["discharged_mass"], r["fill_height"], rate, wins,
                    float(r["rho_b"][0]), int(r["n"][0]), float(r["width"][0]), int(seed), total,
                )
            )  # fmt: skip
    return runs


def _write_beverloo_csv(path: str, runs: list[Discharge]) -> None:
    rows = []
    for r in runs:
        for t, o, f in zip(r.t, r.out, r.fill, strict=True):
            rows.append((r.seed, r.D, float(t), float(o), float(f), r.total, r.bulk_density, r.n, r.wall))
    _write_csv(path, BEVERLOO_CSV, rows)


def beverloo_table(runs: list[Discharge]) -> dict:
    """Per orifice (sorted): the rate averaged over the seeds, each seed's rate, the two halves of the
    middle of the discharge (averaged over the seeds) and their relative difference (first minus
    second, over the rate), the fill heights at 20%, 40% and 60% out (mean over seeds); and sigma,
    the relative standard error of the mean rates: the seeds' relative scatter pooled over the
    orifices over sqrt(seeds), or with one seed half the halves' relative difference, pooled. Runs
    without a rate (clogged before 60% out) are left out."""
    runs = [r for r in runs if np.isfinite(r.rate) and np.all(np.isfinite(r.rate_windows))]
    Ds = sorted({r.D for r in runs})
    table: dict = dict(D=np.array(Ds), W=[], W_seeds=[], halves=[], halves_diff=[], fill=[])
    rel_var = []
    for D in Ds:
        rs = [r for r in runs if r.D == D]
        rates = np.array([r.rate for r in rs])
        halves = np.mean([r.rate_windows for r in rs], axis=0)
        table["W"].append(rates.mean())
        table["W_seeds"].append(rates)
        table["halves"].append(halves)
        table["halves_diff"].append((halves[0] - halves[1]) / rates.mean())
        fills = []
        for r in rs:
            fills.append([np.interp(q * r.total, r.out, r.fill) for q in (0.2, 0.4, 0.6)])
        table["fill"].append(np.mean(fills, axis=0))
        if len(rs) > 1:
            rel_var.append(np.var(rates, ddof=1) / rates.mean() ** 2 / len(rs))
        else:
            rel_var.append((0.5 * table["halves_diff"][-1]) ** 2)
    table["W"] = np.array(table["W"])
    table["halves_diff"] = np.array(table["halves_diff"])
    table["sigma"] = float(math.sqrt(np.mean(rel_var)))
    table["rho_b"] = float(np.mean([r.bulk_density for r in runs]))
    return table


def beverloo_summary(dim: int, runs: list[Discharge], out: str) -> dict:
    """Fit Beverloo's law to the runs (mean rate per orifice), draw granular_beverloo<dim>d.png and
    return the figures."""
    tab = beverloo_table(runs)
    D, W, rho_b = tab["D"], tab["W"], tab["rho_b"]
    fit = beverloo_fit(D, W, dim, rho_b, sigma=tab["sigma"])
    law = fit["C_fixed"] * rho_b * np.maximum(D - fit["k_fixed"], 1e-9) ** fit["b_fixed"]
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    all_D = sorted({r.D for r in runs})
    for r in sorted(runs, key=lambda r: (r.D, r.seed)):
        first = r.seed == min(q.seed for q in runs if q.D == r.D)
        rate = f"W = {tab['W'][list(D).index(r.D)]:.3g}" if r.D in D else "clogged"
        axes[0].plot(
            r.t, r.out / r.total, color=f"C{all_D.index(r.D)}", lw=1.2 if first else 0.6,
            label=f"D = {r.D:g} d: {rate}" if first else None,
        )  # fmt: skip
    axes[0].axhspan(0.2, 0.6, color="0.9", zorder=0)
    axes[0].set_xlabel("t / sqrt(d/g)")
    axes[0].set_ylabel("discharged mass / initial mass")
    axes[0].legend(fontsize=8)
    axes[0].set_title(f"discharge, {len({r.seed for r in runs})} fill(s) per orifice (rate: 20% to 60% out)")
    y = W / (rho_b * math.sqrt(G))
    axes[1].errorbar(D - fit["k"], y, yerr=tab["sigma"] * y, fmt="o", label="measured (mean over fills)")
    dd = np.linspace(D.min(), D.max(), 50)
    axes[1].loglog(
        dd - fit["k"], fit["C"] * (dd - fit["k"]) ** fit["b"], "-",
        label=f"free: b = {fit['b']:.2f} ({fit['b_lo']:.2f} to {fit['b_hi']:.2f}), k = {fit['k']:.2f}, C = {fit['C']:.2f}",
    )  # fmt: skip
    axes[1].loglog(
        dd - fit["k"], fit["C_fixed"] * np.maximum(dd - fit["k_fixed"], 1e-9) ** fit["b_fixed"], ":",
        label=f"b = {fit['b_fixed']} fixed: C = {fit['C_fixed']:.2f}, k = {fit['k_fixed']:.2f}",
    )  # fmt: skip
    axes[1].set_xlabel("(D - k d) / d  (k of the free fit)")
    axes[1].set_ylabel("W / (rho_b sqrt(g))")
    axes[1].legend(fontsize=7)
    axes[1].set_title(f"{dim}D Beverloo fit (rho_b = {rho_b:.3f} rho_s)")
    fig.tight_layout()
    fig.savefig(os.path.join(out, f"granular_beverloo{dim}d.png"), dpi=110)
    plt.close(fig)
    summary = {f"beverloo{dim}d {k}": round(v, 4) if isinstance(v, float) else v for k, v in fit.items()}
    summary[f"beverloo{dim}d sigma (relative error of the rates)"] = round(tab["sigma"], 4)
    summary[f"beverloo{dim}d rho_b"] = round(rho_b, 4)
    for i, Dv in enumerate(D):
        key = f"beverloo{dim}d D={Dv:g}"
        summary[f"{key} W"] = round(float(W[i]), 4)
        summary[f"{key} W per fill"] = np.round(tab["W_seeds"][i], 4).tolist()
        summary[f"{key} halves"] = np.round(tab["halves"][i], 4).tolist()
        summary[f"{key} halves rel. diff"] = round(float(tab["halves_diff"][i]), 4)
        summary[f"{key} fill height at 20/40/60% out"] = np.round(tab["fill"][i], 2).tolist()
        summary[f"{key} W / law(b fixed) - 1"] = round(float(W[i] / law[i] - 1.0), 4)
    return summary


def case_beverloo(dim: int, out: str, verbose: bool = True) -> dict:
    cfg = BEVERLOO_2D if dim == 2 else BEVERLOO_3D
    path = os.path.join(out, f"granular_beverloo{dim}d.csv")
    runs: list[Discharge] = []

    def keep(r: Discharge) -> None:  # the CSV after each orifice, so that a stopped run keeps its data
        runs.append(r)
        _write_beverloo_csv(path, runs)
        if verbose:
            print(f"  seed {r.seed} D = {r.D:g}: W = {r.rate:.4g}, halves {np.round(r.rate_windows, 4)}", flush=True)

    for seed in cfg["seeds"]:
        discharge(
            dim, cfg["orifices"], cfg["n"], cfg["width"], seed=seed, time_max=cfg["time_max"], verbose=verbose,
            done=keep,
        )  # fmt: skip
    return beverloo_summary(dim, runs, out)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(prog="python -m penalty_env.bench granular", description=__doc__.split("\n")[0])
    parser.add_argument("cases", nargs="*", help=f"any of {', '.join(CASES)} (default: all)")
    parser.add_argument("--out", default=DOCS, help="folder for the CSV and PNG files (default: docs/)")
    args = parser.parse_args(argv)
    cases = args.cases or list(CASES)
    bad = [c for c in cases if c not in CASES]
    if bad:
        parser.error(f"unknown case(s) {bad}; choose from {CASES}")
    runners = {
        "packing3d": lambda: case_packing(3, args.out),
        "packing2d": lambda: case_packing(2, args.out),
        "repose2d": lambda: case_repose(2, args.out),
        "repose3d": lambda: case_repose(3, args.out),
        "beverloo2d": lambda: case_beverloo(2, args.out),
        "beverloo3d": lambda: case_beverloo(3, args.out),
        "lammps": lambda: case_lammps(args.out),
        "lammps_repose": lambda: case_lammps_repose(args.out),
    }
    for case in cases:
        tick = time.time()
        summary = runners[case]()
        print(f"{case} ({time.time() - tick:.0f} s):", flush=True)
        for key, value in summary.items():
            print(f"  {key}: {value}", flush=True)


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


def _frozen_type_2(group: str, law, kd: float, m: float) -> str:
    """The LAMMPS input's lines for grains (type 1) among frozen spheres (type 2, the group ``group``):
    ``law(gamma_n)`` between grains with gamma_n = kd / (m / 2) (m_eff = m / 2: our kd), and
    against the frozen spheres with kd / m (the granular pair styles take m_eff = the mobile grain's
    mass there: our kd again); no pairs among the frozen spheres."""
    return f"""group grains type 1
group {group} type 2
pair_style granular
pair_coeff 1 1 {law(kd / (m / 2.0))}
pair_coeff 1 2 {law(kd / m)}
pair_coeff 2 2 {law(kd / m)}
neigh_modify exclude type 2 2
fix freeze {group} freeze
"""


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
    from .peer_lammps import _data_file

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


def _run_lammps(lmp, tmp: str, script: str) -> None:
    import subprocess

    with open(os.path.join(tmp, "in.silo"), "w") as f:
        f.write(script)
    cmd = [lmp.lmp, "-in", "in.silo", "-log", "none", "-echo", "none", "-sf", "omp", "-pk", "omp", "1"]
    res = subprocess.run(cmd, cwd=tmp, env=dict(lmp.env, OMP_NUM_THREADS="1"), capture_output=True, text=True)
    if res.returncode != 0 or "Lost atoms" in res.stdout + res.stderr:
        raise RuntimeError(f"LAMMPS failed: {(res.stdout + res.stderr)[-2000:]}")


def _lammps(lmp):
    from .peer_lammps import Lammps, find_lammps

    lmp = lmp or find_lammps()
    if not isinstance(lmp, Lammps):
        raise RuntimeError(lmp)
    return lmp


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


def ours_pile(s: PileState, settle_time: float) -> Repose:
    """Lift and measure ``s`` in a fresh World, with ``repose_lift``: ``repose``'s lift, but without
    the fill's contact history (as LAMMPS starts), so another realisation of ``repose``'s pile."""
    tick = time.time()
    terrain = repose_terrain(3, s.R, s.half, s.wall_t, s.z0)
    spin = dict(rotation=True, tangential="history", mu=s.mu, mu_r=s.mu_r, kt=s.kt, kd_t=s.kd_t, kr=s.kr)
    common = dict(terrain=terrain, ks=s.contact.ks, kd=s.contact.kd, broadphase="grid", **spin)
    w = World(s.x, s.radii, s.masses, s.v, dt=s.dt, gravity=(0.0, 0.0, -G), **common)
    w.angular_velocities = s.w
    held = np.arange(len(s.x)) >= s.n
    fill = ReposeFill(w, s.n, s.mu, s.mu_r, held, s.z0, s.R, s.half, s.wall_t, s.contact)
    return repose_lift(fill, s.lift, settle_time, tick, "grains")


def lammps_pile(s: PileState, settle_time: float, lmp=None, k_roll: float | None = None) -> tuple:
    """Lift ``s``'s tube in LAMMPS (``lammps_repose_script``; the same state, no contact history,
    the same dt and lift), settle for chunks of 2 time units (733 steps; ``_settle_held`` takes 720)
    until the translational kinetic energy per grain is below 1e-6 m g d (``_settle_held``'s
    criterion; at most ``settle_time``). Returns (the pile's grains'
    positions, seconds, LAMMPS's version)."""
    import tempfile

    from .peer_lammps import _data_file

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
    ours = ours_pile(s, float(cfg["settle_time"]))
    radii = s.radii[: s.n]
    out = dict(seed=seed, mu=mu, mu_r=mu_r, n=s.n, base=len(s.x) - s.n, dt=s.dt)
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
        + ["height_ours", "height_lammps", "seconds_ours", "seconds_lammps", "zhou2002_deg_d10mm", "zhou2002_deg_d1mm"],
        [
            (r["seed"], r["mu"], r["mu_r"], r["n"], r["base"], r["dt"], r["angle"], r["angle_lammps"])
            + (r.get("angle_lammps_soft", float("nan")), r["height"], r["height_lammps"], r["seconds"])
            + (
                r["seconds_lammps"],
                zhou_2002_model_a(r["mu"], r["mu_r"], 10.0),
                zhou_2002_model_a(r["mu"], r["mu_r"], 1.0),
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

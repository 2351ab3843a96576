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
- ``lammps``: one 3D silo discharge run here and in LAMMPS (gran/hooke/history, nve/sphere, the
  nearest walls LAMMPS has), the rates compared. Known to fail for now: LAMMPS's region union has
  no contact at the orifice's rim edge and its run blows up (``lammps_silo_script``).

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
from dataclasses import dataclass, field

import numpy as np

from ..physics import World, theory
from ..physics.shapes import Box, Cylinder, Difference, Plane

CASES = ("packing3d", "packing2d", "repose2d", "repose3d", "beverloo2d", "beverloo3d", "lammps")
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
    up = np.zeros(dim)
    if dim == 2:
        tube = [
            Box([-R - wall_t, half], [wall_t, half], velocity=up),
            Box([R + wall_t, half], [wall_t, half], velocity=up),
        ]
    else:
        c = [0.0, 0.0, z0 + half]
        tube = [Difference(Cylinder(c, R + wall_t, half), Cylinder(c, R, half + 1.0), velocity=up)]
    terrain = [Plane(np.zeros(dim), np.eye(dim)[-1])] + tube
    contact = Contact.for_grains(float(masses.mean()), float(radii.mean()), fill_h, steps_per_contact)
    # rotation and Cundall-Strack springs even without friction (where they change nothing), so that
    # every pile of a dimension compiles to the same kernels
    spin = dict(rotation=True, tangential="history", mu=mu, mu_r=mu_r)
    w = make_world(x, radii, masses, contact, terrain, **spin)
    _step_held(w, int(round((2.0 * math.sqrt(2.0 * h0) + 5.0) / w.dt)), held)
    _settle_held(w, held, 40.0, tol=1e-6, chunk=2.0, drag=0.02)
    # lift the tube until its lower rim is above the highest grain
    free = slice(0, n)
    top = float((w.positions.reshape(-1, dim)[free, -1] + radii[free]).max())
    vel = np.zeros(dim)
    vel[-1] = lift_speed
    for k in range(1, len(terrain)):
        w.set_shape_pose(k, velocity=vel)
    _step_held(w, int(round((top - z0 + 1.0) / lift_speed / w.dt)), held)
    for k in range(1, len(terrain)):
        w.set_shape_pose(k, velocity=np.zeros(dim))
    _settle_held(w, held, settle_time, tol=1e-6, chunk=2.0, drag=0.0)
    x = w.positions.reshape(-1, dim)[free]
    angle, prof, fit = profile_angle(x, radii[free], np.zeros(dim - 1), dim)
    height = float(np.max(prof[1])) - z0
    return Repose(dim, mu, mu_r, angle, n, prof, fit, x, radii[free], height, base, lift_speed, time.time() - tick)


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
    return [
        Difference(Box([0.0, 0.0, -0.5], [R + 2.0, R + 2.0, 0.5]), Cylinder([0, 0, -0.5], D / 2, 1.0)),
        Difference(Cylinder(c, R + 1.0, half), Cylinder(c, R, half + 1.0)),
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
) -> list[Discharge]:
    """Fill the silo with its orifice closed (2D: the plates meet; 3D: a plane over the floor),
    settle, open the orifice and record the discharged mass (grains 3 d below the floor) every
    ``sample`` until ``out_fraction`` of it has left (or ``time_max``). 2D: one batched World, a
    world per orifice (the plates' poses differ per world); 3D: a World per orifice."""
    orifices = list(orifices)
    x, radii, masses, contact, h0 = silo_scene(dim, n, width, seed)
    n = len(x)
    catch = catch or (25.0 if dim == 2 else 20.0)
    kw = spin_kwargs(dim, mu, mu_r)
    results = []
    groups = [orifices] if dim == 2 else [[D] for D in orifices]
    settled = None
    for group in groups:
        B = len(group)
        terrain = silo_terrain(dim, width, group[0], h0 + 4.0, catch)
        xb = np.broadcast_to(x, (B,) + x.shape).copy()
        w = make_world(xb, radii, masses, contact, terrain, **kw)
        big = width
        if settled is not None:  # 3D: every orifice starts from the state settled once (no history)
            w.set_state(positions=np.broadcast_to(settled[0], xb.shape), velocities=np.zeros_like(xb))
        else:
            if dim == 2:  # closed: the plates meet at the centre
                w.set_shape_pose(0, position=[-big, -0.5])
                w.set_shape_pose(1, position=[big, -0.5])
            w.step(int(round((2.0 * math.sqrt(2.0 * h0) + 5.0) / w.dt)))
            settle(w, 60.0, tol=1e-6, chunk=2.0, drag=0.02)
            settled = (w.positions.reshape(B, n, dim)[0].copy(),)
        xs = w.positions.reshape(B, n, dim)
        rho_b = bulk_density(xs[0], radii, dim, width)
        if dim == 2:
            w.set_shape_pose(0, position=[[-D / 2 - big, -0.5] for D in group])
            w.set_shape_pose(1, position=[[D / 2 + big, -0.5] for D in group])
        else:
            w.set_shape_pose(2, position=[0.0, 0.0, -1e4])
        gone = np.zeros((B, n), dtype=bool)
        ts, outs, fills = [0.0], [np.zeros(B)], [[_fill_height(xs[b], gone[b]) for b in range(B)]]
        steps = max(1, int(round(sample / w.dt)))
        t = 0.0
        tick = time.time()
        while t < time_max:
            w.step(steps)
            t += steps * w.dt
            xs = w.positions.reshape(B, n, dim)
            gone |= xs[..., -1] < -3.0
            outs.append(gone.astype(float) @ masses)
            ts.append(t)
            fills.append([_fill_height(xs[b], gone[b]) for b in range(B)])
            if verbose and len(ts) % 40 == 0:
                print(
                    f"  t={t:.0f} out={np.round(outs[-1] / masses.sum(), 2)} ({time.time() - tick:.0f} s)", flush=True
                )
            if np.all(outs[-1] >= out_fraction * masses.sum()):
                break
        times, mass_out, fill = np.array(ts), np.array(outs), np.array(fills)
        for b, D in enumerate(group):
            rate, wins = discharge_rate(times, mass_out[:, b], masses.sum())
            results.append(Discharge(dim, D, times, mass_out[:, b], fill[:, b], rate, wins, rho_b, n, width))
    return results


def _fill_height(x: np.ndarray, gone: np.ndarray) -> float:
    """The fill height: the mean height of the highest 2% of the grains still in the silo."""
    z = np.sort(x[~gone, -1])
    return float(z[-max(5, len(z) // 50) :].mean()) if len(z) else 0.0


def beverloo_fit(D, W, dim: int, rho_b: float, exponent: float | None = None) -> dict:
    """Fit W = C rho_b sqrt(g) (D - k d)^b: with b free (a least-squares fit of log W over k, C, b)
    and with b fixed at Beverloo's (5/2 in 3D, 3/2 in 2D: then W^(1/b) is linear in D)."""
    from scipy.optimize import least_squares

    D, W = np.asarray(D, float), np.asarray(W, float)
    b0 = 2.5 if dim == 3 else 1.5
    y = W / (rho_b * math.sqrt(G))
    # fixed exponent: y^(1/b) = C^(1/b) (D - k)
    s, c0 = np.polyfit(D, y ** (1.0 / b0), 1)
    k_fixed = -c0 / s
    C_fixed = s**b0
    res = least_squares(
        lambda p: np.log(p[0]) + p[2] * np.log(np.maximum(D - p[1], 1e-9)) - np.log(y),
        x0=[C_fixed, k_fixed, b0],
        bounds=([1e-6, -5.0, 0.5], [1e3, float(D.min()) - 0.05, 5.0]),
    )
    C, k, b = res.x
    return dict(C=float(C), k=float(k), b=float(b), C_fixed=float(C_fixed), k_fixed=float(k_fixed), b_fixed=b0)


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
# 3D: 550 equal spheres in a tube 8 d wide, lifted slowly, on a base of grains held at rest (2000
# spheres in a 12 d tube did not finish in the time the shared machine gave)
REPOSE_3D_SETUP = dict(n=550, tube_radius=4.0, lift_speed=0.1, base="grains")


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


BEVERLOO_2D = dict(orifices=(5.0, 6.5, 8.0, 10.0), n=600, width=25.0)
BEVERLOO_3D = dict(orifices=(5.0, 6.0, 7.0, 8.0), n=2500, width=12.0)


def case_beverloo(dim: int, out: str, verbose: bool = True) -> dict:
    cfg = BEVERLOO_2D if dim == 2 else BEVERLOO_3D
    runs = discharge(dim, cfg["orifices"], cfg["n"], cfg["width"], verbose=verbose)
    rho_b = float(np.mean([r.bulk_density for r in runs]))
    fit = beverloo_fit([r.D for r in runs], [r.rate for r in runs], dim, rho_b)
    rows = []
    for r in runs:
        for t, o, f in zip(r.t, r.out, r.fill, strict=True):
            rows.append((r.D, t, o, f))
    _write_csv(os.path.join(out, f"granular_beverloo{dim}d.csv"), ["D", "t", "discharged_mass", "fill_height"], rows)
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    total = runs[0].out.max() / 0.65 if runs[0].out.max() > 0 else 1.0
    for r in runs:
        axes[0].plot(r.t, r.out, label=f"D = {r.D:g} d: W = {r.rate:.3g}")
    axes[0].set_xlabel("t / sqrt(d/g)")
    axes[0].set_ylabel("discharged mass")
    axes[0].legend(fontsize=8)
    axes[0].set_title("discharge (rate fitted between 20% and 60% out)")
    D = np.array([r.D for r in runs])
    W = np.array([r.rate for r in runs])
    axes[1].loglog(D - fit["k"], W / (rho_b * math.sqrt(G)), "o", label="measured")
    dd = np.linspace(D.min(), D.max(), 50)
    axes[1].loglog(dd - fit["k"], fit["C"] * (dd - fit["k"]) ** fit["b"], "-", label=f"fit: b = {fit['b']:.2f}")
    axes[1].loglog(
        dd - fit["k"],
        fit["C_fixed"] * np.maximum(dd - fit["k_fixed"], 1e-9) ** fit["b_fixed"],
        ":",
        label=f"b = {fit['b_fixed']} fixed: C = {fit['C_fixed']:.2f}, k = {fit['k_fixed']:.2f}",
    )
    axes[1].set_xlabel("(D - k d) / d")
    axes[1].set_ylabel("W / (rho_b sqrt(g) d^(b))")
    axes[1].legend(fontsize=8)
    axes[1].set_title(f"{dim}D Beverloo fit (rho_b = {rho_b:.3f} rho_s)")
    fig.tight_layout()
    fig.savefig(os.path.join(out, f"granular_beverloo{dim}d.png"), dpi=110)
    plt.close(fig)
    del total
    spread = {f"beverloo{dim}d D={r.D:g} window spread": round(float(np.ptp(r.rate_windows) / r.rate), 3) for r in runs}
    return (
        {f"beverloo{dim}d {k}": round(v, 4) if isinstance(v, float) else v for k, v in fit.items()}
        | {f"beverloo{dim}d W(D={r.D:g})": round(r.rate, 4) for r in runs}
        | spread
        | {f"beverloo{dim}d rho_b": round(rho_b, 4)}
    )


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

LAMMPS_SILO = dict(n=1500, width=10.0, D=5.0, mu=0.5, catch=20.0, sample=0.5, out_fraction=0.65)


def lammps_silo_script(
    ks: float, kd: float, kt: float, kd_t: float, mu: float, m: float, R: float, D: float, H: float, catch: float
) -> str:
    """The LAMMPS input of the silo (after ``read_data``/``timestep``, before ``run``): pair
    gran/hooke/history with our ks, kt, mu and the dashpots as LAMMPS's mass-scaled gammas (gamma =
    kd / m_eff), integrated by nve/sphere. The walls, in the granular form of the same law that
    peer_lammps uses (hooke, damping mass_velocity, tangential linear_history):

    - the plate with the orifice: ``fix wall/gran/region`` on the free space around it, the union of
      the half-spaces above (z > 0) and below (z < -1) the plate and the hole (a closed cylinder of
      diameter D from -1.5 to 0.5: LAMMPS's union drops a contact whose point lies inside another of
      its regions, unless that region has open faces, so the hole's caps, inside the half-spaces,
      give no contact, and the plane's contact over the hole is dropped), the complement of our
      Difference(Box, Cylinder);
    - the silo's wall: a cylinder region of radius R from the floor to H, side in, caps open;
    - the catch floor: ``fix wall/gran ... zplane`` at -catch.

    The one difference: LAMMPS's regions give contacts with faces only. Where our plate's rim is an
    edge (a grain over the hole, its centre within a radius of the rim's corner), max(phi_a, -phi_b)
    pushes the grain away from the corner as from a square edge, and LAMMPS's union has no contact
    there (a grain that reaches the hole's lateral face from above meets it only once its centre is
    below the plate's top face, with an overlap of up to a radius at once). Measured: the run
    blows up (energy x 3e7, atoms lost, step 3800 of the 10 d silo): the comparison needs an edge
    contact at the rim in LAMMPS (docs/granular.md, section 4)."""
    ks, kd, kt, kd_t, mu, m, R, D, H, catch = (float(v) for v in (ks, kd, kt, kd_t, mu, m, R, D, H, catch))
    xt = kd_t / kd
    law = f"granular hooke {ks!r} {kd / m!r} damping mass_velocity tangential linear_history {kt!r} {xt!r} {mu!r}"
    return f"""
pair_style gran/hooke/history {ks!r} {kt!r} {kd / (m / 2.0)!r} {kd_t / (m / 2.0)!r} {mu!r} 1
pair_coeff * *
region above plane 0.0 0.0 0.0 0.0 0.0 1.0 side in
region below plane 0.0 0.0 -1.0 0.0 0.0 -1.0 side in
region hole cylinder z 0.0 0.0 {D / 2!r} -1.5 0.5 side in
region free union 3 above below hole
region shell cylinder z 0.0 0.0 {R!r} 0.0 {H!r} side in open 1 open 2
fix floor all wall/gran/region {law} region free
fix shell all wall/gran/region {law} region shell
fix catch all wall/gran {law} zplane {-catch!r} NULL
fix grav all gravity {G!r} vector 0.0 0.0 -1.0
fix int all nve/sphere
region gone block INF INF INF INF INF -3.0
variable nout equal count(all,gone)
"""


def lammps_silo(verbose: bool = True) -> dict:
    """The silo of LAMMPS_SILO filled and settled here (orifice closed), then discharged from that
    same state (positions, velocities, spins; no contact history) by a World and by LAMMPS; the
    discharged count every ``sample``, and the rates over the middle of the discharge."""
    import subprocess
    import tempfile

    from .peer_lammps import Lammps, _data_file, find_lammps

    cfg = LAMMPS_SILO
    lmp = find_lammps()
    if not isinstance(lmp, Lammps):
        raise RuntimeError(lmp)
    dim, width, D, mu, catch = 3, cfg["width"], cfg["D"], cfg["mu"], cfg["catch"]
    x, radii, masses, contact, h0 = silo_scene(dim, int(cfg["n"]), width)
    n = len(x)
    H = h0 + 4.0
    terrain = silo_terrain(dim, width, D, H, catch)
    kw = spin_kwargs(dim, mu)
    w = make_world(x, radii, masses, contact, terrain, **kw)
    w.step(int(round((2.0 * math.sqrt(2.0 * h0) + 5.0) / w.dt)))
    settle(w, 60.0, tol=1e-6, chunk=2.0, drag=0.02)
    x0, v0, w0 = w.positions.copy(), w.velocities.copy(), w.angular_velocities.copy()
    # ours: a fresh World from the settled state, the closing plane left out
    open_terrain = [t for k, t in enumerate(silo_terrain(dim, width, D, H, catch)) if k != 2]
    ours = World(x0, radii, masses, v0, dt=w.dt, **dict(terrain=open_terrain, ks=contact.ks, kd=contact.kd, **kw))
    ours.angular_velocities = w0
    steps = int(round(cfg["sample"] / w.dt))
    total_time = 0.0
    counts = [0]
    gone = np.zeros(n, dtype=bool)
    tick = time.time()
    while counts[-1] < cfg["out_fraction"] * n and total_time < 400.0:
        ours.step(steps)
        total_time += steps * w.dt
        gone |= ours.positions[:, 2] < -3.0
        counts.append(int(gone.sum()))
    t_ours = time.time() - tick
    t = np.arange(len(counts)) * steps * w.dt
    m = float(masses[0])
    # LAMMPS: the same state, run as long
    lo = [-width / 2 - 60.0, -width / 2 - 60.0, -catch - 2.0]
    hi = [width / 2 + 60.0, width / 2 + 60.0, H + 10.0]
    script = "units si\natom_style sphere\natom_modify map array\nboundary f f f\ncomm_modify vel yes\n"
    script += "read_data state.data\n"
    script += lammps_silo_script(contact.ks, contact.kd, ours.kt, ours.kd_t, mu, m, width / 2, D, H, catch)
    script += f"neighbor {0.2!r} bin\nneigh_modify delay 0 every 1 check yes\ntimestep {w.dt!r}\n"
    script += f"fix series all ave/time {steps} 1 {steps} v_nout file series.txt\nthermo {steps * 20}\n"
    script += f"run {steps * (len(counts) - 1)}\n"
    tick = time.time()
    with tempfile.TemporaryDirectory(prefix="penalty_env-silo-") as tmp:
        _data_file(os.path.join(tmp, "state.data"), x0, v0, radii, masses, lo, hi, w0)
        with open(os.path.join(tmp, "in.silo"), "w") as f:
            f.write(script)
        cmd = [lmp.lmp, "-in", "in.silo", "-log", "none", "-echo", "none", "-sf", "omp", "-pk", "omp", "1"]
        res = subprocess.run(cmd, cwd=tmp, env=dict(lmp.env, OMP_NUM_THREADS="1"), capture_output=True, text=True)
        if res.returncode != 0:
            raise RuntimeError(f"LAMMPS failed: {(res.stdout + res.stderr)[-2000:]}")
        rows = np.loadtxt(os.path.join(tmp, "series.txt"), comments="#", ndmin=2)
    t_lammps = time.time() - tick
    lt = np.concatenate([[0.0], rows[:, 0] * w.dt])
    lc = np.concatenate([[0.0], rows[:, 1]])
    rate_ours, win_ours = discharge_rate(t, np.array(counts, float) * m, n * m)
    rate_lmp, win_lmp = discharge_rate(lt, lc * m, n * m)
    if verbose:
        print(f"  ours {t_ours:.0f} s, LAMMPS {t_lammps:.0f} s ({lmp.version})", flush=True)
    return dict(
        t=t,
        counts=np.array(counts),
        t_lammps=lt,
        counts_lammps=lc,
        rate=rate_ours,
        rate_lammps=rate_lmp,
        windows=win_ours,
        windows_lammps=win_lmp,
        n=n,
        m=m,
        dt=w.dt,
        ks=contact.ks,
        kd=contact.kd,
        version=lmp.version,
        seconds=(t_ours, t_lammps),
    )


def case_lammps(out: str) -> dict:
    r = lammps_silo()
    rows = [("penalty_env", a, b) for a, b in zip(r["t"], r["counts"], strict=True)]
    rows += [("lammps", a, b) for a, b in zip(r["t_lammps"], r["counts_lammps"], strict=True)]
    _write_csv(os.path.join(out, "granular_lammps.csv"), ["code", "t", "discharged_grains"], rows)
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.plot(r["t"], r["counts"], label=f"penalty_env: W = {r['rate'] / r['m']:.3g} grains / sqrt(d/g)")
    ax.plot(r["t_lammps"], r["counts_lammps"], "--", label=f"LAMMPS: W = {r['rate_lammps'] / r['m']:.3g}")
    ax.axhspan(0.2 * r["n"], 0.6 * r["n"], color="0.9", label="fitted span (20% to 60% out)")
    ax.set_xlabel("t / sqrt(d/g)")
    ax.set_ylabel("discharged grains")
    ax.set_title(f"3D silo, D = {LAMMPS_SILO['D']:g} d, mu = {LAMMPS_SILO['mu']}: the same state in both codes")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "granular_lammps.png"), dpi=110)
    plt.close(fig)
    return {
        "lammps rate ours (grains/time)": round(r["rate"] / r["m"], 4),
        "lammps rate LAMMPS (grains/time)": round(r["rate_lammps"] / r["m"], 4),
        "lammps relative difference": round(r["rate"] / r["rate_lammps"] - 1.0, 4),
        "lammps seconds (ours, LAMMPS)": tuple(round(s) for s in r["seconds"]),
    }

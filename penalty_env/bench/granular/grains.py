"""The grains and the numbers every granular case shares: the units (g, the solid density), the
contact law's spring, dashpot and time step for a bed of a given depth (``Contact``), a World
built on them (``make_world``), random non-overlapping starting positions, settling (stepping until
the kinetic energy per grain falls below a tolerance), the friction arguments and the box a bed is
poured into."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...physics import Box, Plane, World, theory

G = 1.0  # gravity
RHO_S = 1.0  # solid density
RESTITUTION = 0.5
STEPS_PER_CONTACT = 15  # dt = t_c / this (DEM practice: t_c / 10 to t_c / 50)


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

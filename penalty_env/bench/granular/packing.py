"""Case ``packing3d``/``packing2d``: grains poured into a box and settled (``pour_bed``), the solid
fraction of the bed's interior (``solid_fraction``) against random close packing, and the case that
runs both friction coefficients and draws the beds (``case_packing``)."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np

from .grains import (
    RHO_S,
    Contact,
    G,
    box_terrain,
    grain_mass,
    kinetic_per_grain,
    make_world,
    mean_overlap,
    random_sequential,
    settle,
    spin_kwargs,
)
from .output import _plt, _write_csv

# Published values the figures are compared with (docs/granular.md names the sources).
RCP_3D = 0.64  # Scott and Kilgour 1969; Berryman 1983
JAMMING_2D = 0.84  # O'Hern, Silbert, Liu and Nagel 2003, bidisperse disks 1:1.4


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

"""Cases ``beverloo2d``/``beverloo3d``: a flat-bottomed silo discharging through a slot (2D) or a
round orifice (3D) (``discharge``), the rate over the middle of the discharge
(``discharge_rate``), the fit of Beverloo's law to the rates (``beverloo_fit``), and the case that
runs the orifices over several fills, writes their CSV (read back by ``read_beverloo_csv``) and
draws the fit (``case_beverloo``, ``beverloo_table``, ``beverloo_summary``)."""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, field

import numpy as np

from ...physics import Box, Cylinder, Difference, Plane
from .grains import RHO_S, Contact, G, grain_mass, make_world, random_sequential, settle, spin_kwargs
from .output import _plt, _write_csv
from .packing import solid_fraction

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
# The case
# ----------------------------------------------------------------------------------------------


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

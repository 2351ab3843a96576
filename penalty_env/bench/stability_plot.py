"""The charts of ``python -m penalty_env.bench stability`` (:mod:`penalty_env.bench.stability`): the
stability map against the theory, and the tunnelling outcomes against the predicted boundaries.
"""

from __future__ import annotations

import math

import numpy as np

from ..physics import theory
from .stability_runs import GROWING, INTEGRATORS, SHORT, TUN_KS, TUN_M, TUN_PHASES, TUN_R, TUN_ZETA


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

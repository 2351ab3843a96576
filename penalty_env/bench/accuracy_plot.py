"""The charts and tables of ``python -m penalty_env.bench accuracy`` (:mod:`penalty_env.bench.accuracy`):
error against cost per scenario (with the Pareto front and configure's choice), the measured
convergence orders, and the README's markdown tables.
"""

from __future__ import annotations

import math
import os

import numpy as np

from ..physics import configure as CF
from ..physics import theory
from .accuracy_fit import FLOOR
from .accuracy_sweep import INTEGRATORS, supported

# --------------------------------------------------------------------------------------------
# Charts
# --------------------------------------------------------------------------------------------

PANELS = [
    ("pair", "restitution", "1. pair collision: restitution"),
    ("pair", "duration", "1. pair collision: contact duration"),
    ("drop", "restitution", "2. ball into bowl: rebound restitution"),
    ("drop", "peak_overlap", "2. ball into bowl: peak overlap"),
    ("rest", "resting_overlap", "3. resting: overlap vs m g / ks"),
    ("elastic_pile", "energy_drift", "4. elastic pile (kd = 0): energy drift"),
    ("damped_pile", "trajectory", "5. damped pile: position error / r"),
]
COLORS = {
    "explicit_euler": "tab:red",
    "symplectic_euler": "tab:blue",
    "velocity_verlet": "tab:green",
    "rk4": "tab:purple",
    "implicit_euler": "tab:orange",
}
SHORT = {
    "explicit_euler": "explicit Euler",
    "symplectic_euler": "symplectic Euler",
    "velocity_verlet": "velocity Verlet",
    "rk4": "RK4",
    "implicit_euler": "implicit Euler",
}


def _pareto(points):
    """Lower-left front of (cost, error) points."""
    pts = sorted(points)
    front = []
    best = math.inf
    for c, e in pts:
        if e < best:
            front.append((c, e))
            best = e
    return front


def _panel(ax, rows, scen, metric, label, damping, zeta, cost, auto, floor=1e-13):
    """One scenario and metric: error against cost, one line per method, diverged runs as crosses
    along the top, the Pareto front, and configure's choice as a star."""
    import matplotlib.ticker

    z = 0.0 if scen == "elastic_pile" else zeta
    d = "linear" if scen == "elastic_pile" else damping
    sel = [r for r in rows if r["scenario"] == scen and r["metric"] == metric and r["zeta"] == z and r["damping"] == d]
    if not sel:
        ax.set_title(label + " (n/a)", fontsize=8)
        ax.axis("off")
        return
    good = [r for r in sel if not r["diverged"] and r["error"] > 0 and math.isfinite(r[cost])]
    top = max([r["error"] for r in good] + [1.0]) * 3
    for integ in INTEGRATORS:
        for ev in (0, 1):
            pts = sorted(
                (r[cost], max(r["error"], floor)) for r in good if r["integrator"] == integ and r["events"] == ev
            )
            if pts:
                ax.plot(
                    *zip(*pts),
                    color=COLORS[integ],
                    ls="--" if ev else "-",
                    marker="o" if ev else ".",
                    ms=3,
                    lw=1.2 if ev else 1.0,
                    label=f"{SHORT[integ]}{' + events' if ev else ''}",
                )
            bad = [r for r in sel if r["diverged"] and r["integrator"] == integ and r["events"] == ev]
            if bad:
                xs = [_nominal_cost(r, cost, sel) for r in bad]
                ax.plot(xs, [top] * len(xs), ls="none", marker="x", color=COLORS[integ], ms=5)
    front = _pareto([(r[cost], max(r["error"], floor)) for r in good])
    if front:
        ax.step(*zip(*front), where="post", color="0.5", lw=3, alpha=0.35, zorder=0)
    if auto is not None and scen in ("pair", "drop", "rest"):
        integ, ev, spc = auto
        near = [r for r in good if r["integrator"] == integ and r["events"] == int(ev)]
        if len(near) >= 2:
            # configure's steps per contact, placed along its method's measured line (log-log)
            c_s = np.array([r["steps_per_contact"] for r in near], float)
            o = np.argsort(c_s)
            c_c = np.log(np.array([r[cost] for r in near]))[o]
            c_e = np.log(np.array([max(r["error"], floor) for r in near]))[o]
            xc = float(np.exp(np.interp(np.log(spc), np.log(c_s[o]), c_c)))
            ye = float(np.exp(np.interp(np.log(spc), np.log(c_s[o]), c_e)))
            ax.plot([xc], [ye], marker="*", ms=14, color="gold", mec="k", zorder=5)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylim(floor, top * 2)
    ax.grid(True, which="major", alpha=0.3)
    ax.set_title(label, fontsize=9)
    ax.set_xlabel(
        "force evaluations / simulated s" if cost == "evals_per_sim_s" else "wall s / simulated s (per world)",
        fontsize=8,
    )
    ax.set_ylabel("worst-case relative error", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())


def _legend(fig, ax, accuracy, **kw):
    from matplotlib.lines import Line2D

    handles, labels = ax.get_legend_handles_labels()
    handles += [
        Line2D([], [], ls="none", marker="x", color="k"),
        Line2D([], [], color="0.5", lw=3, alpha=0.35),
        Line2D([], [], ls="none", marker="*", ms=12, color="gold", mec="k"),
    ]
    labels += ["diverged", "Pareto front", f"configure(accuracy={accuracy:g})"]
    fig.legend(handles, labels, frameon=False, fontsize=8, **kw)


def _auto_or_none(zeta, damping, accuracy):
    try:
        return _auto_choice(zeta, damping, accuracy) if CF.ERROR_MODELS else None
    except ValueError:
        return None


def plot(rows, path, damping, zeta, cost="evals_per_sim_s", accuracy=0.01, title=None):
    """Every scenario for one damping mode and zeta (zeta = 0 in the elastic pile)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = [p for p in PANELS if any(r["scenario"] == p[0] and r["metric"] == p[1] for r in rows)]
    ncol = 4
    nrow = math.ceil(len(panels) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.0 * ncol, 3.3 * nrow), squeeze=False)
    for ax in axes.flat[len(panels) :]:
        ax.axis("off")
    auto = _auto_or_none(zeta, damping, accuracy)
    for ax, (scen, metric, label) in zip(axes.flat, panels):
        _panel(ax, rows, scen, metric, label, damping, zeta, cost, auto)
    _legend(fig, axes.flat[0], accuracy, loc="lower right", ncol=2, bbox_to_anchor=(0.99, 0.02))
    fig.suptitle(
        title or f"Speed against accuracy: damping {damping}, zeta = {zeta:g} (zeta = 0 in panel 4)", fontsize=11
    )
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    fig.savefig(path, dpi=60)
    plt.close(fig)


MORE_PANELS = [
    ("pair", "restitution", "pair: restitution"),
    ("drop", "peak_overlap", "ball into bowl: peak overlap"),
    ("rest", "resting_overlap", "resting overlap"),
    ("damped_pile", "trajectory", "damped pile: position / r"),
]


def plot_more(rows, path, combos=(("linear", 0.1), ("no_tension", 0.1), ("no_tension", 0.3)), accuracy=0.01):
    """The other zetas and the no-tension mode, four panels per row."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(combos), len(MORE_PANELS), figsize=(16, 3.1 * len(combos) + 0.6), squeeze=False)
    for row, (damping, zeta) in zip(axes, combos):
        auto = _auto_or_none(zeta, damping, accuracy)
        for ax, (scen, metric, label) in zip(row, MORE_PANELS):
            _panel(ax, rows, scen, metric, f"{damping}, zeta {zeta:g}: {label}", damping, zeta, "evals_per_sim_s", auto)
    _legend(fig, axes[0, 0], accuracy, loc="lower center", ncol=7)
    fig.suptitle("Speed against accuracy: other damping ratios and the no-tension mode", fontsize=11)
    fig.tight_layout(rect=(0, 0.07, 1, 0.96))
    fig.savefig(path, dpi=60)
    plt.close(fig)


def _nominal_cost(r, cost, sel):
    """Cost of a diverged run, read off the same method's finite runs at the same steps per contact."""
    same = [
        q[cost]
        for q in sel
        if q["integrator"] == r["integrator"]
        and q["events"] == r["events"]
        and q["steps_per_contact"] == r["steps_per_contact"]
        and math.isfinite(q[cost])
    ]
    if same:
        return same[0]
    ref = [
        q
        for q in sel
        if q["steps_per_contact"] == r["steps_per_contact"]
        and math.isfinite(q[cost])
        and q["integrator"] == "symplectic_euler"
        and not q["events"]
    ]
    if ref and cost == "evals_per_sim_s":
        return ref[0][cost] * {"rk4": 4}.get(r["integrator"], 1)
    finite = [q[cost] for q in sel if math.isfinite(q[cost])]
    return min(finite) if finite else 1.0


def _auto_choice(zeta, damping, accuracy):
    """(integrator, events, steps per contact) that configure picks for one contact of this zeta."""
    best = None
    for integ in INTEGRATORS:
        if not supported(integ, damping):
            continue
        for ev in (False, True):
            need = max(CF._steps_needed(integ, ev, damping, zeta, accuracy, mt) for mt in CF.METRICS)
            if not math.isfinite(need):
                continue
            spc = CF.SAFETY * need
            # the stability guard, in steps per contact
            crit = theory.guard_omega_dt(integ, zeta)
            if math.isfinite(crit):
                if crit <= 0:
                    continue
                spc = max(spc, math.pi / math.sqrt(1 - zeta * zeta) / crit)
            c = CF.config_cost(integ, ev, spc)
            if best is None or c < best[0]:
                best = (c, integ, ev, spc)
    if best is None:
        raise ValueError("no configuration")
    return best[1:]


def make_charts(rows, out, quick=False):
    paths = []
    p = os.path.join(out, "accuracy_linear_zeta0.3.png")
    plot(rows, p, "linear", 0.3)
    paths.append(p)
    p = os.path.join(out, "accuracy_walltime.png")
    plot(
        rows,
        p,
        "linear",
        0.3,
        cost="wall_per_sim_s",
        title="Speed against accuracy: wall time per simulated second (same runs), damping linear, zeta = 0.3",
    )
    paths.append(p)
    if not quick:
        p = os.path.join(out, "accuracy_more.png")
        plot_more(rows, p)
        paths.append(p)
    return paths


def order_table(rows, damping="linear", zeta=0.3, scenario="pair", metric="restitution", spcs=(16, 32, 64, 128)):
    """Measured convergence order (slope of log error against log steps per contact) per method."""
    out = {}
    for integ in INTEGRATORS:
        for ev in (0, 1):
            pts = {
                r["steps_per_contact"]: r["error"]
                for r in rows
                if r["scenario"] == scenario
                and r["metric"] == metric
                and r["integrator"] == integ
                and r["events"] == ev
                and r["damping"] == damping
                and r["zeta"] == zeta
                and not r["diverged"]
            }
            s = [k for k in spcs if k in pts and pts[k] > FLOOR]
            if len(s) >= 2:
                out[(integ, ev)] = float(-np.polyfit(np.log(s), np.log([pts[k] for k in s]), 1)[0])
    return out


def error_table(rows, scenario="pair", metric="restitution", damping="linear", zeta=0.3, spcs=(8, 16, 32, 64, 128)):
    """Markdown table of the worst-case error per method at some steps per contact."""
    lines = ["| method | " + " | ".join(f"{s} steps" for s in spcs) + " |", "|---" * (len(spcs) + 1) + "|"]
    for integ in INTEGRATORS:
        for ev in (0, 1):
            cells = []
            for spc in spcs:
                r = [
                    q
                    for q in rows
                    if q["scenario"] == scenario
                    and q["metric"] == metric
                    and q["integrator"] == integ
                    and q["events"] == ev
                    and q["damping"] == damping
                    and q["zeta"] == zeta
                    and q["steps_per_contact"] == spc
                ]
                cells.append("diverged" if r and r[0]["diverged"] else (f"{100 * r[0]['error']:.2g}%" if r else "-"))
            lines.append(f"| {SHORT[integ]}{' + events' if ev else ''} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def recommendation_table(accuracies=(0.1, 0.03, 0.01, 1e-3, 1e-4), restitutions=(0.9, 0.5, 0.2), damping="linear"):
    """Markdown table of what :func:`configure` picks (one isolated contact, no gravity)."""
    lines = [
        "| restitution accuracy | " + " | ".join(f"e = {e:g}" for e in restitutions) + " |",
        "|---" * (len(restitutions) + 1) + "|",
    ]
    for acc in accuracies:
        cells = []
        for e in restitutions:
            try:
                c = CF.configure([1.0, 1.0], [0.1, 0.1], 1.0, 0.05, e, acc, damping=damping)
                cells.append(
                    f"{SHORT[c.integrator]}{' + events' if c.events else ''}, {c.steps_per_contact:.0f} steps "
                    f"({c.cost_per_contact:.0f})"
                )
            except ValueError:
                cells.append("none measured")
        lines.append(f"| {100 * acc:g}% | " + " | ".join(cells) + " |")
    return "\n".join(lines)

"""Seconds to a trained policy: ``python -m penalty_env.bench train``.

For each id and seed, ``train/train_ppo.py`` runs twice, alternately: with the id's tuned settings
(``train/_tuned.py``, the script's defaults) and with the settings every id had before they were
tuned (``_tuned.LEGACY``, the same-run reference). Each run evaluates its policy on the same 100
held-out episodes every ``EVAL_FREQ[id]`` environment steps, with either setting (the
evaluations are timed apart from the training; a sand id's first stage evaluates at its own id's
interval) and stops at the first evaluation with at least 90% success, or at its budget.
A sand id's tuned run includes its curriculum's first stage, whose training time counts.

Prints, and writes to ``--out`` (``train_times.csv``, ``train_times.md``,
``train_curves.png``):

- per id, setting and seed, the training time (s) and environment steps to 50%, 80% and 90%
  held-out success ("-": not reached within the budget);
- the medians (the upper one of an even count), and the ratio legacy / tuned of the median times to 90% (a run that never reached
  90% sorts after those that did; when the legacy median is such a run, its whole training time
  stands in and the ratio is a lower bound, marked ">");
- where the time went (medians over seeds): env stepping, policy inference and SB3's rollout
  bookkeeping, the PPO update, and the evaluations;
- a chart of held-out success against training time.

Each run is a subprocess (its own torch and Numba threads), in ``--out/<id>/<setting>-seed<s>``;
``--resume`` reuses the runs already there. Needs the repository's ``train/`` folder and the
``train`` extra. ``--figures DIR`` also writes the chart and the table into DIR, and ``--readme``
the README's time-to-90% lines (``bench figures`` passes both, with docs/).
"""

from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

IDS = ("PenaltyBalls-v0", "PenaltyBalls-v1", "PenaltyBallsSand-v1")
THRESHOLDS = (0.5, 0.8, 0.9)
SETTINGS = ("legacy", "tuned")
# held-out evaluation every this many env steps, the same for both settings of an id
EVAL_FREQ = {"PenaltyBalls-v0": 16_384, "PenaltyBalls-v1": 32_768, "PenaltyBallsSand-v1": 131_072}


def train_dir() -> Path:
    """The repository's ``train/`` folder (this bench runs its script)."""
    d = Path(__file__).resolve().parents[2] / "train"
    if not (d / "train_ppo.py").is_file():
        raise SystemExit(f"bench train needs the repository's train/ folder next to the package; not found at {d}")
    return d


def legacy_args() -> list[str]:
    sys.path.insert(0, str(train_dir()))
    import _tuned

    flags = []
    for key, value in _tuned.LEGACY.items():
        if value is False:
            flags.append("--no-" + key.replace("_", "-"))
        else:
            flags += ["--" + key.replace("_", "-"), str(value)]
    return flags


def run_one(env_id: str, setting: str, seed: int, out: Path, eval_freq: int, resume: bool) -> dict[str, Any]:
    summary = out / "summary.json"
    if not (resume and summary.is_file()):
        cmd = [sys.executable, str(train_dir() / "train_ppo.py"), "--env-id", env_id, "--seed", str(seed)]
        cmd += ["--quiet", "--no-gif", "--stop-at", "0.9", "--out", str(out)]
        if setting == "legacy":
            cmd += legacy_args() + ["--no-curriculum"]
        cmd += ["--eval-freq", str(eval_freq)]  # after the legacy flags: both settings evaluate alike
        res = subprocess.run(cmd, capture_output=True, text=True)
        if res.returncode != 0:
            raise SystemExit(f"{' '.join(cmd)} failed:\n{res.stdout[-2000:]}\n{res.stderr[-4000:]}")
    return json.loads(summary.read_text())


def timeline(summary: dict[str, Any]) -> tuple[list[float], list[int], list[float]]:
    """(training time, env steps, success) at each evaluation, a curriculum's first stage first."""
    t0, n0 = 0.0, 0
    times, steps, succ = [], [], []
    for part in ([summary["curriculum"]] if "curriculum" in summary else []) + [summary]:
        for p in part["curve"]:
            times.append(t0 + p["train_time_s"])
            steps.append(n0 + p["timesteps"])
            succ.append(p["success_rate"] if part is summary else 0.0)  # the first stage is not this id
        t0 += part["train_time_s"]
        n0 += part["timesteps"]
    return times, steps, succ


def time_to(summary: dict[str, Any], threshold: float) -> tuple[float | None, int | None]:
    times, steps, succ = timeline(summary)
    for t, n, s in zip(times, steps, succ, strict=True):
        if s >= threshold:
            return t, n
    return None, None


def total_train_time(summary: dict[str, Any]) -> float:
    return float(summary.get("total_train_time_s", summary["train_time_s"]))


def main(argv=None) -> None:
    p = argparse.ArgumentParser(prog="python -m penalty_env.bench train", description=__doc__)
    p.add_argument("--ids", default=",".join(IDS), help="comma-separated ids (default: %(default)s)")
    p.add_argument(
        "--seeds",
        action="append",
        default=[],
        metavar="N or ID=N",
        help="seeds 0..N-1 per id and setting (default: 5); ID=N sets one id's, e.g. PenaltyBallsSand-v1=2",
    )
    p.add_argument("--settings", default=",".join(SETTINGS), help="legacy,tuned or one of them")
    p.add_argument("--out", type=Path, default=Path("runs/bench-train"), help="run folders and results")
    p.add_argument("--resume", action="store_true", help="reuse the runs already in --out")
    p.add_argument("--figures", type=Path, default=None, metavar="DIR", help="also write the chart and table here")
    p.add_argument(
        "--readme",
        action="store_true",
        help="write the README's lines between BEGIN TRAIN TIMES and END TRAIN TIMES (a source checkout)",
    )
    args = p.parse_args(argv)
    ids = [i for i in args.ids.split(",") if i]
    settings = [s for s in args.settings.split(",") if s]
    for s in settings:
        if s not in SETTINGS:
            raise SystemExit(f"--settings: {s!r} is not one of {SETTINGS}")
    n_seeds = seeds_per_id(args.seeds, ids)
    results: dict[tuple[str, str, int], dict[str, Any]] = {}
    for env_id in ids:
        for seed in range(n_seeds[env_id]):
            for setting in settings:  # alternately, so that a slow spell of the machine hits both
                out = args.out / env_id / f"{setting}-seed{seed}"
                summ = run_one(env_id, setting, seed, out, EVAL_FREQ.get(env_id, 32_768), args.resume)
                results[env_id, setting, seed] = summ
                t90, n90 = time_to(summ, 0.9)
                reached = f"90% in {t90:.1f} s ({n90:,} steps)" if t90 is not None else "90% not reached"
                print(f"{env_id:22s} {setting:6s} seed {seed}: {reached}; final {summ['success_rate']:.0%}", flush=True)
    report(results, ids, settings, max(n_seeds.values()), args.out, args.figures)
    if args.readme:
        from .figures import replace_block

        readme = train_dir().parent / "README.md"
        block = (args.out / "readme_lines.md").read_text()
        text = replace_block(readme.read_text(), "<!-- BEGIN TRAIN TIMES -->", "<!-- END TRAIN TIMES -->", block)
        readme.write_text(text)
        print(f"updated {readme}'s time-to-90% lines")


def seeds_per_id(specs: list[str], ids: list[str]) -> dict[str, int]:
    """``--seeds`` values ("5", "PenaltyBallsSand-v1=2") as a count per id."""
    n = {env_id: 5 for env_id in ids}
    for spec in specs:
        key, _, value = spec.rpartition("=")
        if not value.isdigit() or int(value) < 1 or (key and key not in n):
            raise SystemExit(f"--seeds: expected N or ID=N with N >= 1 and ID one of {ids}, got {spec!r}")
        for env_id in [key] if key else ids:
            n[env_id] = int(value)
    return n


def upper_median(values: list[float]) -> float:
    """The median, the upper of the two middle values of an even count (as the tables' times)."""
    return sorted(values)[len(values) // 2]


def _fmt(t: float | None, n: int | None) -> str:
    return "-" if t is None or n is None else f"{t:.1f} s / {n / 1e3:.0f}k"


def report(results, ids, settings, n_seeds, out: Path, figures: Path | None) -> None:
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for (env_id, setting, seed), summ in sorted(results.items()):
        row: dict[str, Any] = {"env_id": env_id, "setting": setting, "seed": seed}
        for th in THRESHOLDS:
            t, n = time_to(summ, th)
            row[f"t{int(th * 100)}_s"] = None if t is None else round(t, 2)
            row[f"steps{int(th * 100)}"] = n
        row["train_time_s"] = round(total_train_time(summ), 2)
        row["final_success"] = summ["success_rate"]
        split = dict(summ["time_split"])
        if "curriculum" in summ:  # the first stage's time counts, its split too
            row["curriculum_s"] = summ["curriculum"]["train_time_s"]
            for key, value in summ["curriculum"]["time_split"].items():
                split[key] = round(split[key] + value, 2)
        row.update(split)
        rows.append(row)
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with open(out / "train_times.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)

    lines = [
        "| id | setting | seed | to 50% | to 80% | to 90% | success where it stopped (100 other held-out episodes) |",
        "|---" * 7 + "|",
    ]
    for (env_id, setting, seed), summ in sorted(results.items()):
        cells = [_fmt(*time_to(summ, th)) for th in THRESHOLDS]
        lines.append(f"| {env_id} | {setting} | {seed} | " + " | ".join(cells) + f" | {summ['success_rate']:.0%} |")
    lines += ["", "| id | median to 90%, legacy | median to 90%, tuned | legacy / tuned |", "|---|---|---|---|"]
    for env_id in ids:
        med = {setting: median_time_to_90(_runs(results, env_id, setting, n_seeds)) for setting in settings}
        leg, tun = med.get("legacy"), med.get("tuned")
        cell = lambda m: "-" if m is None else (f"{m[0]:.1f} s" if m[1] else f"> {m[0]:.1f} s (not reached)")  # noqa: E731
        ratio = "-"
        if leg is not None and tun is not None and tun[1]:
            ratio = f"{'' if leg[1] else '> '}{leg[0] / tun[0]:.1f}x"
        lines.append(f"| {env_id} | {cell(leg)} | {cell(tun)} | {ratio} |")
    lines += ["", "Where the training time went (medians over seeds, s; a curriculum's first stage included):", ""]
    parts = ("env_step_s", "policy_and_rollout_s", "update_s", "evaluation_s")
    lines += [
        "| id | setting | env stepping | policy and rollout | update | evaluation (not training) |",
        "|---" * 6 + "|",
    ]
    for env_id in ids:
        for setting in settings:
            rs = [r for r in rows if r["env_id"] == env_id and r["setting"] == setting]
            if rs:
                cells = [f"{upper_median([r[k] for r in rs]):.1f}" for k in parts]
                lines.append(f"| {env_id} | {setting} | " + " | ".join(cells) + " |")
    table = "\n".join(lines) + "\n"
    (out / "readme_lines.md").write_text(readme_lines(results, ids, n_seeds))
    print(table)
    for folder in [out] + ([figures] if figures is not None else []):
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "train_times.md").write_text(table)
        with open(folder / "train_times.csv", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=keys)
            w.writeheader()
            w.writerows(rows)
        plot(results, ids, settings, folder / "train_curves.png")


def _runs(results, env_id: str, setting: str, n_seeds: int) -> list[dict[str, Any]]:
    return [results[env_id, setting, seed] for seed in range(n_seeds) if (env_id, setting, seed) in results]


def median_time_to_90(runs: list[dict[str, Any]]) -> tuple[float, bool] | None:
    """The median over ``runs`` of the training time to 90% (the upper of the two middle values
    of an even count), and whether that run reached it: a run that never did sorts after every
    one that did and stands in with its whole training time. None for no runs."""
    if not runs:
        return None
    ts = []
    for summ in runs:
        t, _ = time_to(summ, 0.9)
        ts.append((t, True) if t is not None else (total_train_time(summ), False))
    ts.sort(key=lambda v: (not v[1], v[0]))
    return ts[len(ts) // 2]


def readme_lines(results, ids, n_seeds) -> str:
    """One line per id for the README: the tuned run's median time to 90% and its command."""
    lines = []
    for env_id in ids:
        runs = _runs(results, env_id, "tuned", n_seeds)
        med = median_time_to_90(runs)
        if med is None:
            continue
        reached = sum(time_to(r, 0.9)[0] is not None for r in runs)
        when = f"{med[0]:.0f} s" if med[1] else "not reached"
        cmd = "python train/train_ppo.py" + ("" if env_id == "PenaltyBalls-v0" else f" --env-id {env_id}")
        lines.append(
            f"- `{env_id}`: 90% in {when} of training (median of {len(runs)} seeds; {reached} of {len(runs)} "
            f"reached 90% before the stop): `{cmd}`"
        )
    return "\n".join(lines) + "\n"


def plot(results, ids, settings, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(ids), figsize=(4.5 * len(ids), 3.6), squeeze=False)
    colours = {"legacy": "tab:gray", "tuned": "tab:blue"}
    for ax, env_id in zip(axes[0], ids, strict=True):
        for (eid, setting, seed), summ in sorted(results.items()):
            if eid != env_id:
                continue
            times, _, succ = timeline(summ)
            label = setting if seed == 0 else None
            ax.plot(times, succ, "-", color=colours[setting], alpha=0.7, lw=1.2, label=label)
        ax.axhline(0.9, color="green", ls=":", lw=1)
        ax.set_xscale("log")
        ax.set_ylim(-0.02, 1.02)
        ax.set_xlabel("training time (s, log)")
        ax.set_ylabel("held-out success")
        ax.set_title(env_id, fontsize=10)
        ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


if __name__ == "__main__":
    main()

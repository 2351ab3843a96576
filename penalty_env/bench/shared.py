"""Training on a shared machine: ``python -m penalty_env.bench shared``.

Times ``train/train_ppo.py`` (the default command: PenaltyBalls-v0 with its tuned settings, on a
reduced budget) in three situations, in rounds within one invocation:

- **alone**: one run;
- **two together**: two runs started at the same moment (seeds 0 and 1), the commonest way to use
  two cores; each run's time against the round's run alone;
- **beside busy loops**: one run beside ``--busy`` (2) processes that spin (``python -c "while
  True: pass"``), started before it and stopped after; its time against the round's run alone.

The figure is each run's ``train_time_s`` (its summary.json: collecting rollouts and updating,
without the start-up, the compile and the evaluations). The ratios are taken within a round, so a
slow spell of the machine hits both sides; the order of the situations alternates from round to
round, and the medians over rounds are printed against the targets: two together at most
:data:`TARGET_TWO` x alone, beside the busy loops at most :data:`TARGET_BUSY` x alone.

The load average and the number of runnable tasks are printed at each situation's start, and the
torch threads each run used (``--threads auto`` takes 2 only while nothing else runs): "alone" is
alone only when nothing else runs, and other jobs raise every figure of the round.

The budget (``--timesteps``, default 262,144 steps: about 5 s of training alone, a quarter of the
default command's) keeps the bench to a few minutes; the ratios are those of the whole run,
because every rollout and update of a run costs the same (measured: 131,072 steps and 1 M steps
gave the same ratios within the machine's noise). Evaluations are timed apart from the training
and cut to 20 episodes.

``--checkout DIR`` runs another tree's ``train/train_ppo.py`` on that tree's ``penalty_env`` (the
figures before a change, e.g. a ``git archive`` of the commit before); ``--train-args`` adds
flags to every run (e.g. ``--train-args="--threads 2"``). Writes ``shared.json`` and
``shared.md`` into ``--out``.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

TARGET_TWO = 2.5  # two runs started together: each at most this many times one run alone
TARGET_BUSY = 3.0  # one run beside two busy loops: at most this many times its time alone
SITUATIONS = ("alone", "two", "busy")
EVAL_EPISODES = 20  # the runs' held-out evaluations: not timed, cut to keep the bench short


def repository() -> Path:
    """This checkout (its ``train/`` folder holds the script)."""
    return Path(__file__).resolve().parents[2]


def load_now() -> dict[str, float]:
    """The 1-minute load average and the other runnable tasks right now (``/proc/loadavg``, Linux:
    the runnable tasks less this one, which reads it)."""
    out = {"load1": round(os.getloadavg()[0], 2)}
    try:
        out["runnable"] = float(Path("/proc/loadavg").read_text().split()[3].split("/")[0]) - 1.0
    except (OSError, IndexError, ValueError):
        pass
    return out


def cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def train_command(checkout: Path, out: Path, seed: int, timesteps: int, extra: list[str]) -> list[str]:
    script = checkout / "train" / "train_ppo.py"
    cmd = [sys.executable, str(script), "--quiet", "--no-gif", "--seed", str(seed), "--out", str(out)]
    cmd += ["--timesteps", str(timesteps), "--eval-freq", str(timesteps)]
    cmd += ["--eval-episodes", str(EVAL_EPISODES), "--final-episodes", str(EVAL_EPISODES)]
    return cmd + extra


def child_env(checkout: Path) -> dict[str, str]:
    """The runs import the checkout's own ``penalty_env`` (not whichever one is installed)."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(checkout)] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    return env


def run_together(cmds: list[list[str]], env: dict[str, str], busy: int) -> list[dict[str, Any]]:
    """Start ``busy`` spinning processes, then every command at once; wait for the commands, stop
    the spinners. Returns each run's summary.json (with ``"command"``)."""
    spinners = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(busy)]
    try:
        if spinners:
            time.sleep(0.5)  # (running before the run starts)
        procs = [subprocess.Popen(c, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for c in cmds]
        outputs = [p.communicate() for p in procs]
    finally:
        for s in spinners:
            s.kill()
        for s in spinners:
            s.wait()
    summaries = []
    for cmd, p, (stdout, stderr) in zip(cmds, procs, outputs):
        if p.returncode != 0:
            raise SystemExit(f"{shlex.join(cmd)} failed:\n{stdout[-2000:]}\n{stderr[-4000:]}")
        summary = json.loads((Path(cmd[cmd.index("--out") + 1]) / "summary.json").read_text())
        summaries.append({**summary, "command": shlex.join(cmd)})
    return summaries


def measure(args: argparse.Namespace) -> list[dict[str, Any]]:
    """The rounds: per situation, its runs' training times, splits and the load at its start."""
    checkout = Path(args.checkout).resolve()
    if not (checkout / "train" / "train_ppo.py").is_file():
        raise SystemExit(f"--checkout: no train/train_ppo.py in {checkout}")
    env = child_env(checkout)
    extra = shlex.split(args.train_args)
    rounds = []
    for r in range(args.rounds):
        order = SITUATIONS if r % 2 == 0 else SITUATIONS[::-1]
        found: dict[str, Any] = {}
        for situation in order:
            folder = Path(args.out) / f"round{r}" / situation
            seeds = (0, 1) if situation == "two" else (0,)
            cmds = [train_command(checkout, folder / f"seed{s}", s, args.timesteps, extra) for s in seeds]
            load = load_now()
            summaries = run_together(cmds, env, args.busy if situation == "busy" else 0)
            found[situation] = {
                "load_at_start": load,
                "train_time_s": [s["train_time_s"] for s in summaries],
                "time_split": [s["time_split"] for s in summaries],
                "threads": [s.get("threads") for s in summaries],
            }
            times = ", ".join(f"{t:.2f}" for t in found[situation]["train_time_s"])
            used = ", ".join(torch_threads(t) for t in found[situation]["threads"])
            print(
                f"round {r} {situation:5s}: {times} s of training, torch threads {used} (load {load['load1']:.2f}, "
                f"{load.get('runnable', float('nan')):.0f} other tasks runnable at the start)",
                flush=True,
            )
        rounds.append(found)
    return rounds


def torch_threads(threads: Any) -> str:
    """A run's torch threads as summary.json records them ("2", "2>1>2" when ``auto`` changed them,
    "?" for a tree that does not record them)."""
    if not isinstance(threads, dict) or "torch" not in threads:
        return "?"
    used = threads["torch"]
    return ">".join(str(t) for t in used) if isinstance(used, list) else str(used)


def ratios(rounds: list[dict[str, Any]]) -> dict[str, list[float]]:
    """Per round: the slower of the two runs together, and the run beside the busy loops, each
    over the round's run alone."""
    out: dict[str, list[float]] = {"two": [], "busy": []}
    for found in rounds:
        alone = found["alone"]["train_time_s"][0]
        out["two"].append(max(found["two"]["train_time_s"]) / alone)
        out["busy"].append(found["busy"]["train_time_s"][0] / alone)
    return out


def report(rounds: list[dict[str, Any]], args: argparse.Namespace) -> str:
    r = ratios(rounds)
    lines = [
        f"train_ppo.py ({Path(args.checkout).resolve()}) {args.train_args or '(default flags)'}: "
        f"{args.timesteps:,} steps, {len(rounds)} rounds, {cpus()} CPUs, {args.busy} busy loops",
        "",
        "| round | alone, s | two together, s | two / alone (slower run) | beside busy loops, s | busy / alone "
        "| torch threads (alone; two; busy) | load at the starts (alone, two, busy) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for i, found in enumerate(rounds):
        two = found["two"]["train_time_s"]
        loads = ", ".join(f"{found[s]['load_at_start']['load1']:.1f}" for s in SITUATIONS)
        used = "; ".join(", ".join(torch_threads(t) for t in found[s]["threads"]) for s in SITUATIONS)
        lines.append(
            f"| {i} | {found['alone']['train_time_s'][0]:.2f} | {two[0]:.2f}, {two[1]:.2f} | {r['two'][i]:.2f}x | "
            f"{found['busy']['train_time_s'][0]:.2f} | {r['busy'][i]:.2f}x | {used} | {loads} |"
        )
    two, busy = statistics.median(r["two"]), statistics.median(r["busy"])
    lines += [
        "",
        f"two runs together: median {two:.2f}x one run alone (target <= {TARGET_TWO}x): "
        + ("met" if two <= TARGET_TWO else "NOT met"),
        f"one run beside {args.busy} busy loops: median {busy:.2f}x alone (target <= {TARGET_BUSY}x): "
        + ("met" if busy <= TARGET_BUSY else "NOT met"),
    ]
    alone_loads = [found["alone"]["load_at_start"]["load1"] for found in rounds]
    if max(alone_loads) > 0.5:
        lines.append(
            f"note: the load average was up to {max(alone_loads):.1f} when a run alone started: other jobs "
            "shared the machine, and every ratio includes them"
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(prog="python -m penalty_env.bench shared", description=__doc__)
    p.add_argument("--timesteps", type=int, default=262_144, help="each run's budget (default: %(default)s)")
    p.add_argument("--rounds", type=int, default=3, help="rounds of the three situations (default: %(default)s)")
    p.add_argument("--busy", type=int, default=2, help="busy loops beside the run (default: %(default)s)")
    p.add_argument("--train-args", default="", help='flags added to every run, e.g. --train-args="--threads 2"')
    p.add_argument(
        "--checkout", type=Path, default=repository(), help="the tree whose train/train_ppo.py and penalty_env run"
    )
    p.add_argument("--out", type=Path, default=Path("runs/bench-shared"), help="run folders and results")
    args = p.parse_args(argv)
    if args.timesteps < 1 or args.rounds < 1 or args.busy < 0:
        p.error("--timesteps and --rounds must be >= 1, --busy >= 0")
    rounds = measure(args)
    text = report(rounds, args)
    print(text)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "shared.md").write_text(text)
    record = {
        "checkout": str(Path(args.checkout).resolve()),
        "train_args": args.train_args,
        "timesteps": args.timesteps,
        "cpus": cpus(),
        "rounds": rounds,
        "ratios": ratios(rounds),
    }
    (args.out / "shared.json").write_text(json.dumps(record, indent=2))


if __name__ == "__main__":
    main()

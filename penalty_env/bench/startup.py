"""Time to the first step: ``python -m penalty_env.bench startup [--repeat N] [--ids ...] [--quick]``.

What a user waits for before the first ``step`` returns, in a fresh Python process on this machine:
``import`` + ``make`` (or ``make_vec``) + ``reset`` + one ``step``,

  - **cold**: with an empty Numba cache (``NUMBA_CACHE_DIR`` set to a new empty folder, which the
    package caches under), so every kernel the case needs is compiled;
  - **warm**: a second fresh process on that cache, filled by the first;

for every registered id (default arguments), every ``terrain`` of ``PenaltyBalls-v0``, and
``make_vec("PenaltyBalls-v0", num_envs=64)``; beside ``CartPole-v1`` and ``Pusher-v5`` (MuJoCo,
the ``bench`` extra) timed alike in the same run. A last row makes a second scene in the process
that made the first (a ``PenaltyBalls-v0`` bowl, then each other terrain, the 2D twin and the
rolling id): shapes are data, so it should compile nothing new. Each figure is the median over
``--repeat`` processes (each cold one with its own empty cache); the interpreter's own start
(about 20 ms) is not counted. The warm figure is given whole and without the ``import`` (Gymnasium's,
NumPy's and, inside the first ``make``, Numba's: about 0.25 s that no cache saves).

``--against DIR`` times another checkout of the package (``DIR`` put first on the children's
``PYTHONPATH``: for example a worktree of the commit before) in the same run, case by case, for a
before/after table measured on one machine under one load.

The targets: cold at most 5 s for ``PenaltyBalls-v0`` and 10 s for every other case; warm
``make`` + ``reset`` + ``step`` at most 0.3 s.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from dataclasses import dataclass

COLD_TARGET_V0 = 5.0
COLD_TARGET = 10.0
WARM_TARGET = 0.3

# The child: time import, make, reset and one step; print the phases as JSON.
_CHILD = r"""
import json, sys, time
t0 = time.perf_counter()
import gymnasium as gym
import numpy as np
kind, env_id, kwargs = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
if env_id.startswith("PenaltyBalls"):
    import penalty_env  # noqa: F401
t1 = time.perf_counter()
if kind == "vec":
    env = gym.make_vec(env_id, **kwargs)
else:
    env = gym.make(env_id, **kwargs)
t2 = time.perf_counter()
env.reset(seed=0)
t3 = time.perf_counter()
env.step(env.action_space.sample())
t4 = time.perf_counter()
extra = {}
for second in json.loads(sys.argv[4]):
    s0 = time.perf_counter()
    try:
        e2 = gym.make(second["id"], **second["kwargs"])
    except ValueError:  # (a tree measured --against that lacks this case, e.g. a newer terrain)
        extra[second["label"]] = float("nan")
        continue
    e2.reset(seed=0)
    e2.step(e2.action_space.sample())
    extra[second["label"]] = time.perf_counter() - s0
print(json.dumps({"import": t1 - t0, "make": t2 - t1, "reset": t3 - t2, "step": t4 - t3, "total": t4 - t0,
                  "second": extra}))
"""


@dataclass(frozen=True)
class Case:
    label: str
    env_id: str
    kwargs: dict
    kind: str = "make"  # or "vec"
    target: float = COLD_TARGET  # cold target, s (None: a peer, no target)
    second: tuple = ()  # ({"label", "id", "kwargs"}, ...) made after the first step, same process


def cases(quick: bool = False) -> list[Case]:
    import gymnasium as gym

    import penalty_env  # noqa: F401

    from ..envs.balls.params import CHOICE_PARAMETERS

    terrains = CHOICE_PARAMETERS["terrain"][1]
    seconds = tuple(
        {"label": f"then {t}", "id": "PenaltyBalls-v0", "kwargs": {"terrain": t}} for t in terrains if t != "bowl"
    ) + (
        {"label": "then 2D", "id": "PenaltyBalls2D-v0", "kwargs": {}},
        {"label": "then v1", "id": "PenaltyBalls-v1", "kwargs": {}},
    )
    out = [Case("PenaltyBalls-v0", "PenaltyBalls-v0", {}, target=COLD_TARGET_V0, second=seconds)]
    ids = [k for k in gym.registry if k.startswith("PenaltyBalls") and k != "PenaltyBalls-v0"]
    if quick:
        ids = ids[:1]
    out += [Case(i, i, {}) for i in ids]
    out += [Case(f"PenaltyBalls-v0 terrain={t}", "PenaltyBalls-v0", {"terrain": t}) for t in terrains if t != "bowl"]
    out.append(Case("PenaltyBalls-v0 make_vec x 64", "PenaltyBalls-v0", {"num_envs": 64}, kind="vec"))
    out.append(Case("CartPole-v1 (peer)", "CartPole-v1", {}, target=float("nan")))
    try:
        import mujoco  # noqa: F401

        out.append(Case("Pusher-v5 (peer)", "Pusher-v5", {}, target=float("nan")))
    except ImportError:
        pass
    return out


def _run(case: Case, cache: str, source: str | None) -> dict:
    env = dict(os.environ, NUMBA_CACHE_DIR=cache, PYTHONWARNINGS="ignore")
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # as a user runs: bytecode cached too
    if source is not None:
        env["PYTHONPATH"] = os.pathsep.join([source] + [p for p in [os.environ.get("PYTHONPATH")] if p])
    args = [sys.executable, "-c", _CHILD, case.kind, case.env_id, json.dumps(case.kwargs), json.dumps(case.second)]
    done = subprocess.run(args, env=env, capture_output=True, text=True, cwd=tempfile.gettempdir())
    if done.returncode != 0:
        raise RuntimeError(f"{case.label}: the child failed:\n{done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def measure(case: Case, repeat: int, source: str | None = None) -> tuple[list[dict], list[dict]]:
    """``repeat`` cold runs (each on its own new, empty cache) and as many warm ones (each on the
    cache its cold run filled), of the package found first on ``source`` (None: this one)."""
    cold, warm = [], []
    for _ in range(repeat):
        with tempfile.TemporaryDirectory(prefix="penalty_env_startup_") as cache:
            cold.append(_run(case, cache, source))
            warm.append(_run(case, cache, source))
    for r in cold + warm:
        r["first_step"] = r["make"] + r["reset"] + r["step"]
    return cold, warm


def _median(runs: list[dict], key: str) -> float:
    return statistics.median(r[key] for r in runs)


def _row(cold: list[dict], warm: list[dict]) -> str:
    parts = " ".join(f"{_median(cold, k):>6.2f}" for k in ("import", "make", "reset", "step"))
    c, w, w1 = _median(cold, "total"), _median(warm, "total"), _median(warm, "first_step")
    return f"{c:>7.2f}  {parts}  {w:>6.2f} {w1:>6.2f}"


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(prog="python -m penalty_env.bench startup", description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=1, help="processes per figure (median); default 1")
    ap.add_argument("--ids", nargs="*", default=None, help="only the cases whose label contains one of these")
    ap.add_argument("--quick", action="store_true", help="v0, one other id and the peers only")
    ap.add_argument("--against", default=None, metavar="DIR", help="also time the package checked out in DIR")
    ap.add_argument("--json", default=None, help="also write the raw figures to this file")
    a = ap.parse_args(argv)
    if a.repeat < 1:
        ap.error(f"--repeat must be >= 1, got {a.repeat}")
    if a.against is not None and not os.path.isdir(os.path.join(a.against, "penalty_env")):
        ap.error(f"--against {a.against!r} holds no penalty_env package")
    chosen = [c for c in cases(a.quick) if a.ids is None or any(s in c.label for s in a.ids)]
    if not chosen:
        ap.error(f"--ids {a.ids} match no case")
    print(
        f"first step in a fresh process, median of {a.repeat} (python {sys.version.split()[0]}, {os.cpu_count()} cpus); "
        "s; warm without import = make + reset + step"
    )
    print(
        f"{'case':<36} {'cold':>7} {'(import':>8} {'make':>6} {'reset':>6} {'step)':>6} {'warm':>6} {'-import':>6}  target"
    )
    raw: dict = {}
    misses, seconds = [], {}
    for case in chosen:
        cold, warm = measure(case, a.repeat)
        raw[case.label] = {"cold": cold, "warm": warm}
        peer = case.target != case.target
        ok = _median(cold, "total") <= case.target and _median(warm, "first_step") <= WARM_TARGET
        verdict = "peer" if peer else ("ok" if ok else "MISSED")
        if verdict == "MISSED":
            misses.append(case.label)
        goal = "" if peer else f"cold <= {case.target:g}, warm <= {WARM_TARGET:g}: {verdict}"
        print(f"{case.label:<36} {_row(cold, warm)}  {goal}", flush=True)
        if a.against is not None and not peer:
            try:
                b_cold, b_warm = measure(case, a.repeat, a.against)
            except RuntimeError as exc:  # a case the other tree lacks (a newer id or terrain)
                print(f"{'  against ' + a.against:<36} not measured: {str(exc).splitlines()[-1]}", flush=True)
                continue
            raw[case.label + " (against)"] = {"cold": b_cold, "warm": b_warm}
            ratio = _median(b_cold, "total") / _median(cold, "total")
            print(f"{'  against ' + a.against:<36} {_row(b_cold, b_warm)}  cold {ratio:.1f}x this", flush=True)
        for label in cold[0]["second"]:
            seconds[label] = statistics.median(r["second"][label] for r in cold)
    if seconds:
        print("a second scene in the process that made PenaltyBalls-v0 (make + reset + step, cold cache):")
        for label, t in seconds.items():
            print(f"  {label:<34} {t:>7.2f} s")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(raw, f, indent=1)
    print("all targets met" if not misses else f"targets missed: {', '.join(misses)}")


if __name__ == "__main__":
    main()

"""Regenerate every figure in docs/ and the README's main-job output from the current code.

    python -m penalty_env.bench figures [--skip accuracy,stability,energy,train,train-times]

Runs, in a source checkout: ``bench accuracy --fit`` (the full sweep: docs/accuracy*.png and
accuracy.csv.gz; the refitted error models go to a temporary file and are compared with the
package's, not applied), ``bench stability`` (stability_map.png, tunnelling.png), ``bench energy``
(energy_per_collision.png) and the main job, ``python train/train_ppo.py`` (learning_curve.png and
policy.gif are copied from its run folder, and its first and last lines replace the README's block
between ``BEGIN MAIN JOB OUTPUT`` and ``END MAIN JOB OUTPUT``) and, as ``train-times``,
``bench train --readme`` (every id and
seed with the tuned settings and those before them: docs/train_curves.png, train_times.md and .csv,
and the README's lines between ``BEGIN TRAIN TIMES`` and ``END TRAIN TIMES``). About 25 minutes
on 2 cores without ``train``; ``bench train`` alone takes about an hour and a half.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import time

PARTS = ("accuracy", "stability", "energy", "train", "train-times")


def _tree() -> str:
    package = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    tree = os.path.dirname(package)
    if not (os.path.isfile(os.path.join(tree, "pyproject.toml")) and os.path.isdir(os.path.join(tree, "train"))):
        raise SystemExit("bench figures runs in a source checkout (it writes docs/ and README.md)")
    return tree


def _run(cmd: list[str], cwd: str) -> str:
    print("$", " ".join(cmd), flush=True)
    t = time.perf_counter()
    res = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
    sys.stdout.write(res.stdout[-4000:])
    if res.returncode != 0:
        sys.stderr.write(res.stderr[-4000:])
        raise SystemExit(f"failed ({res.returncode}): {' '.join(cmd)}")
    print(f"  ({time.perf_counter() - t:.0f} s)", flush=True)
    return res.stdout


def replace_block(text: str, begin: str, end: str, body: str) -> str:
    """``text`` with the lines between the ``begin`` and ``end`` markers replaced by ``body``."""
    a = text.index(begin) + len(begin)
    b = text.index(end)
    return text[:a] + "\n" + body.rstrip("\n") + "\n" + text[b:]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(
        prog="python -m penalty_env.bench figures",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--skip", default="", help=f"comma-separated parts to skip: {', '.join(PARTS)}")
    args = ap.parse_args(argv)
    skip = set(filter(None, args.skip.split(",")))
    tree = _tree()
    docs = os.path.join(tree, "docs")
    py = sys.executable
    if "accuracy" not in skip:
        # the fit's sweep (its extra pair zetas are in the CSV), the models written aside: refitting
        # the package's error models would change configure's steps, so it is reported, not applied
        import tempfile

        from ..physics import configure as CF

        with tempfile.TemporaryDirectory() as tmp:
            models = os.path.join(tmp, "error_models.json")
            _run([py, "-m", "penalty_env.bench", "accuracy", "--fit", "--models", models, "--out", docs], tree)
            with open(models) as a, open(CF.MODELS_PATH) as b:
                same = a.read() == b.read()
            print(f"  refitted error models {'equal' if same else 'DIFFER from'} the package's ({CF.MODELS_PATH})")
    if "stability" not in skip:
        _run([py, "-m", "penalty_env.bench", "stability", "--out", docs], tree)
    if "energy" not in skip:
        _run([py, "-m", "penalty_env.bench", "energy", "--out", docs], tree)
    if "train" not in skip:
        run = os.path.join(tree, "runs", "figures-main-job")
        out = _run([py, os.path.join("train", "train_ppo.py"), "--no-progress", "--out", run], tree)
        lines = [ln for ln in out.splitlines() if ln.startswith(("training PPO", "done in"))]
        lines = [ln.replace(run, "runs/ppo-PenaltyBalls-v0-seed0") for ln in lines]
        for name in ("learning_curve.png", "policy.gif"):
            shutil.copyfile(os.path.join(run, name), os.path.join(docs, name))
        readme = os.path.join(tree, "README.md")
        with open(readme) as f:
            text = f.read()
        text = replace_block(
            text, "<!-- BEGIN MAIN JOB OUTPUT -->", "<!-- END MAIN JOB OUTPUT -->", "```\n" + "\n".join(lines) + "\n```"
        )
        with open(readme, "w") as f:
            f.write(text)
        print("updated README.md's main-job output:", *lines, sep="\n  ")
    if "train-times" not in skip:
        # seconds to a trained policy, every id and seed, the settings before tuning alongside
        bench_out = os.path.join(tree, "runs", "bench-train")
        _run([py, "-m", "penalty_env.bench", "train", "--out", bench_out, "--figures", docs, "--readme"], tree)


if __name__ == "__main__":
    main()

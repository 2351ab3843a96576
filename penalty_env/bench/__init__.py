"""Benchmarks: ``python -m penalty_env.bench {core,env,accuracy,stability,energy,soak,figures}``."""

import argparse
import os
import tempfile


def output_dir(args: argparse.Namespace) -> str:
    """``--out``, else docs/ of the repository (a temporary folder for ``--quick``), created."""
    out = args.out or os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "docs")
    if args.quick and args.out is None:
        out = os.path.join(tempfile.gettempdir(), "penalty_env_bench_quick")  # keep docs/ for the full run
    os.makedirs(out, exist_ok=True)
    return out

"""``python -m penalty_env.bench {core,env,accuracy,stability,energy,soak,figures,shapes,granular,scale,startup,train,shared,randomize,level,views} [options]``."""

from __future__ import annotations

import importlib
import sys

COMMANDS = {
    "core": "penalty_env.bench.core",
    "env": "penalty_env.bench.env",
    "accuracy": "penalty_env.bench.accuracy",
    "stability": "penalty_env.bench.stability",
    "energy": "penalty_env.bench.energy",
    "soak": "penalty_env.bench.soak",
    "figures": "penalty_env.bench.figures",
    "shapes": "penalty_env.bench.shapes",
    "granular": "penalty_env.bench.granular",
    "scale": "penalty_env.bench.scale",
    "startup": "penalty_env.bench.startup",
    "train": "penalty_env.bench.train",
    "shared": "penalty_env.bench.shared",
    "randomize": "penalty_env.bench.randomize",
    "level": "penalty_env.bench.level",
    "views": "penalty_env.bench.views",
    "sand_profile": "penalty_env.bench.sand_profile",
}


def main(argv=None) -> None:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] not in COMMANDS:
        print(__doc__.strip())
        print("commands: " + ", ".join(COMMANDS))
        raise SystemExit(2 if argv and argv[0] not in ("-h", "--help") else 0)
    importlib.import_module(COMMANDS[argv[0]]).main(argv[1:])


if __name__ == "__main__":
    main()

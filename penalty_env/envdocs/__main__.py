"""``python -m penalty_env.envdocs [--check] [--out DIR]``."""

from . import main

main()

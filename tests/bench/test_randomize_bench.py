"""``python -m penalty_env.bench randomize`` runs end to end (a smoke run: four worlds, short
windows): it reaches into the vector env's episode counters for its staggered case, which moved
once without the bench noticing."""

from __future__ import annotations

import pytest

from penalty_env.bench import randomize


@pytest.mark.slow
def test_the_randomize_bench_runs(capsys):
    randomize.main(["--worlds", "4", "--seconds", "0.01", "--no-compile"])
    out = capsys.readouterr().out
    assert out.count("ratio") >= 4  # v0 and v1, episodes in step and staggered

"""``python -m penalty_env.bench views`` runs and prints every figure (a smoke run: the figures
themselves are the benchmark's output, not a test's)."""

from __future__ import annotations

from penalty_env.bench import views


def test_views_bench_prints_every_figure(capsys):
    rates = views.main(["--worlds", "16", "--seconds", "0.02"])
    out = capsys.readouterr().out
    assert len(rates) == 9 and all(r > 0 for r in rates.values())
    for label in rates:
        assert label in out
    assert "rgb observations/s at 16 worlds" in out

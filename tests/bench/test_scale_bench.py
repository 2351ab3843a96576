"""``python -m penalty_env.bench scale`` in its smallest configuration: it runs, and every figure it
writes is a finite positive rate (no timing asserts: the speed targets live in the benchmark)."""

from __future__ import annotations

import csv
import math

from penalty_env.bench import scale


def test_scale_smallest_configuration_writes_finite_positive_rates(tmp_path):
    scale.main(
        [
            "--max-n",
            "1000",
            "--batches",
            "4x100",
            "--work",
            "2e5",
            "--rounds",
            "1",
            "--no-lammps",
            "--no-core-b",
            "--cache-dir",
            str(tmp_path / "cache"),
            "--out-dir",
            str(tmp_path),
        ]
    )
    with open(tmp_path / "scale.csv") as f:
        rows = list(csv.DictReader(f))
    timed = [r for r in rows if r["section"] in ("single", "batch")]
    assert {r["section"] for r in timed} == {"single", "batch"}
    assert {int(r["threads"]) for r in timed if r["section"] == "single"} >= {1}
    for r in timed:
        rate = float(r["best_per_s"])
        assert math.isfinite(rate) and rate > 0, r
        assert math.isfinite(float(r["median_per_s"])) and float(r["median_per_s"]) > 0, r
    assert any(r["section"] == "batch" and r["note"] == "auto" for r in timed)
    assert (tmp_path / "scale.png").stat().st_size > 0
    assert list((tmp_path / "cache").glob("bed-1000-*.npz"))  # the settled bed was cached

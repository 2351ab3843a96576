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


def test_simd_lever_variants_compute_the_package_forces_bit_for_bit(tmp_path):
    """The lever record (``python -m penalty_env.bench.simd_lever``): its current loop is the
    package's listed pair law and its variants compute the same forces bit for bit (``measure``
    raises otherwise); every timing is finite and positive."""
    from penalty_env.bench import simd_lever

    ns = simd_lever.measure(1000, steps=1, reps=1, cache_dir=tmp_path)
    assert set(ns) == {*simd_lever.VARIANTS, "force pass"}
    assert all(math.isfinite(t) and t > 0 for t in ns.values()), ns


def test_pair_cost_law_row_is_the_package_law_bit_for_bit(tmp_path):
    """The pair-cost breakdown (``python -m penalty_env.bench.pair_cost``): its "law" row computes
    the package's listed pair forces bit for bit (``measure`` raises otherwise); every row is
    timed, finite and positive."""
    from penalty_env.bench import pair_cost

    ns = pair_cost.measure(1000, steps=1, reps=1, cache_dir=tmp_path)
    assert set(ns) == {*pair_cost.VARIANTS, "force pass", "listed pairs per ball"}
    assert all(math.isfinite(t) and t > 0 for t in ns.values()), ns


def test_the_list_pass_block_law_compiles_to_vector_code():
    """The frictionless list pass computes its pairs' forces in one loop per block that LLVM
    vectorises (square roots and divisions of several pairs per instruction): a branch or a gather
    added to ``contact_listed._block_law`` would silently make it scalar again."""
    from penalty_env.bench import pair_cost

    code = pair_cost.block_law_vector_code()
    assert code["<4 x double>"] + code["<2 x double>"] > 0, code
    assert code["vsqrtpd"] > 0 and code["vdivpd"] > 0, code

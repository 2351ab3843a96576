"""bench train's arithmetic: time to a success rate (a curriculum's first stage counted), the
medians and ratios of its table, the per-id seed counts."""

from __future__ import annotations

import pytest

from penalty_env.bench import train as B


def _summary(points, train_time, timesteps, success=0.9, stage=None):
    s = {
        "curve": [{"timesteps": n, "train_time_s": t, "success_rate": r} for n, t, r in points],
        "train_time_s": train_time,
        "timesteps": timesteps,
        "success_rate": success,
        "time_split": {"env_step_s": 1.0, "policy_and_rollout_s": 1.0, "update_s": 2.0, "evaluation_s": 0.5},
    }
    if stage is not None:
        s["curriculum"] = stage
        s["total_train_time_s"] = stage["train_time_s"] + train_time
    return s


def test_time_to_is_the_first_point_at_the_rate():
    s = _summary([(100, 1.0, 0.3), (200, 2.0, 0.85), (300, 3.0, 0.95), (400, 4.0, 0.8)], 4.0, 400)
    assert B.time_to(s, 0.5) == (2.0, 200)
    assert B.time_to(s, 0.9) == (3.0, 300)
    assert B.time_to(s, 0.99) == (None, None)


def test_a_curriculum_stage_counts_its_time_and_steps_but_not_its_success():
    stage = {"curve": [{"timesteps": 50, "train_time_s": 5.0, "success_rate": 0.95}]}
    stage.update(train_time_s=6.0, timesteps=60)
    s = _summary([(100, 1.0, 0.4), (200, 2.0, 0.92)], 2.5, 200, stage=stage)
    times, steps, succ = B.timeline(s)
    assert times == [5.0, 7.0, 8.0] and steps == [50, 160, 260] and succ == [0.0, 0.4, 0.92]
    assert B.time_to(s, 0.9) == (8.0, 260)  # the first stage's 95% on another id does not count
    assert B.total_train_time(s) == 8.5


def test_report_medians_and_ratio(tmp_path):
    results = {}
    for seed, (t_leg, t_tun) in enumerate([(10.0, 2.0), (20.0, 4.0), (30.0, None)]):
        results["X", "legacy", seed] = _summary([(1000, t_leg, 0.9)], t_leg, 1000)
        tuned_points = [(500, 1.0, 0.5)] + ([(900, t_tun, 0.91)] if t_tun else [])
        results["X", "tuned", seed] = _summary(tuned_points, t_tun or 7.0, 900)
    B.report(results, ["X"], ["legacy", "tuned"], 3, tmp_path, None)
    table = (tmp_path / "train_times.md").read_text()
    # legacy median 20 s; tuned: 2, 4 and "not reached" (its 7 s of training) -> median 4 s
    assert "| X | 20.0 s | 4.0 s | 5.0x |" in table
    assert (tmp_path / "train_curves.png").stat().st_size > 0
    assert "2 of 3 reached 90%" in (tmp_path / "readme_lines.md").read_text()


def test_seeds_per_id():
    assert B.seeds_per_id([], ["A", "B"]) == {"A": 5, "B": 5}
    assert B.seeds_per_id(["3", "B=1"], ["A", "B"]) == {"A": 3, "B": 1}
    for bad in ("0", "C=2", "B=x"):
        with pytest.raises(SystemExit, match="--seeds"):
            B.seeds_per_id([bad], ["A", "B"])

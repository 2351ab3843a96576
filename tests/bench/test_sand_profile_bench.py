"""``python -m penalty_env.bench sand_profile``: the parts of a sand env's physics step, as a smoke
run (its figures are timings; here only what they count is checked)."""

from __future__ import annotations

import pytest

from penalty_env.bench import sand_profile


def test_the_profile_counts_the_contacts_it_times():
    f = sand_profile.profile("PenaltyBallsSand-v1", passes=5)
    assert f["balls"] == 302 and f["substeps"] == 9
    assert 0 < f["contacts"] < f["tests"]  # touching pairs among the tested ones
    for part in ("grid build", "pair scan", "terrain", "contact pass", "env step"):
        assert f[part] > 0.0, part
    assert 0.0 <= f["creeping 1 cm/s"] <= f["creeping 3 mm/s"] <= 1.0


def test_a_scene_it_cannot_take_apart_is_refused():
    with pytest.raises(ValueError, match=r"--env-id 'PenaltyBalls-v0'.*3D scene of rolling balls"):
        sand_profile.profile("PenaltyBalls-v0", passes=1)

"""``train/level_headroom.py``: the best of many open-loop sequences per episode is a score some
policy could reach: the best of six sequences on two seeds, replayed in a single env from the
same seed, scores what the batch measured."""

from __future__ import annotations

import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "train"))

import level_headroom as H  # noqa: E402


def test_the_best_sequence_replayed_alone_scores_what_the_batch_measured():
    seqs, structured = H.sequences(0, 15)
    assert structured == len(seqs) == 212  # both directions, every pair of turns, each once
    assert seqs[0].tolist() == [1.0] * 15 and seqs[1].tolist() == [-1.0] + [1.0] * 14  # (a=0: b back, then on)
    assert len(np.unique(seqs, axis=0)) == len(seqs)
    more, _ = H.sequences(300, 15)
    assert len(more) == len(np.unique(more, axis=0)) == 300 and np.array_equal(more[:212], seqs)
    picks = seqs[[0, 7, 40, 106, 150, 211]]
    kw = {"target": "random"}
    table = H.best_of("PenaltySandLevel2D-v0", picks, 10, [H.SEED, H.SEED + 1], kw, 150)
    assert table.shape == (2, 6) and np.ptp(table, axis=1).min() > 0  # (the sequences differ)
    for row, seed in enumerate((H.SEED, H.SEED + 1)):
        best = int(table[row].argmax())
        env = gym.make("PenaltySandLevel2D-v0", **kw)
        env.reset(seed=seed)
        total, t, done = 0.0, 0, False
        while not done:
            _, r, term, trunc, _ = env.step(picks[best, min(t // 10, 14)][None])
            total, t, done = total + r, t + 1, term or trunc
        assert total == pytest.approx(table[row, best], rel=0, abs=1e-9), (seed, best)


def test_a_3d_id_and_bad_counts_are_refused():
    with pytest.raises(ValueError, match="'PenaltySandLevel-v0': level_headroom plays a 2D level id"):
        H.best_of("PenaltySandLevel-v0", np.ones((2, 3), np.float32), 10, [H.SEED], {"target": "random"}, 3)
    with pytest.raises(SystemExit):
        H.main(["--episodes", "0"])

"""The on-disk results cache (penalty_env._results): a result read back is the computed one bit for
bit, an edit of the package's sources or of the error models misses, and a broken entry is a miss."""

import pickle
from dataclasses import asdict

import gymnasium as gym
import numpy as np
import pytest

import penalty_env  # noqa: F401 (registers the ids)
from penalty_env import _results
from penalty_env.envs.balls import sand
from penalty_env.physics import configure as C
from penalty_env.physics import error_models


@pytest.fixture
def results_in(tmp_path, monkeypatch):
    monkeypatch.setattr(_results._numba_config, "CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("PENALTY_ENV_RESULTS_CACHE", raising=False)
    return tmp_path / "penalty_env" / "results"


ARGS = ([1.0, 2.0], [0.1, 0.12], 3.0)
KW = dict(penetration=0.04, restitution=0.8, accuracy=0.02, damping="no_tension", max_force=5.0)


def _bits(cfg):
    return pickle.dumps(asdict(cfg))


def test_configure_from_the_cache_is_the_computed_one_bit_for_bit(results_in, monkeypatch):
    monkeypatch.setenv("PENALTY_ENV_RESULTS_CACHE", "0")
    fresh = C.configure(*ARGS, **KW)
    assert not results_in.exists()
    monkeypatch.delenv("PENALTY_ENV_RESULTS_CACHE")
    first = C.configure(*ARGS, **KW)
    (entry,) = results_in.glob("configure-*.pkl")
    calls = []
    monkeypatch.setattr(C, "_configured", lambda *a: calls.append(a))
    again = C.configure(*ARGS, **KW)
    assert calls == []  # read back, not computed
    assert _bits(again) == _bits(first) == _bits(fresh)
    # another argument is another entry (and is computed)
    C.configure(*ARGS, **dict(KW, restitution=0.7))
    assert len(calls) == 1


def test_an_edit_of_the_sources_or_of_the_error_models_misses(results_in, monkeypatch):
    C.configure(*ARGS, **KW)
    monkeypatch.setattr(_results, "source_hash", lambda: "an-edited-package")
    C.configure(*ARGS, **KW)
    assert len(list(results_in.glob("configure-*.pkl"))) == 2
    monkeypatch.setattr(error_models, "MODELS_STAMP", "refitted-models")
    C.configure(*ARGS, **KW)
    assert len(list(results_in.glob("configure-*.pkl"))) == 3


def test_a_broken_entry_is_a_miss_and_is_rewritten(results_in):
    want = _bits(C.configure(*ARGS, **KW))
    (entry,) = results_in.glob("configure-*.pkl")
    entry.write_bytes(b"\x80\x05truncated")
    assert _bits(C.configure(*ARGS, **KW)) == want
    assert pickle.loads(entry.read_bytes()) is not None


def test_no_writable_folder_computes_every_time(monkeypatch):
    monkeypatch.setattr(_results._numba_config, "CACHE_DIR", "")
    monkeypatch.setattr(_results, "_DIR", [None])
    assert _results.results_dir() is None
    assert _results.cached("x", (1,), lambda: 42) == 42


def test_a_settled_sand_bed_from_the_cache_is_the_settled_one_bit_for_bit(results_in, monkeypatch):
    monkeypatch.setattr(sand, "_BEDS", {})
    bed = gym.make("PenaltyBallsSand-v0", grains=50).unwrapped.scene.bed
    assert len(list(results_in.glob("sand_bed-*.pkl"))) == 1
    monkeypatch.setattr(sand, "_BEDS", {})
    monkeypatch.setattr(sand.SandBed, "_settle", lambda self, kwargs: pytest.fail("settled again"))
    again = gym.make("PenaltyBallsSand-v0", grains=50).unwrapped.scene.bed
    np.testing.assert_array_equal(again, bed)
    assert again.tobytes() == bed.tobytes() and not again.flags.writeable


def test_a_numpy_scalar_is_keyed_by_its_exact_value_not_its_repr(results_in, monkeypatch):
    """np.float32(0.04) is 0.03999999910593033: its configuration is computed, not served the
    float 0.04's (whatever NumPy's repr prints for it)."""
    np.set_printoptions(legacy="1.25")  # (repr(np.float32(0.04)) == "0.04" there, as under NumPy 1.x)
    try:
        C.configure(*ARGS, **KW)
        got = C.configure(*ARGS, **dict(KW, penetration=np.float32(0.04)))
    finally:
        np.set_printoptions(legacy=False)
    monkeypatch.setenv("PENALTY_ENV_RESULTS_CACHE", "0")
    want = C.configure(*ARGS, **dict(KW, penetration=np.float32(0.04)))
    assert _bits(got) == _bits(want)
    assert got.ks != C.configure(*ARGS, **KW).ks

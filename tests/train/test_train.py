"""The training script end to end: a short PPO run saves a run folder that evaluate.py reloads."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
TRAIN = ROOT / "train" / "train_ppo.py"
EVALUATE = ROOT / "train" / "evaluate.py"

pytest.importorskip("stable_baselines3")


def _run(args, timeout):
    res = subprocess.run([sys.executable, *map(str, args)], capture_output=True, text=True, timeout=timeout, cwd=ROOT)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-4000:]
    return res.stdout


SMOKE = [
    "--timesteps",
    4096,
    "--n-envs",
    8,
    "--n-steps",
    256,
    "--batch-size",
    512,
    "--eval-freq",
    2048,
    "--eval-episodes",
    8,
    "--final-episodes",
    16,
    "--numba-threads",
    1,
]


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory):
    """A short run of the script, not on a terminal: no bar, one line per evaluation."""
    out = tmp_path_factory.mktemp("smoke") / "run"
    text = _run([TRAIN, *SMOKE, "--out", out], timeout=600)
    return out, text


def test_training_smoke_run_saves_reloads_and_evaluates(smoke_run, tmp_path):
    out, text = smoke_run
    for name in (
        "model.zip",
        "vecnormalize.pkl",
        "learning_curve.png",
        "policy.gif",
        "summary.json",
        "evaluations.csv",
    ):
        assert (out / name).stat().st_size > 0, name
    summary = json.loads((out / "summary.json").read_text())
    for key in (
        "timesteps",
        "wall_time_s",
        "train_time_s",
        "env_steps_per_s",
        "success_rate",
        "mean_return",
        "random_success_rate",
        "random_mean_return",
    ):
        assert key in summary, key
    assert summary["timesteps"] >= 4096
    assert summary["eval_episodes"] == 16
    assert 0.0 <= summary["success_rate"] <= 1.0 and 0.0 <= summary["random_success_rate"] <= 1.0
    assert [p["timesteps"] for p in summary["curve"]] == [2048, 4096]  # evaluations at 2048 and 4096 steps
    # the evaluations are timed apart from the training, and the parts add up to no more than it
    split = summary["time_split"]
    assert summary["train_time_s"] <= summary["wall_time_s"] and min(split.values()) >= 0
    assert split["env_step_s"] + split["policy_and_rollout_s"] + split["update_s"] <= summary["train_time_s"] + 0.05
    assert text.count("[eval]") == 2 and "%|" not in text  # no bar off a terminal
    # torch's threads chosen by the load (recorded); --numba-threads limits the env's physics too
    threads = summary["threads"]
    assert threads["torch_setting"] == "auto" and threads["torch_schedule"][0][0] == 0
    assert threads["physics"] == 1 and threads["cpus"] >= 1 and threads["load_at_start"] >= 0
    video = tmp_path / "eval.gif"
    text = _run([EVALUATE, out, "--episodes", 10, "--n-envs", 5, "--video", video], timeout=300)
    assert "success" in text and "random policy" in text
    assert video.stat().st_size > 0


def test_progress_bar_on_a_terminal_and_quiet(tmp_path):
    """On a terminal the run draws a bar (steps/s, the held-out success so far, the time left);
    ``--quiet`` draws nothing and prints no evaluation lines."""
    import os
    import pty

    master, slave = pty.openpty()
    proc = subprocess.Popen(
        [sys.executable, str(TRAIN), *map(str, SMOKE), "--no-gif", "--out", str(tmp_path / "a")],
        stdout=slave,
        stderr=slave,
        cwd=ROOT,
    )
    os.close(slave)
    chunks = []
    while True:
        try:
            data = os.read(master, 65536)
        except OSError:  # the terminal closed with the process
            break
        if not data:
            break
        chunks.append(data)
    assert proc.wait(timeout=600) == 0
    os.close(master)
    text = b"".join(chunks).decode(errors="replace")
    assert "%|" in text and " steps/s" in text and "success" in text, text[-2000:]  # tqdm's bar
    assert "[eval]" not in text
    quiet = _run([TRAIN, *SMOKE, "--no-gif", "--quiet", "--out", tmp_path / "b"], timeout=600)
    assert "[eval]" not in quiet and "%|" not in quiet and "done in" in quiet


def test_readme_example_loads_a_run(smoke_run):
    """The README's "load a run" example, on a run folder of the script."""
    import re

    out, _ = smoke_run
    readme = (ROOT / "README.md").read_text()
    code = re.search(r"<!-- BEGIN LOAD A RUN -->\s*```python\n(.*?)```", readme, re.S).group(1)
    assert 'Path("runs/ppo-PenaltyBalls-v0-seed0")' in code
    code = code.replace('Path("runs/ppo-PenaltyBalls-v0-seed0")', f"Path({str(out)!r})")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert res.returncode == 0, res.stderr[-3000:]
    assert "episodes reached the goal" in res.stdout


def test_help_documents_the_options():
    text = _run([TRAIN, "--help"], timeout=120)
    for opt in (
        "--env-id",
        "--timesteps",
        "--n-envs",
        "--seed",
        "--out",
        "--tensorboard",
        "--env-kwarg",
        "--init-from",
        "--stop-at",
        "--quiet",
        "--no-stagger",
        "--no-curriculum",
        "--log-std-init",
        "--sde-sample-freq",
    ):
        assert opt in text


def _train_module():
    sys.path.insert(0, str(ROOT / "train"))
    import train_ppo as T

    return T


def test_torch_threads_are_auto_unless_told_and_a_note_says_when_a_count_would_wait():
    """Every tuned id trains with ``--threads auto`` (legacy: 1); a count is taken as given, and a
    count above 1 on a loaded machine, or above its CPUs, is warned about."""
    T = _train_module()
    import _threads
    import _tuned

    assert T.SETTINGS["threads"] == "auto" and all(
        s["threads"] == "auto"
        for i, s in _tuned.TUNED.items()
        if "Level" not in i  # (train_level.py's: 1)
    )
    assert _tuned.LEGACY["threads"] == 1
    assert T.check_settings({"env_id": "PenaltyBalls-v1"})["threads"] == "auto"
    args = T.build_parser().parse_args(["--threads", "2"])
    assert T.check_settings(T.settings_from_args(args))["threads"] == 2
    for bad in ("0", "two", 0, 1.5):
        with pytest.raises(ValueError, match="'threads' must be 'auto' or an integer >= 1"):
            T.check_settings({"threads": bad})
    assert _threads.note("auto", 2, 9.0) is None and _threads.note(1, 2, 9.0) is None
    assert _threads.note(2, 2, 0.1) is None
    for n_cpus, load in ((2, 3.0), (1, 0.0)):
        text = _threads.note(2, n_cpus, load)
        assert text is not None and "--threads auto" in text


def test_the_physics_thread_count_does_not_change_a_training_run(tmp_path):
    """The same seed trains the same policy, bit for bit, with the env's physics on one thread or
    split over two (the runner steps each world serially within its part)."""
    T = _train_module()
    import torch
    from stable_baselines3 import PPO

    from penalty_env.physics.stepping import runner

    settings = dict(T.SETTINGS, timesteps=4096, n_envs=128, n_steps=16, batch_size=512, eval_freq=4096)
    settings.update(eval_episodes=4, final_episodes=4, gif=False, quiet=True, progress=False)
    weights = []
    for threads in (1, runner.max_threads()):
        T.train({**settings, "numba_threads": threads}, tmp_path / f"t{threads}")
        assert runner.thread_count() == threads
        assert len(runner.split(128, 2 * 9)) == threads  # v0: 2 balls, 9 substeps a step: split when 2
        model = PPO.load(tmp_path / f"t{threads}" / "model.zip", device="cpu")
        weights.append([v.clone() for v in model.policy.state_dict().values()])
    runner.set_thread_count(None)
    for a, b in zip(*weights):
        assert torch.equal(a, b)


def test_auto_gives_the_result_of_threads_2_whenever_it_changes_threads(tmp_path, monkeypatch):
    """Torch's thread count changes only the initial weights (built on 2 threads under ``auto``):
    a run that steps down to one thread after two updates, as beside another job, trains the same
    policy bit for bit as ``--threads 2`` throughout. (Measured on torch 2.13's CPU build; if a
    torch changes that, this test says so.)"""
    T = _train_module()
    import _threads
    import torch
    from stable_baselines3 import PPO

    feed = iter([0.0] * _threads.START_SAMPLES + [2.0] * 100)
    monkeypatch.setattr(_threads, "runnable_others", lambda: next(feed))
    settings = dict(T.SETTINGS, timesteps=8192, n_envs=64, n_steps=16, batch_size=512, eval_freq=8192)
    settings.update(eval_episodes=4, final_episodes=4, gif=False, quiet=True, progress=False)
    auto = T.train({**settings, "threads": "auto"}, tmp_path / "auto")
    assert auto["threads"]["torch"] == [2, 1] and auto["threads"]["torch_init"] == 2
    T.train({**settings, "threads": 2}, tmp_path / "two")
    a, b = (PPO.load(tmp_path / name / "model.zip", device="cpu").policy.state_dict() for name in ("auto", "two"))
    assert all(torch.equal(a[k], b[k]) for k in a)


def test_settings_precedence_and_refusals():
    """The command line wins over the id's tuned value, which wins over the defaults; a rollout
    smaller than a minibatch and an unknown id are refused, naming the setting and the value."""
    T = _train_module()
    import _tuned

    args = T.build_parser().parse_args(["--env-id", "PenaltyBalls-v1", "--n-envs", "8", "--n-steps", "256"])
    s = T.check_settings(T.settings_from_args(args))
    assert s["n_envs"] == 8 and s["n_steps"] == 256  # given
    assert s["gamma"] == _tuned.TUNED["PenaltyBalls-v1"]["gamma"] != T.DEFAULTS["gamma"]  # the id's
    assert s["stagger"] is True
    args = T.build_parser().parse_args(["--no-stagger"])
    assert T.check_settings(T.settings_from_args(args))["stagger"] is False
    with pytest.raises(ValueError, match=r"'batch_size' \(1024\).*16 \* 16 = 256"):
        T.check_settings({"n_envs": 16, "n_steps": 16})
    with pytest.raises(ValueError, match=r"'env_id'.*'PenaltyBalls-v9'"):
        T.check_settings({"env_id": "PenaltyBalls-v9"})
    # the sand ids stop at their tuned rate unless told; 'never' runs to the budget
    parse = T.build_parser().parse_args
    assert T.check_settings(T.settings_from_args(parse(["--env-id", "PenaltyBallsSand-v1"])))["stop_at"] == 0.95
    assert T.check_settings(T.settings_from_args(parse(["--env-id", "PenaltyBalls-v1"])))["stop_at"] is None
    never = parse(["--env-id", "PenaltyBallsSand-v1", "--stop-at", "never"])
    assert T.check_settings(T.settings_from_args(never))["stop_at"] is None
    assert T.check_settings(T.settings_from_args(parse(["--stop-at", "0.8"])))["stop_at"] == 0.8
    with pytest.raises(SystemExit):
        parse(["--stop-at", "soon"])
    # gSDE: off (0) by default, -1 or a period on; below -1 refused
    assert T.check_settings({})["sde_sample_freq"] == 0
    assert T.check_settings(T.settings_from_args(parse(["--sde-sample-freq", "8"])))["sde_sample_freq"] == 8
    with pytest.raises(ValueError, match=r"'sde_sample_freq' must be an integer >= -1, got -2"):
        T.check_settings({"sde_sample_freq": -2})


def test_curriculum_first_stage_takes_the_runs_network_and_threads(tmp_path, monkeypatch):
    """``run`` on a sand id: first its curriculum's id, with that id's tuned settings but this
    run's network, threads, seed and staggering, stopped at CURRICULUM_STOP_AT; then the sand id
    from the first stage's folder."""
    T = _train_module()
    import _tuned

    calls = []

    def fake_train(settings, out, on_eval=None, stage=None):
        calls.append((dict(settings), Path(out), stage))
        Path(out).mkdir(parents=True, exist_ok=True)
        (Path(out) / "model.zip").write_bytes(b"x")
        return {"train_time_s": 1.0, "env_id": settings["env_id"]}

    monkeypatch.setattr(T, "train", fake_train)
    T.run({"env_id": "PenaltyBallsSand-v1", "net_arch": "64,64", "threads": 1, "seed": 3, "stagger": False}, tmp_path)
    (first, first_out, _), (second, second_out, stage) = calls
    assert (
        first["env_id"] == _tuned.CURRICULUM["PenaltyBallsSand-v1"] and first_out == tmp_path / "stage1-PenaltyBalls-v1"
    )
    assert (first["net_arch"], first["threads"], first["seed"], first["stagger"]) == ("64,64", 1, 3, False)
    assert first["stop_at"] == _tuned.CURRICULUM_STOP_AT and "n_envs" not in first  # the rest: v1's tuned
    assert (
        second["init_from"] == str(first_out.resolve())
        and second_out == tmp_path
        and stage["env_id"] == first["env_id"]
    )
    calls.clear()
    T.run({"env_id": "PenaltyBallsSand-v1", "curriculum": False}, tmp_path / "b")
    assert len(calls) == 1 and calls[0][0]["init_from"] is None  # from scratch


def test_held_out_evaluation_schedule_clock_and_stop(monkeypatch):
    """The evaluation runs at the first step at or past each multiple of ``every``, on reseeded
    episodes, outside the training clock; the run stops at the first point at ``stop_at``; the
    evaluation after the last step counts as evaluation time but not as rollout time."""
    sys.path.insert(0, str(ROOT / "train"))
    import _callbacks as CB
    import _common as C

    rates = iter([0.2, 0.95, 0.5, 0.6])
    monkeypatch.setattr(
        C, "run_episodes", lambda venv, act, n, repeat: {"success_rate": next(rates), "mean_return": 1.0}
    )
    monkeypatch.setattr(C, "model_policy", lambda model, vecnorm: None)

    class Venv:
        num_envs = 4

        def __init__(self):
            self.seeds = []

        def seed(self, s):
            self.seeds.append(s)

    venv, curve = Venv(), []
    cb = CB.HeldOutEval(venv, 7, None, every=100, clock=CB.TrainClock(), curve=curve, stop_at=0.9)
    cb.model = None  # SB3 sets it at the start of training; the policy is stubbed above
    for n, more in ((50, True), (128, True), (192, True), (256, False)):
        cb.num_timesteps = n
        assert cb._on_step() is more
    assert [p["timesteps"] for p in curve] == [128, 256] and venv.seeds == [7, 7]
    cb._on_training_end()  # stopped at its point: no further evaluation
    assert len(curve) == 2 and cb.eval_in_rollout == cb.eval_time
    cb2 = CB.HeldOutEval(venv, 7, None, every=100, clock=CB.TrainClock(), curve=(curve2 := []), stop_at=None)
    cb2.model = None
    cb2.num_timesteps = 100
    assert cb2._on_step()
    cb2.num_timesteps = 150
    cb2._on_training_end()  # the end, past the last point: one more, outside the rollouts
    assert [p["timesteps"] for p in curve2] == [100, 150] and cb2.eval_in_rollout < cb2.eval_time
    assert all(0 <= p["train_time_s"] <= p["wall_time_s"] for p in curve + curve2)


@pytest.fixture(scope="module")
def default_runs(tmp_path_factory):
    """The README's main job, ``python train/train_ppo.py``, with seeds 0 to 4."""
    summaries = []
    for seed in range(5):
        out = tmp_path_factory.mktemp("default") / f"seed{seed}"
        _run([TRAIN, "--seed", seed, "--quiet", "--no-gif", "--out", out], timeout=15 * 60)
        summaries.append(json.loads((out / "summary.json").read_text()))
    return summaries


@pytest.mark.slow
def test_default_run_reaches_90_percent_success_on_held_out_seeds(default_runs):
    """The main job succeeds on >= 90% of 100 held-out episodes (the median of five seeds; the
    worst seed >= 85%), while a random policy fails. Its training time is a benchmark's figure
    (``python -m penalty_env.bench train``), not asserted here."""
    import numpy as np

    rates = [s["success_rate"] for s in default_runs]
    assert all(s["eval_episodes"] == 100 for s in default_runs)
    assert np.median(rates) >= 0.9 and min(rates) >= 0.85, rates
    assert max(s["random_success_rate"] for s in default_runs) <= 0.2


def test_init_from_starts_where_the_earlier_run_left_off_and_refuses_what_does_not_fit(tmp_path):
    """``--init-from``: the sand env's policy starts as the earlier (v1) run's policy acts on the
    21 entries they share, whatever its height map says (the extra inputs' weights start at
    zero); the shared normalisation statistics are carried over with a weight of
    INIT_STATS_COUNT samples; a 2D run cannot start a 3D one, nor a missing folder anything."""
    import numpy as np
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecNormalize

    sys.path.insert(0, str(ROOT / "train"))
    import _common as C
    import train_ppo as T

    def model_on(env_id, seed):
        venv = VecNormalize(C.make_env(env_id, 2, seed, {}), gamma=0.99)
        return PPO("MlpPolicy", venv, n_steps=8, batch_size=16, seed=seed, device="cpu"), venv

    old, old_norm = model_on("PenaltyBalls-v1", 0)
    rng = np.random.default_rng(0)
    old_norm.obs_rms.mean[:] = rng.normal(size=21)
    old_norm.obs_rms.var[:] = rng.uniform(0.5, 2.0, 21)
    src = tmp_path / "v1"
    src.mkdir()
    old.save(src / "model.zip")
    old_norm.save(str(src / "vecnormalize.pkl"))

    new, new_norm = model_on("PenaltyBallsSand-v1", 1)
    obs = rng.normal(size=(5, 21 + 25)).astype(np.float32)
    with torch.no_grad():
        before = new.policy.get_distribution(torch.as_tensor(obs)).distribution.mean.numpy()
    T.init_from(new, new_norm, src)
    with torch.no_grad():
        after = new.policy.get_distribution(torch.as_tensor(obs)).distribution.mean.numpy()
        other = obs.copy()
        other[:, 21:] = rng.normal(size=(5, 25))  # another height map: the same action
        after2 = new.policy.get_distribution(torch.as_tensor(other)).distribution.mean.numpy()
        ref = old.policy.get_distribution(torch.as_tensor(obs[:, :21])).distribution.mean.numpy()
        v_new = new.policy.predict_values(torch.as_tensor(obs)).numpy()
        v_ref = old.policy.predict_values(torch.as_tensor(obs[:, :21])).numpy()
    assert not np.allclose(before, ref)
    np.testing.assert_allclose(after, ref, rtol=1e-6, atol=1e-6)
    np.testing.assert_array_equal(after, after2)
    np.testing.assert_allclose(v_new, v_ref, rtol=1e-6, atol=1e-6)
    np.testing.assert_array_equal(new_norm.obs_rms.mean[:21], old_norm.obs_rms.mean)
    np.testing.assert_array_equal(new_norm.obs_rms.var[:21], old_norm.obs_rms.var)
    assert not new_norm.obs_rms.mean[21:].any() and (new_norm.obs_rms.var[21:] == 1.0).all()
    assert new_norm.obs_rms.count == new_norm.ret_rms.count == T.INIT_STATS_COUNT

    flat, _ = model_on("PenaltyBalls2D-v1", 2)
    with pytest.raises(ValueError, match=r"init_from=.*action space"):
        T.init_from(flat, None, src)
    raw, _ = model_on("PenaltyBallsSand-v1", 3)
    with pytest.raises(ValueError, match=r"init_from=.*with VecNormalize, this one without"):
        T.init_from(raw, None, src)
    with pytest.raises(ValueError, match=r"'init_from'.*model\.zip.*nowhere"):
        T.check_settings({"init_from": str(tmp_path / "nowhere")})


@pytest.mark.slow
def test_rolling_balls_reach_90_percent(tmp_path):
    """``python train/train_ppo.py --env-id PenaltyBalls-v1``: >= 90% of 100 held-out episodes."""
    out = tmp_path / "v1"
    _run([TRAIN, "--env-id", "PenaltyBalls-v1", "--quiet", "--no-gif", "--out", out], timeout=20 * 60)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["success_rate"] >= 0.9, summary
    assert summary["random_success_rate"] <= 0.2, summary


@pytest.mark.slow
def test_sand_from_scratch_in_one_command_reaches_90_percent(tmp_path):
    """``python train/train_ppo.py --env-id PenaltyBallsSand-v1``: the script's curriculum (a
    PenaltyBalls-v1 run, then the sand run from its policy, stopped at its first held-out point of
    95%) reaches >= 90% of 100 other held-out sand episodes, where a random policy fails."""
    out = tmp_path / "sand"
    _run([TRAIN, "--env-id", "PenaltyBallsSand-v1", "--quiet", "--no-gif", "--out", out], timeout=40 * 60)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["curriculum"]["env_id"] == "PenaltyBalls-v1"
    assert summary["init_from"] == str((out / "stage1-PenaltyBalls-v1").resolve())
    assert summary["eval_episodes"] == 100
    assert summary["curve"][-1]["success_rate"] >= 0.95 or summary["timesteps"] >= 1_200_000, summary
    assert summary["success_rate"] >= 0.9, summary
    assert summary["random_success_rate"] <= 0.2, summary


def test_action_repeat_holds_each_decision_and_counts_every_reward():
    """``ActionRepeat`` (training) steps each decision ``k`` times and returns the rewards' sum:
    the same bits as the per-step VecEnv given the held actions; ``run_episodes(action_repeat=k)``
    (evaluation) asks the policy at each episode's first step and every k steps after, per world."""
    sys.path.insert(0, str(ROOT / "train"))
    import _common as C
    from stable_baselines3.common.vec_env import VecEnvWrapper

    k, n = 4, 2
    rng = np.random.default_rng(0)
    held = C.make_env("PenaltyBalls2D-v0", n, 5, {}, action_repeat=k)
    plain = C.make_env("PenaltyBalls2D-v0", n, 5, {})
    assert np.array_equal(held.reset(), plain.reset())
    for _ in range(20):  # (no episode ends within these 80 steps)
        a = rng.uniform(-1, 1, (n, *held.action_space.shape)).astype(np.float32)
        obs, reward, done, _ = held.step(a)
        total = np.zeros(n)
        for _ in range(k):
            obs_p, r, d, _ = plain.step(a)
            total = total + r
        assert not done.any() and not d.any()
        assert np.array_equal(obs, obs_p) and np.array_equal(reward, total)

    sent: list[np.ndarray] = []
    ends: list[np.ndarray] = []

    class Record(VecEnvWrapper):
        def reset(self):
            return self.venv.reset()

        def step_async(self, actions):
            sent.append(np.array(actions))
            self.venv.step_async(actions)

        def step_wait(self):
            out = self.venv.step_wait()
            ends.append(out[2].copy())
            return out

    venv = Record(C.make_env("PenaltyBalls2D-v0", n, 5, {}))
    shape = (n, *venv.action_space.shape)
    C.run_episodes(venv, lambda obs: rng.uniform(-1, 1, shape).astype(np.float32), 2, action_repeat=k)
    acts, first_end = np.array(sent), int(np.argmax(np.any(ends, axis=1)))
    assert first_end > 2 * k
    for t in range(1, first_end + 1):  # (until an episode ends, both worlds decide on one clock)
        same = np.all(acts[t] == acts[t - 1], axis=1)
        assert same.all() if t % k else not same.any(), t


def test_imitation_copies_the_raster_sweep_and_is_refused_without_one():
    """``imitate`` fits the policy's mean action to the level task's raster sweep on the training
    worlds (the run's VecNormalize seeing the demonstration): afterwards the deterministic policy
    acts as the sweep does on observations of other episodes; an id without a sweep, or a setting below 0, is refused naming the setting."""
    T = _train_module()
    import _common as C
    from _imitate import imitate
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecNormalize

    kw = {"target": "random"}
    venv = VecNormalize(C.make_env("PenaltySandLevel2D-v0", 16, 3, kw, action_repeat=10), gamma=0.99)
    model = PPO(
        "MlpPolicy", venv, n_steps=16, batch_size=64, seed=0, device="cpu", policy_kwargs=dict(net_arch=[32, 32])
    )
    sweep = C.scripted_policy(venv)
    # other episodes' observations along the sweep's own path (its turns included), and its actions
    probe = C.make_env("PenaltySandLevel2D-v0", 16, 900, kw)
    other = C.scripted_policy(probe)
    seen, wanted = [], []
    obs = probe.reset()
    for _ in range(60):
        act = other(obs)
        seen.append(obs)
        wanted.append(act)
        obs = probe.step(act)[0]
    seen_, wanted_ = np.concatenate(seen), np.concatenate(wanted)
    assert (np.diff(np.stack(wanted)[:, :, 0], axis=0) != 0).any()  # (it turned within those steps)

    def error() -> float:
        return float(np.mean((model.predict(venv.normalize_obs(seen_), deterministic=True)[0] - wanted_) ** 2))

    before = error()
    fit = imitate(model, venv, venv, sweep, 1024, epochs=200)
    assert fit["decisions"] == 1024 and fit["episodes"] > 16 and fit["teacher_mean_return"] > 1.0
    after = error()
    assert after < 0.05 < before, (before, after)
    assert fit["action_mse"] < 0.05 and np.isfinite(fit["value_mse"])
    with pytest.raises(ValueError, match=r"'imitate' \(100\) needs a PenaltySandLevel id.*PenaltyBalls-v0"):
        T.check_settings({"imitate": 100})
    with pytest.raises(ValueError, match=r"'imitate' must be an integer >= 0, got -1"):
        T.check_settings({"env_id": "PenaltySandLevel2D-v0", "imitate": -1})


def test_a_run_with_imitation_records_it_and_starts_its_curve_at_the_copy(tmp_path):
    """``train`` with ``imitate``: the summary's ``imitation`` entry, the curve's first point at 0
    PPO steps (the copy of the sweep, evaluated before PPO), and a time split whose parts stay
    PPO's own (the demonstration's env time is under ``imitation_s``, not ``env_step_s``)."""
    T = _train_module()
    settings = dict(
        env_id="PenaltySandLevel2D-v0",
        env_kwargs={"target": "random"},
        timesteps=256,
        n_envs=16,
        n_steps=16,
        batch_size=128,
        eval_freq=256,
        imitate=512,
        eval_episodes=4,
        final_episodes=4,
        gif=False,
        quiet=True,
        progress=False,
        numba_threads=1,
        threads=1,
    )
    summary = T.train(settings, tmp_path / "run")
    fit = summary["imitation"]
    assert fit["decisions"] == 512 and fit["episodes"] >= 16 and fit["action_mse"] < 1.0
    assert summary["curve"][0]["timesteps"] == 0 and summary["curve"][-1]["timesteps"] == summary["timesteps"] >= 256
    split = summary["time_split"]
    assert split["imitation_s"] > 0 and fit["env_step_s"] > 0
    assert fit["env_steps"] == 512 * summary["hyperparameters"]["action_repeat"] == 5120  # (the id holds 10)
    assert split["policy_and_rollout_s"] >= 0 and 0 < split["env_step_s"] < summary["train_time_s"]
    assert summary["hyperparameters"]["imitate"] == 512


def test_imitation_fits_the_value_to_whole_returns_only():
    """The value's targets: each step's discounted return within its episode, kept only for
    episodes that terminated (one cut by the time limit, or by the demonstration's end, is left
    out: PPO bootstraps those)."""
    T = _train_module()  # (train/ on the path)
    del T
    from _imitate import _returns

    r = np.array([[1.0, 1.0], [2.0, 1.0], [3.0, 1.0], [4.0, 1.0]])  # 4 steps, 2 worlds
    done = np.array([[False, False], [True, True], [False, False], [False, True]])
    cut = np.array([[False, False], [False, True], [False, False], [False, False]])
    ret, whole = _returns(r, done, cut, 0.5)
    assert ret[:, 0].tolist() == [1 + 0.5 * 2, 2, 3 + 0.5 * 4, 4]  # (world 0: an episode ends at step 1)
    assert ret[:, 1].tolist() == [1.5, 1, 1.5, 1]
    assert whole[:, 0].tolist() == [True, True, False, False]  # (steps 2-3: the demonstration ended first)
    assert whole[:, 1].tolist() == [False, False, True, True]  # (steps 0-1: cut by the time limit)

"""The training run's two callbacks: the held-out evaluation, with a clock that leaves it out, and
the progress display; and the timers of where a run's time goes.

:class:`HeldOutEval` evaluates the policy every ``every`` environment steps on ``episodes``
held-out episodes (one per world of its own vector env, the deterministic policy), and times the
training without those evaluations: ``train_time_s`` of a curve point is the time spent collecting
rollouts and updating up to that point, ``wall_time_s`` includes the evaluations. It can stop the
run once the success rate reaches ``stop_at``. :class:`Progress` draws a tqdm bar: steps/s, the
latest success rate and the time left.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import Any

import _common as C
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import VecEnvWrapper


class TrainClock:
    """Wall time with the evaluations left out: ``train_time()`` is the time since ``start()``
    minus every ``pause()`` .. ``resume()`` interval."""

    def __init__(self) -> None:
        self.t0 = time.perf_counter()
        self.paused = 0.0
        self._pause_at: float | None = None

    def start(self) -> None:
        self.t0, self.paused, self._pause_at = time.perf_counter(), 0.0, None

    def pause(self) -> None:
        self._pause_at = time.perf_counter()

    def resume(self) -> None:
        if self._pause_at is not None:
            self.paused += time.perf_counter() - self._pause_at
            self._pause_at = None

    def wall_time(self) -> float:
        return time.perf_counter() - self.t0

    def train_time(self) -> float:
        now = self._pause_at if self._pause_at is not None else time.perf_counter()
        return now - self.t0 - self.paused


class HeldOutEval(BaseCallback):
    """Every ``every`` environment steps (and at the end), the success rate and mean return of
    the deterministic policy over held-out episodes, one per world of ``venv``, reseeded with
    ``seed`` each time (the same episodes at every point; ``vecnorm``: the training's
    normalisation, or None). Each point is appended to ``curve`` and passed to ``on_eval``. The
    evaluation's time is left out of ``clock.train_time()``. Training stops at the first point
    whose success rate is at least ``stop_at`` (None: never)."""

    def __init__(
        self,
        venv,
        seed: int,
        vecnorm,
        every: int,
        clock: TrainClock,
        curve: list[dict[str, Any]],
        on_eval: Callable[[dict[str, Any]], None] | None = None,
        stop_at: float | None = None,
        log: Callable[[str], None] | None = None,
        action_repeat: int = 1,
    ) -> None:
        super().__init__(verbose=0)
        self.venv, self.seed, self.vecnorm, self.every, self.clock = venv, seed, vecnorm, every, clock
        self.curve, self.on_eval, self.stop_at, self.log = curve, on_eval, stop_at, log
        self.action_repeat = action_repeat  # (the policy decides every this many env steps)
        self.next_at = every
        self.eval_time = 0.0  # every evaluation's time
        self.eval_in_rollout = 0.0  # of which during the rollouts (not the one after the last)
        self.reached = False

    def evaluate(self) -> dict[str, Any]:
        self.clock.pause()
        t = time.perf_counter()
        self.venv.seed(self.seed)
        policy = C.model_policy(self.model, self.vecnorm)
        res = C.run_episodes(self.venv, policy, self.venv.num_envs, self.action_repeat)
        self.eval_time += time.perf_counter() - t
        point = {
            "timesteps": int(self.num_timesteps),
            "success_rate": res["success_rate"],
            "mean_return": res["mean_return"],
            "train_time_s": round(self.clock.train_time(), 3),
            "wall_time_s": round(self.clock.wall_time(), 3),
        }
        self.curve.append(point)
        if self.log is not None:
            self.log(
                f"[eval] steps={point['timesteps']:>9,} success={point['success_rate']:.2f} "
                f"return={point['mean_return']:.2f} train_time={point['train_time_s']:.1f}s"
            )
        if self.on_eval is not None:
            self.on_eval(dict(point))
        self.reached = self.stop_at is not None and point["success_rate"] >= self.stop_at
        self.clock.resume()
        return point

    def _on_step(self) -> bool:
        if self.num_timesteps >= self.next_at:
            while self.next_at <= self.num_timesteps:
                self.next_at += self.every
            before = self.eval_time
            self.evaluate()
            self.eval_in_rollout += self.eval_time - before
            return not self.reached
        return True

    def _on_training_end(self) -> None:
        if not self.reached and (not self.curve or self.curve[-1]["timesteps"] != self.num_timesteps):
            self.evaluate()


def show_progress(quiet: bool) -> bool:
    """The progress bar (on standard output) is drawn unless ``quiet`` or standard output is not
    a terminal."""
    return not quiet and sys.stdout.isatty()


class Progress(BaseCallback):
    """A tqdm bar over the run's environment steps: steps/s, the latest held-out success rate
    (from ``curve``) and tqdm's estimate of the time left."""

    def __init__(self, total: int, curve: list[dict[str, Any]], desc: str = "") -> None:
        super().__init__(verbose=0)
        self.total, self.curve, self.desc = total, curve, desc
        self.bar: Any = None
        self._shown = 0

    def _on_training_start(self) -> None:
        import shutil

        from tqdm import tqdm

        # a terminal that reports no size (0 by 0: tqdm would hide the bar) counts as 100 by 24
        size = shutil.get_terminal_size((100, 24))
        self.bar = tqdm(
            total=self.total,
            desc=self.desc,
            unit=" steps",
            unit_scale=True,
            ncols=size.columns,
            nrows=size.lines,
            file=sys.stdout,
        )

    def _on_step(self) -> bool:
        if self.bar is not None:
            n = min(self.num_timesteps, self.total) - self._shown
            if n > 0:
                self.bar.update(n)
                self._shown += n
            if self.curve:
                self.bar.set_postfix_str(f"success {self.curve[-1]['success_rate']:.0%}", refresh=False)
        return True

    def _on_training_end(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None


class TimedVecEnv(VecEnvWrapper):
    """The vector env, with the time spent in its ``step`` summed in ``time``."""

    def __init__(self, venv) -> None:
        super().__init__(venv)
        self.time = 0.0

    def reset(self):
        return self.venv.reset()

    def step_wait(self):
        t = time.perf_counter()
        out = self.venv.step_wait()
        self.time += time.perf_counter() - t
        return out


class TimedPPO(PPO):
    """PPO with the time of its rollouts (``rollout_time``, callbacks included) and of its
    updates (``update_time``) summed; ``before_update``, when set, is called before each update."""

    rollout_time = 0.0
    update_time = 0.0
    before_update: Callable[[], None] | None = None  # called before each update (torch's threads: _threads.py)

    def collect_rollouts(self, *args, **kwargs):
        t = time.perf_counter()
        try:
            return super().collect_rollouts(*args, **kwargs)
        finally:
            self.rollout_time += time.perf_counter() - t

    def _excluded_save_params(self) -> list[str]:
        return [*super()._excluded_save_params(), "before_update"]  # (model.zip loads without train/)

    def train(self) -> None:
        t = time.perf_counter()
        if self.before_update is not None:
            self.before_update()
        super().train()
        self.update_time += time.perf_counter() - t

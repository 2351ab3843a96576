"""A scripted pusher: the task's reference controller (a baseline, and the tests' way to reach
the goal on purpose).

It walks to the push point behind the ball (around the ball when it starts on the wrong side),
then pushes toward the goal while steering the push point back onto the goal line. It reads only
the observation, so it works with any PenaltyBalls env (single or batched observations).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .balls.layout import ObservationLayout

__all__ = ["ScriptedPusher", "RasterSweep", "scripted_policy"]


class ScriptedPusher:
    """``policy(obs) -> action`` for observations of a PenaltyBalls env.

    Args:
        dim: 3 or 2 (the env's ``dim``).
        contact: pusher radius + ball radius (the env's ``scene.radii[0] + scene.radii[1]``).
    """

    def __init__(self, dim: int = 3, contact: float = 0.3) -> None:
        self.dim = int(dim)
        self.contact = float(contact)
        layout = ObservationLayout(self.dim, 0, 1.0, 1.0)  # field positions only (obstacles come last)
        h = self.dim - 1  # the horizontal part of each position
        self._pusher, self._ball, self._goal = (
            slice(layout.slice(name).start, layout.slice(name).start + h)
            for name in ("pusher position", "ball position", "goal position")
        )

    @classmethod
    def for_env(cls, env: Any) -> ScriptedPusher:
        scene = env.unwrapped.scene
        return cls(scene.dim, float(scene.radii[0] + scene.radii[1]))

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        obs = np.asarray(obs)
        if obs.ndim == 2:
            return np.stack([self(o) for o in obs])
        h, c = self.dim - 1, self.contact
        p = obs[self._pusher].astype(np.float64)
        b = obs[self._ball].astype(np.float64)
        g = obs[self._goal].astype(np.float64)
        to_goal = g - b
        u = to_goal / max(float(np.linalg.norm(to_goal)), 1e-9)
        rel = p - b
        along = float(rel @ u)
        if along > -0.5 * c:  # on the wrong side: circle around the ball at a safe distance
            perp = rel - along * u
            n = float(np.linalg.norm(perp))
            side = perp / n if n > 1e-6 else (np.array([-u[1], u[0]]) if h == 2 else -u)
            target = b + side * (c + 0.15) - u * (0.5 * c)
        else:
            target = b - u * (c + 0.02)
        err = target - p
        dist = float(np.linalg.norm(err))
        if dist < 0.05 and along <= -0.5 * c:
            cmd = 0.7 * u + 6.0 * err
        else:  # head for the target; at least 0.25 throttle, to beat the friction dead zone
            cmd = err / max(dist, 1e-9) * min(1.0, 0.25 + 4.0 * dist)
        return np.clip(cmd, -1.0, 1.0).astype(np.float32)


class RasterSweep:
    """``policy(obs) -> action`` for observations of a PenaltySandLevel env: a raster sweep, the
    sand-shaping task's scripted baseline.

    The blade runs along x from its wall to the far end of its range, steps sideways (3D) to the
    next of ``lanes`` lanes spread evenly over its y range, runs back, and so on; after the last
    lane it sweeps the lanes again in reverse order (2D: back and forth along x). Each move is at
    full speed towards the next waypoint (the last step slowed to land on it). It reads the blade's
    position from the observation and keeps one waypoint index per row of a batch; a row whose
    blade velocity reads exactly zero (a fresh episode: the blade starts at rest, and never stops
    during a sweep) starts over.

    Args:
        env: a PenaltySandLevel env (single or vector) whose scene gives the blade's range, speed
            and control period.
        lanes: lanes across y in 3D (ignored in 2D).
    """

    def __init__(self, env: Any, lanes: int = 4) -> None:
        scene = env.unwrapped.scene if hasattr(env, "unwrapped") else env.scene
        self.dim = scene.dim
        self.range = np.asarray(scene.blade_range, dtype=np.float64)
        self.step_length = scene.blade_speed * scene.control_period
        C = scene.n_cells
        self._pos = slice(2 * C, 2 * C + self.dim - 1)
        self._vel = slice(2 * C + self.dim - 1, 2 * C + 2 * (self.dim - 1))
        self.lanes = np.linspace(-self.range[1], self.range[1], lanes) if self.dim == 3 else np.zeros(1)
        self._plans: dict[int, list] = {}
        self._next: dict[int, int] = {}

    def _plan(self, start: np.ndarray) -> list:
        """Waypoints of one sweep from the blade's start (then repeated, reversed)."""
        x0 = float(np.sign(start[0]) or -1.0) * self.range[0]
        if self.dim == 2:
            return [np.array([-x0]), np.array([x0])]
        lanes = self.lanes if abs(start[1] - self.lanes[0]) <= abs(start[1] - self.lanes[-1]) else self.lanes[::-1]
        points, x = [], x0
        for y in lanes:  # along the lane from where the blade is, then across to the next lane
            points.append(np.array([x, y]))
            x = -x
            points.append(np.array([x, y]))
        back = [np.array([p[0], p[1]]) for p in points[::-1]]
        return points + back[1:]

    def reset(self) -> None:
        """Forget every row's progress."""
        self._plans.clear()
        self._next.clear()

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        obs = np.asarray(obs)
        if obs.ndim == 2:
            return np.stack([self._act(i, o) for i, o in enumerate(obs)])
        return self._act(0, obs)

    def _act(self, row: int, obs: np.ndarray) -> np.ndarray:
        pos = obs[self._pos].astype(np.float64)
        if row not in self._plans or not np.any(obs[self._vel]):
            self._plans[row] = self._plan(pos)
            self._next[row] = 0
        plan = self._plans[row]
        k = self._next[row]
        while float(np.max(np.abs(plan[k] - pos))) < 1e-3:
            k = (k + 1) % len(plan)
        self._next[row] = k
        return np.clip((plan[k] - pos) / self.step_length, -1.0, 1.0).astype(np.float32)


def scripted_policy(env: Any) -> Any:
    """The scripted policy of ``env``'s task, ``policy(obs) -> action``: :class:`RasterSweep` for a
    PenaltySandLevel env, :class:`ScriptedPusher` for a PenaltyBalls one. Both read the task's
    state vector, so an env observing anything else (a goal env's dict, ``obs_mode="rgb"`` or
    ``"heightmap"``) is refused with a ValueError naming its id, as is an env of another task."""
    from gymnasium import spaces

    from .balls.scene import PenaltyBallsScene
    from .level.scene import SandLevelScene

    u = env.unwrapped
    name = env.spec.id if getattr(env, "spec", None) is not None else type(u).__name__
    scene = getattr(u, "scene", None)
    batch = getattr(u, "batch", None)
    if not isinstance(scene, (PenaltyBallsScene, SandLevelScene)):
        raise ValueError(f"{name} has no scripted policy (there is one for the PenaltyBalls and PenaltySandLevel ids)")
    if batch is None or not batch.view.is_state or not isinstance(env.observation_space, spaces.Box):
        raise ValueError(
            f"{name}: the scripted policies read the task's state vector, but this env observes "
            f"{env.observation_space}; make it with obs_mode='state' (not a goal id), or record a trained policy"
        )
    if isinstance(scene, SandLevelScene):
        return RasterSweep(env)
    return ScriptedPusher.for_env(env)

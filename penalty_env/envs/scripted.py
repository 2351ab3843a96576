"""A scripted pusher: the task's reference controller (a baseline, and the tests' way to reach
the goal on purpose).

It walks to the push point behind the ball (around the ball when it starts on the wrong side),
then pushes toward the goal while steering the push point back onto the goal line. It reads only
the observation, so it works with any PenaltyBalls env (single or batched observations).
"""

from __future__ import annotations

import numpy as np

from .observation import ObservationLayout

__all__ = ["ScriptedPusher"]


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
    def for_env(cls, env) -> ScriptedPusher:
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

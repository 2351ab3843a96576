"""The PenaltyBalls starts (the env docstring's "Starting State" table): the pusher, the ball and
the goal drawn in a fixed order from a world's generator, and the obstacles placed by rejection
sampling clear of every ball and the goal."""

from __future__ import annotations

import math

import numpy as np

from .params import (
    BALL_START_RADIUS,
    GOAL_DISTANCE,
    OBSTACLE_GAP,
    OBSTACLE_REGION,
    OBSTACLE_TRIES,
    PUSHER_GAP,
)

__all__ = ["StartSampler"]


class StartSampler:
    """Draws the PenaltyBalls starts: the horizontal positions of the pusher, the ball, the
    obstacles and the goal, from a world's generator.

    Args:
        dim: 3 or 2.
        n_obstacles: obstacles to place.
        goal_tolerance: the success radius (obstacles stay clear of the goal's circle).
        radii: the bodies' radii (pusher, ball, obstacles): the fixed scene's.
        push: None, or a randomised scene's (B,) push offsets (pusher + ball radius, per world),
            with ``radii_rows`` its (B, n) radii: world b's start uses its own.
    """

    def __init__(
        self,
        dim: int,
        n_obstacles: int,
        goal_tolerance: float,
        radii: np.ndarray,
        push: np.ndarray | None = None,
        radii_rows: np.ndarray | None = None,
    ) -> None:
        self.dim = dim
        self.n_obstacles = n_obstacles
        self.goal_tolerance = goal_tolerance
        self._radii_list = [float(r) for r in radii]
        self._contact = float(radii[0] + radii[1])
        self._push_offset = push
        self._radii_rows = radii_rows

    def sample(self, rng: np.random.Generator, b: int | None = None) -> list[float]:
        """One start's horizontal coordinates, flat: pusher, ball, obstacles, goal. The draws
        (documented in the env's "Starting State") come in a fixed order. Plain floats: a start is
        a handful of scalars, and numpy's per-call cost would dominate. ``b``: a randomised scene's
        world (its drawn radii); None: the fixed radii."""
        push, rows = self._push_offset, self._radii_rows
        randomised = b is not None and push is not None and rows is not None
        contact = float(push[b]) if randomised else self._contact  # type: ignore[index]
        g0, g1 = GOAL_DISTANCE
        ball: tuple[float, ...]
        target: tuple[float, ...]
        pusher: tuple[float, ...]
        p0, p1 = PUSHER_GAP
        if self.dim == 3:
            u = rng.random(6).tolist()
            rho, phi = BALL_START_RADIUS * math.sqrt(u[0]), 2.0 * math.pi * u[1]
            ball = (rho * math.cos(phi), rho * math.sin(phi))
            dist, phi = g0 + (g1 - g0) * u[2], 2.0 * math.pi * u[3]
            target = (ball[0] + dist * math.cos(phi), ball[1] + dist * math.sin(phi))
            gap, phi = p0 + (p1 - p0) * u[4], 2.0 * math.pi * u[5]
            pusher = (ball[0] + (contact + gap) * math.cos(phi), ball[1] + (contact + gap) * math.sin(phi))
        else:
            u = rng.random(4).tolist()
            ball = (BALL_START_RADIUS * (2.0 * u[0] - 1.0),)
            side = 1.0 if u[1] < 0.5 else -1.0
            # on a line the pusher cannot pass the ball: it starts on the far side from the goal
            target = (ball[0] + side * (g0 + (g1 - g0) * u[2]),)
            pusher = (ball[0] - side * (contact + p0 + (p1 - p0) * u[3]),)
        placed = [pusher, ball]
        if self.n_obstacles:
            self._place_obstacles(rng, placed, target, rows[b].tolist() if randomised else None)  # type: ignore[index]
        placed.append(target)
        return [c for h in placed for c in h]

    def _place_obstacles(
        self, rng: np.random.Generator, placed: list, target: tuple, radii: list[float] | None = None
    ) -> None:
        """Rejection sampling: uniform in the obstacle region, clear of every ball and the goal
        (``radii``: the world's; None: the fixed scene's)."""
        d = self.dim
        region = OBSTACLE_REGION[d]
        radii = self._radii_list if radii is None else radii
        r_o = radii[2]
        goal_clear = r_o + self.goal_tolerance
        for _ in range(self.n_obstacles):
            for _ in range(OBSTACLE_TRIES):
                if d == 3:
                    u = rng.random(2).tolist()
                    rho, phi = region * math.sqrt(u[0]), 2.0 * math.pi * u[1]
                    h: tuple[float, ...] = (rho * math.cos(phi), rho * math.sin(phi))
                else:
                    h = (region * (2.0 * rng.random() - 1.0),)
                clear = math.dist(h, target) >= goal_clear and all(
                    math.dist(h, q) >= r_o + radii[i] + OBSTACLE_GAP for i, q in enumerate(placed)
                )
                if clear:
                    break
            else:  # pragma: no cover - the density check in check_parameters makes this unreachable
                raise RuntimeError("could not place the obstacles without overlap; use fewer or smaller ones")
            placed.append(h)

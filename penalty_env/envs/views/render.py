"""``render()``'s frames of a PenaltyBalls world, drawn by the one raster (:mod:`.raster`).

3D scenes are drawn from above (orthographic): the terrain's image (its height lit by its slope,
steep faces such as walls darker, contour lines every 5 cm of height), and each ball as a lit
sphere with a soft shadow that slides away from it as it rises, higher balls over lower ones. 2D
scenes are drawn from the side: the ground's solid below its surface line, shaded discs above. The
goal is a green ring whose radius is the success tolerance. A body outside the view is drawn small
at the frame's border, so it is never lost. The terrain image is drawn once (per world, and again
when a reset redraws the world's terrain).

Nothing here imports pygame except :class:`HumanWindow` (the ``render`` extra), lazily.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .raster import (
    BALL_COLOR,
    GRAIN_COLOR,
    OBSTACLE_COLOR,
    PUSHER_COLOR,
    VIEW_HALF_WIDTH,
    draw_frame_2d,
    draw_frame_3d,
    ground_heights,
    terrain_images,
)

__all__ = ["Renderer", "HumanWindow"]


class Renderer:
    """Draws world ``b`` of a :class:`~..balls.scene.PenaltyBallsScene` into a uint8
    ``(height, width, 3)`` frame."""

    def __init__(self, scene: Any, width: int, height: int) -> None:
        self.scene = scene
        self.width, self.height = int(width), int(height)
        self.scale = self.width / (2.0 * VIEW_HALF_WIDTH)  # pixels per metre
        self.ground_px = 0.8 * self.height
        self.heights = scene.terrain.heights(scene.world)
        self._backgrounds: dict[int, tuple[int, np.ndarray]] = {}  # world (or 0) -> (terrain version, image)
        colors = [PUSHER_COLOR, BALL_COLOR] + [OBSTACLE_COLOR] * scene.n_obstacles + [GRAIN_COLOR] * scene.n_grains
        self.colors = np.array(colors, dtype=np.float64)  # (0..1)
        self.radii = np.ascontiguousarray(scene.radii, dtype=np.float64)
        self._order = np.zeros(len(self.radii), dtype=np.int64)
        self._ground = np.zeros(len(self.radii))

    def _background(self, b: int) -> np.ndarray:
        """World b's terrain image (one for every world unless the terrain is drawn per world),
        drawn again when the scene's terrain version of that world changes."""
        s = self.scene
        per_world = s.terrain.per_world
        key, version = (b, int(s.terrain_version[b])) if per_world else (0, 0)
        cached = self._backgrounds.get(key)
        if cached is None or cached[0] != version:
            image = np.zeros((1, self.height, self.width, 3), dtype=np.uint8)
            worlds, rows = np.array([b], dtype=np.int64), np.zeros(1, dtype=np.int64)
            terrain_images(worlds, rows, image, self.heights, self.scale, self.ground_px, s.dim)
            cached = self._backgrounds[key] = (version, image[0])
        return cached[1]

    def frame(self, b: int = 0) -> np.ndarray:
        s = self.scene
        # (a randomised scene: world b's drawn radii)
        radii = self.radii if not s.randomize else np.ascontiguousarray(s.world.model.radii[b])
        img = self._background(b).copy()
        pos = np.ascontiguousarray(s.world.positions[b])
        goal = np.ascontiguousarray(s.goal[b])
        if s.dim == 3:
            ground_heights(b, pos, self.heights, self._ground)
            draw_frame_3d(img, pos, radii, self.colors, goal, s.goal_tolerance, self._ground, self.scale, self._order)
        else:
            draw_frame_2d(
                img,
                pos,
                radii,
                self.colors,
                goal,
                s.goal_tolerance,
                s.bowl_radius,
                self.scale,
                self.ground_px,
                s.n_bodies,
            )
        return img


class HumanWindow:
    """A pygame window showing frames at ``fps`` (pygame is imported here, on first use)."""

    def __init__(self, width: int, height: int, fps: float, title: str = "PenaltyBalls") -> None:
        try:
            import pygame
        except ImportError as exc:  # pragma: no cover - depends on the install
            from gymnasium.error import DependencyNotInstalled

            raise DependencyNotInstalled(
                'render_mode="human" needs pygame: pip install -e ".[render]" from the repository\'s root '
                "(or pip install pygame)"
            ) from exc
        self._pygame = pygame
        pygame.display.init()
        pygame.display.set_caption(title)
        self.screen = pygame.display.set_mode((int(width), int(height)))
        self.clock = pygame.time.Clock()
        self.fps = fps

    def show(self, frame: np.ndarray) -> None:
        pg = self._pygame
        pg.event.pump()
        surf = pg.surfarray.make_surface(np.ascontiguousarray(frame.transpose(1, 0, 2)))
        self.screen.blit(surf, (0, 0))
        pg.display.flip()
        self.clock.tick(self.fps)

    def close(self) -> None:
        self._pygame.display.quit()

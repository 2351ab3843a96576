"""Frames of a PenaltyBalls world: a small Numba rasteriser over a precomputed terrain image.

3D scenes are drawn from above (orthographic): the terrain (any shapes: it is found by sphere
tracing their distance from above, the bowl analytically) is shaded by its slope, steep faces such
as walls darker, and ringed with contour lines every 5 cm of height, each ball is a lit sphere (diffuse + specular) with a
soft shadow that slides away from it as it rises, and higher balls are drawn over lower ones.
2D scenes are drawn from the side: the bowl's solid below its surface line, shaded discs above.
The goal is a green ring whose radius is the success tolerance. A body outside the view is drawn
small at the frame's border, so it is never lost.

Nothing here imports pygame except :class:`HumanWindow` (the ``render`` extra), lazily.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit

__all__ = ["Renderer", "HumanWindow", "terrain_image", "terrain_heightmap"]

VIEW_HALF_WIDTH = 1.75  # metres of terrain shown either side of the bowl's bottom
CONTOUR_STEP = 0.05  # metres of height between contour lines (3D)

PUSHER_COLOR = (0.20, 0.42, 0.85)
BALL_COLOR = (0.93, 0.45, 0.10)
OBSTACLE_COLOR = (0.55, 0.55, 0.60)
GOAL_COLOR = (0.10, 0.70, 0.25)
GRAIN_COLOR = (0.70, 0.50, 0.30)
LIGHT = (-0.45, -0.55, 0.70)  # towards the light, image axes (x right, y down, z out of screen)


@njit
def _blend(img, px, py, r, g, b, alpha):
    if alpha <= 0.0:
        return
    if alpha > 1.0:
        alpha = 1.0
    for c, val in enumerate((r, g, b)):
        old = img[py, px, c]
        img[py, px, c] = np.uint8(min(255.0, max(0.0, old + alpha * (val - old)) + 0.5))


@njit
def _sphere(img, cx, cy, rad, r, g, b, lx, ly, lz):
    """A lit sphere of radius ``rad`` pixels at (cx, cy), antialiased at its rim."""
    H, W = img.shape[0], img.shape[1]
    x0 = max(0, int(cx - rad - 1.0))
    x1 = min(W - 1, int(cx + rad + 1.0))
    y0 = max(0, int(cy - rad - 1.0))
    y1 = min(H - 1, int(cy + rad + 1.0))
    # half vector for the specular highlight (viewer along +z)
    hx, hy, hz = lx, ly, lz + 1.0
    hn = math.sqrt(hx * hx + hy * hy + hz * hz)
    hx, hy, hz = hx / hn, hy / hn, hz / hn
    inv = 1.0 / max(rad, 1e-6)
    for py in range(y0, y1 + 1):
        for px in range(x0, x1 + 1):
            dx = px + 0.5 - cx
            dy = py + 0.5 - cy
            dist = math.sqrt(dx * dx + dy * dy)
            cover = rad + 0.5 - dist
            if cover <= 0.0:
                continue
            nx = dx * inv
            ny = dy * inv
            nz2 = 1.0 - nx * nx - ny * ny
            nz = math.sqrt(nz2) if nz2 > 0.0 else 0.0
            diff = max(0.0, nx * lx + ny * ly + nz * lz)
            spec = max(0.0, nx * hx + ny * hy + nz * hz) ** 40
            shade = 0.35 + 0.75 * diff
            _blend(
                img,
                px,
                py,
                255.0 * min(1.0, r * shade + 0.6 * spec),
                255.0 * min(1.0, g * shade + 0.6 * spec),
                255.0 * min(1.0, b * shade + 0.6 * spec),
                cover,
            )


@njit
def _shadow(img, cx, cy, rad, strength):
    """A soft dark disc (a ball's shadow on the terrain)."""
    H, W = img.shape[0], img.shape[1]
    soft = 0.35 * rad + 1.0
    x0 = max(0, int(cx - rad - soft - 1.0))
    x1 = min(W - 1, int(cx + rad + soft + 1.0))
    y0 = max(0, int(cy - rad - soft - 1.0))
    y1 = min(H - 1, int(cy + rad + soft + 1.0))
    for py in range(y0, y1 + 1):
        for px in range(x0, x1 + 1):
            dx = px + 0.5 - cx
            dy = py + 0.5 - cy
            t = (rad + soft - math.sqrt(dx * dx + dy * dy)) / (2.0 * soft)
            if t > 0.0:
                _blend(img, px, py, 0.0, 0.0, 0.0, strength * min(1.0, t))


@njit
def _ring(img, cx, cy, rad, width, r, g, b, fill):
    """An antialiased ring (and a faint fill) of radius ``rad`` pixels."""
    H, W = img.shape[0], img.shape[1]
    x0 = max(0, int(cx - rad - width - 1.0))
    x1 = min(W - 1, int(cx + rad + width + 1.0))
    y0 = max(0, int(cy - rad - width - 1.0))
    y1 = min(H - 1, int(cy + rad + width + 1.0))
    for py in range(y0, y1 + 1):
        for px in range(x0, x1 + 1):
            dx = px + 0.5 - cx
            dy = py + 0.5 - cy
            dist = math.sqrt(dx * dx + dy * dy)
            edge = 0.5 * width + 0.5 - abs(dist - rad)
            if edge > 0.0:
                _blend(img, px, py, r, g, b, min(1.0, edge))
            elif dist < rad:
                _blend(img, px, py, r, g, b, fill)


@njit
def _rect(img, x0f, y0f, x1f, y1f, r, g, b):
    H, W = img.shape[0], img.shape[1]
    for py in range(max(0, int(y0f)), min(H, int(y1f) + 1)):
        for px in range(max(0, int(x0f)), min(W, int(x1f) + 1)):
            _blend(img, px, py, r, g, b, 1.0)


@njit(entry=True)
def _draw_3d(img, pos, radii, colors, goal, goal_tol, ground, scale, order):
    """Top view: x right, y up in the world (down in the image); z gives shadow and order;
    ``ground`` is the terrain's height under each ball."""
    H, W = img.shape[0], img.shape[1]
    ox = 0.5 * W
    oy = 0.5 * H
    lx, ly, lz = LIGHT
    ln = math.sqrt(lx * lx + ly * ly + lz * lz)
    lx, ly, lz = lx / ln, ly / ln, lz / ln
    # goal: ring of the success radius, faint fill, centre dot
    gx = ox + goal[0] * scale
    gy = oy - goal[1] * scale
    _ring(
        img,
        gx,
        gy,
        goal_tol * scale,
        max(1.5, 0.012 * W),
        255.0 * GOAL_COLOR[0],
        255.0 * GOAL_COLOR[1],
        255.0 * GOAL_COLOR[2],
        0.3,
    )
    _ring(
        img, gx, gy, 0.0, max(2.0, 0.012 * W), 255.0 * GOAL_COLOR[0], 255.0 * GOAL_COLOR[1], 255.0 * GOAL_COLOR[2], 0.0
    )
    n = pos.shape[0]
    # shadows first: cast away from the light, farther the higher the ball floats
    for i in range(n):
        x, y, z = pos[i, 0], pos[i, 1], pos[i, 2]
        lift = max(0.0, z - radii[i] - ground[i])
        sx = ox + (x - (lx / lz) * (radii[i] * 0.6 + lift)) * scale
        sy = oy - (y + (ly / lz) * (radii[i] * 0.6 + lift)) * scale
        _shadow(img, sx, sy, radii[i] * scale, 0.45 / (1.0 + 4.0 * lift))
    # balls, lowest first (insertion sort: n is small, and nothing is allocated)
    for t in range(n):
        order[t] = t
    for t in range(1, n):
        i = order[t]
        u = t
        while u > 0 and pos[order[u - 1], 2] > pos[i, 2]:
            order[u] = order[u - 1]
            u -= 1
        order[u] = i
    for t in range(n):
        i = order[t]
        cx = ox + pos[i, 0] * scale
        cy = oy - pos[i, 1] * scale
        rad = radii[i] * scale
        if cx < 0.0 or cx >= W or cy < 0.0 or cy >= H:  # out of view: a small marker at the border
            cx = min(max(cx, 0.35 * rad), W - 0.35 * rad)
            cy = min(max(cy, 0.35 * rad), H - 0.35 * rad)
            rad = 0.35 * rad
        _sphere(img, cx, cy, rad, colors[i, 0], colors[i, 1], colors[i, 2], lx, ly, lz)


@njit(entry=True)
def _draw_2d(img, pos, radii, colors, goal, goal_tol, R, scale, ground_px, bodies):
    """Side view: x right, z up (y = ground_px at z = 0). The balls after the first ``bodies``
    (the grains) are drawn first, the bodies over them."""
    H, W = img.shape[0], img.shape[1]
    ox = 0.5 * W
    lx, ly, lz = LIGHT
    ln = math.sqrt(lx * lx + ly * ly + lz * lz)
    lx, ly, lz = lx / ln, ly / ln, lz / ln
    # goal: a flag pole at the goal and the success band on the ground
    gx = ox + goal[0] * scale
    gz = ground_px - (goal[1] - 0.0) * scale
    band = goal_tol * scale
    gr, gg, gb = 255.0 * GOAL_COLOR[0], 255.0 * GOAL_COLOR[1], 255.0 * GOAL_COLOR[2]
    _rect(img, gx - band, gz + 0.2 * scale * 0.5, gx + band, gz + 0.2 * scale * 0.5 + max(2.0, 0.012 * H), gr, gg, gb)
    _rect(img, gx - 1.0, gz - 0.35 * scale, gx + 1.0, gz + 0.1 * scale, 0.3 * gr, 0.3 * gg, 0.3 * gb)
    _rect(img, gx + 1.0, gz - 0.35 * scale, gx + 1.0 + 0.12 * scale, gz - 0.27 * scale, gr, gg, gb)
    n = pos.shape[0]
    for t in range(n):
        i = (t + bodies) % n
        cx = ox + pos[i, 0] * scale
        cy = ground_px - pos[i, 1] * scale
        rad = radii[i] * scale
        if cx < 0.0 or cx >= W or cy < 0.0 or cy >= H:
            cx = min(max(cx, 0.35 * rad), W - 0.35 * rad)
            cy = min(max(cy, 0.35 * rad), H - 0.35 * rad)
            rad = 0.35 * rad
        _sphere(img, cx, cy, rad, colors[i, 0], colors[i, 1], colors[i, 2], lx, ly, lz)


def _background_3d(W: int, H: int, R: float, scale: float) -> np.ndarray:
    """The bowl seen from above: sand shaded by the terrain's normal, contour rings of height."""
    xs = (np.arange(W) + 0.5 - 0.5 * W) / scale
    ys = -(np.arange(H) + 0.5 - 0.5 * H) / scale
    X, Y = np.meshgrid(xs, ys)
    rho2 = np.minimum(X * X + Y * Y, R * R)
    Z = R - np.sqrt(R * R - rho2)  # terrain height above the bottom
    # outward normal of the terrain surface (pointing into the free space, up): (c - p) / R
    nx, ny, nz = -X / R, -Y / R, (R - Z) / R
    lx, ly, lz = np.array(LIGHT) / np.linalg.norm(LIGHT)
    lambert = np.clip(nx * lx - ny * ly + nz * lz, 0.0, 1.0)  # image y is flipped
    # exaggerate the slope's shading so the bowl's curvature reads at a glance
    shade = 0.78 + 2.5 * (lambert - lz) + 0.06 * (1.0 - Z / max(Z.max(), 1e-9))
    sand = np.array([0.90, 0.84, 0.70])
    img = sand[None, None, :] * np.clip(shade, 0.55, 1.1)[..., None]
    # contour lines: darken where the height is near a multiple of CONTOUR_STEP
    phase = Z / CONTOUR_STEP
    frac = (
        np.abs(phase - np.round(phase))
        * CONTOUR_STEP
        * scale
        / np.maximum(np.sqrt(rho2) / np.maximum(R - Z, 1e-9), 1e-3)
    )  # pixel distance to the nearest contour
    line = np.clip(1.0 - frac, 0.0, 1.0) * (np.round(phase) > 0)
    img *= (1.0 - 0.18 * line)[..., None]
    return np.clip(255.0 * img + 0.5, 0, 255).astype(np.uint8)


def _background_2d(W: int, H: int, R: float, scale: float, ground_px: float) -> np.ndarray:
    """The bowl seen from the side: sky inside the circle, earth outside, a surface line."""
    xs = (np.arange(W) + 0.5 - 0.5 * W) / scale
    zs = (ground_px - (np.arange(H) + 0.5)) / scale
    X, Z = np.meshgrid(xs, zs)
    dist = np.sqrt(X * X + (Z - R) ** 2)  # to the bowl's centre (0, R)
    depth = (dist - R) * scale  # pixels into the solid (> 0) or the free space (< 0)
    return _side_image(Z, depth)


def _shade_3d(
    Z: np.ndarray, nx: np.ndarray, ny: np.ndarray, nz: np.ndarray, scale: float, sky: np.ndarray
) -> np.ndarray:
    """A top view of a height map ``Z`` with normals n: sand lit by the normal (its slope read at a
    glance), contour rings every CONTOUR_STEP of height, steep faces (walls) darker; ``sky`` marks
    columns without ground."""
    lx, ly, lz = np.array(LIGHT) / np.linalg.norm(LIGHT)
    lambert = np.clip(nx * lx - ny * ly + nz * lz, 0.0, 1.0)  # image y is flipped
    span = max(float(np.ptp(Z[~sky])) if np.any(~sky) else 0.0, 1e-9)
    shade = 0.78 + 2.5 * (lambert - lz) + 0.06 * (1.0 - (Z - Z[~sky].min() if np.any(~sky) else Z) / span)
    sand = np.array([0.90, 0.84, 0.70])
    img = sand[None, None, :] * np.clip(shade, 0.45, 1.1)[..., None]
    wall = np.clip((0.5 - nz) * 2.0, 0.0, 1.0)[..., None]  # faces steeper than 60 degrees
    img = img * (1.0 - wall) + np.array([0.52, 0.50, 0.48]) * wall
    gy, gx = np.gradient(Z * scale)
    slope = np.maximum(np.hypot(gx, gy) / max(CONTOUR_STEP * scale, 1e-9), 1e-3)
    phase = Z / CONTOUR_STEP
    frac = np.abs(phase - np.round(phase)) / slope  # pixel distance to the nearest contour
    line = np.clip(1.0 - frac, 0.0, 1.0) * (nz > 0.5)
    img *= (1.0 - 0.18 * line)[..., None]
    img[sky] = np.array([0.80, 0.88, 0.97])
    return np.clip(255.0 * img + 0.5, 0, 255).astype(np.uint8)


def terrain_heightmap(distance, xs: np.ndarray, ys: np.ndarray, top: float, bottom: float):
    """The terrain seen from above, for any shapes: each column (x, y) is marched down from z = top
    by sphere tracing (z <- z - phi, a safe step for a distance or a bound of it) until phi is
    about 0. ``distance(points) -> (phi, normal)``. Returns the height Z, the normal at the hit
    (nx, ny, nz) and where no ground was met above ``bottom``."""
    X, Y = np.meshgrid(xs, ys)
    z = np.full(X.shape, float(top))
    eps = 1e-3
    # first through any solid at the top (a container's lid, the rock around a cavity): the view
    # is a cut-away, the first surface below free space; a column solid all the way down is a wall
    phi, _ = distance(np.stack([X, Y, z], -1))
    lid = phi <= 0.0
    for _ in range(400):
        inside = (phi < 0.0) & (z > bottom)
        if not np.any(inside):
            break
        z = np.where(inside, z - np.maximum(-phi, eps), z)
        phi, _ = distance(np.stack([X, Y, z], -1))
    wall = z <= bottom
    z = np.where(wall, top, np.where(lid, z - eps, z))  # just below the lid's underside
    for _ in range(400):
        phi, _ = distance(np.stack([X, Y, z], -1))
        step = np.where((phi > 1e-4) & ~wall, phi, 0.0)
        if not np.any(step > 0.0):
            break
        z = np.maximum(z - step, bottom - 1.0)
    phi, n = distance(np.stack([X, Y, z], -1))
    sky = (z <= bottom) | ~np.isfinite(phi)
    n = np.where(wall[..., None], np.array([0.0, 0.0, 0.0]), n)  # a wall is drawn as a steep face
    return z, n[..., 0], n[..., 1], n[..., 2], sky


def _background_generic_3d(W: int, H: int, scale: float, distance, top: float) -> tuple[np.ndarray, np.ndarray]:
    """A top view of any terrain (``distance``): the image and its height map (for the shadows)."""
    xs = (np.arange(W) + 0.5 - 0.5 * W) / scale
    ys = -(np.arange(H) + 0.5 - 0.5 * H) / scale
    Z, nx, ny, nz, sky = terrain_heightmap(distance, xs, ys, top, -top)
    return _shade_3d(Z, nx, ny, nz, scale, sky), Z


def _background_generic_2d(W: int, H: int, scale: float, ground_px: float, distance) -> np.ndarray:
    """A side view of any terrain: sky where phi > 0, earth inside the solid, a surface line."""
    xs = (np.arange(W) + 0.5 - 0.5 * W) / scale
    zs = (ground_px - (np.arange(H) + 0.5)) / scale
    X, Z = np.meshgrid(xs, zs)
    phi, _ = distance(np.stack([X, Z], -1))
    depth = -phi * scale  # pixels into the solid (> 0) or the free space (< 0)
    return _side_image(Z, depth)


def _side_image(Z: np.ndarray, depth: np.ndarray) -> np.ndarray:
    sky_top, sky_low = np.array([0.80, 0.88, 0.97]), np.array([0.96, 0.97, 0.99])
    t = np.clip((Z - Z.min()) / max(float(Z.max() - Z.min()), 1e-9), 0.0, 1.0)[..., None]
    sky = sky_low + (sky_top - sky_low) * t
    earth = np.array([0.60, 0.47, 0.32]) * np.clip(1.0 - 0.004 * depth, 0.6, 1.0)[..., None]
    solid = np.clip(depth + 0.5, 0.0, 1.0)[..., None]
    img = sky * (1.0 - solid) + earth * solid
    line = np.clip(1.5 - np.abs(depth), 0.0, 1.0)[..., None]
    img = img * (1.0 - line) + np.array([0.35, 0.25, 0.15]) * line
    return np.clip(255.0 * img + 0.5, 0, 255).astype(np.uint8)


def terrain_image(world, b: int, width: int, height: int) -> np.ndarray:
    """The terrain of world ``b`` of any ``World`` as the renderer draws it: a top view in 3D, a side
    view in 2D, ``2 VIEW_HALF_WIDTH`` metres across (``python -m penalty_env.bench shapes`` draws
    every shape with it)."""
    scale = width / (2.0 * VIEW_HALF_WIDTH)

    def distance(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return world.terrain_distance(points, world=b)

    if world.dim == 3:
        return _background_generic_3d(width, height, scale, distance, top=2.5)[0]
    return _background_generic_2d(width, height, scale, 0.8 * height, distance)


class Renderer:
    """Draws world ``b`` of a :class:`~penalty_env.envs.scene.PenaltyBallsScene` into a uint8
    ``(height, width, 3)`` frame. The terrain image is computed once."""

    def __init__(self, scene, width: int, height: int) -> None:
        self.scene = scene
        self.width, self.height = int(width), int(height)
        self.scale = self.width / (2.0 * VIEW_HALF_WIDTH)  # pixels per metre
        self.ground_px = 0.8 * self.height
        self.bowl = scene.terrain_kind == "bowl"
        R = scene.bowl_radius
        self._backgrounds: dict[
            int, tuple[int, np.ndarray, np.ndarray | None]
        ] = {}  # world -> (version, image, heights)
        if self.bowl:  # the bowl's own drawing (analytic): the same for every world
            if scene.dim == 3:
                self.background = _background_3d(self.width, self.height, R, self.scale)
            else:
                self.background = _background_2d(self.width, self.height, R, self.scale, self.ground_px)
        colors = [PUSHER_COLOR, BALL_COLOR] + [OBSTACLE_COLOR] * scene.n_obstacles + [GRAIN_COLOR] * scene.n_grains
        self.colors = np.array(colors, dtype=np.float64)
        self.radii = np.ascontiguousarray(scene.radii, dtype=np.float64)
        self._order = np.zeros(len(self.radii), dtype=np.int64)

    def _terrain(self, b: int) -> tuple[np.ndarray, np.ndarray | None]:
        """World b's terrain image (and height map in 3D), drawn from its shapes' distance and
        redrawn when the scene's terrain version of that world changes (bumps at a reset)."""
        s = self.scene
        version = int(s.terrain_version[b])
        cached = self._backgrounds.get(b)
        if cached is None or cached[0] != version:
            world = s.world

            def distance(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
                return world.terrain_distance(points, world=b)

            if s.dim == 3:
                img, Z = _background_generic_3d(self.width, self.height, self.scale, distance, top=2.5)
            else:
                img, Z = _background_generic_2d(self.width, self.height, self.scale, self.ground_px, distance), None
            cached = self._backgrounds[b] = (version, img, Z)
        return cached[1], cached[2]

    def _ground(self, b: int, pos: np.ndarray, heights: np.ndarray | None) -> np.ndarray:
        """The terrain's height under each ball (3D): the bowl's analytic floor, or the height map."""
        if self.bowl:
            R = self.scene.bowl_radius
            return R - np.sqrt(np.maximum(R * R - pos[:, 0] ** 2 - pos[:, 1] ** 2, 0.0))
        assert heights is not None
        px = np.clip(((pos[:, 0] * self.scale) + 0.5 * self.width).astype(int), 0, self.width - 1)
        py = np.clip((0.5 * self.height - pos[:, 1] * self.scale).astype(int), 0, self.height - 1)
        return heights[py, px]

    def frame(self, b: int = 0) -> np.ndarray:
        s = self.scene
        # (a randomised scene: world b's drawn radii)
        radii = self.radii if not getattr(s, "randomize", None) else s.world.model.radii[b]
        heights = None
        if self.bowl:
            img = self.background.copy()
        else:
            background, heights = self._terrain(b)
            img = background.copy()
        pos = np.ascontiguousarray(s.world.positions[b])
        goal = np.ascontiguousarray(s.goal[b])
        if s.dim == 3:
            ground = np.ascontiguousarray(self._ground(b, pos, heights))
            _draw_3d(img, pos, radii, self.colors, goal, s.goal_tolerance, ground, self.scale, self._order)
        else:
            _draw_2d(
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

            raise DependencyNotInstalled('render_mode="human" needs pygame: pip install "penalty-env[render]"') from exc
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

"""The one raster: every picture the package draws, the observation images (``obs_mode="rgb"``)
and ``render()``'s frames, is drawn here, over one terrain image per terrain (its height read
through :func:`~..terrains.terrain_height`, the terrains' one height definition).

* :func:`terrain_images`: the terrain seen from above (3D: the ground lit by its slope, steep faces
  and solid columns grey, contour lines every CONTOUR_STEP of height) or from the side (2D: sky
  above the ground line, earth below);
* :func:`rgb_worlds`: an observation image per world, each ball a flat disc of its colour;
* :func:`draw_frame_3d`, :func:`draw_frame_2d`: a rendered frame, each ball a lit sphere (diffuse
  and specular) with a soft shadow that slides away from it as it rises, higher balls over lower;
* :func:`heightmap_worlds`: the height maps of ``obs_mode="heightmap"`` (no pixels, but the same
  terrain height and ball tops).

The two ball styles differ on purpose: an observation image must be cheap and read the same at 16
pixels as at 256 (flat discs), a frame is for people (shading, shadows).
"""

from __future__ import annotations

import math

import numpy as np

from ..._jit import njit
from ..terrains import terrain_height

__all__ = [
    "heightmap_worlds",
    "rgb_worlds",
    "terrain_images",
    "draw_frame_3d",
    "draw_frame_2d",
    "ground_heights",
    "VIEW_HALF_WIDTH",
    "CONTOUR_STEP",
    "PUSHER_COLOR",
    "BALL_COLOR",
    "OBSTACLE_COLOR",
    "GOAL_COLOR",
    "GRAIN_COLOR",
    "BLADE_COLOR",
    "LIGHT",
]

VIEW_HALF_WIDTH = 1.75  # metres of terrain shown either side of the bowl's bottom
CONTOUR_STEP = 0.05  # metres of height between contour lines (3D)

PUSHER_COLOR = (0.20, 0.42, 0.85)
BALL_COLOR = (0.93, 0.45, 0.10)
OBSTACLE_COLOR = (0.55, 0.55, 0.60)
GOAL_COLOR = (0.10, 0.70, 0.25)
GRAIN_COLOR = (0.70, 0.50, 0.30)
BLADE_COLOR = (0.30, 0.30, 0.34)
LIGHT = (-0.45, -0.55, 0.70)  # towards the light, image axes (x right, y down, z out of screen)

# the terrain image's colours
_SAND = (0.90, 0.84, 0.70)
_WALL = (0.52, 0.50, 0.48)
_SKY_TOP, _SKY_LOW = (0.80, 0.88, 0.97), (0.96, 0.97, 0.99)
_EARTH, _LINE = (0.60, 0.47, 0.32), (0.35, 0.25, 0.15)


@njit(entry=True, nogil=True)
def ground_heights(b, pos, terrain, out):
    """The terrain's height under each ball of ``pos`` (n, d) of world b, into ``out`` (3D)."""
    for i in range(pos.shape[0]):
        out[i] = terrain_height(b, pos[i, 0], pos[i, 1], terrain)


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
def draw_frame_3d(img, pos, radii, colors, goal, goal_tol, ground, scale, order):
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
def draw_frame_2d(img, pos, radii, colors, goal, goal_tol, R, scale, ground_px, bodies):
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


@njit(entry=True, nogil=True)
def heightmap_worlds(worlds, out, x, focus, radii, terrain, cells_y, cell, low, high):
    """The height maps of ``worlds`` into ``out`` (one row per world, in order; ``(k, cells,
    cells_y)``, ``cells_y`` 1 in 2D): cells of edge ``cell`` centred on ``focus[b]`` (the
    pusher, the blade), each
    the highest of the terrain at its centre and of every ball's top over it, clipped to [low,
    high]. A ball with a non-finite coordinate is skipped."""
    H = out.shape[1]
    W = cells_y
    D = x.shape[2]
    n = x.shape[1]
    half = 0.5 * (H - 1)
    half_y = 0.5 * (W - 1)
    for t in range(worlds.shape[0]):
        b = worlds[t]
        cx = focus[b, 0]
        cy = focus[b, 1] if D == 3 else 0.0
        if not (np.isfinite(cx) and np.isfinite(cy)):
            cx, cy = 0.0, 0.0
        x0 = cx - half * cell  # the first cell's centre
        y0 = cy - half_y * cell
        for i in range(H):
            for j in range(W):
                out[t, i, j] = terrain_height(b, x0 + i * cell, y0 + j * cell, terrain)
        for k in range(n):
            bx = x[b, k, 0]
            by = x[b, k, 1] if D == 3 else 0.0
            bz = x[b, k, D - 1]
            r = radii[b, k]
            if not (np.isfinite(bx) and np.isfinite(by) and np.isfinite(bz)):
                continue
            i0 = max(0, int(math.ceil((bx - r - x0) / cell)))
            i1 = min(H - 1, int(math.floor((bx + r - x0) / cell)))
            j0, j1 = 0, 0
            if D == 3:
                j0 = max(0, int(math.ceil((by - r - y0) / cell)))
                j1 = min(W - 1, int(math.floor((by + r - y0) / cell)))
            for i in range(i0, i1 + 1):
                dx = x0 + i * cell - bx
                for j in range(j0, j1 + 1):
                    dy = y0 + j * cell - by if D == 3 else 0.0
                    rho2 = dx * dx + dy * dy
                    if rho2 < r * r:
                        top = bz + math.sqrt(r * r - rho2)
                        if top > out[t, i, j]:
                            out[t, i, j] = top
        for i in range(H):
            for j in range(W):
                out[t, i, j] = min(max(out[t, i, j], low), high)


@njit(hot=True)
def _put(img, t, py, px, r, g, b, alpha):
    """Blend colour (r, g, b) (0..255) over pixel (py, px) of image t with opacity alpha."""
    if alpha <= 0.0:
        return
    if alpha > 1.0:
        alpha = 1.0
    for c in range(3):
        val = r if c == 0 else g if c == 1 else b
        old = float(img[t, py, px, c])
        img[t, py, px, c] = np.uint8(min(255.0, max(0.0, old + alpha * (val - old))) + 0.5)


@njit(hot=True)
def _disc(img, t, cx, cy, rad, r, g, b):
    """A flat disc of radius ``rad`` pixels at (cx, cy) (pixel units, y down), antialiased at its
    rim: a pixel whose centre lies within rad - 0.5 of (cx, cy) takes the colour exactly."""
    S = img.shape[1]
    x0 = max(0, int(cx - rad - 1.0))
    x1 = min(S - 1, int(cx + rad + 1.0))
    y0 = max(0, int(cy - rad - 1.0))
    y1 = min(S - 1, int(cy + rad + 1.0))
    for py in range(y0, y1 + 1):
        dy = py + 0.5 - cy
        for px in range(x0, x1 + 1):
            dx = px + 0.5 - cx
            _put(img, t, py, px, r, g, b, rad + 0.5 - math.sqrt(dx * dx + dy * dy))


@njit(entry=True, nogil=True)
def rgb_worlds(worlds, out, x, radii, colors, order, goal, goal_radius, backgrounds, background_of, scale, ground):
    """The images of ``worlds`` into ``out`` (``(k, S, S, 3)`` uint8, one per world, in order):
    world b's terrain image ``backgrounds[background_of[b]]``, the goal (a disc of
    ``goal_radius`` m), then every ball as a disc of its colour (``colors``, 0..255), in the
    order of ``order`` (the grains, the obstacles, the pusher, the ball: the last on top). 3D: top view, x
    right, y up; 2D: side view, z up, z = 0 at pixel row ``ground``; ``scale`` pixels per metre,
    x = 0 at the centre. A ball outside the image is drawn at a third of its size (at least 1.5 pixels) at the border."""
    S = out.shape[1]
    D = x.shape[2]
    ox = 0.5 * S
    oy = 0.5 * S if D == 3 else ground
    for t in range(worlds.shape[0]):
        b = worlds[t]
        bg = backgrounds[background_of[b]]
        for py in range(S):
            for px in range(S):
                for c in range(3):
                    out[t, py, px, c] = bg[py, px, c]
        gx = ox + goal[b, 0] * scale
        gy = oy - goal[b, 1] * scale  # (3D: y; 2D: z)
        if np.isfinite(gx) and np.isfinite(gy):
            _disc(
                out,
                t,
                gx,
                gy,
                max(goal_radius * scale, 1.0),
                255.0 * GOAL_COLOR[0],
                255.0 * GOAL_COLOR[1],
                255.0 * GOAL_COLOR[2],
            )
        for s in range(order.shape[0]):
            k = order[s]
            cx = ox + x[b, k, 0] * scale
            cy = oy - x[b, k, 1] * scale
            if not (np.isfinite(cx) and np.isfinite(cy)):
                continue
            rad = radii[b, k] * scale
            if cx < 0.0 or cx >= S or cy < 0.0 or cy >= S:  # out of view: a small marker at the border
                rad = max(1.5, rad / 3.0)
                cx = min(max(cx, rad), S - rad)
                cy = min(max(cy, rad), S - rad)
            _disc(out, t, cx, cy, rad, colors[k, 0], colors[k, 1], colors[k, 2])


@njit(hot=True)
def _mix(a, b, w):
    return a + (b - a) * w


@njit(entry=True, nogil=True)
def terrain_images(worlds, rows, dest, terrain, scale, ground, dim):
    """The terrain images of ``worlds`` into ``dest[rows[t]]`` (``(K, H, W, 3)`` uint8, ``scale`` pixels per metre, x = 0 at the centre; 3D: y = 0 at
    the centre row; 2D: z = 0 at pixel row ``ground``): 3D a top
    view (sand lit by the slope, steep faces and solid columns grey, contour lines every
    CONTOUR_STEP of height); 2D a side view (sky above the ground line, earth below)."""
    H, W = dest.shape[1], dest.shape[2]
    lx, ly, lz = LIGHT
    ln = math.sqrt(lx * lx + ly * ly + lz * lz)
    lx, ly, lz = lx / ln, -ly / ln, lz / ln  # towards the light, world axes (image y is down)
    e = 0.5 / scale  # half a pixel, for the slope
    for t in range(worlds.shape[0]):
        b = worlds[t]
        q = rows[t]
        for py in range(H):
            for px in range(W):
                X = (px + 0.5 - 0.5 * W) / scale
                if dim == 3:
                    Y = -(py + 0.5 - 0.5 * H) / scale
                    h = terrain_height(b, X, Y, terrain)
                    gx = (terrain_height(b, X + e, Y, terrain) - terrain_height(b, X - e, Y, terrain)) / (2.0 * e)
                    gy = (terrain_height(b, X, Y + e, terrain) - terrain_height(b, X, Y - e, terrain)) / (2.0 * e)
                    nn = math.sqrt(gx * gx + gy * gy + 1.0)
                    nx, ny, nz = -gx / nn, -gy / nn, 1.0 / nn
                    lam = min(max(nx * lx + ny * ly + nz * lz, 0.0), 1.0)
                    shade = min(max(0.78 + 2.5 * (lam - lz), 0.45), 1.1)
                    wall = min(max((0.5 - nz) * 2.0, 0.0), 1.0)
                    if h >= terrain.cap:
                        wall = 1.0
                    grad = max(math.sqrt(gx * gx + gy * gy), 1e-3)
                    phase = h / CONTOUR_STEP
                    near = abs(phase - math.floor(phase + 0.5)) * CONTOUR_STEP / grad * scale  # pixels to a contour
                    line = min(max(1.0 - near, 0.0), 1.0) if (phase >= 0.5 and nz > 0.5) else 0.0
                    for c in range(3):
                        v = _mix(_SAND[c] * shade, _WALL[c], wall) * (1.0 - 0.18 * line)
                        dest[q, py, px, c] = np.uint8(min(max(255.0 * v + 0.5, 0.0), 255.0))
                else:
                    Z = (ground - (py + 0.5)) / scale
                    depth = (terrain_height(b, X, 0.0, terrain) - Z) * scale  # pixels into the solid
                    sky_w = min(max(Z / (2.0 * VIEW_HALF_WIDTH) + 0.2, 0.0), 1.0)
                    solid = min(max(depth + 0.5, 0.0), 1.0)
                    line = min(max(1.5 - abs(depth), 0.0), 1.0)
                    dark = min(max(1.0 - 0.004 * depth, 0.6), 1.0)
                    for c in range(3):
                        v = _mix(_mix(_SKY_LOW[c], _SKY_TOP[c], sky_w), _EARTH[c] * dark, solid)
                        v = _mix(v, _LINE[c], line)
                        dest[q, py, px, c] = np.uint8(min(max(255.0 * v + 0.5, 0.0), 255.0))

"""The observation modes' kernels (:mod:`.views` holds their Python side): the terrain's height
as the kernels read it (:class:`TerrainHeights`), the height maps of a batch of worlds, their
images, and the terrain images behind them. See :mod:`.views` for what each mode holds."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .._jit import njit
from .render import CONTOUR_STEP, GOAL_COLOR, LIGHT, VIEW_HALF_WIDTH

__all__ = ["TerrainHeights", "heightmap_worlds", "rgb_worlds", "terrain_images"]

# terrain kinds as the kernels read them
_BOWL, _ARENA, _BUMPY = 0, 1, 2
_KINDS = {"bowl": _BOWL, "arena": _ARENA, "bumpy": _BUMPY}
# the colours as the kernels read them, 0..255
_SAND = (0.90, 0.84, 0.70)
_WALL = (0.52, 0.50, 0.48)
_SKY_TOP, _SKY_LOW = (0.80, 0.88, 0.97), (0.96, 0.97, 0.99)
_EARTH, _LINE = (0.60, 0.47, 0.32), (0.35, 0.25, 0.15)


class TerrainHeights(NamedTuple):
    """The terrain's height z(x[, y]) as the kernels read it: its kind, the bowl's radius, the
    arena's half width, the cap (the height of solid columns: beyond the bowl's rim, the arena's
    walls), and the bumpy ground's height field (its node heights per world in ``heights``, from
    column ``start``; ``nx`` x ``ny`` nodes, ``cell`` apart from ``origin``). Without a height field
    ``heights`` is a (1, 1) placeholder."""

    kind: int
    radius: float
    half_width: float
    cap: float
    heights: np.ndarray  # (B, m) float64: the World's height-field table
    start: int
    nx: int
    ny: int
    origin_x: float
    origin_y: float
    cell: float


@njit(hot=True)
def _terrain_height(b, x, y, t):
    """The terrain's height at (x, y) of world b (2D: y = 0, and the field's ``ny`` is 1)."""
    if t.kind == _ARENA:
        if abs(x) > t.half_width or abs(y) > t.half_width:
            return t.cap
        return 0.0
    R = t.radius
    rho2 = x * x + y * y
    if rho2 >= R * R:
        return t.cap
    h = R - math.sqrt(R * R - rho2)
    if t.kind == _BUMPY:  # the field, held at its edge beyond the grid; the bowl where higher
        u = min(max((x - t.origin_x) / t.cell, 0.0), t.nx - 1.0)
        i = min(int(u), t.nx - 2)
        fu = u - i
        row = t.heights[b]
        s = t.start
        if t.ny == 1:
            f = row[s + i] * (1.0 - fu) + row[s + i + 1] * fu
        else:
            v = min(max((y - t.origin_y) / t.cell, 0.0), t.ny - 1.0)
            j = min(int(v), t.ny - 2)
            fv = v - j
            k = s + i * t.ny + j
            f = (row[k] * (1.0 - fv) + row[k + 1] * fv) * (1.0 - fu) + (
                row[k + t.ny] * (1.0 - fv) + row[k + t.ny + 1] * fv
            ) * fu
        h = max(h, f)
    return h


@njit(entry=True, nogil=True)
def heightmap_worlds(worlds, out, x, radii, terrain, cells_y, cell, low, high):
    """The height maps of ``worlds`` into ``out`` (one row per world, in order; ``(k, cells,
    cells_y)``, ``cells_y`` 1 in 2D): cells of edge ``cell`` centred on the pusher (ball 0), each
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
        cx = x[b, 0, 0]
        cy = x[b, 0, 1] if D == 3 else 0.0
        if not (np.isfinite(cx) and np.isfinite(cy)):
            cx, cy = 0.0, 0.0
        x0 = cx - half * cell  # the first cell's centre
        y0 = cy - half_y * cell
        for i in range(H):
            for j in range(W):
                out[t, i, j] = _terrain_height(b, x0 + i * cell, y0 + j * cell, terrain)
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
    """The terrain images of ``worlds`` into ``dest[rows[t]]`` (``(K, S, S, 3)`` uint8): 3D a top
    view (sand lit by the slope, steep faces and solid columns grey, contour lines every
    CONTOUR_STEP of height); 2D a side view (sky above the ground line, earth below)."""
    S = dest.shape[1]
    lx, ly, lz = LIGHT
    ln = math.sqrt(lx * lx + ly * ly + lz * lz)
    lx, ly, lz = lx / ln, -ly / ln, lz / ln  # towards the light, world axes (image y is down)
    e = 0.5 / scale  # half a pixel, for the slope
    for t in range(worlds.shape[0]):
        b = worlds[t]
        q = rows[t]
        for py in range(S):
            for px in range(S):
                X = (px + 0.5 - 0.5 * S) / scale
                if dim == 3:
                    Y = -(py + 0.5 - 0.5 * S) / scale
                    h = _terrain_height(b, X, Y, terrain)
                    gx = (_terrain_height(b, X + e, Y, terrain) - _terrain_height(b, X - e, Y, terrain)) / (2.0 * e)
                    gy = (_terrain_height(b, X, Y + e, terrain) - _terrain_height(b, X, Y - e, terrain)) / (2.0 * e)
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
                    depth = (_terrain_height(b, X, 0.0, terrain) - Z) * scale  # pixels into the solid
                    sky_w = min(max(Z / (2.0 * VIEW_HALF_WIDTH) + 0.2, 0.0), 1.0)
                    solid = min(max(depth + 0.5, 0.0), 1.0)
                    line = min(max(1.5 - abs(depth), 0.0), 1.0)
                    dark = min(max(1.0 - 0.004 * depth, 0.6), 1.0)
                    for c in range(3):
                        v = _mix(_mix(_SKY_LOW[c], _SKY_TOP[c], sky_w), _EARTH[c] * dark, solid)
                        v = _mix(v, _LINE[c], line)
                        dest[q, py, px, c] = np.uint8(min(max(255.0 * v + 0.5, 0.0), 255.0))

"""The sand-shaping task's height-map kernel (:mod:`.sand_level`): the bed's height map of every
world in one call.

The map covers the walled arena, ``[-L, L]`` along each horizontal axis, with ``cells`` cells per
axis (row-major: x, then y in 3D). A cell holds the depth of sand over it: the volume of the grains
it is given over its area and a nominal solid fraction, ``sum w V / (a phi)`` (``unit = V / (a
phi)``), so that a layer of grains packed at ``phi`` reads its thickness. Each grain's volume is
shared between the cells around its centre by bilinear (cloud-in-cell) weights on the cells'
centres, a grain beyond the outer centres giving its share to the edge cells: the map changes
continuously as a grain moves, and its sum is the grains' volume exactly. A grain whose position
is not finite, or whose centre lies outside the arena, is skipped (the scene counts it as lost).
Values are clipped to ``top``.
"""

from __future__ import annotations

from ..._jit import njit

__all__ = ["height_maps"]


@njit(entry=True, nogil=True)
def height_maps(x, worlds, half_width, cells, unit, top, out):
    """Write the height map of each world ``b`` of ``worlds`` into ``out[b]`` (``cells``^(d-1)
    entries): one pass over its grains ``x[b]`` (n, d), each worth ``unit`` of depth."""
    D = x.shape[2]
    scale = cells / (2.0 * half_width)
    for t in range(worlds.shape[0]):
        b = worlds[t]
        for c in range(out.shape[1]):
            out[b, c] = 0.0
        for i in range(x.shape[1]):
            px = x[b, i, 0]
            py = x[b, i, 1] if D == 3 else 0.0
            z = x[b, i, D - 1]
            # (a NaN fails every comparison: skipped)
            if not (abs(px) <= half_width and abs(py) <= half_width and abs(z) < 1e300):
                continue
            fx = min(max((px + half_width) * scale - 0.5, 0.0), cells - 1.0)
            ix = min(int(fx), cells - 2) if cells > 1 else 0
            tx = fx - ix
            if D == 2:
                out[b, ix] += (1.0 - tx) * unit
                out[b, ix + 1] += tx * unit
                continue
            fy = min(max((py + half_width) * scale - 0.5, 0.0), cells - 1.0)
            iy = min(int(fy), cells - 2)
            ty = fy - iy
            c = ix * cells + iy
            out[b, c] += (1.0 - tx) * (1.0 - ty) * unit
            out[b, c + 1] += (1.0 - tx) * ty * unit
            out[b, c + cells] += tx * (1.0 - ty) * unit
            out[b, c + cells + 1] += tx * ty * unit
        for c in range(out.shape[1]):
            out[b, c] = min(out[b, c], top)

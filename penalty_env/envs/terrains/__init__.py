"""The PenaltyBalls task's terrains (``terrain=``), one module each, and their registry.

Adding a terrain is a module with a :class:`~.base.Terrain` subclass and one line in
:data:`TERRAINS`: the keyword's allowed values, the env docstring's "Terrain" table (and so the env
pages), the starts, the views, the images and ``render()`` follow from the object.
"""

from __future__ import annotations

from .arena import ArenaTerrain
from .base import BOWL, BUMPY, PLANE, Terrain, TerrainHeights, terrain_height
from .bowl import BowlTerrain
from .bumpy import BumpyTerrain
from .slope import SlopeTerrain

__all__ = [
    "TERRAINS",
    "Terrain",
    "TerrainHeights",
    "terrain_height",
    "make_terrain",
    "terrain_table",
    "BOWL",
    "PLANE",
    "BUMPY",
]

# name -> class, in the order the docs list them (the first is the default)
TERRAINS: dict[str, type[Terrain]] = {
    "bowl": BowlTerrain,
    "arena": ArenaTerrain,
    "bumpy": BumpyTerrain,
    "slope": SlopeTerrain,
}


def make_terrain(name: str, dim: int, bowl_radius: float, roughness: float) -> Terrain:
    """The terrain called ``name`` (a key of :data:`TERRAINS`, checked by the scene's parameters)."""
    return TERRAINS[name](dim, bowl_radius, roughness)


def terrain_table(indent: str = "    ") -> str:
    """The env docstring's "Terrain" table: each terrain's shapes and notes."""
    rows = [f"{indent}| `terrain` | Shapes | Notes |", f"{indent}|---|---|---|"]
    for name, cls in TERRAINS.items():
        rows.append(f'{indent}| `"{name}"`{" (default)" if name == "bowl" else ""} | {cls.shapes_text} | {cls.notes} |')
    return "\n".join(rows)

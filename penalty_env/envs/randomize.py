"""Per-world domain randomisation (``randomize={name: (low, high)}``), what every task shares: the
named fields a task may randomise (:class:`Field`, as MuJoCo Playground's ``randomize.py`` names
each field with its distribution), the ranges' checks, the reset option that narrows them, and the
draws (one uniform per field from each world's own generator).

What a draw sets is the task's (:mod:`.balls.randomize`, the level scene); the physics it derives
is :mod:`.contact`'s.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np

from .. import _validate as V

__all__ = ["Field", "RandomizationWarning", "MAX_SUBSTEPS", "check_ranges", "check_override", "draw", "field_table"]

# a range that needs more substeps per control period than this is refused (no practical step)
MAX_SUBSTEPS = 1000


class RandomizationWarning(UserWarning):
    """Randomisation ranges that need a smaller substep than the fixed scene's: the scene takes more
    substeps per control period (slower), and says which range asked for it."""


class Field(NamedTuple):
    """A randomisable field: drawn uniform in ``(low, high)`` within ``allowed``."""

    name: str
    allowed: tuple[float, float]  # the range a given (low, high) must lie within
    meaning: str
    keyword: str | None = None  # the keyword argument whose value is the field's fixed value (None: 1.0)


def field_table(fields: Mapping[str, Field], indent: str = "    ") -> str:
    """The docstring's table of ``fields``: name, allowed range, meaning."""
    rows = [f"{indent}| Field | Allowed | Meaning |", f"{indent}|---|---|---|"]
    for f in fields.values():
        rows.append(f"{indent}| `{f.name}` | [{f.allowed[0]:g}, {f.allowed[1]:g}] | {f.meaning} |")
    return "\n".join(rows)


def check_ranges(
    randomize: Any, fields: Mapping[str, Field], label: str = "randomize"
) -> dict[str, tuple[float, float]]:
    """``randomize`` (None or a mapping from names of ``fields`` to ``(low, high)`` pairs of finite
    numbers, low <= high, within each field's allowed range) as a dict in the fields' (draw) order;
    {} for None. Raises ValueError naming the bad entry, its value and the allowed range."""
    if randomize is None:
        return {}
    if not isinstance(randomize, Mapping):
        raise V.ArgumentTypeError(
            f"{label} must be None or a dict of (low, high) ranges, got {V.describe(randomize)} "
            f"({type(randomize).__name__})"
        )
    unknown = [k for k in randomize if k not in fields]
    if unknown:
        raise ValueError(f"{label} has unknown name(s) {', '.join(map(repr, unknown))}; allowed: {', '.join(fields)}")
    out: dict[str, tuple[float, float]] = {}
    for name, f in fields.items():
        if name in randomize:
            out[name] = pair_in(f"{label}[{name!r}]", randomize[name], f.allowed[0], f.allowed[1], f.meaning)
    return out


def pair_in(label: str, value: Any, lo_allowed: float, hi_allowed: float, meaning: str) -> tuple[float, float]:
    """A (low, high) pair of finite numbers with lo_allowed <= low <= high <= hi_allowed."""
    pair = value.tolist() if isinstance(value, np.ndarray) else value
    ok = isinstance(pair, (tuple, list)) and len(pair) == 2
    ok = ok and all(isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) for v in pair)
    if ok:
        try:
            lo, hi = float(pair[0]), float(pair[1])
        except OverflowError:  # an int too large for a float
            ok = False
    if not ok or not (math.isfinite(lo) and math.isfinite(hi)):
        raise ValueError(f"{label} must be a (low, high) pair of finite numbers ({meaning}), got {V.describe(value)}")
    if lo > hi:
        raise ValueError(f"{label} = {value!r}: low must be <= high")
    if lo < lo_allowed or hi > hi_allowed:
        raise ValueError(f"{label} = ({lo:g}, {hi:g}) must lie within [{lo_allowed:g}, {hi_allowed:g}] ({meaning})")
    return lo, hi


def check_override(override: Any, ranges: dict[str, tuple[float, float]]) -> dict[str, tuple[float, float]]:
    """The ranges of one reset: ``ranges`` (the make-time ones) with those of ``override`` (reset
    option ``randomize``: a mapping of some of their names to pairs within them) replaced. Raises
    ValueError for a name not randomised at make or a range outside the make-time one (the
    stability guard and the substep cover only those)."""
    if override is None:
        return ranges
    if not ranges:
        raise ValueError(
            "options['randomize'] needs an env made with randomize=... (the guard checks the ranges at make)"
        )
    if not isinstance(override, Mapping):
        raise V.ArgumentTypeError(
            f"options['randomize'] must be a dict of (low, high) ranges, got {V.describe(override)}"
        )
    out = dict(ranges)
    for name, value in override.items():
        if name not in ranges:
            raise ValueError(
                f"options['randomize'] names {name!r}, which the env was not made to randomise "
                f"(randomize={{...}} at make: {', '.join(ranges)})"
            )
        lo, hi = ranges[name]
        out[name] = pair_in(f"options['randomize'][{name!r}]", value, lo, hi, f"within the make-time range of {name}")
    return out


def draw(rngs: list, ranges: dict[str, tuple[float, float]]) -> np.ndarray:
    """One uniform u per field of ``ranges`` (in their order) from each world's generator, as
    ``low + (high - low) u``: (worlds, fields)."""
    lo = np.array([r[0] for r in ranges.values()])
    span = np.array([r[1] - r[0] for r in ranges.values()])
    u = np.array([rng.random(len(ranges)) for rng in rngs]).reshape(len(rngs), len(ranges))
    return lo + span * u

"""The checks every env face applies to what a user hands it: actions, seeds, reset options.

Each refusal names the argument, repeats the value and says what is allowed (a wrong type raises
:class:`~penalty_env._validate.ArgumentTypeError`, both a ``TypeError`` and a ``ValueError``).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .. import _validate as V

__all__ = ["coerce_action", "check_seed", "check_seeds", "check_options", "check_reset_mask", "render_fps"]


def render_fps(control_period: float) -> int:
    """Frames per second of a video of an env: one frame per control period."""
    return max(1, round(1.0 / control_period))


def coerce_action(action: Any, shape: tuple[int, ...]) -> np.ndarray:
    """An action as a float64 array of ``shape``, or a ValueError that says what was wrong (a
    string, an object, a complex or a ragged value, or the wrong shape). NaN and inf pass here: the
    step refuses them, naming the world, before anything moves."""
    try:
        raw = np.asarray(action)
    except (TypeError, ValueError):
        raise ValueError(f"action must be an array of real numbers with shape {shape}, got {action!r}") from None
    if raw.dtype.kind not in "biuf":  # a complex, a string, an object: not a throttle
        raise ValueError(
            f"action must be an array of real numbers with shape {shape}, got dtype {raw.dtype}: {V.describe(action)}"
        )
    a = np.asarray(raw, dtype=np.float64)
    if a.shape != shape:
        raise ValueError(f"action must have shape {shape} (one value per controlled axis), got shape {a.shape}")
    return a


def check_seed(seed: Any, name: str = "seed") -> int | None:
    """A seed: None or an int >= 0 (numpy ints too, bools not)."""
    if seed is None:
        return None
    return V.integer(name, seed, 0, None)


def check_seeds(seed: Any, n: int) -> tuple[list[int | None], int | None]:
    """A vector env's ``reset(seed=...)``: None, an int >= 0 (world i gets ``seed + i``) or a
    sequence (list, tuple or array) of ``n`` seeds, each None or an int >= 0. Returns the seed of
    each world and the int itself (None for a sequence, or for None)."""
    if seed is None or isinstance(seed, (int, np.integer)) and not isinstance(seed, (bool, np.bool_)):
        s = check_seed(seed)
        return ([None] * n if s is None else [s + i for i in range(n)]), s
    if isinstance(seed, (list, tuple, np.ndarray)):
        seeds = [check_seed(s, f"seed[{i}]") for i, s in enumerate(seed)]
        if len(seeds) != n:
            raise ValueError(f"seed must be None, an int or a list of {n} seeds (one per world), got {len(seeds)}")
        return seeds, None
    raise V.ArgumentTypeError(f"seed must be None, an int >= 0 or a list of {n} of them, got {V.describe(seed)}")


def check_options(options: Any, allowed: tuple[str, ...] = (), owner: str = "PenaltyBalls") -> dict[str, Any]:
    """``options`` as a dict: None or a mapping with string keys, each one of ``allowed`` (``owner``:
    the env named in the error)."""
    if options is None:
        return {}
    if not isinstance(options, Mapping):
        raise V.ArgumentTypeError(
            f"options must be None or a dict, got {V.describe(options)} ({type(options).__name__})"
        )
    unknown = [k for k in options if k not in allowed]
    if unknown:
        raise ValueError(
            f"options has unknown key(s) {', '.join(map(repr, unknown))}; {owner} accepts "
            f"{', '.join(map(repr, allowed)) or 'none'}"
        )
    return dict(options)


def check_reset_mask(mask: Any, n: int) -> np.ndarray:
    """``options['reset_mask']``: a bool array of shape (n,) with at least one True value."""
    if not (isinstance(mask, np.ndarray) and mask.dtype == np.bool_ and mask.shape == (n,) and mask.any()):
        raise ValueError(f"options['reset_mask'] must be a bool array of shape ({n},) with a True value, got {mask!r}")
    return mask

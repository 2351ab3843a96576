"""Argument checks shared by the whole package: one helper per kind of argument.

Every message names the argument, repeats the value it got and states what is allowed, so a user
sees at once what to change. A value of the wrong *type* raises :class:`ArgumentTypeError`, which is
both a ``TypeError`` (Python's convention) and a ``ValueError`` (so ``except ValueError`` around a
call that validates its input catches every refusal); a value of the right type outside its range
raises ``ValueError``.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

__all__ = [
    "ArgumentTypeError",
    "real_array",
    "real",
    "positive",
    "non_negative",
    "in_range",
    "integer",
    "choice",
    "flag",
    "describe",
]


class ArgumentTypeError(TypeError, ValueError):
    """An argument of the wrong type (a ``TypeError`` that ``except ValueError`` also catches)."""


def describe(value: Any, limit: int = 80) -> str:
    """A short repr of ``value`` for an error message."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def real_array(
    name: str, value: Any, ndim: Sequence[int] | None = None, shape: tuple | None = None, finite: bool = True
) -> np.ndarray:
    """``value`` as a new float64 array. Refuses strings, objects, ragged nesting, a wrong number of
    dimensions or shape, and (``finite``) NaN or inf, naming ``name``."""
    if isinstance(value, (str, bytes)):
        raise ArgumentTypeError(f"{name} must be an array of real numbers, got the string {describe(value)}")
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError) as exc:  # ragged nesting (numpy >= 1.24 refuses it)
        raise ValueError(f"{name} must be a rectangular array of real numbers, got {describe(value)} ({exc})") from None
    if raw.dtype.kind not in "iuf":
        raise ArgumentTypeError(f"{name} must be an array of real numbers, got dtype {raw.dtype}: {describe(value)}")
    arr = np.array(raw, dtype=np.float64)
    if ndim is not None and arr.ndim not in ndim:
        raise ValueError(f"{name} must have {' or '.join(map(str, ndim))} dimensions, got shape {arr.shape}")
    if shape is not None and arr.shape != tuple(shape):
        raise ValueError(f"{name} must have shape {tuple(shape)}, got {arr.shape}")
    if finite and not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise ValueError(f"{name} must be finite, got NaN or inf at index {tuple(int(i) for i in bad)}")
    return arr


def _float(value: Any) -> float:
    """``float(value)``, with an int too large for a float (``10**400``) as inf (refused as such by
    the caller, naming the argument) instead of a bare OverflowError."""
    try:
        return float(value)
    except OverflowError:
        return math.inf if value > 0 else -math.inf


def real(name: str, value: Any, allowed: str = "a finite real number") -> float:
    """``value`` as a finite float (bools refused)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Real, np.floating, np.integer)):
        raise ArgumentTypeError(f"{name} must be {allowed}, got {describe(value)} ({type(value).__name__})")
    v = _float(value)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be {allowed}, got {describe(value)}")
    return v


def positive(name: str, value: Any) -> float:
    """A finite number > 0."""
    v = real(name, value, "a finite number > 0")
    if not v > 0.0:
        raise ValueError(f"{name} must be a finite number > 0, got {describe(value)}")
    return v


def non_negative(name: str, value: Any) -> float:
    """A finite number >= 0."""
    v = real(name, value, "a finite number >= 0")
    if not v >= 0.0:
        raise ValueError(f"{name} must be a finite number >= 0, got {describe(value)}")
    return v


def in_range(name: str, value: Any, lo: float, hi: float, meaning: str = "") -> float:
    """A finite number in [lo, hi]."""
    what = f"{name} ({meaning})" if meaning else name
    allowed = f"a number in [{lo}, {hi}]"
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Real, np.floating, np.integer)):
        raise ArgumentTypeError(f"{what} must be {allowed}, got {describe(value)} ({type(value).__name__})")
    v = _float(value)
    if not (math.isfinite(v) and lo <= v <= hi):
        raise ValueError(f"{what} must be {allowed}, got {describe(value)}")
    return v


def integer(name: str, value: Any, lo: int | None = None, hi: int | None = None, meaning: str = "") -> int:
    """A Python or numpy integer (bools refused) in [lo, hi] (either end may be open)."""
    what = f"{name} ({meaning})" if meaning else name
    lo_s = "-inf" if lo is None else str(lo)
    hi_s = "inf" if hi is None else str(hi)
    allowed = f"an int in [{lo_s}, {hi_s}]"
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Integral, np.integer)):
        raise ArgumentTypeError(f"{what} must be {allowed}, got {describe(value)} ({type(value).__name__})")
    v = int(value)
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        raise ValueError(f"{what} must be {allowed}, got {v}")
    return v


def choice(name: str, value: Any, allowed: Iterable[str]) -> str:
    """One of the strings in ``allowed``."""
    allowed = tuple(allowed)
    if not isinstance(value, str):
        raise ArgumentTypeError(f"{name} must be one of {allowed}, got {describe(value)} ({type(value).__name__})")
    if value not in allowed:
        raise ValueError(f"{name} must be one of {allowed}, got {value!r}")
    return value


def flag(name: str, value: Any) -> bool:
    """True or False (numpy bools too)."""
    if not isinstance(value, (bool, np.bool_)):
        raise ArgumentTypeError(f"{name} must be True or False, got {describe(value)} ({type(value).__name__})")
    return bool(value)

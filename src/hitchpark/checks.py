"""Input checks shared by every settings and parameter class: one message style, one notion of a number.

Each returns the value as a Python float (or int) and raises :class:`InputError` (a
``ValueError``) naming the field, what is allowed and what was given.
"""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np

__all__ = ["MAX_COORDINATE", "MAX_YAW", "InputError", "check_int", "check_number", "check_range"]


class InputError(ValueError):
    """Bad input to hitchpark: a parameter, a setting, a file, a pose. The message names what and what is allowed.

    A ``ValueError``, so ``except ValueError`` catches it; the command line reports it on one line with
    exit status 2, while any other exception is a bug and keeps its traceback.
    """


#: Largest |x|, |y| accepted for a pose [m]: parking happens within a few hundred metres, and far
#: beyond this double precision no longer resolves the millimetres the controller works in.
MAX_COORDINATE = 1e5

#: Largest |yaw| accepted for a pose [rad]: ten turns either way.
MAX_YAW = 20 * math.pi


def check_number(name: str, value: Any) -> float:
    """A finite real number (NumPy scalars too, booleans not)."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        raise InputError(f"{name} must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise InputError(f"{name} must be finite, got {value}")
    return value


def check_range(
    name: str,
    value: Any,
    low: float = -math.inf,
    high: float = math.inf,
    *,
    low_open: bool = False,
    high_open: bool = False,
    unit: str = "",
) -> float:
    """A finite number within [low, high]; ``low_open``/``high_open`` exclude the ends."""
    v = check_number(name, value)
    too_low = v <= low if low_open else v < low
    too_high = v >= high if high_open else v > high
    if too_low or too_high:
        lo = "" if low == -math.inf else f"{'>' if low_open else '>='} {low:g}"
        hi = "" if high == math.inf else f"{'<' if high_open else '<='} {high:g}"
        allowed = " and ".join(s for s in (lo, hi) if s)
        u = f" {unit}" if unit else ""
        raise InputError(f"{name} must be {allowed}{u}, got {v:g}")
    return v


def check_int(name: str, value: Any, low: int = 1, high: int | None = None) -> int:
    """An integer within [low, high]."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Integral):
        raise InputError(f"{name} must be an integer, got {value!r}")
    value = int(value)
    if value < low or (high is not None and value > high):
        allowed = f">= {low}" + (f" and <= {high}" if high is not None else "")
        raise InputError(f"{name} must be an integer {allowed}, got {value}")
    return value

"""The validation layer: everything that comes in (arguments, TOML and JSON files, API calls) is checked here.

One message style, one notion of a number. Each check returns the value in its canonical
Python type and raises :class:`InputError` (a ``ValueError``) naming the field, what is
allowed and what was given, on one line.

Two ways in:

- the scalar checks (:func:`check_number`, :func:`check_range`, :func:`check_int`,
  :func:`check_flag`, :func:`check_choice`, :func:`check_text`, :func:`check_values`),
  called where a value arrives;
- declared checks on the fields of a settings dataclass: ``speed: float = checked(1.0,
  Real(0, 30, low_open=True, unit="m/s"))``, applied by :func:`check_fields` in
  ``__post_init__``, and :func:`build`, which makes such a class from a mapping (a TOML
  table, a JSON object) and refuses unknown keys. Relations between fields stay in the
  class's ``__post_init__``, after its fields have passed.

Hand-written rather than a schema library: what is checked is mostly physical ranges
with units and relations between lengths, in the message style of the rest of hitchpark;
numbers may be NumPy scalars; the classes are frozen dataclasses that CasADi code hashes
and caches on. A library such as pydantic would add a dependency, wrap these classes,
and still need a formatter for its multi-line errors.
"""

from __future__ import annotations

import math
import numbers
import re
from collections.abc import Callable, Collection, Iterator, Mapping
from dataclasses import MISSING, dataclass, field, fields
from typing import Any, TypeVar

import numpy as np

__all__ = [
    "MAX_COORDINATE",
    "MAX_SPEED",
    "MAX_YAW",
    "Choice",
    "Flag",
    "InputError",
    "Integer",
    "Real",
    "Text",
    "build",
    "check_choice",
    "check_fields",
    "check_flag",
    "check_instance",
    "check_int",
    "check_keys",
    "check_mapping",
    "check_number",
    "check_range",
    "check_text",
    "check_values",
    "checked",
    "shown",
]


class InputError(ValueError):
    """Bad input to hitchpark: a parameter, a setting, a file, a pose. The message names what and what is allowed.

    A ``ValueError``, so ``except ValueError`` catches it; the command line reports it on one line with
    exit status 2, while any other exception is a bug and keeps its traceback.
    """

    def __init__(self, message: str):
        # One line, whatever a caller or a library put into the text.
        super().__init__(" ".join(str(message).split()))


#: Largest |x|, |y| accepted for a pose [m]: parking happens within a few hundred metres, and far
#: beyond this double precision no longer resolves the millimetres the controller works in.
MAX_COORDINATE = 1e5

#: Largest |yaw| accepted for a pose [rad]: ten turns either way.
MAX_YAW = 20 * math.pi

#: Largest |speed| accepted anywhere [m/s]: a kinematic model holds at low speed, parking is at about 1 m/s.
MAX_SPEED = 30.0

#: Longest text shown of a refused value.
_SHOWN = 60


def shown(value: Any) -> str:
    """``repr`` of a refused value, cut to a readable length."""
    text = repr(value)
    return text if len(text) <= _SHOWN else text[: _SHOWN - 3] + "..."


def check_number(name: str, value: Any) -> float:
    """A finite real number (NumPy scalars too, booleans and strings not)."""
    if type(value) is float and math.isfinite(value):  # the common case, checked first
        return value
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        raise InputError(f"{name} must be a number, got {shown(value)}")
    value = float(value)
    if not math.isfinite(value):
        raise InputError(f"{name} must be finite, got {value}")
    return value


def _allowed(low: float, high: float, low_open: bool, high_open: bool) -> str:
    lo = "" if low == -math.inf else f"{'>' if low_open else '>='} {low:g}"
    hi = "" if high == math.inf else f"{'<' if high_open else '<='} {high:g}"
    return " and ".join(s for s in (lo, hi) if s)


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
        u = f" {unit}" if unit else ""
        raise InputError(f"{name} must be {_allowed(low, high, low_open, high_open)}{u}, got {v:g}")
    return v


def check_int(name: str, value: Any, low: int = 1, high: int | None = None) -> int:
    """An integer within [low, high] (a float such as 3.0 is not an integer here)."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Integral):
        raise InputError(f"{name} must be an integer, got {shown(value)}")
    value = int(value)
    if value < low or (high is not None and value > high):
        allowed = f">= {low}" + (f" and <= {high}" if high is not None else "")
        raise InputError(f"{name} must be an integer {allowed}, got {value}")
    return value


def check_flag(name: str, value: Any) -> bool:
    """``True`` or ``False`` itself: not ``"false"`` (which Python would read as true), not 0 or 1."""
    if not isinstance(value, bool | np.bool_):
        raise InputError(f"{name} must be true or false, got {shown(value)}")
    return bool(value)


def check_choice(name: str, value: Any, choices: Collection[str]) -> str:
    """One of the names in ``choices``."""
    if not isinstance(value, str) or value not in choices:
        raise InputError(f"{name} must be one of {', '.join(map(repr, choices))}, got {shown(value)}")
    return value


def check_text(name: str, value: Any, pattern: str | None = None, what: str = "", max_length: int = 500) -> str:
    """A string of at most ``max_length`` characters, matching ``pattern`` (described by ``what``) if given."""
    if not isinstance(value, str):
        raise InputError(f"{name} must be a string, got {shown(value)}")
    if len(value) > max_length:
        raise InputError(f"{name} must be at most {max_length} characters, got {len(value)}")
    if pattern is not None and not re.fullmatch(pattern, value):
        raise InputError(f"{name} must be {what or 'of the form ' + pattern}, got {shown(value)}")
    return value


def check_instance(name: str, value: Any, cls: type | tuple[type, ...], hint: str = "") -> Any:
    """``value`` itself if it is an instance of ``cls``; else refused, with ``hint`` on how to make one."""
    if not isinstance(value, cls):
        names = " or ".join(c.__name__ for c in (cls if isinstance(cls, tuple) else (cls,)))
        raise InputError(f"{name} must be a {names}{' (' + hint + ')' if hint else ''}, got {shown(value)}")
    return value


def check_mapping(name: str, value: Any) -> Mapping[str, Any]:
    """A table (a TOML table, a JSON object, a dict) whose keys are strings."""
    if not isinstance(value, Mapping) or not all(isinstance(k, str) for k in value):
        raise InputError(f"{name} must be a table of named fields, got {shown(value)}")
    return value


def check_values(
    name: str,
    value: Any,
    *,
    ndim: int | None = None,
    allow_nan: bool = False,
    low: float = -math.inf,
    high: float = math.inf,
    unit: str = "",
) -> np.ndarray:
    """A number or an array of real numbers (lists too), finite unless ``allow_nan``, within [low, high].

    Strings, booleans, objects and ragged lists are refused, so are complex numbers. ``ndim``
    fixes the number of dimensions. Returns a float array (0-d for a number).
    """
    if isinstance(value, float | int) and not isinstance(value, bool) and ndim in (None, 0):  # one number: fast
        if allow_nan and math.isnan(value):
            return np.asarray(math.nan)
        return np.asarray(check_range(name, value, low, high, unit=unit))
    if isinstance(value, bool | np.bool_ | str | bytes):
        raise InputError(f"{name} must be numbers, got {shown(value)}")
    if isinstance(value, list | tuple):  # JSON or Python lists: every item a number, whatever NumPy would cast
        for item in _items(value):
            if isinstance(item, bool) or not isinstance(item, numbers.Real):
                raise InputError(f"{name} must be numbers, got {shown(item)} among them")
    try:
        array = np.asarray(value)
    except (ValueError, TypeError):  # ragged nesting
        raise InputError(f"{name} must be numbers in a regular array, got {shown(value)}") from None
    if array.size and not (np.issubdtype(array.dtype, np.integer) or np.issubdtype(array.dtype, np.floating)):
        raise InputError(f"{name} must be real numbers in a regular array, got {array.dtype} values")
    if ndim is not None and array.ndim != ndim:
        shape = "a single number" if ndim == 0 else f"a {ndim}-D array"
        raise InputError(f"{name} must be {shape}, got shape {array.shape}")
    array = array.astype(float)
    flat = array.ravel()
    bad = ~np.isfinite(flat)
    if allow_nan:
        bad &= ~np.isnan(flat)
    if np.any(bad):
        raise InputError(f"{name} must be finite{' or missing' if allow_nan else ''}, got {flat[bad][0]}")
    with np.errstate(invalid="ignore"):
        outside = (flat < low) | (flat > high)
    if np.any(outside):
        u = f" {unit}" if unit else ""
        raise InputError(f"{name} must be {_allowed(low, high, False, False)}{u}, got {flat[outside][0]:g}")
    return array


def check_keys(what: str, data: Any, allowed: Collection[str], unknown_is: str = "") -> dict[str, Any]:
    """The table ``[what]`` as a dict, refused if it is not a table or has a key outside ``allowed``.

    An unknown key is named ``what.key``, or as ``unknown_is`` says (``"top-level key {!r}"``, ``"table [{}]"``).
    """
    table = check_mapping(f"[{what}]", data)
    unknown = sorted(set(table) - set(allowed))
    if unknown:
        key = unknown_is.format(unknown[0]) if unknown_is else f"key {what}.{unknown[0]}"
        raise InputError(f"unknown {key}; allowed: {', '.join(allowed)}")
    return dict(table)


def _items(value: list[Any] | tuple[Any, ...]) -> Iterator[Any]:
    """The leaves of nested lists."""
    for item in value:
        if isinstance(item, list | tuple):
            yield from _items(item)
        else:
            yield item


# --- Declared checks on dataclass fields -------------------------------------------------------------------


@dataclass(frozen=True)
class Real:
    """A finite number within [low, high] (``low_open``/``high_open`` exclude the ends); ``None`` if ``optional``."""

    low: float = -math.inf
    high: float = math.inf
    low_open: bool = False
    high_open: bool = False
    unit: str = ""
    optional: bool = False

    def __call__(self, name: str, value: Any) -> float | None:
        if value is None and self.optional:
            return None
        return check_range(
            name, value, self.low, self.high, low_open=self.low_open, high_open=self.high_open, unit=self.unit
        )


@dataclass(frozen=True)
class Integer:
    """An integer within [low, high]; ``None`` if ``optional``."""

    low: int = 0
    high: int | None = None
    optional: bool = False

    def __call__(self, name: str, value: Any) -> int | None:
        if value is None and self.optional:
            return None
        return check_int(name, value, self.low, self.high)


@dataclass(frozen=True)
class Flag:
    """True or false; ``None`` if ``optional``."""

    optional: bool = False

    def __call__(self, name: str, value: Any) -> bool | None:
        if value is None and self.optional:
            return None
        return check_flag(name, value)


@dataclass(frozen=True)
class Choice:
    """One of a set of names, fixed or given by a function (a registry's current names); ``None`` if ``optional``."""

    choices: Collection[str] | Callable[[], Collection[str]]
    optional: bool = False

    def __call__(self, name: str, value: Any) -> str | None:
        if value is None and self.optional:
            return None
        choices = self.choices() if callable(self.choices) else self.choices
        return check_choice(name, value, choices)


@dataclass(frozen=True)
class Text:
    """A string, matching ``pattern`` if given."""

    pattern: str | None = None
    what: str = ""
    max_length: int = 500

    def __call__(self, name: str, value: Any) -> str:
        return check_text(name, value, self.pattern, self.what, self.max_length)


def checked(default: Any = MISSING, check: Callable[[str, Any], Any] | None = None, **kwargs: Any) -> Any:
    """A dataclass field whose value :func:`check_fields` checks with ``check(name, value)``.

    ``default`` may be omitted (a required field); other keyword arguments go to
    :func:`dataclasses.field` (``default_factory``, ``hash``...).
    """
    metadata = {"check": check} if check is not None else {}
    if default is MISSING:
        return field(metadata=metadata, **kwargs)
    return field(default=default, metadata=metadata, **kwargs)


def check_fields(obj: Any, prefix: str = "") -> None:
    """Check every declared field of the dataclass instance ``obj`` and store the canonical value.

    Field names in messages carry ``prefix`` (``"nmpc."``), as in the TOML table they come from.
    """
    for f in fields(obj):
        check = f.metadata.get("check")
        if check is not None:
            object.__setattr__(obj, f.name, check(f"{prefix}{f.name}", getattr(obj, f.name)))


T = TypeVar("T")


def build(cls: type[T], data: Any, what: str, convert: Mapping[str, Callable[[Any], Any]] | None = None) -> T:
    """An instance of the dataclass ``cls`` from a mapping of its field names (a TOML table, a JSON object).

    Unknown keys and a value that is not a table are refused, naming ``what`` (the table,
    e.g. ``"nmpc"``); ``convert`` maps a field name to a function applied to its value first
    (lists to tuples, say). The checks themselves run in the class's ``__post_init__``.
    """
    table = check_keys(what, data, [f.name for f in fields(cls)])  # type: ignore[arg-type]
    values = {k: (convert[k](v) if convert and k in convert else v) for k, v in table.items()}
    try:
        return cls(**values)
    except TypeError as exc:  # a required field missing
        raise InputError(f"[{what}]: {exc}") from None

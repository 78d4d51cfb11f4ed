"""Saving results: JSON files written whole or not at all; reading TOML and JSON."""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

from .checks import InputError
from .outputs import replacing
from .staging import StagedFolder  # here too, where it was first

__all__ = [
    "FORMATS",
    "StagedFolder",
    "check_format",
    "format_tag",
    "read_json",
    "read_toml",
    "to_jsonable",
    "write_json",
]

#: The version of each file format hitchpark writes: a file says which in its ``"format"`` key, ``NAME/VERSION``.
#: A change that an older reader would misread (a field renamed, removed or of another meaning) raises the
#: version; a new optional field does not. ``docs/reference/formats.md`` describes each.
FORMATS = {"maneuver": 1, "sweep-summary": 1}


def format_tag(name: str) -> str:
    """What a file of format ``name`` carries in its ``"format"`` key: ``hitchpark-NAME/VERSION``."""
    return f"hitchpark-{name}/{FORMATS[name]}"


def check_format(name: str, data: dict[str, Any]) -> None:
    """Refuse a file whose ``"format"`` is not this version of ``name`` (none: written before formats had
    versions, which are version 1)."""
    tag = data.get("format")
    if tag is not None and tag != format_tag(name):
        raise InputError(
            f"format {str(tag)[:80]!r} is not one this version of hitchpark reads: it reads {format_tag(name)!r}"
        )


def to_jsonable(value: Any) -> Any:
    """NumPy types to plain Python; NaN and infinities to ``None`` (JSON has no NaN)."""
    if isinstance(value, dict):
        return {str(k): to_jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [to_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return [to_jsonable(v) for v in value.tolist()]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def write_json(path: str | Path, data: Any) -> Path:
    """Write ``data`` as JSON atomically: a reader sees the old file or the new one, never half of one."""
    path = Path(path)
    text = json.dumps(to_jsonable(data), indent=1, allow_nan=False)
    with replacing(path) as tmp:
        tmp.write_text(text + "\n", encoding="utf-8")
    return path


def read_toml(path: str | Path, what: str) -> dict[str, Any]:
    """Parse a TOML file; an unreadable or invalid one is a ``ValueError`` naming ``what`` and the path."""
    path = Path(path)
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise InputError(f"cannot read {what} file {path}: {exc.strerror or exc}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"{what} file {path} is not valid TOML: {exc}") from None


def read_json(path: str | Path) -> Any:
    with open(path, encoding="utf-8") as fh:
        return json.load(fh)

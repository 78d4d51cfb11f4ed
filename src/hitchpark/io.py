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

__all__ = ["StagedFolder", "read_json", "read_toml", "to_jsonable", "write_json"]


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

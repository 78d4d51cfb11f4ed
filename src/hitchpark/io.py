"""Saving results: JSON files written whole or not at all."""

from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

from .checks import InputError
from .outputs import replacing

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


class StagedFolder:
    """Build a command's output in a hidden folder inside ``target``, then publish it whole.

    ``with StagedFolder(out) as stage: ...write into stage...``: on success each entry of
    the stage replaces the entry of the same name in ``out`` (folders first, files such as
    a summary last); on any error the stage is removed and ``out`` is left as it was (and
    removed again if this created it). A clash (a file where a folder goes, or the other
    way round) is found before anything moves.
    """

    def __init__(self, target: str | Path):
        self.target = Path(target)
        if self.target.exists() and not self.target.is_dir():
            raise InputError(f"output folder {self.target} exists and is not a folder")
        self._created = False
        self.path = self.target

    def __enter__(self) -> Path:
        self._created = not self.target.exists()
        self.target.mkdir(parents=True, exist_ok=True)
        self.path = Path(tempfile.mkdtemp(prefix=".hitchpark-staging-", dir=self.target))
        return self.path

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        try:
            if exc_type is None:
                self._publish()
        except BaseException:
            self._discard()
            raise
        self._discard()

    def _publish(self) -> None:
        entries = sorted(self.path.iterdir(), key=lambda p: (not p.is_dir(), p.name))
        for entry in entries:
            dest = self.target / entry.name
            if dest.exists() and dest.is_dir() != entry.is_dir():
                kind = "folder" if entry.is_dir() else "file"
                raise InputError(f"cannot write the {kind} {dest}: something else of that name is in the way")
        for entry in entries:
            dest = self.target / entry.name
            if dest.is_dir():
                shutil.rmtree(dest)
            os.replace(entry, dest)

    def _discard(self) -> None:
        shutil.rmtree(self.path, ignore_errors=True)
        if self._created and self.target.is_dir() and not any(self.target.iterdir()):
            self.target.rmdir()


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

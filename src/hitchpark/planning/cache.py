"""Arrays the planner builds once and keeps on disk beside the compiled solvers (the trailer table, goal trees).

A file is written whole (to a temporary name, then renamed), so a reader never sees half of one; a cache
that cannot be read or written is built again, never an error.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..solvers.compiled import cache_dir

__all__ = ["cached_arrays"]


def cached_arrays(
    name: str, names: tuple[str, ...], build: Callable[[], dict[str, np.ndarray]]
) -> dict[str, np.ndarray]:
    """The arrays ``names`` of the cache file ``name`` (``.npz``), or ``build()``'s, then written there."""
    path = Path(cache_dir()) / f"{name}.npz"
    try:
        with np.load(path) as data:
            return {k: data[k] for k in names}
    except (OSError, ValueError, KeyError):
        pass
    arrays = build()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        partial = path.with_name(f"{path.stem}.{os.getpid()}.tmp.npz")
        np.savez(partial, **arrays)  # type: ignore[arg-type]
        os.replace(partial, path)
    except OSError:
        pass
    return arrays

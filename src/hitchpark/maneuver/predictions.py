"""The NMPC's predictions, row by row: an optional column group of a maneuver (``park(..., predictions=True)``).

At each row where an NMPC acted, the trailer axle's path it predicted over its horizon, in the world frame; an
empty path where no NMPC acted (a forward pursuit, a path tracker, a brake, the wheels set standing still, the
final row). Saved in ``maneuver.json`` under ``"predictions"`` as ``{"x_trailer": [[...], ...], "y_trailer":
[[...], ...]}``, one list per row of the trajectory; absent when not recorded (the default: a sweep keeps none).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..checks import InputError, check_keys, check_values, shown
from ..control.step import ControlStep
from ..model.state import Pose, from_goal_frame

__all__ = ["PREDICTION_COLUMNS", "Predictions", "predicted_path"]

#: The columns of a prediction: the trailer axle's position [m], world frame.
PREDICTION_COLUMNS = ("x_trailer", "y_trailer")

_NONE = np.zeros((0, 2))


def predicted_path(goal: Pose, why: ControlStep | None) -> np.ndarray:
    """The (k, 2) world-frame trailer-axle path the controller predicted (its states in ``goal``'s parking frame,
    x, y, yaw first); (0, 2) when it predicted nothing."""
    states = None if why is None else why.predicted_states
    if states is None or states.ndim != 2 or states.shape[0] == 0 or states.shape[1] < 3:
        return _NONE
    x, y, _ = from_goal_frame(goal, states[:, 0], states[:, 1], states[:, 2])
    return np.column_stack([x, y])


@dataclass(frozen=True)
class Predictions:
    """One predicted trailer-axle path per row of a trajectory: ``paths[row]`` a (k, 2) array (k = 0: none)."""

    paths: tuple[np.ndarray, ...]

    def __len__(self) -> int:
        return len(self.paths)

    @classmethod
    def of(cls, paths: Sequence[np.ndarray]) -> Predictions:
        return cls(tuple(np.asarray(p, dtype=float).reshape(-1, 2) for p in paths))

    def to_dict(self) -> dict[str, list[list[float]]]:
        return {name: [p[:, i].tolist() for p in self.paths] for i, name in enumerate(PREDICTION_COLUMNS)}

    @classmethod
    def from_dict(cls, data: Any) -> Predictions:
        """Read back :meth:`to_dict`'s table; anything else is an :class:`InputError` saying what."""
        table = check_keys("predictions", data, PREDICTION_COLUMNS)
        columns = []
        for name in PREDICTION_COLUMNS:
            rows = table.get(name)
            if not isinstance(rows, list):
                raise InputError(
                    f"predictions.{name} must be a list of lists of numbers (one per row), got {shown(rows)}"
                )
            columns.append([check_values(f"predictions.{name}[{i}]", r, ndim=1) for i, r in enumerate(rows)])
        xs, ys = columns
        if len(xs) != len(ys):
            raise InputError(f"predictions.x_trailer has {len(xs)} rows, predictions.y_trailer {len(ys)}")
        for i, (x, y) in enumerate(zip(xs, ys, strict=True)):
            if len(x) != len(y):
                raise InputError(f"predictions row {i}: {len(x)} x_trailer values but {len(y)} y_trailer values")
        return cls(tuple(np.column_stack([x, y]) if len(x) else _NONE for x, y in zip(xs, ys, strict=True)))

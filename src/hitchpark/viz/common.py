"""What every maneuver figure shares: colours, stage names and shading, limit lines, texts, extents.

Internal to :mod:`hitchpark.viz`; matplotlib is only ever handed in as an ``Axes``.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ..model.geometry import to_goal_frame

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from ..maneuver.result import ManeuverResult

__all__ = [
    "AREA_EDGE",
    "DF",
    "DPSI",
    "EPSI",
    "LIMIT_COLOR",
    "OBSTACLE_EDGE",
    "OBSTACLE_FACE",
    "SPACE_EDGE",
    "SPACE_FACE",
    "STAGE_COLORS",
    "TRAILER_EDGE",
    "TRAILER_FACE",
    "VEHICLE_EDGE",
    "VEHICLE_FACE",
    "WHEEL_COLOR",
    "Extent",
    "clearance_text",
    "final_errors",
    "fmt_len",
    "headline",
    "limit_lines",
    "outcome",
    "shade_stages",
    "stage_color",
    "stage_name",
    "stage_summary",
    "step_series",
]

#: Colour of stage i is ``STAGE_COLORS[i % len(STAGE_COLORS)]`` (Okabe-Ito, colour-blind safe, then wine).
STAGE_COLORS = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#882255")

VEHICLE_FACE, VEHICLE_EDGE = "#c6dbef", "#08306b"
TRAILER_FACE, TRAILER_EDGE = "#fdd9b5", "#7f2704"
SPACE_FACE, SPACE_EDGE = "#ececec", "#7a7a7a"
WHEEL_COLOR = "#303030"
LIMIT_COLOR = "#b22222"
OBSTACLE_FACE, OBSTACLE_EDGE = "#a6a6a6", "#4d4d4d"
AREA_EDGE = "#4d4d4d"

# Mathtext symbols used in labels.
DF, DPSI, EPSI = r"$\delta_f$", r"$\Delta\psi$", r"$e_\psi$"


def stage_color(index: int) -> str:
    return STAGE_COLORS[index % len(STAGE_COLORS)]


#: How a stage's controller is named in titles (files without it: by the stage's kind, as the 3-stage process).
CONTROLLER_NAMES = {"nmpc": "NMPC", "pursuit": "pure pursuit", "tracking": "path tracking"}


def stage_name(result: ManeuverResult, index: int) -> str:
    stage = result.stages[index]
    how = CONTROLLER_NAMES.get(stage.controller) or ("NMPC" if stage.kind == "reverse" else "pure pursuit")
    return f"Stage {index + 1}: {stage.kind} ({how})"


def outcome(result: ManeuverResult) -> str:
    n = len(result.stages)
    word = "stage" if n == 1 else "stages"
    if result.success:
        return f"parked in {n} {word}, {result.duration:.1f} s"
    return f"FAILED ({result.reason}) after {n} {word}, {result.duration:.1f} s"


def final_errors(result: ManeuverResult) -> tuple[float, float, float]:
    """Final trailer distance error [m], orientation error [deg], hitch angle [deg]."""
    tr = result.trajectory
    gx, gy, gyaw = to_goal_frame(result.goal, tr["x_trailer"][-1], tr["y_trailer"][-1], tr["yaw_trailer"][-1])
    return float(math.hypot(gx, gy)), math.degrees(float(gyaw)), math.degrees(float(tr["hitch"][-1]))


def headline(result: ManeuverResult) -> str:
    d, e, h = final_errors(result)
    name = result.name or "maneuver"
    clearance = result.min_clearance_m
    among = "" if clearance is None else f";  least clearance {clearance_text(clearance)}"
    return (
        f"{name}: {outcome(result)}\n"
        f"final trailer error: distance {fmt_len(d)}, orientation {e:.3g}°;  final hitch {h:.3g}°;  "
        f"max |{DF}| {result.max_abs_front_steer_deg:.1f}°, max |{DPSI}| {result.max_abs_hitch_deg:.1f}°{among}"
    )


def clearance_text(metres: float) -> str:
    """A clearance for a label: centimetres, or 0 as a collision."""
    return "0 (collision)" if metres == 0.0 else f"{100 * metres:.1f} cm" if metres < 1.0 else f"{metres:.2f} m"


def fmt_len(metres: float) -> str:
    if metres >= 0.1:
        return f"{metres:.2f} m"
    if metres >= 1e-4:
        return f"{metres * 1000:.1f} mm"
    return f"{metres:.1e} m"


def stage_summary(result: ManeuverResult, index: int) -> str:
    st = result.stages[index]
    t = result.trajectory["t"]
    span = t[st.last_row] - t[st.first_row]
    return (
        f"{span:.1f} s, end: d = {fmt_len(st.distance_error_m)}, "
        f"{EPSI} = {st.orientation_error_deg:.3g}°, {DPSI} = {st.final_hitch_deg:.3g}° ({st.reason})"
    )


class Extent:
    """Running bounding box of drawn geometry."""

    def __init__(self) -> None:
        self.low = np.array([np.inf, np.inf])
        self.high = np.array([-np.inf, -np.inf])

    def add(self, points: np.ndarray) -> None:
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        pts = pts[np.all(np.isfinite(pts), axis=1)]
        if len(pts):
            self.low = np.minimum(self.low, pts.min(axis=0))
            self.high = np.maximum(self.high, pts.max(axis=0))

    def apply(self, ax: Axes, margin: float = 0.8) -> None:
        if not np.all(np.isfinite(self.low)):
            return
        # Grow the data limits rather than fixing the view, so that an equal aspect with
        # adjustable="datalim" can still widen whichever axis has room.
        ax.update_datalim([self.low - margin, self.high + margin])
        ax.margins(0.0)
        ax.autoscale_view()

    @property
    def aspect(self) -> float:
        """Height over width of the box (1 if empty)."""
        if not np.all(np.isfinite(self.low)):
            return 1.0
        w, h = self.high - self.low + 1.6
        return float(h / w)


def shade_stages(ax: Axes, result: ManeuverResult, labels: bool) -> None:
    """Tint each stage's time span in its colour, mark the changes, and (``labels``) name them on top."""
    t = result.trajectory["t"]
    total = max(float(t[-1] - t[0]), 1e-9)
    for i, st in enumerate(result.stages):
        t0, t1 = t[st.first_row], t[st.last_row]
        label = f"S{i + 1} {st.kind}" if (t1 - t0) / total > 0.07 else f"S{i + 1}"
        ax.axvspan(t0, t1, color=stage_color(i), alpha=0.09, lw=0, zorder=0)
        if i > 0:
            ax.axvline(t0, color="#888888", lw=0.8, ls=":", zorder=1)
        if labels:
            ax.text(
                0.5 * (t0 + t1),
                1.02,
                label,
                transform=ax.get_xaxis_transform(),
                ha="center",
                va="bottom",
                fontsize=8.5,
                color=stage_color(i),
                clip_on=False,
            )


def limit_lines(ax: Axes, value: float, label: str) -> None:
    """Dashed lines at ``±value``; only the upper one carries ``label`` into the legend."""
    ax.axhline(value, color=LIMIT_COLOR, ls="--", lw=1.0, label=label)
    ax.axhline(-value, color=LIMIT_COLOR, ls="--", lw=1.0)


def step_series(values: np.ndarray, first: int, last: int) -> np.ndarray:
    """Commands of rows [first, last) held to t[last]: values padded with the last command, for steps-post."""
    held = values[first:last]
    if len(held) == 0:
        return held
    return np.append(held, held[-1])

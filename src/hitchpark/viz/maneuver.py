"""Figures 8-15 of the paper for one parking maneuver, and an animated GIF of it.

``plot_maneuver`` writes three PNG files:

* ``motion.png`` (Figs. 8/10/12/14 a-d): one panel per stage with the trailer-axle
  and rear-axle paths and the bodies at several instants, plus the overall trajectory;
* ``inputs.png`` (Figs. 8e-f): front steer, rear-axle speed and hitch angle against time;
* ``nmpc.png`` (Figs. 9/11/13/15): per reverse stage, the NMPC cost, the virtual
  inputs, the trailer position in the parking frame and the trailer orientation error.

``body_outlines`` and ``wheel_outlines`` are plain NumPy (no matplotlib), so they can
also serve collision checks. Matplotlib is imported only inside the plotting functions.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..checks import InputError
from ..model.geometry import along, body_outlines, parking_space, to_goal_frame, wheel_outlines
from ..model.inverse import virtual_steer_bounds
from . import use_headless_backend

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes

    from ..maneuver.process import ManeuverResult

__all__ = [
    "STAGE_COLORS",
    "animate_maneuver",
    "body_outlines",
    "parking_space",
    "plot_maneuver",
    "wheel_outlines",
]

#: Colour of stage i is ``STAGE_COLORS[i % len(STAGE_COLORS)]`` (Okabe-Ito, colour-blind safe, then wine).
STAGE_COLORS = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#882255")

_VEHICLE_FACE, _VEHICLE_EDGE = "#c6dbef", "#08306b"
_TRAILER_FACE, _TRAILER_EDGE = "#fdd9b5", "#7f2704"
_SPACE_FACE, _SPACE_EDGE = "#ececec", "#7a7a7a"
_WHEEL_COLOR = "#303030"

# Mathtext symbols used in labels.
_DF, _DPSI, _EPSI = r"$\delta_f$", r"$\Delta\psi$", r"$e_\psi$"

# --------------------------------------------------------------------------- helpers


def _stage_color(index: int) -> str:
    return STAGE_COLORS[index % len(STAGE_COLORS)]


def _stage_name(result: ManeuverResult, index: int) -> str:
    kind = result.stages[index].kind
    how = "NMPC" if kind == "reverse" else "pure pursuit"
    return f"Stage {index + 1}: {kind} ({how})"


def _outcome(result: ManeuverResult) -> str:
    n = len(result.stages)
    word = "stage" if n == 1 else "stages"
    if result.success:
        return f"parked in {n} {word}, {result.duration:.1f} s"
    return f"FAILED ({result.reason}) after {n} {word}, {result.duration:.1f} s"


def _final_errors(result: ManeuverResult) -> tuple[float, float, float]:
    """Final trailer distance error [m], orientation error [deg], hitch angle [deg]."""
    tr = result.trajectory
    gx, gy, gyaw = to_goal_frame(result.goal, tr["x_trailer"][-1], tr["y_trailer"][-1], tr["yaw_trailer"][-1])
    return float(math.hypot(gx, gy)), math.degrees(float(gyaw)), math.degrees(float(tr["hitch"][-1]))


def _headline(result: ManeuverResult) -> str:
    d, e, h = _final_errors(result)
    name = result.name or "maneuver"
    return (
        f"{name}: {_outcome(result)}\n"
        f"final trailer error: distance {_fmt_len(d)}, orientation {e:.3g}°;  final hitch {h:.3g}°;  "
        f"max |{_DF}| {result.max_abs_front_steer_deg:.1f}°, max |{_DPSI}| {result.max_abs_hitch_deg:.1f}°"
    )


def _fmt_len(metres: float) -> str:
    if metres >= 0.1:
        return f"{metres:.2f} m"
    if metres >= 1e-4:
        return f"{metres * 1000:.1f} mm"
    return f"{metres:.1e} m"


def _stage_summary(result: ManeuverResult, index: int) -> str:
    st = result.stages[index]
    t = result.trajectory["t"]
    span = t[st.last_row] - t[st.first_row]
    return (
        f"{span:.1f} s, end: d = {_fmt_len(st.distance_error_m)}, "
        f"{_EPSI} = {st.orientation_error_deg:.3g}°, {_DPSI} = {st.final_hitch_deg:.3g}° ({st.reason})"
    )


def _snapshot_rows(t: np.ndarray, first: int, last: int, every: float, max_count: int = 8) -> list[int]:
    """Rows strictly between ``first`` and ``last`` about ``every`` seconds apart (at most ``max_count``)."""
    duration = float(t[last] - t[first])
    if last - first < 2 or duration <= 0:
        return []
    step = max(every, duration / (max_count + 1))
    targets = t[first] + np.arange(step, duration - 0.5 * step + 1e-9, step)
    rows = np.searchsorted(t[first : last + 1], targets) + first
    return sorted({int(r) for r in rows if first < r < last})


class _Extent:
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


def _rig(result: ManeuverResult, row: int) -> tuple[dict[str, np.ndarray], np.ndarray]:
    tr = result.trajectory
    args = (tr["x_trailer"][row], tr["y_trailer"][row], tr["yaw_trailer"][row], tr["hitch"][row])
    return body_outlines(result.vehicle, *args), wheel_outlines(result.vehicle, *args, tr["front_steer"][row])


def _draw_rig(ax: Axes, result: ManeuverResult, row: int, bold: bool, zorder: float = 3) -> None:
    """Draw vehicle, trailer, drawbar and (bold only) wheels at ``row``."""
    from matplotlib.patches import Polygon

    bodies, wheels = _rig(result, row)
    if bold:
        for w in wheels:
            ax.add_patch(Polygon(w, closed=True, fc=_WHEEL_COLOR, ec="none", zorder=zorder))
        for key, face, edge in (
            ("vehicle", _VEHICLE_FACE, _VEHICLE_EDGE),
            ("trailer", _TRAILER_FACE, _TRAILER_EDGE),
        ):
            ax.add_patch(Polygon(bodies[key], closed=True, fc=face, ec=edge, lw=1.4, alpha=0.85, zorder=zorder + 0.1))
        lw, alpha = 1.8, 1.0
    else:
        for key, edge in (("vehicle", _VEHICLE_EDGE), ("trailer", _TRAILER_EDGE)):
            ax.add_patch(Polygon(bodies[key], closed=True, fill=False, ec=edge, lw=0.7, alpha=0.35, zorder=zorder))
        lw, alpha = 0.8, 0.35
    for key in ("drawbar", "tow_bar"):
        seg = bodies[key]
        ax.plot(
            seg[:, 0],
            seg[:, 1],
            color="#404040",
            lw=lw,
            alpha=alpha,
            zorder=zorder + 0.2,
            solid_capstyle="round",
        )
    ax.plot(*bodies["hitch"], "o", ms=3.0 if bold else 2.0, color="k", alpha=alpha, zorder=zorder + 0.3)


def _draw_goal(ax: Axes, result: ManeuverResult) -> None:
    """The parking space, a cross at the goal trailer-axle centre and an arrow along the goal heading."""
    from matplotlib.patches import Polygon

    goal, v = result.goal, result.vehicle
    space = parking_space(v, goal)
    ax.add_patch(
        Polygon(
            space,
            closed=True,
            fc=_SPACE_FACE,
            ec=_SPACE_EDGE,
            lw=1.2,
            ls="--",
            zorder=1,
        )
    )
    arrow = 0.5 * (v.trailer_front + v.trailer_rear)
    tip = along(goal.x, goal.y, goal.yaw, arrow)
    ax.annotate(
        "",
        xy=tuple(tip),
        xytext=(goal.x, goal.y),
        zorder=4.8,
        arrowprops={"arrowstyle": "-|>", "color": "#222222", "lw": 1.4, "mutation_scale": 12},
    )
    ax.plot(
        goal.x,
        goal.y,
        marker="+",
        ms=9,
        mew=1.6,
        color="#222222",
        ls="none",
        zorder=4.8,
    )


def _paths(ax: Axes, result: ManeuverResult, rows: slice, color: str) -> None:
    """Trailer-axle path (solid) and vehicle rear-axle path (dashed) over ``rows``."""
    tr = result.trajectory
    xt, yt = tr["x_trailer"][rows], tr["y_trailer"][rows]
    xr, yr = tr["x_rear"][rows], tr["y_rear"][rows]
    ax.plot(xt, yt, color=color, lw=2.0, zorder=5)
    ax.plot(
        xr,
        yr,
        color=color,
        lw=1.2,
        ls=(0, (4, 2)),
        alpha=0.9,
        zorder=5,
    )


def _shade_stages(ax: Axes, result: ManeuverResult, labels: bool) -> None:
    t = result.trajectory["t"]
    total = max(float(t[-1] - t[0]), 1e-9)
    for i, st in enumerate(result.stages):
        t0, t1 = t[st.first_row], t[st.last_row]
        label = f"S{i + 1} {st.kind}" if (t1 - t0) / total > 0.07 else f"S{i + 1}"
        ax.axvspan(t0, t1, color=_stage_color(i), alpha=0.09, lw=0, zorder=0)
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
                color=_stage_color(i),
                clip_on=False,
            )


def _limit_lines(ax: Axes, value: float, label: str) -> None:
    ax.axhline(value, color="#b22222", ls="--", lw=1.0, label=label)
    ax.axhline(-value, color="#b22222", ls="--", lw=1.0)


def _step_series(values: np.ndarray, first: int, last: int) -> np.ndarray:
    """Commands of rows [first, last) held to t[last]: values padded with the last command, for steps-post."""
    held = values[first:last]
    if len(held) == 0:
        return held
    return np.append(held, held[-1])


# --------------------------------------------------------------------------- figures


def _panel_rows(result: ManeuverResult, snapshot_every: float) -> list[tuple[slice, list[int], list[int]]]:
    """For each panel (stages, then the overall one): path rows, light-body rows, bold-body rows."""
    t = result.trajectory["t"]
    panels = []
    for i, st in enumerate(result.stages):
        bold = [st.first_row] if st.last_row == st.first_row else [st.first_row, st.last_row]
        panels.append((result.stage_rows(i), _snapshot_rows(t, st.first_row, st.last_row, snapshot_every), bold))
    light = [st.first_row for st in result.stages[1:]]
    panels.append((slice(0, len(t)), light, [0, len(t) - 1]))
    return panels


def _motion_figure(result: ManeuverResult, path: Path, dpi: int, snapshot_every: float) -> Path:
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    tr = result.trajectory
    n_stages = len(result.stages)
    panels = _panel_rows(result, snapshot_every)
    n_panels = len(panels)
    ncols = 2 if n_panels <= 4 else 3
    nrows = math.ceil(n_panels / ncols)

    # Extents first, to give the panels a height that suits the data.
    extents = []
    for rows, light, bold in panels:
        ext = _Extent()
        ext.add(parking_space(result.vehicle, result.goal))
        ext.add(np.column_stack([tr["x_trailer"][rows], tr["y_trailer"][rows]]))
        ext.add(np.column_stack([tr["x_rear"][rows], tr["y_rear"][rows]]))
        for row in (*light, *bold):
            bodies, _ = _rig(result, row)
            ext.add(bodies["vehicle"])
            ext.add(bodies["trailer"])
        extents.append(ext)
    width = 6.0
    aspect = float(np.median([e.aspect for e in extents]))
    height = float(np.clip(width * aspect * 0.92, 2.0, 5.5)) + 1.15
    fig, axes = plt.subplots(
        nrows, ncols, figsize=(width * ncols, height * nrows + 1.3), constrained_layout=True, squeeze=False
    )
    flat = axes.ravel()
    letters = "abcdefghij"
    for p, ((_rows, light, bold), ext) in enumerate(zip(panels, extents, strict=True)):
        ax = flat[p]
        _draw_goal(ax, result)
        for i in range(n_stages) if p == n_stages else [p]:
            _paths(ax, result, result.stage_rows(i), _stage_color(i))
        for row in light:
            _draw_rig(ax, result, row, bold=False)
        for j, row in enumerate(bold):
            _draw_rig(ax, result, row, bold=True, zorder=3 + 0.5 * j)
        first, last = bold[0], bold[-1]
        start_color = _stage_color(p if p < n_stages else 0)
        end_color = _stage_color(p if p < n_stages else n_stages - 1)
        ax.plot(
            tr["x_trailer"][first],
            tr["y_trailer"][first],
            "o",
            ms=6.5,
            mfc="white",
            mec=start_color,
            mew=1.8,
            zorder=6,
        )
        ax.plot(tr["x_trailer"][last], tr["y_trailer"][last], "s", ms=6, color=end_color, zorder=6)
        ext.apply(ax)
        if p < n_stages:
            title = f"({letters[p]}) {_stage_name(result, p)}\n{_stage_summary(result, p)}"
        else:
            title = f"({letters[p]}) Overall trajectory\nbodies at the start, at each stage change and at the end"
        ax.set_title(title, fontsize=10)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.grid(True, lw=0.4, alpha=0.5)
    for ax in flat[n_panels:]:
        ax.set_visible(False)
    handles: list[Artist] = [
        Line2D([], [], color=_stage_color(i), lw=2.0, label=f"stage {i + 1} ({st.kind})")
        for i, st in enumerate(result.stages)
    ]
    handles += [
        Line2D([], [], color="#555555", lw=2.0, label="trailer-axle path"),
        Line2D([], [], color="#555555", lw=1.2, ls=(0, (4, 2)), label="vehicle rear-axle path"),
        Line2D([], [], marker="o", mfc="white", mec="#555555", mew=1.6, ls="none", label="start (trailer axle)"),
        Line2D([], [], marker="s", color="#555555", ls="none", label="end (trailer axle)"),
        Patch(fc=_VEHICLE_FACE, ec=_VEHICLE_EDGE, label="vehicle"),
        Patch(fc=_TRAILER_FACE, ec=_TRAILER_EDGE, label="trailer (drawbar to the hitch •)"),
        Line2D(
            [],
            [],
            lw=0.8,
            color=_VEHICLE_EDGE,
            alpha=0.45,
            label=f"bodies every {snapshot_every:g} s (at most 8 per stage)",
        ),
        Patch(fc=_SPACE_FACE, ec=_SPACE_EDGE, ls="--", label="parking space, goal heading →"),
    ]
    fig.legend(
        handles=handles,
        loc="outside lower center",
        ncol=min(6, math.ceil(len(handles) / 2)),
        fontsize=8.5,
        frameon=False,
    )
    fig.suptitle(_headline(result), fontsize=11)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


def _inputs_figure(result: ManeuverResult, path: Path, dpi: int) -> Path:
    import matplotlib.pyplot as plt

    tr = result.trajectory
    t = tr["t"]
    v = result.vehicle
    fig, axes = plt.subplots(3, 1, figsize=(10, 8), sharex=True, constrained_layout=True)
    ax = axes[0]
    _shade_stages(ax, result, labels=True)
    ax.plot(
        t,
        np.degrees(tr["front_steer"]),
        color="#1a1a1a",
        lw=1.4,
        drawstyle="steps-post",
        label=r"front steer $\delta_f$",
    )
    _limit_lines(ax, math.degrees(v.max_steer), f"±{math.degrees(v.max_steer):.1f}° limit")
    ax.set_ylabel(r"front steer $\delta_f$ [deg]")
    ax.set_title(
        f"(e) Tractor vehicle inputs: max |{_DF}| = {result.max_abs_front_steer_deg:.1f}°",
        fontsize=10,
        pad=16,
    )
    ax.legend(fontsize=8, loc="best", framealpha=0.9)
    ax = axes[1]
    _shade_stages(ax, result, labels=False)
    ax.plot(t, tr["rear_speed"], color="#1a1a1a", lw=1.4, drawstyle="steps-post", label="rear-axle speed $V_R$")
    ax.axhline(0.0, color="#888888", lw=0.6)
    ax.set_ylabel("rear-axle speed $V_R$ [m/s]")
    ax.legend(fontsize=8, loc="best", framealpha=0.9)
    ax = axes[2]
    _shade_stages(ax, result, labels=False)
    ax.plot(
        t,
        np.degrees(tr["hitch"]),
        color="#1a1a1a",
        lw=1.4,
        label=r"hitch angle $\Delta\psi = \psi_1 - \psi_2$",
    )
    _limit_lines(ax, math.degrees(v.max_hitch), f"±{math.degrees(v.max_hitch):.0f}° jackknife limit")
    ax.axhline(0.0, color="#888888", lw=0.6)
    ax.set_ylabel(r"hitch angle $\Delta\psi$ [deg]")
    ax.set_xlabel("time t [s]")
    ax.set_title(
        f"(f) Hitch angle: max |{_DPSI}| = {result.max_abs_hitch_deg:.1f}°, final {_final_errors(result)[2]:.3g}°",
        fontsize=10,
    )
    ax.legend(fontsize=8, loc="best", framealpha=0.9)
    if len(t) > 1:
        axes[2].set_xlim(t[0], t[-1])
    for ax in axes:
        ax.grid(True, lw=0.4, alpha=0.5)
    fig.suptitle(_headline(result), fontsize=10.5)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


def _nmpc_figure(result: ManeuverResult, path: Path, dpi: int) -> Path:
    import matplotlib.pyplot as plt

    tr = result.trajectory
    t = tr["t"]
    v = result.vehicle
    nmpc = result.settings.nmpc
    reverse = [i for i, st in enumerate(result.stages) if st.kind == "reverse"]
    fig = plt.figure(figsize=(18, 3.3 * len(reverse) + 0.5), constrained_layout=True)
    subfigs = np.asarray(fig.subfigures(len(reverse), 1, squeeze=False)).ravel()
    gx, gy, gyaw = to_goal_frame(result.goal, tr["x_trailer"], tr["y_trailer"], tr["yaw_trailer"])
    for sub, i in zip(subfigs, reverse, strict=True):
        st = result.stages[i]
        first, last = st.first_row, st.last_row
        cmd_t = t[first:last]  # commands applied from these instants
        held_t = t[first : last + 1] if last > first else t[first:first]
        state_t = t[first : last + 1]
        axes = sub.subplots(1, 5)
        color = _stage_color(i)
        # Cost.
        ax = axes[0]
        cost = tr["cost"][first:last]
        ax.plot(cmd_t, cost, color=color, lw=1.5)
        finite = cost[np.isfinite(cost)]
        if len(finite) and np.all(finite > 0) and finite.max() > 100 * finite.min():  # spans > 2 decades
            ax.set_yscale("log")
        ax.set_ylabel("cost $J$" + (" (log scale)" if ax.get_yscale() == "log" else ""))
        ax.set_title("cost function", fontsize=9.5)
        # Virtual inputs.
        ax = axes[1]
        ax.plot(
            held_t,
            _step_series(tr["trailer_speed"], first, last),
            color=color,
            lw=1.5,
            drawstyle="steps-post",
            label="$V_T$",
        )
        ax.axhline(nmpc.speed_min, color="#b22222", ls="--", lw=1.0, label="bounds")
        ax.axhline(nmpc.speed_max, color="#b22222", ls="--", lw=1.0)
        ax.set_ylabel("trailer speed $V_T$ [m/s]")
        ax.set_title("virtual input: trailer speed", fontsize=9.5)
        ax.legend(fontsize=8, loc="best")
        ax = axes[2]
        if last > first:
            low, high = virtual_steer_bounds(v, tr["hitch"][first:last], nmpc.virtual_limit)
            ax.fill_between(
                held_t,
                np.degrees(_step_series(np.asarray(low), 0, len(low))),
                np.degrees(_step_series(np.asarray(high), 0, len(high))),
                step="post",
                color=color,
                alpha=0.12,
                lw=0,
                label="feasible (Eqs. 56-57)",
            )
        ax.plot(
            held_t,
            np.degrees(_step_series(tr["virtual_steer"], first, last)),
            color=color,
            lw=1.5,
            drawstyle="steps-post",
            label=r"$\delta_T$",
        )
        _limit_lines(ax, math.degrees(nmpc.virtual_limit), f"±{math.degrees(nmpc.virtual_limit):.1f}°")
        ax.set_ylabel(r"virtual steer $\delta_T$ [deg]")
        ax.set_title("virtual input: virtual steer", fontsize=9.5)
        ax.legend(fontsize=8, loc="best")
        # Trailer position and orientation in the parking frame.
        ax = axes[3]
        dot = "o" if len(state_t) == 1 else None  # a stage that ended at once: show its one state
        ax.plot(state_t, gx[first : last + 1], color=color, lw=1.5, marker=dot, label="$X$ (along goal heading)")
        ax.plot(state_t, gy[first : last + 1], color=color, lw=1.5, ls="--", marker=dot and "s", label="$Y$ (lateral)")
        ax.axhline(0.0, color="#888888", lw=0.6)
        ax.set_ylabel("trailer position [m] (goal frame)")
        ax.set_title("trailer axle position", fontsize=9.5)
        ax.legend(fontsize=8, loc="best")
        ax = axes[4]
        ax.plot(state_t, np.degrees(gyaw[first : last + 1]), color=color, lw=1.5, marker=dot)
        ax.axhline(0.0, color="#888888", lw=0.6)
        ax.set_ylabel(r"trailer yaw error $\psi_2 - \psi_{goal}$ [deg]")
        ax.set_title("trailer orientation error", fontsize=9.5)
        if last == first:
            for ax in axes[:3]:
                ax.text(0.5, 0.5, "no step applied", transform=ax.transAxes, ha="center", va="center", color="#666666")
        for ax in axes:
            ax.set_xlabel("time t [s]")
            ax.grid(True, lw=0.4, alpha=0.5)
            if len(state_t) > 1:
                ax.set_xlim(state_t[0], state_t[-1])
        sub.suptitle(
            f"{_stage_name(result, i)}: {st.steps} steps, {_stage_summary(result, i)}",
            fontsize=10.5,
            color=color,
        )
    fig.suptitle(_headline(result), fontsize=11)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


def plot_maneuver(
    result: ManeuverResult,
    out_dir: str | Path,
    prefix: str = "",
    *,
    dpi: int = 150,
    snapshot_every: float = 2.0,
) -> list[Path]:
    """Write the paper's Figs. 8-15 for one maneuver as PNG files.

    Parameters
    ----------
    result : ManeuverResult
        A maneuver, fresh from ``park`` or loaded back from JSON.
    out_dir : str or Path
        Directory for the files (created if missing).
    prefix : str
        Prepended to each file name, e.g. ``"scenario1_"``.
    dpi : int
        Resolution of the PNG files.
    snapshot_every : float
        Time between the light body outlines drawn in each stage panel [s]; fewer are
        drawn in long stages (at most 8 per stage).

    Returns
    -------
    list of Path
        ``motion.png``, ``inputs.png`` and ``nmpc.png`` (with the prefix), in that order.

    Raises
    ------
    ValueError
        If ``snapshot_every`` is not a positive time, or the maneuver has no rows or stages.
    """
    if not math.isfinite(snapshot_every) or snapshot_every <= 0:
        raise InputError(f"snapshot_every must be a finite time > 0 s, got {snapshot_every!r}")
    if len(result.trajectory) == 0 or not result.stages:
        raise InputError("the maneuver has no trajectory rows or no stages: nothing to plot")
    use_headless_backend()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    return [
        _motion_figure(result, out / f"{prefix}motion.png", dpi, snapshot_every),
        _inputs_figure(result, out / f"{prefix}inputs.png", dpi),
        _nmpc_figure(result, out / f"{prefix}nmpc.png", dpi),
    ]


# --------------------------------------------------------------------------- animation


def _frame_rows(n_rows: int, max_frames: int) -> np.ndarray:
    """At most ``max_frames`` rows spread evenly over ``n_rows``, first and last included."""
    count = max(1, min(n_rows, max_frames))
    return np.unique(np.round(np.linspace(0, n_rows - 1, count)).astype(int))


def animate_maneuver(
    result: ManeuverResult,
    path: str | Path,
    fps: int = 10,
    max_frames: int = 300,
    *,
    dpi: int = 80,
    width: float = 6.0,
) -> Path:
    """Write an animated GIF of the whole maneuver.

    Each frame shows the parking space and goal heading, the bodies (with steered
    front wheels), the trailer-axle path so far coloured by stage, the rear-axle path
    so far, and a header with time, stage, rear-axle speed, front steer, hitch angle
    and the trailer's distance and orientation errors. The rows are subsampled evenly
    to at most ``max_frames`` frames (first and last row always included); the last
    frame is held for 1.5 s.

    Parameters
    ----------
    result : ManeuverResult
        A maneuver, fresh from ``park`` or loaded back from JSON.
    path : str or Path
        The GIF file to write (parent directories are created).
    fps : int
        Frames per second of the GIF (>= 1).
    max_frames : int
        Upper bound on the number of frames (>= 1).
    dpi : int
        Resolution; the GIF is ``width * dpi`` pixels wide.
    width : float
        Figure width in inches; the height follows the shape of the scene (3.2-6.5 in).

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    ValueError
        If ``fps`` or ``max_frames`` is not an integer >= 1, or the maneuver has no rows or stages.
    """
    if isinstance(fps, bool) or not isinstance(fps, int) or fps < 1:
        raise InputError(f"fps must be an integer >= 1, got {fps!r}")
    if isinstance(max_frames, bool) or not isinstance(max_frames, int) or max_frames < 1:
        raise InputError(f"max_frames must be an integer >= 1, got {max_frames!r}")
    tr = result.trajectory
    if len(tr) == 0 or not result.stages:
        raise InputError("the maneuver has no trajectory rows or no stages: nothing to animate")
    use_headless_backend()
    import matplotlib.pyplot as plt
    from matplotlib.patches import Polygon

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    rows = _frame_rows(len(tr), max_frames)
    stage_of = np.clip(tr["stage"].astype(int), 0, len(result.stages) - 1)
    geometry = {int(r): _rig(result, int(r)) for r in rows}
    ext = _Extent()
    ext.add(parking_space(result.vehicle, result.goal))
    ext.add(np.column_stack([tr["x_trailer"], tr["y_trailer"]]))
    for bodies, _ in geometry.values():
        ext.add(bodies["vehicle"])
        ext.add(bodies["trailer"])
    height = float(np.clip(0.85 * width * ext.aspect + 1.5, 3.2, 6.5))

    fig, ax = plt.subplots(figsize=(width, height), dpi=dpi, constrained_layout=True)
    _draw_goal(ax, result)
    ext.apply(ax, margin=0.6)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, color="#dddddd", lw=0.6)
    fig.suptitle(f"{result.name or 'maneuver'}: {_outcome(result)}", fontsize=10)

    def polygon(**style: Any) -> Any:
        return ax.add_patch(Polygon(np.zeros((5, 2)), closed=True, **style))

    rear_line = ax.plot([], [], color="#777777", lw=0.9, ls=(0, (4, 2)), zorder=4)[0]
    stage_lines = [ax.plot([], [], color=_stage_color(i), lw=1.8, zorder=5)[0] for i in range(len(result.stages))]
    wheel_patches = [polygon(fc=_WHEEL_COLOR, ec="none", zorder=6) for _ in range(6)]
    vehicle_patch = polygon(fc=_VEHICLE_FACE, ec=_VEHICLE_EDGE, lw=1.3, alpha=0.9, zorder=7)
    trailer_patch = polygon(fc=_TRAILER_FACE, ec=_TRAILER_EDGE, lw=1.3, alpha=0.9, zorder=7)
    bars = [ax.plot([], [], color="#303030", lw=1.8, zorder=8, solid_capstyle="round")[0] for _ in range(2)]
    hitch_dot = ax.plot([], [], "o", ms=3.5, color="k", zorder=9)[0]
    info = ax.set_title("", fontsize=8.5, family="monospace", loc="left")
    t = tr["t"]
    n_stages = len(result.stages)
    gx, gy, gyaw = to_goal_frame(result.goal, tr["x_trailer"], tr["y_trailer"], tr["yaw_trailer"])
    distance = np.hypot(gx, gy)

    def update(row: int) -> None:
        k = int(stage_of[row])
        for i, line in enumerate(stage_lines):
            lo, hi = result.stages[i].first_row, min(row, result.stages[i].last_row)
            if i <= k and hi >= lo:
                line.set_data(tr["x_trailer"][lo : hi + 1], tr["y_trailer"][lo : hi + 1])
            else:
                line.set_data([], [])
        rear_line.set_data(tr["x_rear"][: row + 1], tr["y_rear"][: row + 1])
        bodies, wheels = geometry[row]
        vehicle_patch.set_xy(bodies["vehicle"])
        trailer_patch.set_xy(bodies["trailer"])
        for patch, wheel in zip(wheel_patches, wheels, strict=True):
            patch.set_xy(wheel)
        for bar, key in zip(bars, ("drawbar", "tow_bar"), strict=True):
            bar.set_data(bodies[key][:, 0], bodies[key][:, 1])
        hitch_dot.set_data([bodies["hitch"][0]], [bodies["hitch"][1]])
        info.set_text(
            f"t {t[row]:5.1f} s   stage {k + 1}/{n_stages} {result.stages[k].kind:<7}  "
            f"V_R {tr['rear_speed'][row]:+5.2f} m/s\n"
            f"δf {math.degrees(tr['front_steer'][row]):+5.1f}°   "
            f"Δψ {math.degrees(tr['hitch'][row]):+5.1f}°   "
            f"trailer: d {distance[row]:5.2f} m, e_ψ {math.degrees(gyaw[row]):+6.2f}°"
        )
        info.set_color(_stage_color(k))

    # Lay the figure out once, then freeze it: re-running the constrained layout on every
    # frame would more than double the render time.
    update(int(rows[-1]))
    fig.canvas.draw()
    fig.set_layout_engine(None)
    # The last frame holds every colour in use (all stage paths are drawn by then); its
    # palette serves every frame, which is fast and gives the GIF one global palette.
    palette = _canvas_image(fig).quantize(colors=255, dither=_no_dither())
    writer = _make_gif_writer(fps, palette, hold_last_s=1.5)
    with writer.saving(fig, str(path), dpi):
        for row in rows:
            update(int(row))
            writer.grab_frame()
    plt.close(fig)
    return path


def _canvas_image(fig: Any) -> Any:
    """The figure's Agg canvas as an RGB ``PIL.Image`` (the canvas must have been drawn)."""
    from PIL import Image

    width, height = fig.canvas.get_width_height(physical=True)
    return Image.frombuffer("RGBA", (width, height), fig.canvas.buffer_rgba(), "raw", "RGBA", 0, 1).convert("RGB")


def _no_dither() -> Any:
    from PIL import Image

    return Image.Dither.NONE


def _make_gif_writer(fps: int, palette: Any, hold_last_s: float) -> Any:
    """A ``PillowWriter`` that draws each frame once and maps it onto a fixed palette.

    The stock writer renders every frame through ``savefig`` and lets Pillow quantize
    every frame on its own when saving, which dominates the run time for a few hundred
    frames. The last frame is shown for ``hold_last_s`` seconds.
    """
    from matplotlib.animation import PillowWriter

    class _PaletteGifWriter(PillowWriter):
        def setup(self, fig: Any, outfile: Any, dpi: float | None = None) -> None:
            super().setup(fig, outfile, dpi=dpi)
            self._paletted: list[Any] = []

        def grab_frame(self, **savefig_kwargs: Any) -> None:
            self.fig.canvas.draw()
            self._paletted.append(_canvas_image(self.fig).quantize(palette=palette, dither=_no_dither()))

        def finish(self) -> None:
            frame_ms = round(1000 / self.fps)
            durations = [frame_ms] * len(self._paletted)
            durations[-1] = max(frame_ms, round(1000 * hold_last_s))
            self._paletted[0].save(
                self.outfile, save_all=True, append_images=self._paletted[1:], duration=durations, loop=0
            )

    return _PaletteGifWriter(fps=fps)

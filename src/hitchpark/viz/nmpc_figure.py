"""``nmpc.png`` (Figs. 9/11/13/15): per reverse stage, the NMPC's cost, the virtual inputs, the trailer's position
in the parking frame and its orientation error (:func:`~.figures.plot_maneuver` writes it where an NMPC drove).

Matplotlib is imported only inside the plotting function.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ..model.geometry import to_goal_frame
from ..model.inverse import virtual_steer_bounds
from . import use_headless_backend
from .common import LIMIT_COLOR, headline, limit_lines, stage_color, stage_name, stage_summary, step_series

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from ..maneuver.result import ManeuverResult

__all__ = ["nmpc_figure"]


def nmpc_figure(result: ManeuverResult) -> Figure:
    """The NMPC figure: a row of panels per reverse stage (the caller saves and closes it)."""
    use_headless_backend()
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
        color = stage_color(i)
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
            step_series(tr["trailer_speed"], first, last),
            color=color,
            lw=1.5,
            drawstyle="steps-post",
            label="$V_T$",
        )
        ax.axhline(nmpc.speed_min, color=LIMIT_COLOR, ls="--", lw=1.0, label="bounds")
        ax.axhline(nmpc.speed_max, color=LIMIT_COLOR, ls="--", lw=1.0)
        ax.set_ylabel("trailer speed $V_T$ [m/s]")
        ax.set_title("virtual input: trailer speed", fontsize=9.5)
        ax.legend(fontsize=8, loc="best")
        ax = axes[2]
        if last > first:
            low, high = virtual_steer_bounds(v, tr["hitch"][first:last], nmpc.virtual_limit)
            ax.fill_between(
                held_t,
                np.degrees(step_series(np.asarray(low), 0, len(low))),
                np.degrees(step_series(np.asarray(high), 0, len(high))),
                step="post",
                color=color,
                alpha=0.12,
                lw=0,
                label="feasible (Eqs. 56-57)",
            )
        ax.plot(
            held_t,
            np.degrees(step_series(tr["virtual_steer"], first, last)),
            color=color,
            lw=1.5,
            drawstyle="steps-post",
            label=r"$\delta_T$",
        )
        limit_lines(ax, math.degrees(nmpc.virtual_limit), f"±{math.degrees(nmpc.virtual_limit):.1f}°")
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
            f"{stage_name(result, i)}: {st.steps} steps, {stage_summary(result, i)}",
            fontsize=10.5,
            color=color,
        )
    fig.suptitle(headline(result), fontsize=11)
    return fig

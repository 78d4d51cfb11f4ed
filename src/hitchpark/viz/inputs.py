"""``inputs.png`` (Figs. 8e-f): the vehicle's inputs and the hitch angle against time."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from . import use_headless_backend
from .common import DF, DPSI, final_errors, headline, limit_lines, shade_stages

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from ..maneuver.process import ManeuverResult

__all__ = ["inputs_figure"]


def inputs_figure(result: ManeuverResult) -> Figure:
    """The inputs figure (the caller saves and closes it)."""
    use_headless_backend()
    import matplotlib.pyplot as plt

    tr = result.trajectory
    t = tr["t"]
    v = result.vehicle
    fig, axes = plt.subplots(3, 1, figsize=(10, 8), sharex=True, constrained_layout=True)
    ax = axes[0]
    shade_stages(ax, result, labels=True)
    ax.plot(
        t,
        np.degrees(tr["front_steer"]),
        color="#1a1a1a",
        lw=1.4,
        drawstyle="steps-post",
        label=r"front steer $\delta_f$",
    )
    limit_lines(ax, math.degrees(v.max_steer), f"±{math.degrees(v.max_steer):.1f}° limit")
    ax.set_ylabel(r"front steer $\delta_f$ [deg]")
    ax.set_title(
        f"(e) Tractor vehicle inputs: max |{DF}| = {result.max_abs_front_steer_deg:.1f}°",
        fontsize=10,
        pad=16,
    )
    ax.legend(fontsize=8, loc="best", framealpha=0.9)
    ax = axes[1]
    shade_stages(ax, result, labels=False)
    ax.plot(t, tr["rear_speed"], color="#1a1a1a", lw=1.4, drawstyle="steps-post", label="rear-axle speed $V_R$")
    ax.axhline(0.0, color="#888888", lw=0.6)
    ax.set_ylabel("rear-axle speed $V_R$ [m/s]")
    ax.legend(fontsize=8, loc="best", framealpha=0.9)
    ax = axes[2]
    shade_stages(ax, result, labels=False)
    ax.plot(
        t,
        np.degrees(tr["hitch"]),
        color="#1a1a1a",
        lw=1.4,
        label=r"hitch angle $\Delta\psi = \psi_1 - \psi_2$",
    )
    limit_lines(ax, math.degrees(v.max_hitch), f"±{math.degrees(v.max_hitch):.0f}° jackknife limit")
    ax.axhline(0.0, color="#888888", lw=0.6)
    ax.set_ylabel(r"hitch angle $\Delta\psi$ [deg]")
    ax.set_xlabel("time t [s]")
    ax.set_title(
        f"(f) Hitch angle: max |{DPSI}| = {result.max_abs_hitch_deg:.1f}°, final {final_errors(result)[2]:.3g}°",
        fontsize=10,
    )
    ax.legend(fontsize=8, loc="best", framealpha=0.9)
    if len(t) > 1:
        axes[2].set_xlim(t[0], t[-1])
    for ax in axes:
        ax.grid(True, lw=0.4, alpha=0.5)
    fig.suptitle(headline(result), fontsize=10.5)
    return fig

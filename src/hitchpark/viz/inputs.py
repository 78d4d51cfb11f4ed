"""``inputs.png`` (Figs. 8e-f): front steer, steer rate, rear-axle speed and hitch angle against time.

Row k of a trajectory holds the state at t_k and what happened from t_k to t_k+1. With a
steering actuator, ``front_steer`` and ``rear_speed`` are the actual values at t_k (drawn as
lines through the samples) and ``front_steer_cmd`` and ``rear_speed_cmd`` the commands issued
at t_k and held to t_k+1 (drawn as steps); ``hitch_measured`` is what the controllers saw (the sensor's
reading, or its estimate when ``settings.estimator`` filters it) beside the true ``hitch``. Each of these
extra columns is drawn only when present, so a maneuver saved without them still plots: there
``front_steer`` and ``rear_speed`` are the commands themselves, drawn as steps as before.

The steer rate is a finite difference in both cases: the actual one, (δ_k+1 - δ_k) / Δt, is
drawn over [t_k, t_k+1), where the wheels made that change; the commanded one,
(u_k - u_k-1) / Δt, over [t_k, t_k+1) too, the sample in which the actuator is asked to
make the jump the command took at t_k. An ideal actuator (δ_k+1 = u_k) gives two equal curves.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from . import use_headless_backend
from .common import DF, DPSI, final_errors, headline, limit_lines, shade_stages

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from ..maneuver.result import ManeuverResult

__all__ = ["inputs_figure", "steer_rate_limit"]

_ACTUAL, _COMMANDED, _MEASURED = "#1a1a1a", "#CC79A7", "#0072B2"
_LEGEND = {"fontsize": 8, "loc": "upper left", "bbox_to_anchor": (1.01, 1.0), "borderaxespad": 0.0}


def steer_rate_limit(result: ManeuverResult) -> float | None:
    """The plant's steer-rate limit [rad/s], or None if the result carries no plant or no finite limit.

    The ideal plant (the paper's: commands act at once) has none, whatever its settings say.
    """
    plant = getattr(result, "plant", None)
    if getattr(plant, "kind", None) == "ideal":
        return None
    rate = getattr(plant, "steer_rate_max", None)
    if rate is None:
        return None
    rate = float(rate)
    return rate if math.isfinite(rate) and rate > 0 else None


def _finite(values: np.ndarray) -> np.ndarray:
    return np.where(np.isfinite(values), values, np.nan)


def _state_rate(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Rate of a sampled state over [t_k, t_k+1), at row k; NaN on the last row."""
    out = np.full(len(t), np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        out[:-1] = np.diff(x) / np.diff(t)
    return _finite(out)


def _command_rate(t: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Jump of a held command at t_k over the sample before it, at row k; NaN on the first row."""
    out = np.full(len(t), np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        out[1:] = np.diff(u) / np.diff(t)
    return _finite(out)


def _max_abs(values: np.ndarray) -> float:
    finite = np.abs(values[np.isfinite(values)])
    return float(finite.max()) if len(finite) else 0.0


def _steer_panel(ax: Axes, result: ManeuverResult) -> None:
    tr, t, v = result.trajectory, result.trajectory["t"], result.vehicle
    shade_stages(ax, result, labels=True)
    if "front_steer_cmd" in tr:
        cmd = np.degrees(tr["front_steer_cmd"])
        ax.plot(t, cmd, color=_COMMANDED, lw=1.2, drawstyle="steps-post", label=r"commanded $\delta_{f,cmd}$")
        ax.plot(t, np.degrees(tr["front_steer"]), color=_ACTUAL, lw=1.4, label=r"actual $\delta_f$ (road wheels)")
    else:
        ax.plot(
            t, np.degrees(tr["front_steer"]), color=_ACTUAL, lw=1.4, drawstyle="steps-post", label=f"front steer {DF}"
        )
    limit_lines(ax, math.degrees(v.max_steer), f"±{math.degrees(v.max_steer):.1f}° limit")
    ax.set_ylabel(f"front steer {DF} [deg]")
    ax.set_title(
        f"(e) Tractor vehicle inputs: max |{DF}| = {result.max_abs_front_steer_deg:.1f}°",
        fontsize=10,
        pad=16,
    )


def _steer_rate_panel(ax: Axes, result: ManeuverResult) -> None:
    tr, t = result.trajectory, result.trajectory["t"]
    shade_stages(ax, result, labels=False)
    if "front_steer_cmd" in tr:
        cmd = np.degrees(_command_rate(t, tr["front_steer_cmd"]))
        act = np.degrees(_state_rate(t, tr["front_steer"]))
        ax.plot(
            t,
            cmd,
            color=_COMMANDED,
            lw=1.0,
            drawstyle="steps-post",
            label=f"commanded, max |·| {_max_abs(cmd):.0f}°/s",
        )
        ax.plot(t, act, color=_ACTUAL, lw=1.3, drawstyle="steps-post", label=f"actual, max |·| {_max_abs(act):.0f}°/s")
    else:
        rate = np.degrees(_command_rate(t, tr["front_steer"]))
        ax.plot(
            t,
            rate,
            color=_ACTUAL,
            lw=1.3,
            drawstyle="steps-post",
            label=f"change per step, max |·| {_max_abs(rate):.0f}°/s",
        )
    limit = steer_rate_limit(result)
    if limit is not None:
        limit_lines(ax, math.degrees(limit), f"±{math.degrees(limit):.0f}°/s rate limit")
    ax.axhline(0.0, color="#888888", lw=0.6)
    ax.set_ylabel(f"steer rate d{DF}/dt [deg/s]")


def _speed_panel(ax: Axes, result: ManeuverResult) -> None:
    tr, t = result.trajectory, result.trajectory["t"]
    shade_stages(ax, result, labels=False)
    if "rear_speed_cmd" in tr:
        ax.plot(t, tr["rear_speed_cmd"], color=_COMMANDED, lw=1.2, drawstyle="steps-post", label="commanded")
        ax.plot(t, tr["rear_speed"], color=_ACTUAL, lw=1.4, label="actual")
    else:
        ax.plot(t, tr["rear_speed"], color=_ACTUAL, lw=1.4, drawstyle="steps-post", label="rear-axle speed $V_R$")
    ax.axhline(0.0, color="#888888", lw=0.6)
    ax.set_ylabel("rear-axle speed $V_R$ [m/s]")


def _hitch_panel(ax: Axes, result: ManeuverResult) -> None:
    tr, t, v = result.trajectory, result.trajectory["t"], result.vehicle
    shade_stages(ax, result, labels=False)
    true = np.degrees(tr["hitch"])
    title = f"(f) Hitch angle: max |{DPSI}| = {result.max_abs_hitch_deg:.1f}°, final {final_errors(result)[2]:.3g}°"
    if "hitch_measured" in tr:
        measured = np.degrees(tr["hitch_measured"])
        seen = "estimated (filtered sensor)" if result.settings.estimator.filters else "measured (sensor)"
        ax.plot(t, measured, ls="none", marker=".", ms=3.0, alpha=0.45, color=_MEASURED, label=seen)
        doubt = np.degrees(tr["hitch_doubt"]) if "hitch_doubt" in tr else np.zeros(len(t))
        if np.any(doubt > 0.0):  # the estimator's doubt: where the truth may be, what the guard allows for
            ax.fill_between(t, measured - doubt, measured + doubt, color=_MEASURED, alpha=0.15, lw=0, label="doubt")
        ax.plot(t, true, color=_ACTUAL, lw=1.4, label=r"true $\Delta\psi = \psi_1 - \psi_2$")
        error = measured - true
        error = error[np.isfinite(error)]
        if len(error):
            title += f";  measured - true: mean {error.mean():+.2f}°, sd {error.std():.2f}°"
    else:
        ax.plot(t, true, color=_ACTUAL, lw=1.4, label=r"hitch angle $\Delta\psi = \psi_1 - \psi_2$")
    limit_lines(ax, math.degrees(v.max_hitch), f"±{math.degrees(v.max_hitch):.0f}° jackknife limit")
    ax.axhline(0.0, color="#888888", lw=0.6)
    ax.set_ylabel(f"hitch angle {DPSI} [deg]")
    ax.set_xlabel("time t [s]")
    ax.set_title(title, fontsize=10)


def inputs_figure(result: ManeuverResult) -> Figure:
    """The inputs figure (the caller saves and closes it).

    Four stacked panels sharing the time axis, each an ``Axes`` labelled for lookup
    (``ax.get_label()``): ``"front_steer"``, ``"steer_rate"``, ``"rear_speed"`` and ``"hitch"``.
    Legends sit to the right of the panels so that they never hide a curve.
    """
    use_headless_backend()
    import matplotlib.pyplot as plt

    t = result.trajectory["t"]
    fig, axes = plt.subplots(4, 1, figsize=(11.5, 10.5), sharex=True, constrained_layout=True)
    panels = (
        ("front_steer", _steer_panel),
        ("steer_rate", _steer_rate_panel),
        ("rear_speed", _speed_panel),
        ("hitch", _hitch_panel),
    )
    for ax, (name, draw) in zip(axes, panels, strict=True):
        ax.set_label(name)
        draw(ax, result)
        ax.legend(**_LEGEND)
        ax.grid(True, lw=0.4, alpha=0.5)
    if len(t) > 1:
        axes[-1].set_xlim(t[0], t[-1])
    fig.suptitle(headline(result), fontsize=10.5)
    return fig

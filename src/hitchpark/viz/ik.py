"""Fig. 4: desired vs. actual virtual steer in the inverse-kinematics study."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from . import use_headless_backend

if TYPE_CHECKING:
    from ..app.ik_study import IKStudyResult


def plot_ik_study(result: IKStudyResult, path: str | Path) -> Path:
    """Save the study figure: virtual steer (desired, actual), front steer and hitch, trailer paths."""
    use_headless_backend()
    import matplotlib.pyplot as plt

    tr = result.trajectory
    t = tr["t"]
    fig, axes = plt.subplots(2, 2, figsize=(11, 7), constrained_layout=True)
    ax = axes[0, 0]
    ax.plot(t, np.degrees(tr["desired_virtual_steer"]), lw=3, alpha=0.5, label="desired $\\delta_T$")
    ax.plot(t, np.degrees(tr["actual_virtual_steer"]), "k--", lw=1.2, label="actual $\\delta_T$, Eq. (46)")
    ax.set(xlabel="t [s]", ylabel="virtual steer [deg]", title="Virtual steer tracking (Fig. 4)")
    ax.legend()
    ax = axes[0, 1]
    err = np.degrees(tr["actual_virtual_steer"] - tr["desired_virtual_steer"])
    ax.plot(t, err)
    ax.set(xlabel="t [s]", ylabel="actual - desired [deg]", title=f"Error, max |e| = {np.max(np.abs(err)):.1e} deg")
    ax = axes[1, 0]
    ax.plot(t, np.degrees(tr["front_steer"]), label="front steer $\\delta_f$, Eq. (45)")
    ax.plot(t, np.degrees(tr["hitch"]), label="hitch angle $\\Delta\\psi$")
    ax.set(xlabel="t [s]", ylabel="[deg]", title="Vehicle input and hitch angle")
    ax.legend()
    ax = axes[1, 1]
    ax.plot(tr["x_trailer"], tr["y_trailer"], lw=3, alpha=0.5, label="full model, Eqs. (19)-(24)")
    ax.plot(tr["x_trailer_only"], tr["y_trailer_only"], "k--", lw=1.2, label="trailer-only model, Eq. (47)")
    ax.set(xlabel="x [m]", ylabel="y [m]", title=f"Trailer axle, max gap {result.max_pose_error:.1e} m")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend()
    v = result.vehicle
    fig.suptitle(
        f"Inverse kinematics study: L={v.wheelbase:g} m, L_H={v.hitch_offset:g} m, L_T={v.trailer_length:g} m, "
        f"V_R={result.rear_speed:g} m/s"
    )
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path

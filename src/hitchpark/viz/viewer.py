"""``maneuver.html``: one maneuver in a page that opens from disk, with a timeline to scrub and play.

The page is one self-contained file: the style (``viewer.css``), the script (``viewer.js``, plain JavaScript
drawing on canvases, no library) and the data (JSON) inlined into ``viewer.html``; it asks nothing of a
network or a server. Plain canvas rather than a plotting library: Plotly's inline bundle alone is about 3.5 MB,
over the 2 MB a viewer may take.

What the page needs and the geometry knows, Python computes here, with the functions the PNG figures use: the
outlines of the bodies in their own frames (:func:`~hitchpark.model.geometry.body_outlines`,
:func:`~hitchpark.model.geometry.wheel_outlines`, the real car's lengths, placed by the page at each row's
poses), the parking space, and among obstacles the clearance of each row
(:class:`~hitchpark.model.checker.SceneChecker`) and where the motion came nearest the scene. Numbers are
rounded to what the eye needs (millimetres, a ten-thousandth of a radian).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..app.report import VIEWER_FILE
from ..model.checker import SceneChecker
from ..model.collision import swept_contact
from ..model.geometry import body_outlines, parking_space, wheel_outlines
from ..model.kinematics import rear_axle_pose
from .common import STAGE_COLORS, stage_name
from .page import page, write_page

if TYPE_CHECKING:
    from ..maneuver.result import ManeuverResult

__all__ = ["VIEWER_FILE", "render_viewer", "viewer_data", "viewer_html", "write_viewer"]


#: Decimals kept: lengths [m] and times [s] to the millimetre and millisecond, angles [rad] to 1e-4.
LENGTH_DECIMALS, ANGLE_DECIMALS = 3, 4

#: The trajectory columns the page reads, with the decimals each keeps.
_COLUMNS = {
    "t": LENGTH_DECIMALS,
    "x_trailer": LENGTH_DECIMALS,
    "y_trailer": LENGTH_DECIMALS,
    "yaw_trailer": ANGLE_DECIMALS,
    "hitch": ANGLE_DECIMALS,
    "hitch_measured": ANGLE_DECIMALS,
    "hitch_doubt": ANGLE_DECIMALS,
    "x_rear": LENGTH_DECIMALS,
    "y_rear": LENGTH_DECIMALS,
    "yaw_vehicle": ANGLE_DECIMALS,
    "front_steer": ANGLE_DECIMALS,
    "front_steer_cmd": ANGLE_DECIMALS,
    "rear_speed": LENGTH_DECIMALS,
    "rear_speed_cmd": LENGTH_DECIMALS,
    "stage": 0,
    "cost": 4,
    "solve_ms": 2,
}


def rounded(values: Iterable[float], decimals: int) -> list[float | None]:
    """The values rounded, a non-finite one as None (null in JSON)."""
    out: list[float | None] = []
    for v in values:
        v = float(v)
        out.append(None if not math.isfinite(v) else (round(v) if decimals == 0 else round(v, decimals)))
    return out


def _points(xy: np.ndarray, decimals: int = LENGTH_DECIMALS) -> list[list[float | None]]:
    return [rounded(p, decimals) for p in np.asarray(xy, dtype=float).reshape(-1, 2)]


def _shapes(result: ManeuverResult) -> dict[str, Any]:
    """The real car's outlines in their own frames: the trailer's at its axle, the car's at its rear axle (x ahead),
    the front wheels about their centres (the page turns them by the row's steer)."""
    vehicle = result.plant_vehicle
    bodies = body_outlines(vehicle, 0.0, 0.0, 0.0, 0.0)  # the trailer frame is the world's
    wheels = wheel_outlines(vehicle, 0.0, 0.0, 0.0, 0.0, 0.0)
    x_r, y_r, _ = (float(c) for c in rear_axle_pose(vehicle, 0.0, 0.0, 0.0, 0.0))  # heading 0: a shift only
    car = np.array([x_r, y_r])
    front = [w - w[:4].mean(axis=0) for w in wheels[2:4]]
    return {
        "trailer": _points(bodies["trailer"]),
        "drawbar": _points(bodies["drawbar"]),
        "trailer_wheels": [_points(w) for w in wheels[4:6]],
        "vehicle": _points(bodies["vehicle"] - car),
        "tow_bar": _points(bodies["tow_bar"] - car),
        "hitch": rounded(bodies["hitch"] - car, LENGTH_DECIMALS),
        "rear_wheels": [_points(w - car) for w in wheels[0:2]],
        "front_wheels": [_points(w) for w in front],
        "front_centres": [rounded(w[:4].mean(axis=0) - car, LENGTH_DECIMALS) for w in wheels[2:4]],
    }


def _clearance(result: ManeuverResult) -> dict[str, Any] | None:
    """Among obstacles: the clearance of each row and where the whole motion came nearest (None in open space)."""
    if result.scene.is_empty:
        return None
    states = result.trajectory.states()
    per_row = SceneChecker(result.plant_vehicle, result.scene).clearances(states)
    least, row, contact = swept_contact(result.plant_vehicle, result.scene, states)
    return {
        "rows": rounded(per_row, LENGTH_DECIMALS),
        "least": round(float(least), LENGTH_DECIMALS),
        "row": int(row),
        "points": None if contact is None else _points(contact.points),
        "what": "" if contact is None else contact.describe(),
    }


def viewer_data(result: ManeuverResult) -> dict[str, Any]:
    """What the page draws, as JSON-ready plain data (the schema is the page's: ``viewer.js`` reads it)."""
    tr, vehicle, goal = result.trajectory, result.plant_vehicle, result.goal
    predictions = None
    if result.predictions is not None:
        predictions = [_points(p) if len(p) else [] for p in result.predictions.paths]
    return {
        "name": result.name,
        "success": result.success,
        "reason": result.reason,
        "detail": result.detail,
        "columns": {c: rounded(tr[c], d) for c, d in _COLUMNS.items()},
        "stages": [
            {
                "name": stage_name(result, i),
                "kind": s.kind,
                "controller": s.controller,
                "first_row": s.first_row,
                "last_row": s.last_row,
                "reason": s.reason,
            }
            for i, s in enumerate(result.stages)
        ],
        "stage_colors": list(STAGE_COLORS),
        "limits": {
            "max_steer": round(vehicle.max_steer, ANGLE_DECIMALS),
            "max_steer_rate": round(vehicle.max_steer_rate, ANGLE_DECIMALS),
            "max_hitch": round(vehicle.max_hitch, ANGLE_DECIMALS),
            "min_clearance_m": result.settings.success.min_clearance_m,
        },
        "shapes": _shapes(result),
        "goal": {"x": goal.x, "y": goal.y, "yaw": goal.yaw, "space": _points(parking_space(vehicle, goal))},
        "arrow": round(0.5 * (vehicle.trailer_front + vehicle.trailer_rear), LENGTH_DECIMALS),
        "obstacles": [{"name": o.name, "polygon": _points(o.polygon)} for o in result.scene.obstacles],
        "area": None if result.scene.area is None else _points(result.scene.area.boundary),
        "plans": [
            {"status": p.status, "x": rounded(p.path["x_trailer"], 3), "y": rounded(p.path["y_trailer"], 3)}
            for p in result.plans
            if len(p.path.get("x_trailer", ())) >= 2
        ],
        "predictions": predictions,
        "clearance": _clearance(result),
    }


def viewer_html(result: ManeuverResult) -> str:
    """The whole page of ``result``: template, style, script and data in one string."""
    title = f"{result.name or 'maneuver'}: {'parked' if result.success else result.reason}"
    return page("viewer.js", title, viewer_data(result))


def write_viewer(result: ManeuverResult, path: str | Path, force: bool = False) -> Path:
    """Write the page of ``result`` to ``path`` whole or not at all; an existing file only with ``force``."""
    return write_page(viewer_html(result), path, force=force)


def render_viewer(result: ManeuverResult, folder: Path) -> dict[str, Path]:
    """The viewer into ``folder`` (:data:`VIEWER_FILE`), replacing one there: a renderer's part, by name."""
    return {"viewer": write_page(viewer_html(result), folder / VIEWER_FILE, force=True)}

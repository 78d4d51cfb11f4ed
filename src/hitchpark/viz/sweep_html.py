"""A sweep as one HTML page (``hitchpark sweep --html``): every start at its pose, coloured by outcome.

The page (``sweep.js`` on ``page.html``, :mod:`.page`) opens from disk with no network: hover a start for its
case, reason, path length, planning time and switches; filter by outcome and reason; histograms of path
length, planning time and switches of the starts shown. A start whose maneuver was kept
(``--keep-maneuvers DIR``: ``DIR/case_NNNN/maneuver.html``) links to its viewer.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..model.geometry import parking_space
from ..model.scene import Scene
from ..model.state import Pose
from ..model.vehicle import VehicleTrailer
from .page import page, write_page
from .viewer import LENGTH_DECIMALS, rounded

if TYPE_CHECKING:
    from ..app.records import CaseRecord
    from ..app.starts import Region

__all__ = ["sweep_data", "sweep_html", "write_sweep_page"]

#: The record fields the page shows, with their decimals.
_FIELDS = {
    "path_length_m": 2,
    "planning_s": 3,
    "maneuver_time_s": 1,
    "min_clearance_m": 3,
    "max_abs_hitch_deg": 1,
    "distance_error_m": 4,
}


def sweep_data(
    records: Sequence[CaseRecord],
    vehicle: VehicleTrailer | None = None,
    region: Region | None = None,
    title: str = "",
    goal: Pose | None = None,
    scene: Scene | None = None,
    links: Mapping[int, str] | None = None,
) -> dict[str, Any]:
    """What the page draws, as JSON-ready plain data, one list per field (``links``: case -> relative address)."""
    vehicle, goal, scene = vehicle or VehicleTrailer(), goal or Pose(), scene or Scene()
    links = links or {}
    cases: dict[str, list[Any]] = {
        "case": [r.case for r in records],
        "x": rounded((r.start.x for r in records), LENGTH_DECIMALS),
        "y": rounded((r.start.y for r in records), LENGTH_DECIMALS),
        "yaw_deg": rounded((r.start.yaw_deg for r in records), 2),
        "hitch_deg": rounded((r.start.hitch_deg for r in records), 2),
        "success": [r.success for r in records],
        "reason": [r.reason for r in records],
        "switches": [r.direction_switches for r in records],
        "link": [links.get(r.case) for r in records],
    }
    for name, decimals in _FIELDS.items():
        cases[name] = rounded((math_or_nan(getattr(r, name)) for r in records), decimals)
    return {
        "title": title or "Sweep",
        "cases": cases,
        "goal": {"x": goal.x, "y": goal.y, "yaw": goal.yaw},
        "space": [rounded(p, LENGTH_DECIMALS) for p in parking_space(vehicle, goal)],
        "trailer": {"front": vehicle.trailer_front, "rear": vehicle.trailer_rear, "width": vehicle.trailer_width},
        "region": None if region is None else {"x": list(region.x), "y": list(region.y)},
        "obstacles": [
            {"name": o.name, "polygon": [rounded(p, LENGTH_DECIMALS) for p in o.polygon]} for o in scene.obstacles
        ],
        "area": None if scene.area is None else [rounded(p, LENGTH_DECIMALS) for p in scene.area.boundary],
    }


def math_or_nan(value: float | None) -> float:
    return float("nan") if value is None else float(value)


def sweep_html(records: Sequence[CaseRecord], **kwargs: Any) -> str:
    """The whole page of a sweep (:func:`sweep_data`'s keywords)."""
    data = sweep_data(records, **kwargs)
    return page("sweep.js", data["title"], data)


def kept_links(page_path: Path, keep: Path | None, cases: Sequence[int]) -> dict[int, str]:
    """Relative addresses from ``page_path``'s folder to the viewers kept in ``keep`` (those that exist)."""
    if keep is None:
        return {}
    links = {}
    for case in cases:
        viewer = keep / f"case_{case:04d}" / "maneuver.html"
        if viewer.is_file():
            links[case] = Path(os.path.relpath(viewer.resolve(), page_path.resolve().parent)).as_posix()
    return links


def write_sweep_page(records: Sequence[CaseRecord], path: str | Path, keep: Path | None = None, **kwargs: Any) -> Path:
    """Write the sweep's page to ``path`` (replaced, as ``--map`` is), linking to the viewers kept in ``keep``."""
    path = Path(path)
    links = kept_links(path, keep, [r.case for r in records])
    return write_page(sweep_html(records, links=links, **kwargs), path, force=True, flag="--html")

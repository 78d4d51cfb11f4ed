"""``hitchpark drive``: the knob assist live, a page on a local server with a WebSocket for the ticks.

The server (aiohttp: one library for the page and the WebSocket, no ASGI stack to assemble) serves one page
and, on ``/ws``, ticks one :class:`~hitchpark.maneuver.live.LiveDrive` at the plant's rate (``dt`` of wall
time per tick, ``time_scale`` times faster for tests): each tick takes the last knob and speed the page sent,
steps the car and sends the page what to draw. Esc on the page stops the car; once it stands the drive is saved
(``maneuver.json``, ``trajectory.csv`` and the viewer ``maneuver.html``) and the server ends. One page drives at
a time. The server listens on the loopback address unless told otherwise (:func:`check_host`).
"""

from __future__ import annotations

import asyncio
import ipaddress
import json
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ..checks import InputError
from ..maneuver.live import LiveDrive
from ..maneuver.result import ManeuverResult
from ..maneuver.scenario import Scenario
from .page import page

__all__ = ["LOOPBACK", "check_host", "drive_page", "serve_drive"]

LOOPBACK = "127.0.0.1"

#: The page shows the scene up to this far [m] around the start and the goal.
VIEW_MARGIN_M = 12.0


def check_host(host: str, allow_remote: bool) -> str:
    """``host`` if it is a loopback address (or ``localhost``), or if ``allow_remote``; else an InputError."""
    if host == "localhost":
        return host
    try:
        loopback = ipaddress.ip_address(host).is_loopback
    except ValueError:
        loopback = False
    if not loopback and not allow_remote:
        raise InputError(
            f"--host {host} is not a loopback address: anyone who reaches it could drive; "
            "give --allow-remote to serve it anyway"
        )
    return host


def drive_page(drive: LiveDrive) -> str:
    """The page of ``drive``: the scene and the limits embedded, the script inline, WebSocket to its own server."""
    sc = drive.scenario
    scene = sc.scene.to_dict()
    obstacles = [o["polygon"] for o in scene["obstacles"]]
    area = scene["area"]["boundary"] if scene.get("area") else None
    state = drive.view(None)
    points = [p for poly in [*obstacles, *([area] if area else []), state["vehicle"], state["trailer"]] for p in poly]
    # The view: the scene, but no more of it than VIEW_MARGIN_M around the start and the goal (a long aisle or
    # street drawn whole leaves the rig a few pixels long).
    near = np.array([[sc.start.x, sc.start.y], [sc.goal.x, sc.goal.y]])
    lo, hi = near.min(axis=0) - VIEW_MARGIN_M, near.max(axis=0) + VIEW_MARGIN_M
    bounds = np.clip(np.array([*points, [sc.goal.x, sc.goal.y]], dtype=float), lo, hi).tolist()
    title = f"hitchpark drive: {sc.name}"
    data = {
        "title": title,
        "obstacles": obstacles,
        "area": area,
        "goal": sc.goal.to_dict() | {"yaw": sc.goal.yaw},
        "bounds": bounds,
        "max_hitch_deg": math.degrees(drive.loop.plant.vehicle.max_hitch),
        "kappa_max": drive.assist.kappa_max,
        "max_speed": drive.settings.max_speed,
        "dt": drive.dt,
    }
    text = page("drive.js", title, data)
    return text.replace("connect-src 'none'", "connect-src 'self'")  # the page talks to its own server only


def _inputs(message: str, current: dict[str, float], max_speed: float) -> dict[str, Any]:
    """The page's message read leniently: a knob and a speed clipped to their ranges, or a stop; junk ignored."""
    try:
        data = json.loads(message)
    except ValueError:
        return current
    if not isinstance(data, dict):
        return current
    out = dict(current)
    for key, low, high in (("knob", -1.0, 1.0), ("speed", 0.0, max_speed)):
        value = data.get(key)
        if isinstance(value, int | float) and math.isfinite(value):
            out[key] = min(high, max(low, float(value)))
    if data.get("stop") is True:
        out["stop"] = True
    return out


async def _run(
    drive: LiveDrive,
    host: str,
    port: int,
    save: Callable[[ManeuverResult], str],
    time_scale: float,
    on_ready: Callable[[str], None],
) -> ManeuverResult:
    from aiohttp import WSMsgType, web

    finished: asyncio.Future[ManeuverResult] = asyncio.get_running_loop().create_future()
    html = drive_page(drive)
    busy = False

    async def index(request: web.Request) -> web.Response:
        return web.Response(text=html, content_type="text/html")

    async def socket(request: web.Request) -> web.WebSocketResponse:
        nonlocal busy
        ws = web.WebSocketResponse()
        await ws.prepare(request)
        if busy:
            await ws.close(message=b"another page is driving")
            return ws
        busy = True
        inputs: dict[str, Any] = {"knob": 0.0, "speed": 0.0}

        async def read() -> None:
            nonlocal inputs
            async for msg in ws:
                if msg.type == WSMsgType.TEXT:
                    inputs = _inputs(msg.data, inputs, drive.settings.max_speed)
                    if inputs.pop("stop", False):
                        drive.stop()

        reader = asyncio.create_task(read())
        period = drive.dt / time_scale
        next_tick = time.perf_counter()
        try:
            while not drive.done and not ws.closed:
                view = drive.tick(inputs["knob"], inputs["speed"])
                await ws.send_json(view)
                next_tick += period
                await asyncio.sleep(max(0.0, next_tick - time.perf_counter()))
            result = drive.result()
            where = save(result)
            if not ws.closed:
                await ws.send_json({"saved": where})
        finally:
            reader.cancel()
            if not finished.done():
                finished.set_result(drive.result())
        return ws

    app = web.Application()
    app.add_routes([web.get("/", index), web.get("/ws", socket)])
    runner = web.AppRunner(app, access_log=None)
    await runner.setup()
    site = web.TCPSite(runner, host, port)
    await site.start()
    bound = runner.addresses[0]
    on_ready(f"http://{'[' + bound[0] + ']' if ':' in bound[0] else bound[0]}:{bound[1]}/")
    try:
        return await finished
    finally:
        await runner.cleanup()


def serve_drive(
    scenario: Scenario,
    save: Callable[[ManeuverResult], str],
    *,
    host: str = LOOPBACK,
    port: int = 8765,
    allow_remote: bool = False,
    time_scale: float = 1.0,
    max_time: float = 600.0,
    on_ready: Callable[[str], None] = print,
) -> ManeuverResult:
    """Serve the live drive of ``scenario`` until it ends; ``save`` writes the result and says where.

    ``port`` 0 takes a free one; ``on_ready`` is told the page's address once it listens.
    """
    check_host(host, allow_remote)
    if not (isinstance(port, int) and 0 <= port <= 65535):
        raise InputError(f"--port must be an integer in [0, 65535], got {port!r}")
    if not (math.isfinite(time_scale) and 0.1 <= time_scale <= 100.0):
        raise InputError(f"time_scale must be in [0.1, 100], got {time_scale:g}")
    drive = LiveDrive(scenario, max_time)
    return asyncio.run(_run(drive, host, port, save, time_scale, on_ready))


def save_into(folder: Path) -> Callable[[ManeuverResult], str]:
    """A ``save`` for :func:`serve_drive`: ``maneuver.json``, ``trajectory.csv`` and ``maneuver.html`` in ``folder``."""
    from ..app.report import save_maneuver
    from .viewer import render_viewer

    def save(result: ManeuverResult) -> str:
        files = save_maneuver(result, folder, render_viewer)
        return str(files["maneuver"])

    return save

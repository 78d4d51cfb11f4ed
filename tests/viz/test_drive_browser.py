"""``hitchpark drive`` in a real headless browser (Chromium): a scripted person holds full left knob for 20 s of
the car's time from a straight start, then presses Esc; and a person backs the bay scene into its space by keys,
recorded by Playwright (a trace, ``HITCHPARK_RECORD_DIR`` keeps it with the drive), the drive opening in the viewer.

Skipped, saying why, where no browser is found (see :mod:`browser`) or aiohttp (the ``drive`` extra) is missing.
"""

from __future__ import annotations

import json
import math
import os
import queue
import shutil
import threading
from pathlib import Path
from typing import Any

import pytest
from browser import Page, launched
from person import Person, in_the_bay

from hitchpark.maneuver.result import ManeuverResult
from hitchpark.maneuver.scenario import Scenario, builtin_scenario
from hitchpark.model import State
from hitchpark.viz.drive import save_into, serve_drive
from hitchpark.viz.viewer import write_viewer

pytest.importorskip("aiohttp", reason="hitchpark drive needs aiohttp: pip install -e '.[drive]'")


def _serve(scenario: Scenario, folder: Path, time_scale: float) -> tuple[str, threading.Thread, dict[str, object]]:
    """``hitchpark drive`` of ``scenario`` on a free port in a thread, saving into ``folder``: its address, the
    thread, and where its result lands (``"result"``)."""
    ready: queue.Queue[str] = queue.Queue()
    outcome: dict[str, object] = {}

    def serve() -> None:
        outcome["result"] = serve_drive(
            scenario, save_into(folder), port=0, time_scale=time_scale, max_time=120.0, on_ready=ready.put
        )

    server = threading.Thread(target=serve, daemon=True)
    server.start()
    return ready.get(timeout=60), server, outcome


def _open(page: Any, url: str) -> list[str]:
    """Open the live page at ``url`` with every other request aborted, once it ticks; its console errors."""
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.route("**/*", lambda r: r.continue_() if r.request.url.startswith(url) else r.abort())
    page.goto(url)
    page.wait_for_function("() => window.hitchDrive && window.hitchDrive.ticks > 0", timeout=30_000)
    return errors


@pytest.mark.slow
def test_a_person_holds_full_left_knob_and_stops_with_escape(tmp_path):
    scenario = Scenario("straight <b>&</b>", State(0.0, 0.0, 0.0, 0.0))  # a name that is not HTML
    url, server, outcome = _serve(scenario, tmp_path, time_scale=2.0)  # 50 ms a tick: Esc within one, loaded
    assert url.startswith("http://127.0.0.1:")
    with launched() as browser:
        page = browser.new_page()
        errors = _open(page, url)
        assert page.locator("h1").inner_text() == "hitchpark drive: straight <b>&</b>"  # shown as text, not markup
        for _ in range(12):
            page.keyboard.press("ArrowLeft")
        page.keyboard.down("ArrowUp")
        page.wait_for_function("() => window.hitchDrive.last.t >= 20.0", timeout=60_000)
        drive = page.evaluate("window.hitchDrive")
        assert drive["knob"] == 1.0 and drive["last"]["knob"] == 1.0
        # The rig turned: the trailer's heading swung well round, the hitch stayed inside its limit.
        assert abs(drive["last"]["state"][2]) > math.radians(60.0)
        assert 20.0 < drive["maxAbsHitch"] < 70.0
        # An override was shown as it happened (the knob flicked to full lock is followed at a rate, at least).
        assert drive["overridesSeen"] and page.locator("#overrides li").count() >= 1
        moving = abs(drive["last"]["speed"])
        assert moving > 0.3
        page.keyboard.press("Escape")
        page.wait_for_function("() => window.hitchDrive.last.stopping === true", timeout=10_000)
        drive = page.evaluate("window.hitchDrive")
        # Within one tick of the Esc (one more may be in flight): the request is zero and the car brakes.
        assert drive["ticks"] - drive["stopSentAt"] <= 2
        assert drive["last"]["speed_request"] == 0.0
        page.wait_for_function("() => window.hitchDrive.saved !== null", timeout=30_000)
        assert page.locator("#status").inner_text().startswith("ended: stopped by driver")
        page.keyboard.up("ArrowUp")
        assert not errors, errors
    server.join(timeout=30)
    result = outcome["result"]
    assert isinstance(result, ManeuverResult) and result.reason == "stopped_by_driver" and result.success
    saved = ManeuverResult.from_dict(json.loads((tmp_path / "maneuver.json").read_text()))
    assert saved.reason == "stopped_by_driver" and saved.max_abs_hitch_deg < 70.0
    assert (tmp_path / "maneuver.html").exists()
    assert write_viewer(saved, tmp_path / "again.html").stat().st_size > 0  # what `hitchpark view` does
    # After Esc the car stood within the braking time: its speed at the acceleration limit, plus the lag.
    t, v, stopping = saved.trajectory["t"], saved.trajectory["rear_speed"], saved.trajectory["speed_request"]
    first = next(i for i in range(len(t)) if t[i] > 20.0 and stopping[i] == 0.0)
    still = next(i for i in range(first, len(t)) if v[i] == 0.0)
    assert t[still] - t[first] <= moving / saved.vehicle.max_accel + 0.3


@pytest.mark.slow
def test_a_person_backs_the_bay_into_its_space_by_keys_recorded(tmp_path):
    """From the bay's start, the person of :mod:`person` at the page, in real time: ↑ held, ← and → a few
    presses a look at most, Esc at the end of the goal line. The trailer ends in its space, nothing touched; the
    saved drive opens in the viewer from disk with no error."""
    url, server, outcome = _serve(builtin_scenario("bay"), tmp_path, time_scale=1.0)
    with launched() as browser:
        context = browser.new_context(viewport={"width": 1100, "height": 700})
        context.tracing.start(screenshots=True, snapshots=True)
        page = context.new_page()
        errors = _open(page, url)
        data = json.loads(page.locator("#hitchpark-data").text_content())
        person = Person(data["kappa_max"])
        page.keyboard.down("ArrowUp")
        presses = 0
        while True:
            drive = page.evaluate("window.hitchDrive")
            assert drive["done"] is None, drive["done"]
            x, y, yaw, _ = drive["last"]["state"]
            person.knob = drive["knob"]  # they see where the knob is
            keys = person.look(x, y, yaw)
            for key in keys:
                page.keyboard.press(key)
            presses += len(keys)
            if keys == ["Escape"]:
                break
            page.wait_for_function("n => window.hitchDrive.ticks > n", arg=drive["ticks"], timeout=10_000)
        page.wait_for_function("() => window.hitchDrive.saved !== null", timeout=30_000)
        page.keyboard.up("ArrowUp")
        drive = page.evaluate("window.hitchDrive")
        assert page.locator("#status").inner_text().startswith("ended: stopped by driver")
        page.screenshot(path=str(tmp_path / "drive.png"))
        context.tracing.stop(path=str(tmp_path / "person.zip"))
        assert not errors, errors
        saved = ManeuverResult.from_dict(json.loads((tmp_path / "maneuver.json").read_text()))
        assert saved.reason == "stopped_by_driver" and presses > 10
        in_the_bay(saved)
        viewer = Page(browser, write_viewer(saved, tmp_path / "again.html"))  # what `hitchpark view` writes
        assert not viewer.errors and not viewer.blocked
        assert viewer.js("() => document.querySelectorAll('canvas, svg').length") > 0
    server.join(timeout=30)
    assert isinstance(outcome["result"], ManeuverResult) and outcome["result"].reason == "stopped_by_driver"
    assert (tmp_path / "person.zip").stat().st_size > 10_000  # the recording: Playwright's trace of the drive
    keep = os.environ.get("HITCHPARK_RECORD_DIR")
    if keep:
        Path(keep).mkdir(parents=True, exist_ok=True)
        for name in ("person.zip", "drive.png", "maneuver.json", "maneuver.html"):
            shutil.copy(tmp_path / name, Path(keep) / name)

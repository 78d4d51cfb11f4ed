"""The viewer in a real headless browser (Chromium): it loads offline, scrubs, plays, hides layers.

Skipped, saying why, only where no browser is found (see :mod:`browser`).
"""

from __future__ import annotations

import io

import numpy as np
import pytest
from browser import Page, launched
from PIL import Image
from test_viewer import maneuver, with_wall  # noqa: F401 (the fixture)

from hitchpark.viz.viewer import write_viewer

PREDICTION = (0xC5, 0x1B, 0x7D)  # the colour viewer.js draws the NMPC's predictions in


@pytest.fixture(scope="module")
def browser():
    with launched() as b:
        yield b


@pytest.fixture(scope="module")
def page(browser, maneuver, tmp_path_factory):  # noqa: F811
    path = write_viewer(with_wall(maneuver), tmp_path_factory.mktemp("page") / "maneuver.html")
    p = Page(browser, path)
    yield p
    p.close()


def scene_pixels(p: Page) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(p.page.locator("#scene").screenshot())).convert("RGB"), dtype=int)


def colour_count(pixels: np.ndarray, rgb: tuple[int, int, int], tol: int = 12) -> int:
    return int(np.sum(np.all(np.abs(pixels - np.array(rgb)) <= tol, axis=-1)))


def row(p: Page) -> int:
    return int(p.js("document.body.dataset.row"))


def test_it_loads_from_disk_with_the_network_blocked_and_no_error(page):
    assert page.errors == [] and page.blocked == []
    assert int(page.js("document.getElementById('timeline').max")) == page.js("window.hitchview.rows") - 1
    assert "parked" in page.page.locator("#outcome").inner_text()


def test_moving_the_slider_moves_the_rig_and_the_readout(page):
    page.js("window.hitchview.setRow(0)")
    before, text = scene_pixels(page), page.page.locator("#readout").inner_text()
    page.page.locator("#timeline").fill("150")
    assert row(page) == 150
    assert np.mean(np.any(scene_pixels(page) != before, axis=-1)) > 0.002  # the picture changed
    assert page.page.locator("#readout").inner_text() != text


def test_arrow_keys_step_one_tick(page):
    page.js("window.hitchview.setRow(40)")
    page.page.keyboard.press("ArrowRight")
    assert row(page) == 41
    page.page.keyboard.press("ArrowLeft")
    page.page.keyboard.press("ArrowLeft")
    assert row(page) == 39


def test_play_advances_the_time_and_pause_holds_it(page):
    page.js("window.hitchview.setRow(0)")
    page.page.select_option("#speed", "8")
    page.page.click("#play")
    page.page.wait_for_function("() => Number(document.body.dataset.row) > 20", timeout=10_000)
    page.page.click("#play")
    held = row(page)
    page.page.wait_for_timeout(300)
    assert row(page) == held > 20
    assert page.page.locator("#play").inner_text() == "Play"


def test_toggling_a_layer_hides_it(page):
    solved = [k for k, p in enumerate(page.js("window.hitchview.data.predictions")) if p]
    page.js(f"window.hitchview.setRow({solved[10]})")
    shown = scene_pixels(page)
    assert colour_count(shown, PREDICTION) > 20 and "predictions" in page.js("window.hitchview.view.drawn")
    page.page.uncheck("#layer-predictions")
    hidden = scene_pixels(page)
    assert colour_count(hidden, PREDICTION) == 0 and "predictions" not in page.js("window.hitchview.view.drawn")
    page.page.check("#layer-predictions")
    assert colour_count(scene_pixels(page), PREDICTION) > 20
    # The clearance layer takes its plot away, and brings it back.
    assert page.page.locator("#plot-clearance").is_visible()
    page.page.uncheck("#layer-clearance")
    assert not page.page.locator("#plot-clearance").is_visible()
    page.page.check("#layer-clearance")
    assert page.page.locator("#plot-clearance").is_visible()
    assert page.errors == []


def test_a_screenshot_is_not_blank(page, tmp_path):
    shot = np.asarray(Image.open(io.BytesIO(page.page.screenshot(full_page=True))).convert("RGB"), dtype=int)
    colours = len(np.unique(shot.reshape(-1, 3) // 16, axis=0))
    dark = np.mean(shot.sum(axis=-1) < 200)
    assert colours > 30 and 0.001 < dark < 0.5

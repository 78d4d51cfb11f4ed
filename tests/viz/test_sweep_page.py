"""The sweep's HTML page (``sweep --html``): its data, and in headless Chromium its map, hover, filters and links."""

from __future__ import annotations

import json
import re
import time

import numpy as np
import pytest
from browser import Page, launched

from hitchpark.app.records import CaseRecord, Start
from hitchpark.app.starts import DEFAULT_REGION
from hitchpark.viz.sweep_html import sweep_data, write_sweep_page

REASONS = ("parked", "no_path", "collision", "timeout")


def synthetic(n: int, seed: int = 0) -> list[CaseRecord]:
    """``n`` records of made-up outcomes over the default region (no maneuver is run)."""
    rng = np.random.default_rng(seed)
    out = []
    for case in range(n):
        reason = REASONS[int(rng.choice(4, p=[0.7, 0.1, 0.1, 0.1]))]
        out.append(
            CaseRecord(
                case=case,
                start=Start(float(rng.uniform(4, 16)), float(rng.uniform(-8, 8)), float(rng.uniform(-90, 90)), 0.0),
                success=reason == "parked",
                reason=reason,
                stages=3,
                distance_error_m=0.01,
                orientation_error_deg=0.1,
                final_hitch_deg=0.2,
                max_abs_hitch_deg=30.0,
                max_abs_steer_deg=30.0,
                max_abs_steer_rate_deg_s=20.0,
                path_length_m=float(rng.uniform(10, 40)),
                maneuver_time_s=float(rng.uniform(20, 60)),
                wall_s=1.0,
                collision=reason == "collision",
                min_clearance_m=None,
                direction_switches=int(rng.integers(0, 5)),
                planning_s=float(rng.uniform(0, 2)),
            )
        )
    return out


def test_the_page_holds_every_start_and_links_only_to_kept_viewers(tmp_path):
    records = synthetic(20)
    keep = tmp_path / "kept"
    (keep / "case_0003").mkdir(parents=True)
    (keep / "case_0003" / "maneuver.html").write_text("<!DOCTYPE html>a viewer")
    path = write_sweep_page(records, tmp_path / "pages" / "sweep.html", keep, region=DEFAULT_REGION)
    data = json.loads(re.search(r'type="application/json">(.*?)</script>', path.read_text(), re.S).group(1))
    assert data == json.loads(json.dumps(sweep_data(records, region=DEFAULT_REGION, links=data_links(data))))
    assert data["cases"]["case"] == list(range(20))
    assert data["cases"]["link"][3] == "../kept/case_0003/maneuver.html"
    assert [c for c, link in enumerate(data["cases"]["link"]) if link] == [3]


def data_links(data: dict) -> dict[int, str]:
    return {c: link for c, link in zip(data["cases"]["case"], data["cases"]["link"], strict=True) if link}


@pytest.fixture(scope="module")
def browser():
    with launched() as b:
        yield b


def test_hundreds_of_starts_open_hover_filter_and_link(browser, tmp_path):
    records = synthetic(1000)
    xy = np.array([[r.start.x, r.start.y] for r in records])
    gaps = np.linalg.norm(xy[:, None] - xy[None], axis=-1) + np.eye(len(xy)) * 1e9
    alone = int(np.argmax(gaps.min(axis=1)))  # the start farthest from any other: hovered without ambiguity
    keep = tmp_path / "kept"
    (keep / f"case_{alone:04d}").mkdir(parents=True)
    (keep / f"case_{alone:04d}" / "maneuver.html").write_text("<!DOCTYPE html><title>kept viewer</title>")
    path = write_sweep_page(records, tmp_path / "sweep.html", keep, region=DEFAULT_REGION)
    t0 = time.perf_counter()
    page = Page(browser, path)
    took = time.perf_counter() - t0
    print(f"\nsweep page of {len(records)} starts ({path.stat().st_size / 1e3:.0f} kB) opened in {took:.2f} s")
    assert page.errors == [] and page.blocked == []
    drawn = "() => Number(document.getElementById('map').dataset.drawn)"
    assert page.js(drawn) == len(records)
    # Hover a start: its case and its numbers.
    x, y = page.js(f"window.hitchsweep.screenOf({alone})")
    page.page.mouse.move(x, y)
    tip = page.page.locator("#tip")
    assert tip.is_visible()
    text = tip.inner_text()
    assert f"case {alone}: {records[alone].reason}" in text
    assert f"path length {records[alone].path_length_m:.2f} m" in text and "click to open" in text
    # Filters: hiding the failed leaves the parked; hiding a reason leaves the others.
    page.page.uncheck("#filter-failed")
    assert page.js(drawn) == sum(r.success for r in records)
    page.page.check("#filter-failed")
    page.page.uncheck("#filter-reason-no-path")
    assert page.js(drawn) == len(records) - sum(r.reason == "no_path" for r in records)
    page.page.check("#filter-reason-no-path")
    assert page.errors == []
    # A kept start links to its viewer.
    page.page.mouse.click(x, y)
    page.page.wait_for_url(f"**/kept/case_{alone:04d}/maneuver.html")
    assert page.page.title() == "kept viewer"
    page.close()


@pytest.mark.slow
def test_sweep_keeps_each_maneuver_and_its_viewer_and_the_page_links_them(tmp_path, capsys):
    from hitchpark.io import read_json
    from hitchpark.maneuver import ManeuverResult
    from test_cli import run

    settings = tmp_path / "fast.toml"
    settings.write_text('[nmpc]\nkind = "paper"\nsolver = "sqp"\n')
    argv = ["sweep", "--n", "2", "--seed", "1", "--settings", str(settings), "--workers", "1"]
    out = [*argv, "--out", str(tmp_path / "x.jsonl"), "--html", str(tmp_path / "s.html")]
    assert run([*out, "--keep-maneuvers", str(tmp_path / "kept")]) == 0, capsys.readouterr().err
    for case in (0, 1):
        folder = tmp_path / "kept" / f"case_{case:04d}"
        assert ManeuverResult.from_dict(read_json(folder / "maneuver.json")).name == f"case {case}"
        assert (folder / "maneuver.html").read_text(encoding="utf-8").startswith("<!DOCTYPE html>")
    data = json.loads(re.search(r'type="application/json">(.*?)</script>', (tmp_path / "s.html").read_text(), re.S)[1])
    assert data["cases"]["link"] == ["kept/case_0000/maneuver.html", "kept/case_0001/maneuver.html"]


@pytest.mark.parametrize(
    ("flags", "says"),
    [
        (["--html", "s.png"], "--html s.png: an HTML page's name must end in .html"),
        (["--keep-maneuvers", "f"], "not a folder"),
    ],
)
def test_sweep_refuses_a_page_or_a_folder_it_cannot_write(tmp_path, monkeypatch, capsys, flags, says):
    from test_cli import one_error_line, run

    monkeypatch.chdir(tmp_path)
    (tmp_path / "f").write_text("a file")
    assert run(["sweep", "--n", "2", "--seed", "1", "--out", "x.jsonl", *flags]) == 2
    assert says in one_error_line(capsys.readouterr().err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f"]

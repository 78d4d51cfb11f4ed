"""The maneuver viewer's file: what it embeds, how `hitchpark view` writes it and refuses what it cannot."""

from __future__ import annotations

import json
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from hitchpark.control import NMPCSettings
from hitchpark.io import write_json
from hitchpark.maneuver import ManeuverResult, ManeuverSettings, park
from hitchpark.model import IDEAL, VehicleTrailer
from hitchpark.model.scene import Obstacle, Scene
from hitchpark.model.simulate import State
from hitchpark.viz.viewer import viewer_data, viewer_html, write_viewer
from test_cli import one_error_line, run

DATA = re.compile(r'<script id="hitchpark-data" type="application/json">(.*?)</script>', re.S)


def embedded(text: str) -> dict:
    found = DATA.search(text)
    assert found is not None
    return json.loads(found.group(1))


@pytest.fixture(scope="module")
def maneuver() -> ManeuverResult:
    """The paper's parallel parking on the ideal plant, with the NMPC's predictions (about 0.3 s)."""
    settings = ManeuverSettings(nmpc=NMPCSettings(kind="paper", solver="sqp"))
    return park(VehicleTrailer(), State(6, 3, 0, 0), settings=settings, name="parallel", plant=IDEAL, predictions=True)


def with_wall(result: ManeuverResult) -> ManeuverResult:
    """The same motion beside a wall (a scene added after the fact: the viewer measures its clearance)."""
    wall = Obstacle("wall", np.array([[-4.0, -3.0], [14.0, -3.0], [14.0, -2.5], [-4.0, -2.5]]))
    return replace(result, scene=Scene((wall,)))


@pytest.fixture(scope="module")
def saved(maneuver, tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("view") / "m" / "maneuver.json"
    path.parent.mkdir()
    write_json(path, maneuver.to_dict())
    return path


def test_the_page_embeds_the_record_rounded_and_nothing_from_outside(maneuver):
    text = viewer_html(maneuver)
    data = embedded(text)
    assert data == json.loads(json.dumps(viewer_data(maneuver)))
    tr = maneuver.trajectory
    for name in ("t", "x_trailer", "y_trailer", "hitch", "front_steer", "rear_speed_cmd"):
        np.testing.assert_allclose(data["columns"][name], tr[name], atol=5e-4, rtol=0)
    assert len(data["predictions"]) == len(tr)
    assert sum(1 for p in data["predictions"] if p) == int(np.isfinite(tr["cost"]).sum())
    assert data["reason"] == maneuver.reason and data["success"] is True
    assert data["clearance"] is None  # open space: nothing to measure
    # Self-contained: no address to load from, the script and the style inline.
    assert not re.search(r"(src|href)\s*=|https?://|@import|url\(", text)
    assert "function" in text and "<style>" in text


def test_among_obstacles_the_page_holds_each_row_s_clearance(maneuver):
    near = with_wall(maneuver)
    data = viewer_data(near)
    rows = np.array(data["clearance"]["rows"])
    assert rows.shape == (len(near.trajectory),)
    assert data["clearance"]["least"] == pytest.approx(near.min_clearance_m, abs=1e-3)
    assert rows.min() == pytest.approx(near.min_clearance_m, abs=0.03)  # swept: at most MAX_STEP_M / 2 below
    assert data["obstacles"][0]["name"] == "wall"


def test_a_name_cannot_close_the_script_it_sits_in(maneuver):
    odd = replace(maneuver, name="</script><script>alert(1)</script>")
    text = viewer_html(odd)
    assert text.count("</script>") == 2  # the data's and the viewer's own
    assert embedded(text)["name"] == odd.name


def test_a_60_s_maneuver_stays_under_2_mb(maneuver, tmp_path):
    path = write_viewer(maneuver, tmp_path / "v.html")
    per_second = path.stat().st_size / maneuver.duration
    assert 60 * per_second < 2e6, f"{path.stat().st_size} bytes for {maneuver.duration:.1f} s"


def test_view_writes_beside_the_json_and_never_replaces_without_force(saved, capsys):
    beside = saved.parent / "maneuver.html"
    beside.unlink(missing_ok=True)
    assert run(["view", str(saved)]) == 0
    assert beside.read_text(encoding="utf-8").startswith("<!DOCTYPE html>")
    beside.write_text("the user's page")
    capsys.readouterr()
    assert run(["view", str(saved)]) == 2
    assert "exists; give --force" in one_error_line(capsys.readouterr().err)
    assert beside.read_text() == "the user's page"
    assert run(["view", str(saved), "--force"]) == 0
    assert embedded(beside.read_text(encoding="utf-8"))["name"] == "parallel"
    assert not [p for p in saved.parent.iterdir() if p.name.startswith(".")]  # no temporary left


@pytest.mark.parametrize(
    ("content", "out", "says"),
    [
        (None, "v.html", "cannot read"),
        ("not json", "v.html", "not JSON text"),
        ("[1, 2]", "v.html", "not a JSON object"),
        ('{"name": "x"}', "v.html", "lacks 'vehicle'"),
        ('{"wrong": 1}', "v.html", "unknown top-level key 'wrong'; allowed:"),
        ("GOOD", "v.png", "must end in .html"),
        ("GOOD", "folder", "must end in .html"),
    ],
)
def test_view_refuses_bad_input_on_one_line_and_writes_nothing(saved, tmp_path, capsys, content, out, says):
    source = tmp_path / "in.json"
    if content == "GOOD":
        source.write_bytes(saved.read_bytes())
    elif content is not None:
        source.write_text(content)
    assert run(["view", str(source), "--out", str(tmp_path / out)]) == 2
    assert says in one_error_line(capsys.readouterr().err)
    assert sorted(p.name for p in tmp_path.iterdir()) == (["in.json"] if content is not None else [])

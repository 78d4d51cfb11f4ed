"""The documentation's lists of fields are the code's: reference/formats.md names every field the code writes."""

from __future__ import annotations

import re
from dataclasses import fields
from pathlib import Path

from hitchpark.app.records import CaseRecord
from hitchpark.assist import OVERRIDES
from hitchpark.maneuver.result import _DERIVED_KEYS, _SAVED_KEYS, ASSIST_COLUMNS, MANEUVER_COLUMNS, Outcome

FORMATS = Path(__file__).resolve().parent.parent / "docs" / "reference" / "formats.md"


def _named(text: str) -> set[str]:
    return set(re.findall(r"`([a-z_]+)`", text))


def _section(title: str) -> str:
    text = FORMATS.read_text(encoding="utf-8")
    start = text.index(f"## {title}")
    end = text.find("\n## ", start + 1)
    return text[start : end if end > 0 else len(text)]


def test_the_maneuver_file_lists_every_key_and_column_it_has():
    named = _named(_section("`maneuver.json`"))
    assert set(_SAVED_KEYS) <= named and set(_DERIVED_KEYS) <= named
    assert set(MANEUVER_COLUMNS) <= named and set(ASSIST_COLUMNS) <= named
    assert set(OVERRIDES) <= named and {o.value for o in Outcome if " " not in o.value} <= named


def test_the_sweep_records_list_every_field_and_no_other():
    named = _named(_section("A sweep's `--out`"))
    record_fields = {f.name for f in fields(CaseRecord)}
    assert record_fields <= named
    assert named - record_fields <= {"x", "y", "yaw_deg", "hitch_deg", "out"}  # the start's keys, the heading


def test_the_scene_tutorials_file_is_the_one_it_shows_and_loads():
    from hitchpark.maneuver.scenario import load_scenario

    docs = FORMATS.parent.parent
    shown = re.search(r"```toml\n(.*?)```", (docs / "tutorials" / "scene.md").read_text(encoding="utf-8"), re.S)
    example = docs / "examples" / "my_driveway.toml"
    assert shown is not None and shown.group(1) == example.read_text(encoding="utf-8")
    scenario = load_scenario(example)
    assert scenario.name == "my_driveway" and len(scenario.scene.obstacles) == 2
    assert scenario.start_region is not None


def test_the_assist_sweep_records_list_every_field():
    from hitchpark.app.assist_sweep import AssistRecord

    named = _named(_section("An assist sweep's `--out`"))
    assert {f.name for f in fields(AssistRecord)} <= named

"""Saving results (hitchpark.io)."""

from __future__ import annotations

import math
import os
import stat

import numpy as np
import pytest

from hitchpark.io import StagedFolder, read_json, to_jsonable, write_json


def test_to_jsonable_converts_numpy_and_non_finite_numbers():
    data = {
        "array": np.array([1.0, np.nan, np.inf]),
        "scalar": np.float64(2.5),
        "count": np.int64(3),
        "nested": ({"x": -math.inf},),
        4: "key becomes text",
    }
    assert to_jsonable(data) == {
        "array": [1.0, None, None],
        "scalar": 2.5,
        "count": 3,
        "nested": [{"x": None}],
        "4": "key becomes text",
    }
    assert type(to_jsonable(np.int64(3))) is int


def test_write_then_read(tmp_path):
    path = write_json(tmp_path / "a" / "b.json", {"t": np.arange(3) * 0.5, "bad": math.nan})
    assert path == tmp_path / "a" / "b.json"
    assert read_json(path) == {"t": [0.0, 0.5, 1.0], "bad": None}
    assert path.read_text(encoding="utf-8").endswith("\n")


def test_failed_write_keeps_the_old_file(tmp_path):
    path = tmp_path / "out.json"
    write_json(path, {"version": 1})
    with pytest.raises(TypeError):
        write_json(path, {"version": object()})
    assert read_json(path) == {"version": 1}
    assert [p.name for p in tmp_path.iterdir()] == ["out.json"]


def test_written_file_has_the_usual_mode(tmp_path):
    """Not the 0600 of a temporary file: what open() would have given under the current umask."""
    umask = os.umask(0)
    os.umask(umask)
    path = write_json(tmp_path / "out.json", {"a": 1})
    assert stat.S_IMODE(path.stat().st_mode) == 0o666 & ~umask


def test_staged_folder_publishes_whole(tmp_path):
    out = tmp_path / "out"
    (out / "a").mkdir(parents=True)
    (out / "a" / "old.txt").write_text("old")
    (out / "keep.txt").write_text("keep")
    with StagedFolder(out) as stage:
        (stage / "a").mkdir()
        (stage / "a" / "new.txt").write_text("new")
        (stage / "summary.json").write_text("{}")
    assert sorted(p.name for p in out.iterdir()) == ["a", "keep.txt", "summary.json"]
    assert [p.name for p in (out / "a").iterdir()] == ["new.txt"]  # a folder is replaced, not merged


def test_staged_folder_leaves_nothing_on_error(tmp_path):
    out = tmp_path / "out"
    with pytest.raises(RuntimeError), StagedFolder(out) as stage:
        (stage / "half.json").write_text("{")
        raise RuntimeError("boom")
    assert not out.exists()  # created by the stage, removed again


def test_staged_folder_clash_moves_nothing(tmp_path):
    out = tmp_path / "out"
    (out / "summary.json").mkdir(parents=True)  # a folder where a file goes
    with pytest.raises(ValueError, match="in the way"), StagedFolder(out) as stage:
        (stage / "scenario").mkdir()
        (stage / "summary.json").write_text("{}")
    assert sorted(p.name for p in out.iterdir()) == ["summary.json"]


def test_staged_folder_target_is_a_file(tmp_path):
    target = tmp_path / "file"
    target.write_text("x")
    with pytest.raises(ValueError, match="not a folder"):
        StagedFolder(target)

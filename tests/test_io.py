"""Saving results (hitchpark.io); output folders are tested in test_staging.py, output paths in test_outputs.py."""

from __future__ import annotations

import math
import os
import stat

import numpy as np
import pytest

from hitchpark.io import read_json, to_jsonable, write_json


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

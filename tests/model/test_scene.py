"""Scenes (hitchpark.model.scene): obstacles and an area, checked on construction, round trips, equality."""

from __future__ import annotations

import json
import math
import pickle

import numpy as np
import pytest

from hitchpark.checks import MAX_COORDINATE, InputError
from hitchpark.model.scene import Area, Obstacle, Scene, check_polygon

SQUARE = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]]
FIELD = [[-20.0, -20.0], [20.0, -20.0], [20.0, 20.0], [-20.0, 20.0]]


def scene() -> Scene:
    return Scene(
        (Obstacle("parked car", SQUARE), Obstacle("", [[5, 5], [6, 5], [5.5, 7]])),
        Area(FIELD),
    )


def test_polygon_is_a_read_only_float_array_without_the_closing_vertex():
    closed = check_polygon("p", [*SQUARE, SQUARE[0]])
    assert closed.shape == (4, 2) and closed.dtype == float
    assert np.array_equal(closed, np.array(SQUARE))
    with pytest.raises(ValueError):
        closed[0, 0] = 1.0


def test_either_orientation_is_accepted():
    clockwise = SQUARE[::-1]
    assert np.array_equal(Obstacle("cw", clockwise).polygon, np.array(clockwise))


def test_empty_scene():
    assert Scene().is_empty
    assert Scene().to_dict() == {"obstacles": [], "area": None}
    assert Scene.from_dict({}) == Scene()
    assert not Scene(area=Area(FIELD)).is_empty
    assert not Scene((Obstacle("a", SQUARE),)).is_empty


def test_round_trip_through_json():
    original = scene()
    data = json.loads(json.dumps(original.to_dict()))
    assert data["obstacles"][0] == {"name": "parked car", "polygon": SQUARE}
    assert data["area"] == {"boundary": FIELD}
    again = Scene.from_dict(data)
    assert again == original and hash(again) == hash(original)
    assert again.to_dict() == original.to_dict()


def test_equality_and_hash_by_value():
    assert scene() == scene() and hash(scene()) == hash(scene())
    assert scene() != Scene((Obstacle("parked car", SQUARE),), Area(FIELD))
    assert Obstacle("a", SQUARE) != Obstacle("b", SQUARE)
    assert Obstacle("a", SQUARE) != Obstacle("a", SQUARE[1:] + SQUARE[:1])  # same shape, other first vertex
    assert len({scene(), scene(), Scene()}) == 2
    assert pickle.loads(pickle.dumps(scene())) == scene()


def test_obstacles_as_a_list_become_a_tuple():
    assert Scene([Obstacle("a", SQUARE)]).obstacles == (Obstacle("a", SQUARE),)


def test_name_is_optional_in_a_table():
    s = Scene.from_dict({"obstacles": [{"polygon": SQUARE}]})
    assert s.obstacles[0].name == ""


BAD_POLYGONS = [
    ("bowtie", [[0, 0], [2, 2], [2, 0], [0, 2]], "simple polygon"),
    ("two points", [[0, 0], [1, 1]], "at least 3 distinct vertices"),
    ("three points, two the same", [[0, 0], [1, 1], [0, 0], [1, 1]], "at least 3 distinct vertices"),
    ("on one line", [[0, 0], [1, 0], [2, 0]], "non-zero area"),
    ("NaN", [[0, 0], [1, float("nan")], [1, 1]], "finite"),
    ("infinite", [[0, 0], [1, math.inf], [1, 1]], "finite"),
    ("far away", [[0, 0], [1e300, 0], [1, 1]], f"<= {MAX_COORDINATE:g}"),
    ("a string", "[[0, 0], [1, 0], [1, 1]]", "list of [x, y] points"),
    ("strings inside", [["0", "0"], ["1", "0"], ["1", "1"]], "numbers"),
    ("a number", 5.0, "list of [x, y] points"),
    ("a table", {"x": [0, 1, 1]}, "list of [x, y] points"),
    ("ragged", [[0, 0], [1], [1, 1]], "regular array"),
    ("points of three", [[0, 0, 0], [1, 0, 0], [1, 1, 0]], "points of 3 numbers"),
    ("flat list", [0, 0, 1, 0, 1, 1], "2-D array"),
    ("booleans", [[True, False], [1, 0], [1, 1]], "numbers"),
    ("self-touching ring", [[0, 0], [2, 0], [2, 2], [1, 0], [0, 2]], "simple polygon"),
]


@pytest.mark.parametrize(("case", "polygon", "message"), BAD_POLYGONS, ids=[c[0] for c in BAD_POLYGONS])
def test_bad_polygons_refused_naming_the_obstacle(case, polygon, message):
    data = {
        "obstacles": [
            {"name": "a", "polygon": SQUARE},
            {"name": "b", "polygon": SQUARE},
            {"name": "parked car", "polygon": polygon},
        ]
    }
    with pytest.raises(InputError) as err:
        Scene.from_dict(data)
    text = str(err.value)
    assert text.startswith('obstacles[2] ("parked car").polygon'), text
    assert message in text
    assert "\n" not in text


@pytest.mark.parametrize(("case", "polygon", "message"), BAD_POLYGONS, ids=[c[0] for c in BAD_POLYGONS])
def test_bad_boundaries_refused(case, polygon, message):
    with pytest.raises(InputError, match=r"^area\.boundary"):
        Scene.from_dict({"area": {"boundary": polygon}})
    with pytest.raises(InputError, match=r"^area\.boundary"):
        Area(polygon)


def test_bad_polygon_in_the_constructor_names_the_obstacle():
    with pytest.raises(InputError, match=r'^obstacle \("wall"\)\.polygon must be a simple polygon'):
        Obstacle("wall", [[0, 0], [2, 2], [2, 0], [0, 2]])


BAD_SCENES = [
    ("not a table", [1, 2], "must be a table"),
    ("unknown key", {"obstacle": []}, "unknown key 'obstacle'"),
    ("obstacles not a list", {"obstacles": {"polygon": SQUARE}}, "obstacles must be a list"),
    ("obstacle not a table", {"obstacles": [SQUARE]}, r"\[obstacles\[0\]\] must be a table"),
    ("obstacle key unknown", {"obstacles": [{"polygon": SQUARE, "height": 2}]}, r"obstacles\[0\]\.height"),
    ("polygon missing", {"obstacles": [{"name": "x"}]}, r'obstacles\[0\] \("x"\)\.polygon is missing'),
    ("name not text", {"obstacles": [{"name": 3, "polygon": SQUARE}]}, r"obstacles\[0\]\.name must be a string"),
    ("area not a table", {"area": SQUARE}, r"\[area\] must be a table"),
    ("boundary missing", {"area": {}}, "area.boundary is missing"),
    ("area key unknown", {"area": {"boundary": FIELD, "polygon": FIELD}}, "area.polygon"),
]


@pytest.mark.parametrize(("case", "data", "message"), BAD_SCENES, ids=[c[0] for c in BAD_SCENES])
def test_bad_scene_tables_refused(case, data, message):
    with pytest.raises(InputError, match=message):
        Scene.from_dict(data)


def test_wrong_types_in_the_constructor_refused():
    with pytest.raises(InputError, match=r"obstacles\[1\] must be an Obstacle"):
        Scene((Obstacle("a", SQUARE), SQUARE))
    with pytest.raises(InputError, match="obstacles must be a list"):
        Scene("wall")
    with pytest.raises(InputError, match="area must be an Area"):
        Scene(area=FIELD)
    with pytest.raises(InputError, match="obstacle name must be a string"):
        Obstacle(None, SQUARE)

"""The NMPC's predictions, an optional column group of a maneuver: recorded on request, the maneuver unchanged."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hitchpark.checks import InputError
from hitchpark.control import NMPCSettings
from hitchpark.maneuver import ManeuverResult, ManeuverSettings, park
from hitchpark.model import IDEAL, VehicleTrailer
from hitchpark.model.simulate import State

SETTINGS = ManeuverSettings(nmpc=NMPCSettings(kind="paper", solver="sqp"))


def _park(predictions: bool) -> ManeuverResult:
    return park(VehicleTrailer(), State(6, 3, 0, 0), settings=SETTINGS, plant=IDEAL, predictions=predictions)


@pytest.fixture(scope="module")
def pair() -> tuple[ManeuverResult, ManeuverResult]:
    return _park(False), _park(True)


def _without_times(data: dict) -> dict:
    data = json.loads(json.dumps(data))
    data["trajectory"].pop("solve_ms")  # wall-clock time of each solve: the one column that varies between runs
    return data


def test_recording_predictions_changes_nothing_else(pair):
    off, on = pair
    assert off.predictions is None and "predictions" not in off.to_dict()
    with_them = on.to_dict()
    with_them.pop("predictions")
    assert _without_times(with_them) == _without_times(off.to_dict())


def test_one_prediction_per_row_where_the_nmpc_acted(pair):
    _, on = pair
    assert on.predictions is not None and len(on.predictions) == len(on.trajectory)
    tr = on.trajectory
    solved = np.isfinite(tr["cost"])
    sizes = np.array([len(p) for p in on.predictions.paths])
    assert np.all(sizes[solved] == SETTINGS.nmpc.horizon + 1) and np.all(sizes[~solved] == 0)
    # The prediction starts where the trailer is (the paper's NMPC acts at once on the ideal plant).
    row = int(np.flatnonzero(solved)[5])
    np.testing.assert_allclose(on.predictions.paths[row][0], [tr["x_trailer"][row], tr["y_trailer"][row]], atol=1e-9)


def test_the_file_round_trips_with_and_without_predictions(pair):
    for result in pair:
        text = json.dumps(result.to_dict())
        again = ManeuverResult.from_dict(json.loads(text))
        assert json.dumps(again.to_dict()) == text


def test_malformed_predictions_are_refused_saying_what(pair):
    _, on = pair
    data = json.loads(json.dumps(on.to_dict()))
    data["predictions"]["x_trailer"].pop()
    with pytest.raises(InputError, match=r"x_trailer has .* rows"):
        ManeuverResult.from_dict(data)
    data = json.loads(json.dumps(on.to_dict()))
    data["predictions"]["x_trailer"] = data["predictions"]["x_trailer"][1:]
    data["predictions"]["y_trailer"] = data["predictions"]["y_trailer"][1:]
    with pytest.raises(InputError, match=r"predictions has .* rows, the trajectory"):
        ManeuverResult.from_dict(data)
    data["predictions"] = {"x_trailer": "no"}
    with pytest.raises(InputError, match="predictions"):
        ManeuverResult.from_dict(data)

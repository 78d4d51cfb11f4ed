"""Maneuver figures (Figs. 8-15), the GIF animation and the body outlines they draw."""

from __future__ import annotations

import itertools
import math
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from PIL import Image

from hitchpark.control import NMPCSettings
from hitchpark.io import read_json, write_json
from hitchpark.maneuver import ManeuverResult, ManeuverSettings, SuccessCriteria, park
from hitchpark.model import IDEAL, Pose, VehicleTrailer, hitch_point, rear_axle_pose
from hitchpark.model.simulate import State
from hitchpark.viz.maneuver import animate_maneuver, body_outlines, parking_space, plot_maneuver, wheel_outlines

VEHICLES = (
    VehicleTrailer(),  # Table 4 with the default body
    VehicleTrailer(wheelbase=3.0, hitch_offset=1.0, trailer_length=2.5),  # Table 2
    VehicleTrailer(  # long overhangs, hitch under the rear bumper, wide trailer
        wheelbase=2.5,
        hitch_offset=0.6,
        trailer_length=4.0,
        front_overhang=1.2,
        rear_overhang=0.9,
        vehicle_width=1.7,
        trailer_front=3.5,
        trailer_rear=1.5,
        trailer_width=2.3,
    ),
)

poses = st.tuples(st.floats(-50, 50), st.floats(-50, 50), st.floats(-math.pi, math.pi), st.floats(-1.2, 1.2))


def inside(point: np.ndarray, polygon: np.ndarray) -> bool:
    """Crossing-number test for a point strictly inside a closed polygon (last vertex = first)."""
    x, y = point
    crossings = 0
    for (x0, y0), (x1, y1) in itertools.pairwise(polygon):
        if (y0 > y) != (y1 > y) and x < x0 + (y - y0) * (x1 - x0) / (y1 - y0):
            crossings += 1
    return crossings % 2 == 1


def signed_area(polygon: np.ndarray) -> float:
    x, y = polygon[:, 0], polygon[:, 1]
    return 0.5 * float(np.sum(x[:-1] * y[1:] - x[1:] * y[:-1]))


@pytest.fixture(scope="module")
def maneuver() -> ManeuverResult:
    """The parallel-parking example, the paper's process on the ideal plant: 3 stages, parked (about 0.2 s)."""
    settings = ManeuverSettings(nmpc=NMPCSettings(kind="paper", solver="sqp"))
    return park(VehicleTrailer(), State(6, 3, 0, 0), settings=settings, name="parallel", plant=IDEAL)


@pytest.fixture(scope="module")
def failed_maneuver() -> ManeuverResult:
    """One reverse stage only, not parked: a failure ("max_stages") with a single stage."""
    settings = ManeuverSettings(nmpc=NMPCSettings(kind="paper", solver="sqp"), success=SuccessCriteria(max_stages=1))
    return park(VehicleTrailer(), State(6, 3, 0, 0), settings=settings, name="one stage", plant=IDEAL)


# --------------------------------------------------------------------------- geometry


@pytest.mark.parametrize("vehicle", VEHICLES)
def test_body_dimensions(vehicle: VehicleTrailer) -> None:
    out = body_outlines(vehicle, 1.0, -2.0, 0.3, 0.4)
    for key in ("vehicle", "trailer"):
        assert out[key].shape == (5, 2)
        np.testing.assert_allclose(out[key][0], out[key][-1])  # closed
    assert out["drawbar"].shape == (2, 2)
    assert out["hitch"].shape == (2,)
    car, trailer = out["vehicle"], out["trailer"]
    length = vehicle.front_overhang + vehicle.wheelbase + vehicle.rear_overhang
    assert np.linalg.norm(car[1] - car[0]) == pytest.approx(length)
    assert np.linalg.norm(car[2] - car[1]) == pytest.approx(vehicle.vehicle_width)
    assert signed_area(car) == pytest.approx(length * vehicle.vehicle_width)  # counter-clockwise, a rectangle
    t_length = vehicle.trailer_front + vehicle.trailer_rear
    assert np.linalg.norm(trailer[1] - trailer[0]) == pytest.approx(t_length)
    assert np.linalg.norm(trailer[2] - trailer[1]) == pytest.approx(vehicle.trailer_width)
    assert signed_area(trailer) == pytest.approx(t_length * vehicle.trailer_width)


@given(pose=poses, vehicle=st.sampled_from(VEHICLES))
def test_axles_inside_and_hitch_distances(pose: tuple[float, float, float, float], vehicle: VehicleTrailer) -> None:
    x, y, yaw, hitch = pose
    out = body_outlines(vehicle, x, y, yaw, hitch)
    x_r, y_r, yaw_v = rear_axle_pose(vehicle, x, y, yaw, hitch)
    rear, axle = np.array([x_r, y_r]), np.array([x, y])
    assert inside(rear, out["vehicle"])
    assert inside(axle, out["trailer"])
    np.testing.assert_allclose(out["rear_axle"], rear, atol=1e-9)
    np.testing.assert_allclose(out["trailer_axle"], axle, atol=1e-9)
    np.testing.assert_allclose(out["hitch"], hitch_point(vehicle, x, y, yaw), atol=1e-9)
    assert np.linalg.norm(out["hitch"] - axle) == pytest.approx(vehicle.trailer_length)
    assert np.linalg.norm(out["hitch"] - rear) == pytest.approx(vehicle.hitch_offset, abs=1e-9)
    # The drawbar runs from the middle of the trailer body's front edge to the hitch.
    front_mid = 0.5 * (out["trailer"][1] + out["trailer"][2])
    np.testing.assert_allclose(out["drawbar"][0], front_mid, atol=1e-9)
    np.testing.assert_allclose(out["drawbar"][1], out["hitch"], atol=1e-12)
    assert np.linalg.norm(out["drawbar"][1] - out["drawbar"][0]) == pytest.approx(
        vehicle.trailer_length - vehicle.trailer_front
    )
    # The vehicle body points along the vehicle heading.
    heading = out["vehicle"][1] - out["vehicle"][0]
    gap = math.atan2(heading[1], heading[0]) - yaw_v
    assert math.atan2(math.sin(gap), math.cos(gap)) == pytest.approx(0.0, abs=1e-9)  # equal modulo 2 pi


@given(pose=poses, vehicle=st.sampled_from(VEHICLES))
def test_turning_the_yaw_turns_the_outlines(pose: tuple[float, float, float, float], vehicle: VehicleTrailer) -> None:
    x, y, yaw, hitch = pose
    before = body_outlines(vehicle, x, y, yaw, hitch)
    after = body_outlines(vehicle, x, y, yaw + math.pi / 2, hitch)
    quarter = np.array([[0.0, -1.0], [1.0, 0.0]])  # +90 deg about the trailer axle
    centre = np.array([x, y])
    for key in ("vehicle", "trailer", "drawbar", "tow_bar", "hitch", "rear_axle"):
        np.testing.assert_allclose(after[key] - centre, (before[key] - centre) @ quarter.T, atol=1e-9)


def test_outlines_are_plain_numbers_and_independent_arrays() -> None:
    out = body_outlines(VehicleTrailer(), np.float64(0.0), 0, 0, 0)
    for value in out.values():
        assert isinstance(value, np.ndarray)
        assert value.dtype == float
        assert np.all(np.isfinite(value))
    out["vehicle"][0, 0] = 99.0  # a caller may edit its copy
    assert body_outlines(VehicleTrailer(), 0.0, 0.0, 0.0, 0.0)["vehicle"][0, 0] != 99.0


def test_wheels_and_parking_space() -> None:
    vehicle = VehicleTrailer()
    steer = 0.4
    wheels = wheel_outlines(vehicle, 0.0, 0.0, 0.0, 0.2, steer)
    assert wheels.shape == (6, 5, 2)
    bodies = body_outlines(vehicle, 0.0, 0.0, 0.0, 0.2)
    for k, body in ((0, "vehicle"), (1, "vehicle"), (2, "vehicle"), (3, "vehicle"), (4, "trailer"), (5, "trailer")):
        assert inside(wheels[k, :4].mean(axis=0), bodies[body])
    front = wheels[2, 1] - wheels[2, 0]
    assert math.atan2(front[1], front[0]) == pytest.approx(0.2 + steer)  # vehicle yaw + steer
    goal = Pose(3.0, -1.0, 1.0)
    space = parking_space(vehicle, goal)
    parked = body_outlines(vehicle, goal.x, goal.y, goal.yaw, 0.0)["trailer"]
    assert all(inside(p, space) for p in parked[:4])


# --------------------------------------------------------------------------- figures


@pytest.mark.slow
def test_plot_maneuver_writes_three_pngs_from_json(maneuver: ManeuverResult, tmp_path) -> None:
    saved = write_json(tmp_path / "maneuver.json", maneuver.to_dict())
    loaded = ManeuverResult.from_dict(read_json(saved))
    files = plot_maneuver(loaded, tmp_path / "figs", prefix="s1_")
    assert [f.name for f in files] == ["s1_motion.png", "s1_inputs.png", "s1_nmpc.png"]
    for f in files:
        assert f.stat().st_size > 10_000
        with Image.open(f) as im:
            assert im.format == "PNG"
            assert im.width > 800 and im.height > 400


@pytest.mark.slow
def test_plot_maneuver_on_a_failed_single_stage_maneuver(failed_maneuver: ManeuverResult, tmp_path) -> None:
    assert not failed_maneuver.success and len(failed_maneuver.stages) == 1
    files = plot_maneuver(failed_maneuver, tmp_path)
    assert all(f.is_file() and f.stat().st_size > 0 for f in files)


def test_plot_maneuver_rejects_a_bad_snapshot_interval(maneuver: ManeuverResult, tmp_path) -> None:
    with pytest.raises(ValueError, match="snapshot_every"):
        plot_maneuver(maneuver, tmp_path, snapshot_every=0.0)
    assert not list(tmp_path.iterdir())


def single_row(result: ManeuverResult) -> ManeuverResult:
    """A maneuver that stopped before its first step: one row, one empty stage."""
    data = result.to_dict()
    data["trajectory"] = {k: v[:1] for k, v in data["trajectory"].items()}
    first = dict(data["stages"][0], steps=0, first_row=0, last_row=0, reason="solver: failed")
    data.update(stages=[first], success=False, reason="solver: failed")
    return ManeuverResult.from_dict(data)


def test_plots_and_animation_survive_an_empty_stage(maneuver: ManeuverResult, tmp_path) -> None:
    degenerate = single_row(maneuver)
    assert all(f.stat().st_size > 0 for f in plot_maneuver(degenerate, tmp_path))
    gif = animate_maneuver(degenerate, tmp_path / "one.gif")
    with Image.open(gif) as im:
        assert im.n_frames == 1


# --------------------------------------------------------------------------- animation


def test_animate_maneuver_writes_a_gif(maneuver: ManeuverResult, tmp_path) -> None:
    gif = animate_maneuver(maneuver, tmp_path / "anim" / "parallel.gif", fps=12, max_frames=25)
    assert gif == tmp_path / "anim" / "parallel.gif"
    with Image.open(gif) as im:
        assert im.format == "GIF"
        assert 1 < im.n_frames <= 25
        assert im.width == 6 * 80


@pytest.mark.parametrize(("kwargs", "message"), [({"fps": 0}, "fps"), ({"max_frames": 0}, "max_frames")])
def test_animate_maneuver_rejects_bad_arguments(maneuver: ManeuverResult, tmp_path, kwargs, message) -> None:
    with pytest.raises(ValueError, match=message):
        animate_maneuver(maneuver, tmp_path / "x.gif", **kwargs)


def test_core_does_not_import_matplotlib() -> None:
    code = (
        "import sys, hitchpark, hitchpark.maneuver.process, hitchpark.viz.maneuver; "
        "assert 'matplotlib' not in sys.modules, 'matplotlib imported'"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)

"""The live drive without a browser (hitchpark.maneuver.live, hitchpark.viz.drive): ticks, Esc, the saved drive,
the page's messages read leniently, and the loopback rule of ``hitchpark drive``."""

from __future__ import annotations

import pytest
from person import Person, in_the_bay

from hitchpark.checks import InputError
from hitchpark.cli import main
from hitchpark.maneuver.live import LiveDrive
from hitchpark.maneuver.scenario import Scenario, builtin_scenario
from hitchpark.model import State
from hitchpark.viz.drive import _inputs, check_host, drive_page


def test_ticks_turn_the_rig_and_escape_brakes_it_to_a_saved_stop():
    drive = LiveDrive(Scenario("straight", State(0.0, 0.0, 0.0, 0.0)))
    for _ in range(100):
        view = drive.tick(1.0, 1.0)
    assert view["override"] in ("none", "jackknife_prevented") and view["hitch_deg"] > 20.0
    drive.stop()
    speeds = []
    while not drive.done:
        speeds.append(abs(drive.tick(1.0, 1.0)["speed"]))
    assert speeds[-1] == 0.0 and len(speeds) <= 15  # 1 m/s at 1 m/s^2, and the steering lag
    result = drive.result()
    assert result.reason == "stopped_by_driver" and result.success
    assert result.trajectory["speed_request"][100] == 0.0


def test_a_drive_left_rolling_is_stopped_within_the_limits_when_saved():
    drive = LiveDrive(builtin_scenario("parallel"))
    for _ in range(30):
        drive.tick(-0.5, 1.0)
    result = drive.result()
    assert result.reason == "stopped_by_driver"
    speed = result.trajectory["rear_speed_cmd"][:-1]  # the last row records a stop, not a command
    assert abs(speed[-1]) == 0.0 and max(abs(speed[1:] - speed[:-1])) <= 0.1 + 1e-12


def test_a_scripted_person_backs_the_bay_into_its_space_by_knob():
    """The person of the browser test, ticking the drive directly: from the bay's start, a look a tick."""
    drive = LiveDrive(builtin_scenario("bay"), max_time=120.0)
    person = Person(drive.assist.kappa_max)
    view = drive.view(None)
    while not drive.done:
        x, y, yaw, _ = view["state"]
        if person.look(x, y, yaw) == ["Escape"]:
            drive.stop()
        view = drive.tick(person.knob, drive.settings.max_speed)
    result = drive.result()
    assert result.reason == "stopped_by_driver"
    in_the_bay(result)


def test_the_page_is_one_file_that_talks_to_its_own_server_only():
    text = drive_page(LiveDrive(builtin_scenario("bay")))
    assert "connect-src 'self'" in text and "http" not in text.split("<script")[0].lower().replace("http-equiv", "")


def test_the_pages_messages_are_read_leniently():
    now = {"knob": 0.2, "speed": 0.5}
    assert _inputs('{"knob": 3, "speed": -1}', now, 1.0) == {"knob": 1.0, "speed": 0.0}
    assert _inputs("not json", now, 1.0) == now and _inputs("[1]", now, 1.0) == now
    assert _inputs('{"knob": NaN}', now, 1.0) == now
    assert _inputs('{"stop": true}', now, 1.0)["stop"] is True


def test_only_a_loopback_address_is_served_unless_named(tmp_path, capsys):
    assert check_host("127.0.0.1", False) == "127.0.0.1" and check_host("::1", False) == "::1"
    assert check_host("0.0.0.0", True) == "0.0.0.0"
    with pytest.raises(InputError, match="--allow-remote"):
        check_host("0.0.0.0", False)
    args = ["drive", "--scenario", "bay", "--out", str(tmp_path / "d"), "--host", "192.168.1.5"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not a loopback address" in err

"""``hitchpark sil``: the exported controller drives the paper's four scenarios as the in-process one, to the bit."""

from __future__ import annotations

import pytest

from hitchpark.app.sil import run_sil
from hitchpark.maneuver.scenario import BUILTIN_ORDER, builtin_scenario


@pytest.mark.slow
@pytest.mark.parametrize("name", BUILTIN_ORDER)
def test_sil_equals_in_process_on_the_papers_scenarios(name, library, compiled_in_process):
    report = run_sil(builtin_scenario(name), library=library).to_dict()
    assert report["same_outcome"], report
    assert report["exported"]["outcome"] == "parked"
    assert report["rows"]["exported"] == report["rows"]["in_process"]
    assert report["max_command_difference"] == 0.0
    assert report["max_state_difference"] == 0.0
    assert report["c_steps"] > 0 and report["c_step_time_ns"]["median"] > 0
    assert 0 < report["workspace_bytes"] <= report["workspace_bound_bytes"]
    assert report["library_bytes"] > 0


def test_sil_refuses_a_scene_of_obstacles():
    with pytest.raises(ValueError, match="open space"):
        run_sil(builtin_scenario("driveway"))

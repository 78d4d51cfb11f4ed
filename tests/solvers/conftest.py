"""Closed-loop NMPC problems recorded once for the solver tests: the paper's, the full model's, the obstacle OCP's."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import replace

import numpy as np
import pytest

from hitchpark.control import NMPCSettings, make_nmpc
from hitchpark.control.nmpc import NLPProblem
from hitchpark.maneuver import builtin_scenarios, park
from hitchpark.maneuver.scenario import builtin_scenario


def _recorded(kind: str, scenario: int, every: int) -> tuple[object, list[NLPProblem]]:
    sc = builtin_scenarios()[scenario]
    settings = replace(sc.settings, nmpc=NMPCSettings(kind=kind))
    with _uncompiled():
        controller = make_nmpc(sc.vehicle, settings.nmpc)
        controller.recorder = []
        result = park(sc.vehicle, sc.start, sc.goal, settings, controller=controller, plant=sc.plant)
    assert result.success
    return controller, controller.recorder[::every]


@contextmanager
def _uncompiled() -> Iterator[None]:
    """The suite's setting whichever test asks first (one with ``jit_cache`` compiles): the same problems."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("HITCHPARK_JIT", "0")
        yield


@pytest.fixture(scope="session")
def paper_problems():
    return _recorded("paper", 0, 10)


@pytest.fixture(scope="session")
def full_problems():
    return _recorded("full", 2, 5)


@pytest.fixture(scope="session")
def obstacle_problems():
    """The obstacle OCP's problems (the full model keeping clear of the scene) while parking at the campsite."""
    sc = builtin_scenario("campsite")
    with _uncompiled():
        controller = make_nmpc(sc.vehicle, sc.settings.nmpc)
        controller.recorder = []
        result = park(sc.vehicle, sc.start, sc.goal, sc.settings, controller=controller, plant=sc.plant, scene=sc.scene)
    assert result.success
    lines = np.array([p.p[6:] for p in controller.recorder]).reshape(len(controller.recorder), -1, 3)
    assert np.any(lines[..., 2] != -1.0)  # the scene is near: some lines are in use
    return controller, controller.recorder[::10]


def _problems(ocp, paper_problems, full_problems, obstacle_problems):
    return {"paper": paper_problems, "full": full_problems, "obstacles": obstacle_problems}[ocp]

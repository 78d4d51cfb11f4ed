"""Closed-loop NMPC problems recorded once a run for the solver tests (``recorded_park``, ``tests/conftest.py``): the
paper's, the full model's, the obstacle OCP's."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from hitchpark.control import NMPCSettings
from hitchpark.control.nmpc import NLPProblem
from hitchpark.maneuver import builtin_scenarios
from hitchpark.solvers.registry import make_solver


def _recorded(recorded_park, kind: str, scenario: int) -> tuple[object, list[NLPProblem]]:
    """The controller and every problem it posed parking from one of the paper's scenarios with the NMPC ``kind``."""
    sc = builtin_scenarios()[scenario]
    settings = replace(sc.settings, nmpc=NMPCSettings(kind=kind))
    controller, result, problems = recorded_park(f"{kind}-{sc.name}", sc.vehicle, sc.start, sc.goal, settings, sc.plant)
    assert result.success
    return controller, problems


@pytest.fixture(scope="session")
def paper_problems(recorded_park):
    controller, problems = _recorded(recorded_park, "paper", 0)
    return controller, problems[::10]


@pytest.fixture(scope="session")
def full_recorded(recorded_park):
    """Every problem of the full model's NMPC parking from the perpendicular scenario (``test_warm_duals`` takes
    every 8th)."""
    return _recorded(recorded_park, "full", 2)


@pytest.fixture(scope="session")
def full_problems(full_recorded):
    controller, problems = full_recorded
    return controller, problems[::5]


@pytest.fixture(scope="session")
def obstacle_problems(campsite_recorded):
    """The obstacle OCP's problems (the full model keeping clear of the scene) while parking at the campsite."""
    controller, result, problems = campsite_recorded
    assert result.success
    lines = np.array([p.p[6:] for p in problems]).reshape(len(problems), -1, 3)
    assert np.any(lines[..., 2] != -1.0)  # the scene is near: some lines are in use
    return controller, problems[::10]


def _problems(ocp, paper_problems, full_problems, obstacle_problems):
    return {"paper": paper_problems, "full": full_problems, "obstacles": obstacle_problems}[ocp]


def _solve_all(solver, problems) -> list[tuple[bool, np.ndarray, float]]:
    """Each problem solved in turn: success, the answer's x and its cost (as ``test_routes._solve_all``)."""
    out = []
    for problem in problems:
        answer = solver(**problem.inputs())
        out.append((solver.stats()["success"], np.asarray(answer["x"]).ravel(), float(answer["f"])))
    return out


@pytest.fixture(scope="session")
def ipopt_answers(once_a_run):
    """``ipopt_answers(ocp, controller, problems)``: IPOPT's answers (success, x, cost) to the recorded problems of
    ``ocp`` (its fixture's ``controller, problems``), solved once a run (``once_a_run``) for every test that compares
    a route with IPOPT on them. A call of IPOPT depends on its inputs alone (the same bits whatever the solver solved
    before: checked when this was written), so each test compares with the answers an IPOPT of its own would give."""
    given: dict[str, list[NLPProblem]] = {}
    solved: dict[str, list[tuple[bool, np.ndarray, float]]] = {}

    def answers(ocp: str, controller, problems: list[NLPProblem]) -> list[tuple[bool, np.ndarray, float]]:
        assert given.setdefault(ocp, problems) is problems  # the session's recorded problems of this OCP
        if ocp not in solved:
            tr = controller.transcription

            def solve() -> list[tuple[bool, np.ndarray, float]]:
                return _solve_all(make_solver("ipopt", tr.nlp, list(tr.lbg == tr.ubg)), problems)

            solved[ocp] = once_a_run(f"ipopt-{ocp}", solve)
        return solved[ocp]

    return answers

"""What every generated input must meet, the example count, and the tally of outcomes.

``HITCHPARK_FUZZ_EXAMPLES`` sets the examples per test (default 25, enough for the default suite
to exercise every generator); ``benchmarks/fuzz_inputs.py`` runs the suite with thousands and
reads the tally that ``HITCHPARK_FUZZ_REPORT`` names (written by this folder's ``conftest.py``).
"""

from __future__ import annotations

import os
from collections import Counter, defaultdict
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any
from unittest import mock

from hypothesis import HealthCheck, settings

from hitchpark.checks import InputError
from hitchpark.cli import EXIT_BAD_INPUT, main

EXAMPLES = int(os.environ.get("HITCHPARK_FUZZ_EXAMPLES", "25"))

FUZZ = settings(
    max_examples=EXAMPLES,
    deadline=None,
    derandomize=bool(os.environ.get("CI")),
    database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow, HealthCheck.filter_too_much],
)

#: test name -> outcome ("accepted", "refused") -> count.
TALLY: defaultdict[str, Counter[str]] = defaultdict(Counter)


class Accepted(Exception):
    """Raised in place of the work a command would do once its input has passed every check."""


def _accept(*args: Any, **kwargs: Any) -> Any:
    raise Accepted


#: The expensive work behind each command, replaced while fuzzing: every input check runs first, the work
#: itself (a maneuver's car, an open-loop run, drawing, a sweep) does not.
WORK = (
    "hitchpark.maneuver.process.Plant",
    "hitchpark.app.report.run_scenario",
    "hitchpark.viz.maneuver.render_maneuver",
    "hitchpark.viz.viewer.write_viewer",
    "hitchpark.app.sweep.run_sweep",
    "hitchpark.model.simulate.step_full",
    "hitchpark.app.ik_study.inverse_kinematics_study",
)


@contextmanager
def _patched() -> Iterator[None]:
    patches = [mock.patch(target, _accept) for target in WORK]
    for p in patches:
        p.start()
    try:
        yield
    finally:
        for p in patches:
            p.stop()


def files_under(folder: Path) -> set[Path]:
    return {p.relative_to(folder) for p in folder.rglob("*")}


def check_command(test: str, argv: list[str], folder: Path, capsys: Any) -> str:
    """Run ``hitchpark ARGV`` in-process with its work replaced; assert the contract; tally and return the outcome.

    Accepted: the checks passed and the work was reached (nothing written yet). Refused: exit
    status 2, one line on the standard error, no traceback. Nothing may be written in either case.
    Anything else (an exception escaping, another status) fails the test.
    """
    before = files_under(folder)
    capsys.readouterr()
    with _patched():
        try:
            code = main(argv)
        except Accepted:
            code = None
        except SystemExit as exc:  # argparse's refusals
            code = exc.code
    err = capsys.readouterr().err
    assert files_under(folder) == before, f"{argv} wrote {files_under(folder) - before}"
    if code is None:
        outcome = "accepted"
    else:
        assert code == EXIT_BAD_INPUT, f"{argv} exited {code}: {err}"
        assert "Traceback" not in err
        assert len(err.strip().splitlines()) == 1, f"{argv}: {err!r}"
        assert err.startswith("hitchpark"), err
        outcome = "refused"
    TALLY[test][outcome] += 1
    return outcome


def check_call(test: str, call: Callable[[], Any]) -> str:
    """Call the library; it must return or raise ``InputError`` with a one-line message. Tally the outcome."""
    try:
        call()
    except InputError as exc:
        assert "\n" not in str(exc) and str(exc), repr(exc)
        outcome = "refused"
    else:
        outcome = "accepted"
    TALLY[test][outcome] += 1
    return outcome

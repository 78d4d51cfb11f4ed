"""The benchmark scripts a user runs by hand refuse bad input as the CLI does: one line, status 2, no file touched."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPLAY = Path(__file__).resolve().parents[1] / "benchmarks" / "replay_problems.py"


def _replay(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(REPLAY), *args], capture_output=True, text=True, timeout=120)


def test_replay_does_not_overwrite_a_file(tmp_path: Path) -> None:
    existing = tmp_path / "mine.npz"
    existing.write_bytes(b"a user's file")
    done = _replay("record", "paper", "10", str(existing))
    assert done.returncode == 2
    assert "not overwritten" in done.stderr and "Traceback" not in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1
    assert existing.read_bytes() == b"a user's file"


@pytest.mark.slow
def test_replay_refuses_a_file_that_is_not_recorded_problems(tmp_path: Path) -> None:
    text = tmp_path / "notes.txt"
    text.write_text("not arrays\n")
    other = tmp_path / "other.npz"
    np.savez(other, p=np.zeros((2, 3)))
    for path, says in ((text, "not a file of recorded problems"), (other, "no w0, lbx")):
        done = _replay("solve", "paper", "10", str(path))
        assert done.returncode == 2, done.stderr
        assert says in done.stderr and "Traceback" not in done.stderr
    missing = _replay("solve", "paper", "10", str(tmp_path / "absent.npz"))
    assert missing.returncode == 2 and "is not a file" in missing.stderr


def test_replay_refuses_a_bad_horizon_or_count(tmp_path: Path) -> None:
    for args, says in (
        (("record", "paper", "0", str(tmp_path / "a.npz")), "horizon must be 1 to 500"),
        (("solve", "paper", "10", str(tmp_path / "a.npz"), "--repeat", "0"), "positive number"),
    ):
        done = _replay(*args)
        assert done.returncode == 2 and says in done.stderr
    assert not list(tmp_path.iterdir())


@pytest.mark.slow
def test_replay_round_trip_of_the_paper_ocp(tmp_path: Path) -> None:
    """What ``record`` saves is what the controller posed, and ``solve`` answers it from the file."""
    from hitchpark.app.bench import BENCH_OCPS, own_problems, record_problems
    from hitchpark.model import VehicleTrailer

    path = tmp_path / "paper10.npz"
    done = _replay("record", "paper", "10", str(path))
    assert done.returncode == 0, done.stderr
    assert not [p for p in tmp_path.iterdir() if p != path]  # no partial file left
    ocp = BENCH_OCPS["paper"]
    controller, recorded = record_problems(ocp, VehicleTrailer(), ocp.starts(4), 10)
    problems = own_problems(controller, recorded)
    with np.load(path) as archive:
        data = dict(archive)
    assert len(data["p"]) == len(problems) > 100
    assert f"{len(problems)} problems" in done.stdout
    for i in (0, len(problems) // 2, len(problems) - 1):
        for name in ("p", "w0", "lbx", "ubx", "lbg", "ubg"):
            np.testing.assert_array_equal(data[name][i], getattr(problems[i], name))
        if problems[i].lam_x0 is None:
            assert not data["duals"][i] and np.isnan(data["lam_x0"][i]).all()
        else:
            assert data["duals"][i]
            np.testing.assert_array_equal(data["lam_g0"][i], problems[i].lam_g0)
    assert data["duals"].sum() == sum(p.lam_x0 is not None for p in problems)
    solved = _replay("solve", "paper", "10", str(path), "--limit", "5", "--repeat", "2")
    assert solved.returncode == 0, solved.stderr
    assert "10 calls" in solved.stdout and "0 failed" in solved.stdout
    wrong = _replay("solve", "full", "10", str(path))  # another OCP's layout
    assert wrong.returncode == 2 and "full at N = 10 has" in wrong.stderr

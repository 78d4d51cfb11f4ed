"""Ctrl-C and kills, as a terminal and a user deal them: the command in a session of its own, signals to its group.

A terminal's Ctrl-C sends SIGINT to every process of the foreground group: the command and its workers.
The command must stop with exit status 130 and one line on stderr, its workers with it and silently,
and leave nothing half-written. Killed outright (SIGKILL), it cannot stop its workers: they must end
by themselves. The processes are found through /proc (Linux).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import hitchpark
from hitchpark.app.records import RecordWriter, scan_records
from hitchpark.app.sweep import CaseTask, SweepConfig, run_case
from hitchpark.app.workers import interrupts_deferred
from hitchpark.cli import EXIT_INTERRUPTED, main
from hitchpark.cli.interrupts import caused_by_interrupt
from hitchpark.control import NMPCSettings
from hitchpark.maneuver import ManeuverSettings
from hitchpark.model import PlantSettings

pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="finds processes through /proc")

SRC = str(Path(hitchpark.__file__).resolve().parents[1])
CODE = "import sys; from hitchpark.cli import main; sys.exit(main(sys.argv[1:]))"

#: The paper's process on the ideal plant: about 0.15 s a case, so sweeps of a few dozen cases stay short.
PAPER_IDEAL = {"paper.toml": '[nmpc]\nkind = "paper"\n', "ideal.toml": '[plant]\nkind = "ideal"\n'}

IDEAL = PlantSettings(kind="ideal")

#: Hang guards: how long a step may take before the test gives up (generous; nothing is timed).
START_S = 60.0
EXIT_S = 60.0  # measured: 10 s was too little on a 2-core machine running two sweeps beside the suite


def _stat(pid: int) -> list[str] | None:
    """Fields of /proc/PID/stat after the name (state, ppid, pgrp, ...); None once the process is gone."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii", errors="replace") as fh:
            stat = fh.read()
    except OSError:
        return None
    return stat[stat.rfind(")") + 2 :].split()


def alive(pid: int) -> bool:
    fields = _stat(pid)
    return fields is not None and fields[0] != "Z"


def processes(where: int, by: int) -> list[int]:
    """Live processes whose field ``by`` (1: parent, 2: process group) is ``where``."""
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit() and (fields := _stat(int(entry))) and fields[0] != "Z" and int(fields[by]) == where:
            found.append(int(entry))
    return found


def group(pgid: int) -> list[int]:
    return processes(pgid, by=2)


def children(pid: int) -> list[int]:
    return processes(pid, by=1)


def wait_until(condition, what: str, limit: float = START_S, proc: subprocess.Popen | None = None) -> None:
    deadline = time.monotonic() + limit
    while not condition():
        if proc is not None:
            assert proc.poll() is None, f"the command ended before {what}"
        assert time.monotonic() < deadline, f"no {what} within {limit:.0f} s"
        time.sleep(0.01)


def shown_lines(data: bytes) -> list[str]:
    """The lines a terminal shows: each line's text after its last carriage return, blank ones dropped."""
    text = data.decode("utf-8", "replace")
    return [shown for line in text.split("\n") if (shown := line.rsplit("\r", 1)[-1].strip())]


def start(argv: list[str], tmp_path: Path) -> subprocess.Popen:
    """The command in a session (and process group) of its own, output to files in ``tmp_path``."""
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join(p for p in (SRC, os.environ.get("PYTHONPATH")) if p),
        "PYTHONUNBUFFERED": "1",
        "HITCHPARK_JIT": "0",
    }
    with open(tmp_path / "stdout", "wb") as stdout, open(tmp_path / "stderr", "wb") as stderr:
        return subprocess.Popen(
            [sys.executable, "-c", CODE, *argv], env=env, stdout=stdout, stderr=stderr, start_new_session=True
        )


def interrupt_and_wait(proc: subprocess.Popen, times: int = 1) -> int:
    """Ctrl-C as a terminal sends it (``times`` presses), then wait for the command (hang guard only)."""
    try:
        for i in range(times):
            if i:
                time.sleep(0.05)
            os.killpg(proc.pid, signal.SIGINT)
        return proc.wait(timeout=EXIT_S)
    finally:
        if proc.poll() is None or group(proc.pid):
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()


def assert_group_ends(pgid: int) -> None:
    deadline = time.monotonic() + EXIT_S
    while (left := group(pgid)) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not left, f"processes of the command still running: {left}"


def sweep_argv(tmp_path: Path, out: Path, n: int, workers: int) -> list[str]:
    for name, text in PAPER_IDEAL.items():
        (tmp_path / name).write_text(text, encoding="utf-8")
    files = ["--settings", str(tmp_path / "paper.toml"), "--plant", str(tmp_path / "ideal.toml")]
    return ["sweep", "--n", str(n), "--seed", "11", *files, "--workers", str(workers), "--out", str(out)]


def whole_records(data: bytes) -> list[dict]:
    assert data == b"" or data.endswith(b"\n"), "the records file ends in a cut line"
    return [json.loads(line) for line in data.splitlines()]


@pytest.mark.slow
def test_ctrl_c_stops_a_pool_sweep_its_workers_and_keeps_whole_records_for_a_resume(tmp_path):
    out = tmp_path / "sweep.jsonl"
    argv = sweep_argv(tmp_path, out, n=12, workers=2)
    proc = start(argv, tmp_path)
    wait_until(lambda: out.exists() and b"\n" in out.read_bytes(), "record", proc=proc)
    workers = children(proc.pid)
    assert interrupt_and_wait(proc) == EXIT_INTERRUPTED
    err = (tmp_path / "stderr").read_bytes()
    assert b"Traceback" not in err
    assert shown_lines(err) == [
        f"hitchpark sweep: interrupted; the finished cases stay in {out}, the same command resumes"
    ]
    assert_group_ends(proc.pid)
    assert not [pid for pid in workers if alive(pid)]
    interrupted = out.read_bytes()
    done = whole_records(interrupted)
    assert 1 <= len(done) < 12
    resumed = start([*argv[:-4], "--workers", "1", "--out", str(out)], tmp_path)
    assert resumed.wait(timeout=START_S) == 0
    after = out.read_bytes()
    assert after.startswith(interrupted)
    assert sorted(r["case"] for r in whole_records(after)) == list(range(12))


@pytest.mark.slow
def test_ctrl_c_twice_while_reproduce_draws_leaves_the_output_folder_as_it_was(tmp_path):
    out = tmp_path / "out"
    (out / "parallel").mkdir(parents=True)
    earlier = {"summary.json": b'{"scenarios": []}\n', "parallel/maneuver.json": b"{}\n", "notes.txt": b"mine\n"}
    for name, data in earlier.items():
        (out / name).write_bytes(data)
    proc = start(["reproduce", "--out", str(out)], tmp_path)
    stdout = tmp_path / "stdout"
    # The four maneuvers done (a progress line each), the figures are being drawn by the pool's workers.
    wait_until(lambda: stdout.read_bytes().count(b"\n") >= 4, "progress lines", proc=proc)
    if (os.cpu_count() or 1) > 1:  # one core draws in the command's own process
        wait_until(lambda: len(children(proc.pid)) >= 2, "render workers", proc=proc)
    workers = children(proc.pid)
    assert interrupt_and_wait(proc, times=2) == EXIT_INTERRUPTED
    err = (tmp_path / "stderr").read_bytes()
    assert b"Traceback" not in err
    assert shown_lines(err) == ["hitchpark reproduce: interrupted"]
    assert_group_ends(proc.pid)
    assert not [pid for pid in workers if alive(pid)]
    assert sorted(p.relative_to(out).as_posix() for p in out.rglob("*")) == sorted([*earlier, "parallel"])
    assert all((out / name).read_bytes() == data for name, data in earlier.items())


@pytest.mark.slow
def test_ctrl_c_during_a_solve_stops_a_serial_sweep(tmp_path):
    # The default full NMPC on one process: most of the time goes into CasADi's solver, which catches
    # Ctrl-C itself; the interrupt must still reach the command.
    out = tmp_path / "serial.jsonl"
    proc = start(["sweep", "--n", "30", "--seed", "3", "--workers", "1", "--out", str(out)], tmp_path)
    wait_until(lambda: out.exists() and b"\n" in out.read_bytes(), "record", proc=proc)
    assert interrupt_and_wait(proc) == EXIT_INTERRUPTED
    err = (tmp_path / "stderr").read_bytes()
    assert b"Traceback" not in err and b"KeyboardInterrupt" not in err
    assert len(shown_lines(err)) == 1
    assert 1 <= len(whole_records(out.read_bytes())) < 30


@pytest.mark.slow
def test_ctrl_c_stops_a_sweep_on_a_dask_local_cluster_and_its_workers(tmp_path):
    pytest.importorskip("distributed")
    out = tmp_path / "dask.jsonl"
    argv = sweep_argv(tmp_path, out, n=30, workers=1)
    proc = start([*argv[:-2], "--dask", "local", "--out", str(out)], tmp_path)
    wait_until(lambda: out.exists() and b"\n" in out.read_bytes(), "record", proc=proc)
    workers = children(proc.pid)
    assert interrupt_and_wait(proc) == EXIT_INTERRUPTED
    err = (tmp_path / "stderr").read_bytes()
    assert b"Traceback" not in err
    assert len(shown_lines(err)) == 1
    assert_group_ends(proc.pid)
    assert not [pid for pid in workers if alive(pid)]
    assert 1 <= len(whole_records(out.read_bytes())) < 30


def test_workers_of_a_killed_sweep_end_by_themselves(tmp_path):
    out = tmp_path / "killed.jsonl"
    proc = start(sweep_argv(tmp_path, out, n=40, workers=2), tmp_path)
    try:
        wait_until(lambda: out.exists() and b"\n" in out.read_bytes(), "record", proc=proc)
        workers = children(proc.pid)  # the pool's workers (and multiprocessing's resource tracker)
        assert len(workers) >= 2
        os.kill(proc.pid, signal.SIGKILL)  # the command alone: nothing tells its workers
        proc.wait()
        deadline = time.monotonic() + EXIT_S
        while (left := [pid for pid in workers if alive(pid)]) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not left, f"workers still running after their parent was killed: {left}"
    finally:
        if group(proc.pid):
            os.killpg(proc.pid, signal.SIGKILL)


def test_a_process_watching_its_parent_ends_after_the_parent_is_killed(tmp_path):
    # The portable fallback (no PR_SET_PDEATHSIG): a thread that checks the parent every half second.
    child = (
        "import os, sys, time; from hitchpark.app.workers import end_with_parent; "
        "end_with_parent(os.getppid(), pdeathsig=False); print(os.getpid(), flush=True); time.sleep(60)"
    )
    parent = f"import subprocess, sys, time; subprocess.Popen([sys.executable, '-c', {child!r}]); time.sleep(60)"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (SRC, os.environ.get("PYTHONPATH")) if p)}
    proc = subprocess.Popen([sys.executable, "-c", parent], env=env, stdout=subprocess.PIPE, start_new_session=True)
    try:
        assert proc.stdout is not None
        pid = int(proc.stdout.readline())
        assert alive(pid)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
        deadline = time.monotonic() + EXIT_S
        while alive(pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not alive(pid)
    finally:
        if group(proc.pid):
            os.killpg(proc.pid, signal.SIGKILL)


# --- the pieces, in this process ------------------------------------------------------------------------


def test_a_ctrl_c_during_a_deferred_block_comes_at_its_end():
    reached_end = False
    with pytest.raises(KeyboardInterrupt):
        with interrupts_deferred():
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)  # Python runs the handler between bytecodes: here it only takes note
            reached_end = True
    assert reached_end
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_record_line_cut_short_by_ctrl_c_is_taken_back(tmp_path):
    config = SweepConfig(seed=1, n=2, settings=ManeuverSettings(nmpc=NMPCSettings(kind="paper")), plant=IDEAL)
    starts = config.starts()
    records = [run_case(CaseTask(config, case, start)) for case, start in enumerate(starts)]
    out = tmp_path / "records.jsonl"

    class HalfThenInterrupt:
        """The record file, but its next write puts out half of what it is given, and then Ctrl-C comes."""

        def __init__(self, fh):
            self.fh = fh

        def write(self, data):
            self.fh.write(data[: len(data) // 2])
            raise KeyboardInterrupt

        def __getattr__(self, name):
            return getattr(self.fh, name)

    with RecordWriter(out, scan_records(out, starts)) as writer:
        writer.write(records[0])
        whole = out.read_bytes()
        real, writer._fh = writer._fh, HalfThenInterrupt(writer._fh)
        with pytest.raises(KeyboardInterrupt):
            writer.write(records[1])
        writer._fh = real
    assert out.read_bytes() == whole


def test_an_interrupt_that_comes_back_from_c_code_as_another_error_is_an_interrupt(monkeypatch, capsys, tmp_path):
    # Ctrl-C landing in CasADi's DM.__array__, called by NumPy's C code, reached the command as
    # "SystemError: ... returned a result with an exception set", its cause the KeyboardInterrupt.
    def interrupted_in_c(*args, **kwargs):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as exc:
            raise SystemError("<function DM.__array__> returned a result with an exception set") from exc

    monkeypatch.setattr("hitchpark.maneuver.process.park", interrupted_in_c)
    code = main(["park", "--start", "10,3.5,0,0", "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == EXIT_INTERRUPTED
    assert err.count("\n") == 1 and "interrupted" in err and "Traceback" not in err
    assert caused_by_interrupt(SystemError()) is False


def test_a_bug_is_not_taken_for_an_interrupt(monkeypatch, tmp_path):
    def bug(*args, **kwargs):
        raise ZeroDivisionError

    monkeypatch.setattr("hitchpark.maneuver.process.park", bug)
    with pytest.raises(ZeroDivisionError):
        main(["park", "--start", "10,3.5,0,0", "--out", str(tmp_path / "out")])

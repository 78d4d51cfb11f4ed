"""Ctrl-C, measured: each command interrupted at a random moment of its work, several times.

    python benchmarks/interrupts.py [RUNS] [SEED]

Runs each case RUNS times (default 6) in a session of its own and, at a random moment after the
command has started working, sends SIGINT to its whole process group, as a terminal's Ctrl-C
does. Per case it prints the exit codes seen, the time from the signal to the exit of the command
(median and max), the lines left on stderr (as a terminal shows them: a progress bar redrawn with
carriage returns is one line) and whether any holds a traceback, the processes of the group still
alive a second after the exit, the staging folders left in the output folder, and whether what was
there before (an earlier result, finished sweep records) is unchanged.

"Started working" is the command's first output (the sweep's progress bar, reproduce's first
scenario) or, for park, which prints only at the end, 0.6 s after its start. A run that ends
before its signal is counted apart. The sweeps use the default settings (full NMPC, compiled
solver from the cache: run a sweep once beforehand so that no run compiles).
"""

from __future__ import annotations

import json
import os
import random
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"
CODE = "import sys; from hitchpark.cli import main; sys.exit(main(sys.argv[1:]))"


@dataclass
class Case:
    name: str
    argv: list[str]  # OUT stands for the output path
    window_s: float  # the signal comes uniformly within this many seconds after work started
    out_is_folder: bool
    quiet_until_end: bool = False


CASES = [
    Case("reproduce (plots)", ["reproduce", "--out", "OUT"], 12.0, True),
    Case("sweep pool", ["sweep", "--n", "60", "--seed", "5", "--workers", "2", "--out", "OUT"], 8.0, False),
    Case("sweep serial", ["sweep", "--n", "60", "--seed", "5", "--workers", "1", "--out", "OUT"], 8.0, False),
    Case(
        "sweep dask local",
        ["sweep", "--n", "60", "--seed", "5", "--workers", "2", "--dask", "local", "--out", "OUT"],
        8.0,
        False,
    ),
    Case("park (plots)", ["park", "--start", "12,-4,40,15", "--out", "OUT"], 5.0, True, quiet_until_end=True),
]


@dataclass
class Outcome:
    code: int | None = None
    seconds: float | None = None
    lines: int = 0
    traceback: bool = False
    leftover: int = 0
    staging: int = 0
    earlier_kept: bool = True
    finished_first: bool = False
    notes: list[str] = field(default_factory=list)


def group_members(pgid: int) -> list[int]:
    """Live (not zombie) processes of the process group ``pgid``."""
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat", encoding="ascii", errors="replace") as fh:
                stat = fh.read()
        except OSError:
            continue
        fields = stat[stat.rfind(")") + 2 :].split()
        if fields[0] != "Z" and int(fields[2]) == pgid:
            found.append(int(entry))
    return found


def shown_lines(data: bytes) -> list[str]:
    """The lines a terminal would show: each line's text after its last carriage return, blanks dropped."""
    text = data.decode("utf-8", "replace")
    return [shown for line in text.split("\n") if (shown := line.rsplit("\r", 1)[-1].strip())]


def prepare(case: Case, tmp: Path) -> tuple[Path, dict[str, bytes]]:
    """The output path, with an earlier result in it: what must still be there, byte for byte, after."""
    if case.out_is_folder:
        out = tmp / "out"
        out.mkdir()
        earlier = {"summary.json": b'{"earlier": true}\n', "notes.txt": b"an earlier result\n"}
        for name, data in earlier.items():
            (out / name).write_bytes(data)
        return out, earlier
    out = tmp / "sweep.jsonl"
    return out, {}


def run_once(case: Case, rng: random.Random) -> Outcome:
    outcome = Outcome()
    with tempfile.TemporaryDirectory(prefix="hitchpark-int-") as name:
        tmp = Path(name)
        out, earlier = prepare(case, tmp)
        argv = [str(out) if a == "OUT" else a for a in case.argv]
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (str(SRC), os.environ.get("PYTHONPATH")) if p)}
        proc = subprocess.Popen(
            [sys.executable, "-c", CODE, *argv],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            start_new_session=True,
        )
        streams: dict[str, bytearray] = {"out": bytearray(), "err": bytearray()}
        started = threading.Event()

        def read(stream: object, key: str) -> None:
            assert hasattr(stream, "read1")
            while chunk := stream.read1(65536):
                streams[key] += chunk
                started.set()

        readers = [
            threading.Thread(target=read, args=(proc.stdout, "out"), daemon=True),
            threading.Thread(target=read, args=(proc.stderr, "err"), daemon=True),
        ]
        for r in readers:
            r.start()
        if case.quiet_until_end:
            started.wait(0.6)
        else:
            while not started.wait(0.05) and proc.poll() is None:
                pass
        time.sleep(rng.uniform(0.0, case.window_s))
        if proc.poll() is not None:
            outcome.finished_first = True
            proc.wait()
            for r in readers:
                r.join()
            return outcome
        t_signal = time.monotonic()
        os.killpg(proc.pid, signal.SIGINT)
        try:
            proc.wait(timeout=60)
        except subprocess.TimeoutExpired:
            outcome.notes.append("did not exit within 60 s")
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
        outcome.seconds = time.monotonic() - t_signal
        outcome.code = proc.returncode
        time.sleep(1.0)
        outcome.leftover = len(group_members(proc.pid))
        if outcome.leftover:
            os.killpg(proc.pid, signal.SIGKILL)
        for r in readers:
            r.join(timeout=5)
        err = bytes(streams["err"])
        outcome.traceback = b"Traceback" in err
        outcome.lines = len(shown_lines(err))  # a sweep's progress bar is cleared on Ctrl-C
        if case.out_is_folder:
            outcome.staging = len(list(out.glob(".hitchpark-staging-*"))) if out.is_dir() else 0
            outcome.earlier_kept = all((out / n).read_bytes() == d for n, d in earlier.items())
        else:
            data = out.read_bytes() if out.exists() else b""
            lines = data.split(b"\n")
            whole = lines[-1] == b"" and all(_is_json(line) for line in lines[:-1])
            outcome.earlier_kept = whole
            if not whole:
                outcome.notes.append("records file holds a cut or broken line")
    return outcome


def _is_json(line: bytes) -> bool:
    try:
        json.loads(line)
    except ValueError:
        return False
    return True


def main(runs: int = 6, seed: int = 1) -> None:
    if not Path("/proc").is_dir():
        sys.exit("needs /proc (Linux) to find the processes left over")
    rng = random.Random(seed)
    header = (
        f"{'case':<18} {'runs':>4} {'exit codes':<14} {'signal->exit s':>15} {'stderr lines':>13} "
        f"{'traceback':>9} {'leftover procs':>14} {'staging':>7} {'earlier kept':>12}"
    )
    print(header)
    print("-" * len(header))
    for case in CASES:
        outcomes = [run_once(case, rng) for _ in range(runs)]
        hit = [o for o in outcomes if not o.finished_first]
        codes = sorted({o.code for o in hit if o.code is not None})
        times = [o.seconds for o in hit if o.seconds is not None]
        timing = f"{statistics.median(times):.2f} / {max(times):.2f}" if times else "-"
        lines = sorted({o.lines for o in hit})
        print(
            f"{case.name:<18} {len(hit):>4} {','.join(map(str, codes)) or '-':<14} {timing:>15} "
            f"{','.join(map(str, lines)) or '-':>13} {sum(o.traceback for o in hit):>9} "
            f"{sum(o.leftover for o in hit):>14} {sum(o.staging for o in hit):>7} "
            f"{sum(o.earlier_kept for o in hit):>9}/{len(hit):<2}"
        )
        for o in hit:
            for note in o.notes:
                print(f"    note: {note}")
        if len(hit) < len(outcomes):
            print(f"    ({len(outcomes) - len(hit)} run(s) finished before the signal)")
    print("\nsignal->exit: median / max seconds; stderr lines: the distinct counts seen; the last three columns")
    print("sum over the runs (processes of the group alive 1 s after the exit, staging folders left).")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:3]))

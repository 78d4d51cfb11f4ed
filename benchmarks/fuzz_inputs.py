"""Run the generated-bad-input suite (tests/fuzz) at scale and print what it saw.

    python benchmarks/fuzz_inputs.py [EXAMPLES]      # default 2000 examples per generator

Each generator (command lines, TOML files, saved maneuvers, library calls) draws EXAMPLES inputs;
every one must be accepted or refused on one line (exit status 2 / InputError), with no traceback
and nothing written. Prints the examples per generator, how many were refused and accepted, the
time, and pytest's verdict; exits with pytest's status.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def main(argv: list[str]) -> int:
    examples = int(argv[1]) if len(argv) > 1 else 2000
    with tempfile.TemporaryDirectory() as tmp:
        report = Path(tmp) / "tally.json"
        env = {**os.environ, "HITCHPARK_FUZZ_EXAMPLES": str(examples), "HITCHPARK_FUZZ_REPORT": str(report)}
        env.pop("CI", None)  # explore new examples, not the fixed ones CI replays
        started = time.perf_counter()
        proc = subprocess.run(
            [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(ROOT / "tests" / "fuzz")],
            cwd=ROOT,
            env=env,
            capture_output=True,
            text=True,
            check=False,
        )
        elapsed = time.perf_counter() - started
        tally = json.loads(report.read_text(encoding="utf-8")) if report.exists() else {}
    print(f"{'generator':<26}{'examples':>10}{'refused':>10}{'accepted':>10}")
    for name, counts in tally.items():
        total = sum(counts.values())
        print(f"{name:<26}{total:>10}{counts.get('refused', 0):>10}{counts.get('accepted', 0):>10}")
    total = sum(sum(c.values()) for c in tally.values())
    print(f"{'all':<26}{total:>10}")
    print(f"{elapsed:.0f} s; pytest: {proc.stdout.strip().splitlines()[-1] if proc.stdout.strip() else '(no output)'}")
    if proc.returncode != 0:
        print(proc.stdout[-5000:])
        print(proc.stderr[-2000:], file=sys.stderr)
    return proc.returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv))

"""The exported package's memory and code, by horizon: ``python benchmarks/export_sizes.py [--horizons 10 40 80]``.

For each horizon N it exports the default full-model NMPC (``hitchpark export``, the paper's random scenario for
the example) with ``nmpc.horizon = N``, builds it with the package's own Makefile (``make``: the static and the
shared library and the example, ``-O2``) and prints:

- the workspace: ``HITCHPARK_NMPC_WORKSPACE_BYTES`` (the header's bound, known when compiling) and what
  ``hitchpark_nmpc_workspace_size()`` of the built library needs;
- the sizes of ``libhitchpark_nmpc.a`` and ``libhitchpark_nmpc.so``, and of their text (code) and data
  (``size``), which do not grow with N (the generated functions are a stage's, the solver loops over stages);
- whether the example parks from the scenario's start (its exit status).
"""

from __future__ import annotations

import argparse
import ctypes
import shutil
import subprocess
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

from hitchpark.app.export import ExportSpec, package_files
from hitchpark.app.export_folder import copy_package
from hitchpark.maneuver.scenario import builtin_scenario
from hitchpark.ocp.settings import NMPCSettings


def text_and_data(library: Path) -> str:
    """``size``'s text and data+bss of a library (all members of an archive summed), or '-' without ``size``."""
    tool = shutil.which("size")
    if tool is None:
        return "-"
    lines = subprocess.run([tool, str(library)], capture_output=True, text=True, check=True).stdout.splitlines()[1:]
    text = sum(int(line.split()[0]) for line in lines)
    data = sum(int(line.split()[1]) + int(line.split()[2]) for line in lines)
    return f"{text / 1e3:.1f} kB / {data / 1e3:.1f} kB"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--horizons", type=int, nargs="+", default=[10, 40, 80])
    args = parser.parse_args(argv)
    if shutil.which("make") is None:
        print("no make on this machine", file=sys.stderr)
        return 2
    sc = builtin_scenario("random")
    head = f"{'N':>4} {'workspace bound':>16} {'workspace':>10} {'lib .a':>9} {'lib .so':>9}"
    print(f"{head}  text / data (.so)   example")
    with tempfile.TemporaryDirectory() as scratch:
        for n in args.horizons:
            spec = ExportSpec(sc.vehicle, replace(NMPCSettings(), horizon=n), sc.start, sc.goal, sc.plant, sc.name)
            files = package_files(spec)
            folder = Path(scratch) / f"N{n}"
            copy_package(files, folder)
            done = subprocess.run(["make", "-s", "-C", str(folder)], capture_output=True, text=True)
            if done.returncode != 0:
                print(f"{n:>4} did not build: {done.stderr.strip()[:300]}")
                return 1
            bound = next(line for line in files["include/hitchpark_nmpc.h"].splitlines() if "WORKSPACE_BYTES " in line)
            build = folder / "build"
            lib = ctypes.CDLL(str(build / "libhitchpark_nmpc.so"))
            lib.hitchpark_nmpc_workspace_size.restype = ctypes.c_size_t
            run = subprocess.run([str(build / "example")], capture_output=True, text=True, timeout=300)
            print(
                f"{n:>4} {int(bound.split()[-1]):>14} B {lib.hitchpark_nmpc_workspace_size():>8} B "
                f"{(build / 'libhitchpark_nmpc.a').stat().st_size / 1e3:>6.0f} kB "
                f"{(build / 'libhitchpark_nmpc.so').stat().st_size / 1e3:>6.0f} kB  "
                f"{text_and_data(build / 'libhitchpark_nmpc.so'):19}"
                f"{'parks' if run.returncode == 0 else f'exit {run.returncode}'}",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""What single precision costs the exported package: ``python benchmarks/single_precision.py [--settings FILE.toml]``.

For each of the paper's four scenarios it exports the full-model NMPC (``hitchpark export``, the scenario's start
and ideal plant for the example) twice: with the default solver options, and with ``--settings`` (default
``benchmarks/settings/single_precision.toml``, a tolerance float resolves). It builds the first in double precision
and the second in double and in single (the package's own Makefile: ``make``, ``make REAL=float``), runs each
example (one reverse stage in closed loop) and prints, per scenario: the stage's end and final distance at the
default options, the same with the settings, and the float build's largest differences from the double build of
the same settings (trailer position, commanded steer) and whether their rows are as many.
"""

from __future__ import annotations

import argparse
import io
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from hitchpark.app.export import ExportSpec, package_files
from hitchpark.app.export_folder import copy_package
from hitchpark.app.sil import sil_settings
from hitchpark.app.sweep import load_settings
from hitchpark.checks import InputError
from hitchpark.maneuver.scenario import BUILTIN_ORDER, builtin_scenario

SETTINGS = Path(__file__).with_name("settings") / "single_precision.toml"


def example_rows(folder: Path, real: str) -> np.ndarray:
    """The example's CSV rows, built with the package's Makefile in ``real`` precision (exit status 0 or 1 alike:
    parked within 5 cm or not; 2, a failure, raises)."""
    build = f"build-{real}"
    subprocess.run(["make", "-s", f"BUILD={build}", f"REAL={real}"], cwd=folder, check=True, capture_output=True)
    run = subprocess.run([str(folder / build / "example")], capture_output=True, text=True)
    if run.returncode not in (0, 1):
        raise RuntimeError(f"{folder.name} in {real}: {run.stderr.strip()}")
    return np.genfromtxt(io.StringIO(run.stdout), delimiter=",", names=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--settings", type=Path, default=SETTINGS, help="the settings the float build runs")
    args = parser.parse_args(argv)
    try:
        loose = load_settings(args.settings).nmpc
    except InputError as exc:
        print(f"single_precision: error: {exc}", file=sys.stderr)
        return 2
    print(f"{'scenario':15s} {'default, double':>22s} {'settings, double':>22s}  float against double (settings)")
    with tempfile.TemporaryDirectory() as scratch:
        for name in BUILTIN_ORDER:
            sc = builtin_scenario(name)
            rows = {}
            for label, nmpc in (("default", None), ("settings", loose)):
                settings = sil_settings(sc.settings, nmpc)
                folder = Path(scratch) / f"{name}-{label}"
                copy_package(package_files(ExportSpec(sc.vehicle, settings.nmpc, sc.start, sc.goal, sc.plant, name)),
                             folder)  # fmt: skip
                rows[label] = example_rows(folder, "double")
                if label == "settings":
                    rows["float"] = example_rows(folder, "float")

            def end(r: np.ndarray) -> str:
                return f"{r['t'][-1]:6.1f} s {1e3 * np.hypot(r['x_trailer'][-1], r['y_trailer'][-1]):8.2f} mm"

            a, b = rows["settings"], rows["float"]
            n = min(len(a), len(b))
            trailer = np.hypot(a["x_trailer"][:n] - b["x_trailer"][:n], a["y_trailer"][:n] - b["y_trailer"][:n]).max()
            steer = np.abs(a["front_steer_cmd"][:n] - b["front_steer_cmd"][:n]).max()
            same = "the same rows" if len(a) == len(b) else f"rows {len(a)} and {len(b)}"
            print(f"{name:15s} {end(rows['default']):>22s} {end(a):>22s}  trailer {1e6 * trailer:6.1f} um, "
                  f"steer command {steer:.1e} rad, {same} ({len(a)})")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())

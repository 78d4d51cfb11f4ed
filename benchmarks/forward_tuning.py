"""How the forward stage's settings shape the maneuver: the measurement behind their defaults.

    python benchmarks/forward_tuning.py

Parks from 40 start poses (the four scenarios plus 36 drawn with a fixed seed:
x ~ U(5, 12) m, y ~ U(-6, 6) m, yaw ~ U(-60, 60) deg, hitch ~ U(-25, 25) deg) for a grid of
look-ahead distances (2-6 m), distance thresholds (6, 8 m) and with/without the alignment condition, and
prints the success rate, mean maneuver time and the accuracy of the final reverse stage.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import replace

import numpy as np

from hitchpark.control import TrailerNMPC
from hitchpark.maneuver import ManeuverSettings, builtin_scenarios, park
from hitchpark.model import VehicleTrailer
from hitchpark.model.simulate import State


def starts() -> list[State]:
    out = [sc.start for sc in builtin_scenarios()]
    rng = np.random.default_rng(7)
    for _ in range(36):
        x, y, yaw, hitch = rng.uniform(5, 12), rng.uniform(-6, 6), rng.uniform(-60, 60), rng.uniform(-25, 25)
        out.append(State(x, y, math.radians(yaw), math.radians(hitch)))
    return out


def main() -> None:
    vehicle = VehicleTrailer()
    base = ManeuverSettings()
    controller = TrailerNMPC(vehicle, base.nmpc)
    poses = starts()
    print(f"{len(poses)} starts. Errors are those of the final reverse stage of the maneuvers that parked")
    print("after at least one forward stage; 'one-stage' counts those parked at once.\n")
    print(
        f"{'lookahead':>9}{'dist thr':>9}{'align':>6}{'parked':>8}{'one-stage':>10}{'stages':>7}{'T mean s':>9}"
        f"{'dist med mm':>12}{'dist max mm':>12}{'orient max':>11}{'hitch max':>10}"
    )
    grid = itertools.product([2.0, 3.0, 4.0, 6.0], [6.0, 8.0], [True, False])
    for lookahead, dist_thr, align in grid:
        fwd = replace(
            base.forward,
            lookahead=lookahead,
            distance_threshold=dist_thr,
            orientation_threshold=base.forward.orientation_threshold if align else math.pi,
        )
        settings = replace(base, forward=fwd)
        res = [park(vehicle, s, settings=settings, controller=controller) for s in poses]
        ok = [r for r in res if r.success]
        repositioned = [r for r in ok if len(r.stages) > 1]
        last = [[s for s in r.stages if s.kind == "reverse"][-1] for r in repositioned]
        d = np.array([s.distance_error_m for s in last]) * 1e3
        o = np.array([abs(s.orientation_error_deg) for s in last])
        h = np.array([abs(s.final_hitch_deg) for s in last])
        print(
            f"{lookahead:>9.1f}{dist_thr:>9.1f}{'yes' if align else 'no':>6}{len(ok):>5}/{len(res):<2}"
            f"{len(ok) - len(repositioned):>10}"
            f"{np.mean([len(r.stages) for r in res]):>7.2f}{np.mean([r.duration for r in res]):>9.1f}"
            f"{np.median(d):>12.3f}{d.max():>12.3f}{o.max():>11.4f}{h.max():>10.3f}"
        )


if __name__ == "__main__":
    main()

"""The viewer of each paper scenario and each scene of the obstacle suite, checked in headless Chromium.

    python benchmarks/viewers.py [--out DIR] [--only NAME ...]

Parks each of the nine built-in scenarios (the paper's four, the obstacle suite's five) as ``hitchpark park
--predictions`` does, writes its ``maneuver.html`` into DIR/NAME/ (default: a temporary folder), and opens it from
``file://`` in Debian's Chromium (Playwright, as the test suite does: ``tests/viz/browser.py``) with every other
request aborted. Per viewer it checks:

- it loads with no console error and no request off the disk;
- moving the timeline from the first row to the middle changes the picture of the scene and the readout;
- Play advances the time, and Pause holds it;
- unchecking each layer the record has (plan, predictions, paths, clearance) takes it off the scene (the viewer's
  list of what it drew, and the picture), checking it again brings it back;
- a screenshot of the whole page is not blank (many colours, a little dark ink).

It prints one row per scenario (duration, rows, file size, each check) and exits 1 if any check fails.
"""

from __future__ import annotations

import argparse
import io
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "viz"))

from hitchpark.app.report import suite_scenarios  # noqa: E402
from hitchpark.maneuver.process import park  # noqa: E402
from hitchpark.viz.viewer import write_viewer  # noqa: E402

LAYERS = ("plan", "predictions", "paths", "clearance")


def pixels(page) -> np.ndarray:
    from PIL import Image

    shot = page.page.locator("#scene").screenshot()
    return np.asarray(Image.open(io.BytesIO(shot)).convert("RGB"), dtype=int)


def changed(a: np.ndarray, b: np.ndarray) -> float:
    """The share of the scene's pixels that differ."""
    return float(np.mean(np.any(a != b, axis=-1))) if a.shape == b.shape else 1.0


def check(browser, path: Path) -> dict[str, str]:
    """Each check's verdict on one viewer: 'ok', or what went wrong."""
    from browser import Page
    from PIL import Image

    out: dict[str, str] = {}
    p = Page(browser, path)
    try:
        out["loads"] = "ok" if not p.errors and not p.blocked else f"errors {p.errors[:2]} blocked {p.blocked[:2]}"
        rows = int(p.js("window.hitchview.rows"))
        p.js("window.hitchview.setRow(0)")
        before, text = pixels(p), p.page.locator("#readout").inner_text()
        p.page.locator("#timeline").fill(str(rows // 2))
        moved = changed(before, pixels(p))
        same_text = p.page.locator("#readout").inner_text() == text
        at = int(p.js("document.body.dataset.row"))
        slid = at == rows // 2 and moved > 0.001 and not same_text
        out["slider"] = "ok" if slid else f"row {at}, {moved:.4f} changed"
        p.js("window.hitchview.setRow(0)")
        p.page.select_option("#speed", "8")
        p.page.click("#play")
        p.page.wait_for_function("() => Number(document.body.dataset.row) > 10", timeout=15_000)
        p.page.click("#play")
        held = int(p.js("document.body.dataset.row"))
        p.page.wait_for_timeout(300)
        out["play"] = "ok" if int(p.js("document.body.dataset.row")) == held > 10 else "did not hold"
        # A row where the record has a prediction (an NMPC acted), else the middle.
        preds = p.js("window.hitchview.data.predictions") or []
        solved = [k for k, q in enumerate(preds) if q]
        p.js(f"window.hitchview.setRow({solved[len(solved) // 2] if solved else rows // 2})")
        verdicts = []
        for layer in LAYERS:
            box = p.page.locator(f"#layer-{layer}")
            if box.is_disabled():
                verdicts.append(f"{layer}: none")
                continue
            shown, drew = pixels(p), layer in p.js("window.hitchview.view.drawn")
            box.uncheck()
            hidden, gone = pixels(p), layer not in p.js("window.hitchview.view.drawn")
            box.check()
            back = layer in p.js("window.hitchview.view.drawn")
            ok = drew and gone and back and changed(shown, hidden) > 0
            verdicts.append(f"{layer}: {'ok' if ok else 'FAILED'}")
        out["layers"] = ", ".join(verdicts)
        shot = np.asarray(Image.open(io.BytesIO(p.page.screenshot(full_page=True))).convert("RGB"), dtype=int)
        colours = len(np.unique(shot.reshape(-1, 3) // 16, axis=0))
        dark = float(np.mean(shot.sum(axis=-1) < 200))
        out["screenshot"] = "ok" if colours > 30 and 0.001 < dark < 0.5 else f"{colours} colours, {dark:.4f} dark"
        if p.errors:
            out["loads"] = f"errors {p.errors[:2]}"
    finally:
        p.close()
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, help="where to keep the viewers (default: a temporary folder)")
    parser.add_argument("--only", nargs="*", help="these scenarios only")
    args = parser.parse_args(argv)
    from browser import launched

    scenarios = [*suite_scenarios("paper"), *suite_scenarios("obstacles")]
    if args.only:
        scenarios = [s for s in scenarios if s.name in args.only]
    failed = False
    with tempfile.TemporaryDirectory() as scratch:
        out = args.out or Path(scratch)
        try:
            context = launched()
            browser = context.__enter__()
        except BaseException as e:  # pytest.skip outside pytest: no browser here
            print(f"no browser: {e}", file=sys.stderr)
            return 2
        try:
            print(f"{'scenario':16} {'parked':>6} {'time':>6} {'rows':>5} {'size':>8}  checks")
            for sc in scenarios:
                result = park(sc.vehicle, sc.start, sc.goal, sc.settings, name=sc.name, plant=sc.plant,
                              scene=sc.scene, predictions=True)  # fmt: skip
                folder = out / sc.name
                folder.mkdir(parents=True, exist_ok=True)
                path = write_viewer(result, folder / "maneuver.html", force=True)
                verdict = check(browser, path)
                bad = [k for k, v in verdict.items() if v != "ok" and ("FAILED" in v or k != "layers")]
                failed |= bool(bad)
                print(
                    f"{sc.name:16} {'yes' if result.success else 'no':>6} {result.duration:5.1f}s "
                    f"{len(result.trajectory['t']):5d} {path.stat().st_size / 1e6:6.3f}MB  "
                    + "; ".join(f"{k} {v}" for k, v in verdict.items()),
                    flush=True,
                )
        finally:
            context.__exit__(None, None, None)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

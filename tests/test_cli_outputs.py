"""What the commands may write: their own files only, never through a link or into a FIFO, never "" as a path."""

from __future__ import annotations

import errno
import os
import shutil
from pathlib import Path

import pytest

from hitchpark.app.report import ANIMATION_FILE, FIGURE_FILES, MANEUVER_FILES, VIEWER_FILE, reproduce
from hitchpark.cli import EXIT_BAD_INPUT
from hitchpark.maneuver.scenario import builtin_scenarios
from test_cli import one_error_line, run, simulate_argv
from test_cli_maneuver import run_captured
from test_staging import snapshot

PAPER_TOML, IDEAL_TOML = '[nmpc]\nkind = "paper"\n', '[plant]\nkind = "ideal"\n'
PARK = ["park", "--start", "10,3.5,0,0"]


def sweep_argv(tmp_path: Path, **paths: str) -> list[str]:
    """A one-case sweep of the paper's process on the ideal car (fast), with output paths ``--out``, ..."""
    (tmp_path / "paper.toml").write_text(PAPER_TOML, encoding="utf-8")
    (tmp_path / "ideal.toml").write_text(IDEAL_TOML, encoding="utf-8")
    argv = ["sweep", "--n", "1", "--seed", "0", "--workers", "1"]
    argv += ["--settings", str(tmp_path / "paper.toml"), "--plant", str(tmp_path / "ideal.toml")]
    paths = {"out": str(tmp_path / "s.jsonl"), **paths}
    return argv + [item for flag, path in paths.items() for item in (f"--{flag}", path)]


# --- "" is no path ----------------------------------------------------------------------------------------

EMPTY = {
    "simulate --json": lambda p: [*simulate_argv(Path("x"))[:-1], ""],
    "park --out": lambda p: [*PARK, "--out", ""],
    "reproduce --out": lambda p: ["reproduce", "--out", ""],
    "ik-study --out": lambda p: ["ik-study", "--out", ""],
    "plot --out": lambda p: ["plot", str(p / "maneuver.json"), "--out", ""],
    "sweep --out": lambda p: sweep_argv(p, out=""),
    "sweep --json": lambda p: sweep_argv(p, json=""),
    "sweep --map": lambda p: sweep_argv(p, map=""),
}


@pytest.mark.parametrize("case", list(EMPTY))
def test_an_empty_output_path_is_refused(tmp_path, monkeypatch, capsys, case):
    """``--out ""`` would write into the current folder: refused, nothing written anywhere."""
    argv = EMPTY[case](tmp_path)
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    monkeypatch.chdir(cwd)
    before = snapshot(tmp_path)
    assert run(argv) == EXIT_BAD_INPUT
    line = one_error_line(capsys.readouterr().err)
    assert f"{case.split()[1]} is empty" in line, line
    assert snapshot(tmp_path) == before


# --- FIFOs, devices, links --------------------------------------------------------------------------------


def make_special(tmp_path: Path, kind: str) -> Path:
    if kind == "FIFO":
        os.mkfifo(tmp_path / "pipe")
        return tmp_path / "pipe"
    if kind == "device":
        return Path(os.devnull)
    (tmp_path / "mine.txt").write_text("the user's own file\n")
    (tmp_path / "link").symlink_to(tmp_path / "mine.txt")
    return tmp_path / "link"


SPECIAL = [
    (command, flag, kind)
    for command, flag in [("simulate", "--json"), ("sweep", "--out"), ("sweep", "--json"), ("sweep", "--map")]
    for kind in ("FIFO", "device", "symbolic link")
]


@pytest.mark.parametrize(("command", "flag", "kind"), SPECIAL)
def test_an_output_file_that_is_not_a_regular_file_is_refused(tmp_path, capsys, command, flag, kind):
    target = make_special(tmp_path, kind)
    if command == "simulate":
        argv = simulate_argv(target)
    else:
        argv = sweep_argv(tmp_path, **{flag[2:]: str(target)})
    before = snapshot(tmp_path)
    assert run(argv) == EXIT_BAD_INPUT
    line = one_error_line(capsys.readouterr().err)
    assert f"{flag} {target} is a" in line and kind in line and "not a regular file" in line, line
    assert snapshot(tmp_path) == before  # the link, the file it points to, the FIFO: as they were


def test_an_out_folder_link_is_followed_only_to_a_folder(tmp_path, capsys):
    (tmp_path / "results").mkdir()
    (tmp_path / "to-folder").symlink_to(tmp_path / "results")
    assert run(["ik-study", "--out", str(tmp_path / "to-folder"), "--no-plots"]) == 0
    assert (tmp_path / "to-folder").is_symlink()
    assert [p.name for p in (tmp_path / "results").iterdir()] == ["ik_study.json"]
    (tmp_path / "to-file").symlink_to(tmp_path / "results" / "ik_study.json")
    before = snapshot(tmp_path)
    assert run(["ik-study", "--out", str(tmp_path / "to-file"), "--no-plots"]) == EXIT_BAD_INPUT
    assert "is a symbolic link to no folder" in one_error_line(capsys.readouterr().err)
    assert snapshot(tmp_path) == before


def test_a_folder_that_is_not_writable_is_refused_before_any_work(tmp_path, monkeypatch, capsys):
    import hitchpark.maneuver.process as process

    real_access = os.access
    monkeypatch.setattr(os, "access", lambda path, mode, **kw: Path(path) != tmp_path and real_access(path, mode))
    monkeypatch.setattr(process, "park", lambda *a, **kw: pytest.fail("the maneuver ran"))
    assert run([*PARK, "--out", str(tmp_path), "--no-plots"]) == EXIT_BAD_INPUT
    assert f"--out {tmp_path} is a folder that is not writable" in one_error_line(capsys.readouterr().err)
    assert run(simulate_argv(tmp_path / "new" / "run.json")) == EXIT_BAD_INPUT
    assert f"the folder {tmp_path} is not writable" in one_error_line(capsys.readouterr().err)
    assert not any(tmp_path.iterdir())


# --- a command replaces its own files and no others ---------------------------------------------------


def seed_stale(folder: Path, names: tuple[str, ...]) -> None:
    """Files of an earlier run at the names a command owns, and the user's own beside them."""
    folder.mkdir(parents=True, exist_ok=True)
    for name in names:
        (folder / name).write_text(f"earlier {name}")
    (folder / "notes.txt").write_text("the user's notes")
    (folder / "mine").mkdir()
    (folder / "mine" / "motion.png").write_text("the user's picture")


@pytest.fixture(scope="module")
def reparked(tmp_path_factory):
    """``park --no-plots`` into a folder that holds a full earlier park's files and the user's own."""
    folder = tmp_path_factory.mktemp("repark") / "out"
    seed_stale(folder, MANEUVER_FILES)
    return run_captured([*PARK, "--out", str(folder), "--no-plots"], folder)


def test_park_without_plots_removes_the_figures_of_an_earlier_run(reparked):
    assert reparked.code == 0, reparked.err
    tree = snapshot(reparked.folder)
    assert sorted(tree) == ["maneuver.json", "mine", "mine/motion.png", "notes.txt", "trajectory.csv"]
    assert tree["notes.txt"] == b"the user's notes" and tree["mine/motion.png"] == b"the user's picture"
    assert tree["maneuver.json"].startswith(b"{")  # the new one


@pytest.mark.slow
def test_plot_replaces_only_figures(reparked, tmp_path, capsys):
    """Plotting beside a maneuver.json: the figures and the viewer are new, the stale GIF is gone, the data and notes
    stay."""
    folder = tmp_path / "m"
    shutil.copytree(reparked.folder, folder)
    (folder / ANIMATION_FILE).write_text("a GIF of an earlier maneuver")
    (folder / "motion.png").write_text("a figure of an earlier maneuver")
    data = snapshot(folder)
    assert run(["plot", str(folder / "maneuver.json"), "--no-animation"]) == 0, capsys.readouterr().err
    tree = snapshot(folder)
    kept = ("maneuver.json", "trajectory.csv", "notes.txt", "mine/motion.png")
    assert sorted(tree) == sorted({*FIGURE_FILES, VIEWER_FILE, *kept, "mine"})
    assert tree[VIEWER_FILE].startswith(b"<!DOCTYPE html>")
    for name in kept:
        assert tree[name] == data[name]
    for name in FIGURE_FILES:
        assert tree[name].startswith(b"\x89PNG")


def test_ik_study_without_plots_removes_its_earlier_figure(tmp_path):
    folder = tmp_path / "ik"
    seed_stale(folder, ("ik_study.json", "ik_study.png"))
    assert run(["ik-study", "--out", str(folder), "--no-plots"]) == 0
    tree = snapshot(folder)
    assert sorted(tree) == ["ik_study.json", "mine", "mine/motion.png", "notes.txt"]
    assert tree["ik_study.json"].startswith(b"{")


def test_reproduce_merges_into_the_user_s_scenario_folders(tmp_path):
    """Only summary.json and each <scenario>/ maneuver file are the command's; a folder is never replaced."""
    out = tmp_path / "rep"
    seed_stale(out / "parallel", MANEUVER_FILES)
    (out / "summary.json").write_text("earlier summary")
    (out / "report.md").write_text("the user's report")
    (out / "random").mkdir()
    (out / "random" / "maneuver.json").write_text("not this run's scenario: stays")
    reproduce(out, scenarios=builtin_scenarios()[:1])
    tree = snapshot(out)
    assert sorted(tree) == [
        "parallel",
        "parallel/maneuver.json",
        "parallel/mine",
        "parallel/mine/motion.png",
        "parallel/notes.txt",
        "parallel/trajectory.csv",
        "random",
        "random/maneuver.json",
        "report.md",
        "summary.json",
    ]
    assert tree["parallel/notes.txt"] == b"the user's notes" and tree["report.md"] == b"the user's report"
    assert tree["summary.json"].startswith(b"{")


# --- the sweep's summary and map ---------------------------------------------------------------------------


def test_sweep_map_is_written_whole(tmp_path, monkeypatch, capsys):
    from matplotlib.figure import Figure

    (tmp_path / "map.png").write_text("the earlier map")

    def broken_savefig(self, fname, **kwargs):
        Path(fname).write_bytes(b"\x89PNG half")
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(Figure, "savefig", broken_savefig)
    assert run(sweep_argv(tmp_path, map=str(tmp_path / "map.png"))) == EXIT_BAD_INPUT
    line = capsys.readouterr().err.splitlines()[-1]  # after the progress bar
    assert line.startswith("hitchpark sweep: error: cannot write output: ") and "Traceback" not in line
    assert f"{tmp_path / 'map.png'}: No space left" in line
    assert (tmp_path / "map.png").read_text() == "the earlier map"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ideal.toml", "map.png", "paper.toml", "s.jsonl"]

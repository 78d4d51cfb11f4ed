"""Output folders published whole (hitchpark.staging): owned files only, all or nothing, crashes cleaned up."""

from __future__ import annotations

import errno
import os
import signal
import stat
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import hitchpark
from hitchpark import outputs
from hitchpark.staging import STAGING_PREFIX, StagedFolder, clean_stale_staging

SRC = str(Path(hitchpark.__file__).resolve().parents[1])


def snapshot(root: Path) -> dict[str, str | bytes]:
    """Every entry under ``root`` (hidden ones too): a folder as "dir", a link as its target, a file as its bytes.

    Anything else (a FIFO) as its kind, never opened.
    """
    tree: dict[str, str | bytes] = {}
    for here, dirs, files in os.walk(root):
        for name in dirs + files:
            path = Path(here) / name
            rel = path.relative_to(root).as_posix()
            mode = path.lstat().st_mode
            if stat.S_ISLNK(mode):
                tree[rel] = "link -> " + os.readlink(path)
            elif stat.S_ISDIR(mode):
                tree[rel] = "dir"
            elif stat.S_ISREG(mode):
                tree[rel] = path.read_bytes()
            else:
                tree[rel] = f"special {stat.S_IFMT(mode):o}"
    return tree


def staging_name(pid: int, start: str = "0") -> str:
    return f"{STAGING_PREFIX}{outputs._host()}-{pid}-{start}-abc123"


def ended_pid() -> int:
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


# --- what publishing replaces ------------------------------------------------------------------------


def test_publish_merges_and_replaces_only_owned_files(tmp_path):
    out = tmp_path / "out"
    (out / "a").mkdir(parents=True)
    (out / "a" / "notes.txt").write_text("the user's")
    (out / "a" / "fig.png").write_text("a figure of an earlier run")
    (out / "keep.txt").write_text("keep")
    (out / "summary.json").write_text("old")
    with StagedFolder(out, owns=["summary.json", "a/new.txt", "a/fig.png"]) as stage:
        (stage / "a").mkdir()
        (stage / "a" / "new.txt").write_text("new")
        (stage / "summary.json").write_text("{}")
    assert snapshot(out) == {
        "a": "dir",
        "a/new.txt": b"new",
        "a/notes.txt": b"the user's",  # a folder is merged: what the command does not own stays
        "keep.txt": b"keep",
        "summary.json": b"{}",
    }  # the stale owned figure is gone, and so is the staging folder


def test_an_owned_name_that_is_a_folder_is_left_alone(tmp_path):
    out = tmp_path / "out"
    (out / "fig.png").mkdir(parents=True)
    (out / "fig.png" / "mine").write_text("x")
    with StagedFolder(out, owns=["fig.png", "data.json"]) as stage:
        (stage / "data.json").write_text("{}")
    assert snapshot(out) == {"fig.png": "dir", "fig.png/mine": b"x", "data.json": b"{}"}


def test_an_owned_link_is_replaced_not_written_through(tmp_path):
    elsewhere = tmp_path / "elsewhere.png"
    elsewhere.write_text("the user's picture")
    out = tmp_path / "out"
    out.mkdir()
    (out / "fig.png").symlink_to(elsewhere)
    with StagedFolder(out, owns=["fig.png"]) as stage:
        (stage / "fig.png").write_text("new figure")
    assert not (out / "fig.png").is_symlink() and (out / "fig.png").read_text() == "new figure"
    assert elsewhere.read_text() == "the user's picture"


def test_staged_folder_leaves_nothing_on_error(tmp_path):
    out = tmp_path / "out"
    with pytest.raises(RuntimeError), StagedFolder(out) as stage:
        (stage / "half.json").write_text("{")
        raise RuntimeError("boom")
    assert not out.exists()  # created by the stage, removed again


@pytest.mark.parametrize("in_the_way", ["file", "link"])
def test_staged_folder_clash_moves_nothing(tmp_path, in_the_way):
    out = tmp_path / "out"
    (out / "summary.json").mkdir(parents=True)  # a folder where a file goes
    if in_the_way == "file":
        (out / "scenario").write_text("a file where a folder goes")
    else:
        (out / "scenario").symlink_to(tmp_path)  # a link where a folder goes: never written through
    before = snapshot(out)
    with pytest.raises(ValueError, match="in the way"), StagedFolder(out, owns=["x.json"]) as stage:
        (stage / "scenario").mkdir()
        (stage / "scenario" / "x.json").write_text("{}")
        (stage / "summary.json").write_text("{}")
    assert snapshot(out) == before


def test_staged_folder_target_is_a_file(tmp_path):
    target = tmp_path / "file"
    target.write_text("x")
    with pytest.raises(ValueError, match="not a folder"):
        StagedFolder(target)


@pytest.mark.parametrize("name", ["/abs.json", "../up.json", "a/../../up.json", ""])
def test_owned_names_stay_inside(tmp_path, name):
    with pytest.raises(ValueError, match="inside the output folder"):
        StagedFolder(tmp_path, owns=[name])


# --- all or nothing ------------------------------------------------------------------------------------


def fill_old(out: Path) -> None:
    (out / "a").mkdir(parents=True)
    (out / "a" / "m.json").write_text("old m")
    (out / "a" / "x.png").write_text("old x")
    (out / "a" / "user.txt").write_text("the user's")
    (out / "summary.json").write_text("old summary")


def stage_new(stage: Path) -> None:
    (stage / "a").mkdir()
    (stage / "a" / "m.json").write_text("new m")
    (stage / "b").mkdir()
    (stage / "b" / "new.json").write_text("new b")
    (stage / "summary.json").write_text("new summary")


OWNS = ["summary.json", "a/m.json", "a/x.png", "b/new.json"]
# Three owned files there are moved aside, then three new ones moved in.
REPLACES = 6


def failing_replace(monkeypatch, nth: int, error: BaseException, then_all: bool = False) -> None:
    """``os.replace`` fails on its ``nth`` call (and every later one if ``then_all``)."""
    real = os.replace
    calls = [0]

    def replace(src, dst):
        calls[0] += 1
        if calls[0] == nth or (then_all and calls[0] > nth):
            raise error
        real(src, dst)

    monkeypatch.setattr(os, "replace", replace)


@pytest.mark.parametrize("error", [OSError(errno.EIO, "I/O error"), KeyboardInterrupt()], ids=["EIO", "interrupt"])
@pytest.mark.parametrize("nth", range(1, REPLACES + 1))
def test_publish_failing_halfway_leaves_the_folder_as_it_was(tmp_path, monkeypatch, nth, error):
    out = tmp_path / "out"
    fill_old(out)
    before = snapshot(out)
    with pytest.raises(type(error)), StagedFolder(out, OWNS) as stage:
        stage_new(stage)
        failing_replace(monkeypatch, nth, error)
    monkeypatch.undo()
    assert snapshot(out) == before


def test_publish_without_failure_replaces_all(tmp_path):
    out = tmp_path / "out"
    fill_old(out)
    with StagedFolder(out, OWNS) as stage:
        stage_new(stage)
    assert snapshot(out) == {
        "a": "dir",
        "a/m.json": b"new m",
        "a/user.txt": b"the user's",
        "b": "dir",
        "b/new.json": b"new b",
        "summary.json": b"new summary",
    }


def test_a_failed_roll_back_keeps_the_old_files_for_the_next_run(tmp_path, monkeypatch):
    """If even moving back fails, the old files wait in the staging folder; a later run puts them back."""
    out = tmp_path / "out"
    fill_old(out)
    before = snapshot(out)
    with pytest.raises(OSError), StagedFolder(out, OWNS) as stage:
        stage_new(stage)
        failing_replace(monkeypatch, 5, OSError(errno.EIO, "I/O error"), then_all=True)
    monkeypatch.undo()
    (left,) = (p for p in out.iterdir() if p.name.startswith(STAGING_PREFIX))
    assert sorted((left / "old").rglob("*.*")) != []
    left.rename(out / staging_name(ended_pid()))  # as if this process had died since
    with StagedFolder(out):
        pass
    assert snapshot(out) == before


# --- a killed run, cleaned up by the next --------------------------------------------------------------

CHILD = textwrap.dedent(
    """
    import os, signal, sys
    from pathlib import Path
    from hitchpark.staging import StagedFolder

    out, nth = Path(sys.argv[1]), int(sys.argv[2])
    real, calls = os.replace, [0]

    def replace(src, dst):
        calls[0] += 1
        if calls[0] == nth:
            os.kill(os.getpid(), signal.SIGKILL)
        real(src, dst)

    with StagedFolder(out, ["summary.json", "a/m.json", "a/x.png", "b/new.json"]) as stage:
        (stage / "a").mkdir()
        (stage / "a" / "m.json").write_text("new m")
        (stage / "b").mkdir()
        (stage / "b" / "new.json").write_text("new b")
        (stage / "summary.json").write_text("new summary")
        os.replace = replace
    """
)


@pytest.mark.parametrize("nth", [1, 3, 4, 6])
def test_a_run_killed_mid_publish_is_rolled_back_by_the_next(tmp_path, nth):
    out = tmp_path / "out"
    fill_old(out)
    before = snapshot(out)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (SRC, os.environ.get("PYTHONPATH")) if p)}
    proc = subprocess.run([sys.executable, "-c", CHILD, str(out), str(nth)], env=env, check=False)
    assert proc.returncode == -signal.SIGKILL
    assert snapshot(out) != before  # killed halfway: a staging folder, maybe a mix of old and new
    with StagedFolder(out):  # the next run into the same folder
        pass
    assert snapshot(out) == before


def test_only_staging_folders_of_ended_processes_are_removed(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "user.txt").write_text("the user's")
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        start = outputs._start_time(sleeper.pid) or "0"
        keep = [
            staging_name(sleeper.pid, start),  # a live process
            staging_name(os.getpid(), outputs._start_time(os.getpid()) or "0"),  # this one
            f"{STAGING_PREFIX}0badc0de-{ended_pid()}-0-abc123",  # another machine's
            f"{STAGING_PREFIX}k3jd8x",  # a name of no known owner
        ]
        gone = [staging_name(ended_pid())]  # killed while it staged: no plan, nothing published
        for name in keep + gone:
            (out / name / "new").mkdir(parents=True)
            (out / name / "new" / "half.json").write_text("{")
        assert clean_stale_staging(out) == [out / name for name in gone]
        assert sorted(p.name for p in out.iterdir()) == sorted([*keep, "user.txt"])
    finally:
        sleeper.kill()
        sleeper.wait()


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="start times are read from /proc")
def test_a_reused_pid_does_not_keep_a_staging_folder(tmp_path):
    name = staging_name(os.getpid(), "1")  # this PID, but a process that started at another time
    (tmp_path / name / "new").mkdir(parents=True)
    assert clean_stale_staging(tmp_path) == [tmp_path / name]
    assert not any(tmp_path.iterdir())

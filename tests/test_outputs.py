"""The checks of output paths and files replaced whole (hitchpark.outputs)."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from hitchpark import outputs
from hitchpark.outputs import check_output_file, check_output_folder, replacing


def fifo(tmp_path: Path) -> Path:
    path = tmp_path / "pipe"
    os.mkfifo(path)
    return path


def link_to_file(tmp_path: Path) -> Path:
    (tmp_path / "real.json").write_text("the user's")
    (tmp_path / "link.json").symlink_to(tmp_path / "real.json")
    return tmp_path / "link.json"


def link_to_folder(tmp_path: Path) -> Path:
    (tmp_path / "real").mkdir()
    (tmp_path / "link").symlink_to(tmp_path / "real")
    return tmp_path / "link"


def dangling_link(tmp_path: Path) -> Path:
    (tmp_path / "dangling").symlink_to(tmp_path / "absent")
    return tmp_path / "dangling"


def unix_socket(tmp_path: Path) -> Path:
    path = tmp_path / "s.sock"
    server = socket.socket(socket.AF_UNIX)
    server.bind(str(path))
    server.close()  # the socket file stays
    return path


def folder(tmp_path: Path) -> Path:
    (tmp_path / "dir").mkdir()
    return tmp_path / "dir"


def regular(tmp_path: Path) -> Path:
    (tmp_path / "file").write_text("x")
    return tmp_path / "file"


def through_a_file(tmp_path: Path) -> Path:
    return regular(tmp_path) / "inside.json"


BAD_FILES = {
    "empty": (lambda p: "", "--json is empty"),
    "folder": (folder, "is a folder"),
    "FIFO": (fifo, "is a FIFO (named pipe), not a regular file"),
    "link to a file": (link_to_file, "is a symbolic link, not a regular file"),
    "dangling link": (dangling_link, "is a symbolic link"),
    "socket": (unix_socket, "is a socket"),
    "device": (lambda p: Path(os.devnull), "is a device"),
    "path through a file": (through_a_file, "a part of the path is not a folder"),
}


@pytest.mark.parametrize("case", list(BAD_FILES))
def test_check_output_file_refuses(tmp_path, case):
    make, words = BAD_FILES[case]
    path = make(tmp_path)
    with pytest.raises(ValueError, match=r"^--json") as exc:
        check_output_file(path, "--json")
    assert words in str(exc.value)


def test_check_output_file_allows_a_file_or_a_new_name(tmp_path):
    assert check_output_file(str(regular(tmp_path)), "--json") == tmp_path / "file"
    assert check_output_file(tmp_path / "new" / "deeper" / "a.json", "--json") == tmp_path / "new" / "deeper" / "a.json"
    assert not (tmp_path / "new").exists()  # a check creates nothing


BAD_FOLDERS = {
    "empty": (lambda p: "", "--out is empty"),
    "file": (regular, "exists and is not a folder: it is a regular file"),
    "FIFO": (fifo, "it is a FIFO"),
    "link to a file": (link_to_file, "is a symbolic link to no folder"),
    "dangling link": (dangling_link, "is a symbolic link to no folder"),
    "path through a file": (through_a_file, "a part of the path is not a folder"),
}


@pytest.mark.parametrize("case", list(BAD_FOLDERS))
def test_check_output_folder_refuses(tmp_path, case):
    make, words = BAD_FOLDERS[case]
    with pytest.raises(ValueError, match=r"^--out") as exc:
        check_output_folder(make(tmp_path), "--out")
    assert words in str(exc.value)


def test_check_output_folder_allows_a_folder_a_link_to_one_or_a_new_name(tmp_path):
    assert check_output_folder(folder(tmp_path), "--out") == tmp_path / "dir"
    assert check_output_folder(link_to_folder(tmp_path), "--out") == tmp_path / "link"
    assert check_output_folder(".", "--out") == Path(".")
    assert check_output_folder(tmp_path / "a" / "b", "--out") == tmp_path / "a" / "b"
    assert not (tmp_path / "a").exists()


def deny_writing(monkeypatch, where: Path) -> None:
    """``os.access`` says ``where`` is not writable (a real read-only folder does not stop root)."""
    real = os.access

    def access(path, mode, **kwargs):
        return not (mode & os.W_OK and Path(path) == where) and real(path, mode, **kwargs)

    monkeypatch.setattr(os, "access", access)


def test_a_folder_that_is_not_writable_is_refused(tmp_path, monkeypatch):
    deny_writing(monkeypatch, tmp_path)
    with pytest.raises(ValueError, match="is a folder that is not writable"):
        check_output_folder(tmp_path, "--out")
    with pytest.raises(ValueError, match=f"the folder {tmp_path} is not writable"):
        check_output_folder(tmp_path / "new", "--out")
    with pytest.raises(ValueError, match=f"the folder {tmp_path} is not writable"):
        check_output_file(tmp_path / "a" / "b.json", "--json")


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root writes into any folder")
def test_a_read_only_folder_is_refused(tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o555)
    try:
        with pytest.raises(ValueError, match="not writable"):
            check_output_folder(locked, "--out")
        with pytest.raises(ValueError, match="not writable"):
            check_output_file(locked / "a.json", "--json")
    finally:
        locked.chmod(0o755)


def test_appending_needs_a_writable_file(tmp_path, monkeypatch):
    path = regular(tmp_path)
    deny_writing(monkeypatch, path)
    assert check_output_file(path, "--json") == path  # replaced by a rename: the folder's permission counts
    with pytest.raises(ValueError, match="is not writable"):
        check_output_file(path, "--out", append=True)


def test_replacing_is_whole_or_nothing(tmp_path):
    path = tmp_path / "map.png"
    path.write_text("old")
    with pytest.raises(RuntimeError), replacing(path) as tmp:
        assert tmp.parent == tmp_path and tmp.suffix == ".png" and tmp != path
        tmp.write_text("half")
        raise RuntimeError("drawing failed")
    assert path.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["map.png"]
    with replacing(path) as tmp:
        tmp.write_text("new")
    assert path.read_text() == "new"
    assert [p.name for p in tmp_path.iterdir()] == ["map.png"]


def test_temporaries_of_ended_processes_are_removed_by_the_next_writer(tmp_path):
    path = tmp_path / "summary.json"
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        live_start = outputs._start_time(sleeper.pid) or "0"
        host = outputs._host()
        dead = tmp_path / f".summary.json.hitchpark-{host}-999999999-1.abc.tmp.json"  # no such process
        live = tmp_path / f".summary.json.hitchpark-{host}-{sleeper.pid}-{live_start}.abc.tmp.json"
        other_file = tmp_path / f".other.json.hitchpark-{host}-999999999-1.abc.tmp.json"
        for p in (dead, live, other_file):
            p.write_text("half")
        with replacing(path) as tmp:
            tmp.write_text("{}")
        assert path.read_text() == "{}"
        assert not dead.exists()  # a kill while writing: its half file goes
        assert live.exists() and other_file.exists()  # a live writer's, and another file's, stay
    finally:
        sleeper.kill()
        sleeper.wait()

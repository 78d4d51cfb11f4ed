"""Where a command may write: the checks of every output path, and files replaced in one step.

Every command checks its output paths here before it does any work, so a bad one gets the same
one-line :class:`~hitchpark.checks.InputError` whichever command was given it:

* :func:`check_output_file`: a regular file to replace (or append to) or a new name;
  :func:`check_output_files` several, each a different file;
* :func:`check_output_folder`: a folder to write into, or a new one;
* :func:`replacing`: write a file under a temporary name beside it, then swap it in whole.
"""

from __future__ import annotations

import hashlib
import os
import re
import socket
import stat
import tempfile
from collections.abc import Collection, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path

from .checks import InputError

__all__ = [
    "FIGURE_SUFFIXES",
    "check_figure_name",
    "check_output_file",
    "check_output_files",
    "check_output_folder",
    "owner_alive",
    "owner_tag",
    "replacing",
]

#: The image formats a figure file may have, by its suffix (matplotlib writes each of them).
FIGURE_SUFFIXES = (".png", ".pdf", ".svg")


def check_figure_name(path: str | Path, flag: str) -> Path:
    """A figure's file name must end in one of :data:`FIGURE_SUFFIXES` (checked before any work)."""
    path = Path(path)
    if path.suffix.lower() not in FIGURE_SUFFIXES:
        raise InputError(f"{flag} {path} must end in {', '.join(FIGURE_SUFFIXES)} (the image format)")
    return path


def _kind(mode: int) -> str:
    """What a file of this mode is, in words, for messages."""
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    if stat.S_ISLNK(mode):
        return "a symbolic link"
    if stat.S_ISDIR(mode):
        return "a folder"
    return "a regular file" if stat.S_ISREG(mode) else "a special file"


def _nonempty(path: str | Path, flag: str, what: str) -> Path:
    if not os.fspath(path):  # Path("") would be the current folder
        raise InputError(f"{flag} is empty; give {what}")
    return Path(path)


def _lstat(path: Path, flag: str) -> os.stat_result | None:
    """The path's own status (a link not followed), None if there is nothing of that name."""
    try:
        return path.lstat()
    except FileNotFoundError:
        return None
    except NotADirectoryError:
        raise InputError(f"{flag} {path}: a part of the path is not a folder") from None
    except OSError as exc:  # a component that is a file, a folder that cannot be searched
        raise InputError(f"{flag} {path}: {exc.strerror or exc}") from None


def _check_can_create_in(folder: Path, flag: str, path: Path) -> None:
    """``path`` can be made inside ``folder``: its nearest existing ancestor is a folder this user may write."""
    existing = folder
    while not os.path.lexists(existing) and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise InputError(f"{flag} {path}: {existing} is not a folder")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise InputError(f"{flag} {path}: the folder {existing} is not writable")


def check_output_file(path: str | Path, flag: str, *, append: bool = False) -> Path:
    """The file ``flag`` names, as a ``Path``, if a command may write it; else an :class:`InputError`.

    Allowed: a regular file (replaced whole; appended to if ``append``, then it must be writable)
    or a new name whose folder exists or can be made, in a folder this user may write. Refused: an
    empty name, a folder, a symbolic link (never written through), a FIFO, a device, a socket.
    """
    path = _nonempty(path, flag, "a file name")
    st = _lstat(path, flag)
    if st is not None:
        if stat.S_ISDIR(st.st_mode):
            raise InputError(f"{flag} {path} is a folder; it must be a file")
        if not stat.S_ISREG(st.st_mode):
            kind = _kind(st.st_mode)
            raise InputError(f"{flag} {path} is {kind}, not a regular file; give a regular file or a new name")
        if append and not os.access(path, os.W_OK):
            raise InputError(f"{flag} {path} is not writable")
    _check_can_create_in(path.parent, flag, path)
    return path


def check_output_files(paths: Mapping[str, str | Path | None], append: Collection[str] = ()) -> dict[str, Path]:
    """:func:`check_output_file` of each path given (None: not given) by flag, and no two the same file."""
    files = {
        flag: check_output_file(path, flag, append=flag in append) for flag, path in paths.items() if path is not None
    }
    if len({path.resolve() for path in files.values()}) < len(files):
        raise InputError(f"{', '.join(files)} must name different files")
    return files


def check_output_folder(path: str | Path, flag: str) -> Path:
    """The folder ``flag`` names, as a ``Path``, if a command may write into it; else an :class:`InputError`.

    Allowed: a folder this user may write, a symbolic link to one (the output goes into the folder it
    points to), or a new name that can be made. Refused: an empty name (``.`` is the current folder),
    anything else of that name (a file, a FIFO, a device, a link to no folder), a folder not writable.
    """
    path = _nonempty(path, flag, "a folder name (. for the current folder)")
    st = _lstat(path, flag)
    if st is None:
        _check_can_create_in(path.parent, flag, path)
        return path
    if stat.S_ISLNK(st.st_mode) and not path.is_dir():
        raise InputError(f"{flag} {path} is a symbolic link to no folder; give a folder")
    if not stat.S_ISDIR(st.st_mode) and not stat.S_ISLNK(st.st_mode):
        raise InputError(f"{flag} {path} exists and is not a folder: it is {_kind(st.st_mode)}")
    if not os.access(path, os.W_OK | os.X_OK):
        raise InputError(f"{flag} {path} is a folder that is not writable")
    return path


def _host() -> str:
    return hashlib.sha1(socket.gethostname().encode(), usedforsecurity=False).hexdigest()[:8]


def _start_time(pid: int) -> str | None:
    """When process ``pid`` started (clock ticks since boot, Linux), None where that cannot be read."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text(encoding="ascii", errors="replace")
    except OSError:
        return None
    fields = text.rsplit(")", 1)[-1].split()  # after the command name, which may hold spaces
    return fields[19] if len(fields) > 19 and fields[19].isdigit() else None


def owner_alive(host: str, pid: int, start: str) -> bool:
    """Whether the process that named a staging folder or a temporary file may still run: only a sure "no" is False."""
    if host != _host() or os.name != "posix":  # another machine's process, or no signal 0 to ask with
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # it exists, but is another user's
        pass
    now = _start_time(pid)
    return start == "0" or now is None or now == start  # another start time: the PID was reused


def owner_tag() -> str:
    """``HOST-PID-START`` of this process, for names of what it writes aside (a staging folder, a temporary file)."""
    return f"{_host()}-{os.getpid()}-{_start_time(os.getpid()) or '0'}"


_TMP_OWNER = re.compile(r"\.hitchpark-([0-9a-f]{8})-([1-9][0-9]*)-([0-9]+)\.")


def _clean_stale_temporaries(path: Path) -> None:
    """Remove the temporary files of ``path`` left by processes that have ended (a kill while writing)."""
    try:
        names = os.listdir(path.parent)
    except OSError:
        return
    head = f".{path.name}.hitchpark-"
    for name in names:
        match = _TMP_OWNER.match(name[len(path.name) + 1 :]) if name.startswith(head) else None
        if match and not owner_alive(match[1], int(match[2]), match[3]):
            (path.parent / name).unlink(missing_ok=True)


@contextmanager
def replacing(path: str | Path) -> Iterator[Path]:
    """Write a file whole or not at all: ``with replacing(path) as tmp: ...write tmp...``.

    ``tmp`` is a new empty file beside ``path`` (same folder, so the swap is one rename, and with
    ``path``'s suffix, so writers that read the format from it still do). On success it replaces
    ``path`` in one step, with the mode a new file gets under the umask; on any error it is
    removed and ``path`` is left as it was. An ``OSError`` names ``path``. The temporary name
    carries this process's :func:`owner_tag`: one left by a killed process is removed by the
    next writer of ``path``.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    _clean_stale_temporaries(path)
    prefix = f".{path.name}.hitchpark-{owner_tag()}."
    fd, name = tempfile.mkstemp(prefix=prefix, suffix=f".tmp{path.suffix}", dir=path.parent)
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the file the usual mode
        os.replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise OSError(exc.errno, exc.strerror, str(path)) from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise

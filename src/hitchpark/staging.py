"""A command's output folder, published whole: built aside, then swapped in for what the command owns.

:class:`StagedFolder` builds the output in a hidden staging folder inside the target and, when all
of it is there, publishes it: each file the command *owns* (a fixed set of names per command, plus
whatever it wrote) replaces the file of that name, an owned file it did not write this time (a
figure of an earlier run with figures) is removed, and every other entry of the target (a user's
file, a folder) stays as it is. Publishing is all-or-nothing as far as renames allow: the old owned
files are first moved into the staging folder (``old/``), then the new ones moved in; an error
moves everything back.

A staging folder is named after the process that owns it (host, PID, start time). One left behind
by a killed process is cleaned up by the next :class:`StagedFolder` into the same target: if the
kill came mid-publish, the files it had moved in are taken out and the old ones put back first.
Staging folders of live processes, of other hosts, and of unknown names are never touched.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import tempfile
from collections.abc import Iterable
from pathlib import Path, PurePosixPath
from typing import Any

from .checks import InputError
from .outputs import check_output_folder, owner_alive, owner_tag

__all__ = ["STAGING_PREFIX", "StagedFolder", "clean_stale_staging"]

STAGING_PREFIX = ".hitchpark-staging-"
_NAME = re.compile(re.escape(STAGING_PREFIX) + r"([0-9a-f]{8})-([1-9][0-9]*)-([0-9]+)-")
_NEW, _OLD, _PLAN, _DONE = "new", "old", "plan.json", "done"


def _entries(root: Path) -> tuple[list[str], list[str]]:
    """The files (anything not a folder) and the folders under ``root``, as relative POSIX paths."""
    files, folders = [], []
    for here, dirs, names in os.walk(root):
        rel = PurePosixPath(Path(here).relative_to(root).as_posix())
        folders += [str(rel / d) for d in dirs if not os.path.islink(os.path.join(here, d))]
        files += [str(rel / n) for n in names]
        files += [str(rel / d) for d in dirs if os.path.islink(os.path.join(here, d))]
    return sorted(files), sorted(folders)


def _real_folder(path: Path) -> bool:
    return path.is_dir() and not path.is_symlink()


def _recover(staging: Path, target: Path) -> None:
    """Undo what a dead process's staging folder did to ``target``, then remove it (OSError if it cannot)."""
    if not (staging / _DONE).exists():
        try:
            plan = json.loads((staging / _PLAN).read_text(encoding="utf-8"))
        except (OSError, ValueError):
            plan = {}  # killed before publishing began: nothing of it is in the target
        for rel in plan.get("files", []):  # moved in, not yet moved back: out again
            if not os.path.lexists(staging / _NEW / rel):
                (target / rel).unlink(missing_ok=True)
        old, _ = _entries(staging / _OLD)
        for rel in old:  # the files that were there before, back in place
            (target / rel).parent.mkdir(parents=True, exist_ok=True)
            os.replace(staging / _OLD / rel, target / rel)
        for rel in sorted(plan.get("folders", []), key=lambda r: -r.count("/")):
            try:
                (target / rel).rmdir()
            except OSError:
                pass  # not empty: someone else's now
    shutil.rmtree(staging)


def clean_stale_staging(target: str | Path) -> list[Path]:
    """Recover and remove the staging folders in ``target`` whose process is gone; return those removed.

    One that cannot be recovered (a rename fails) is left for a later run; nothing is lost.
    """
    removed: list[Path] = []
    try:
        names = os.listdir(target)
    except OSError:
        return removed
    for name in names:
        match = _NAME.match(name)
        if match is None or owner_alive(match[1], int(match[2]), match[3]):
            continue
        staging = Path(target) / name
        try:
            _recover(staging, Path(target))
        except OSError:
            continue
        removed.append(staging)
    return removed


class StagedFolder:
    """Build a command's output in a hidden folder inside ``target``, then publish it whole.

    ``with StagedFolder(out, owns=names) as stage: ...write into stage...``. ``owns`` are the
    relative paths (``"a/b.png"``) of every file the command may write with full options. On
    success each file written to ``stage`` replaces the file of that name in ``out`` (folders are
    merged, never replaced), and each owned file not written this time is removed; nothing else in
    ``out`` changes. On any error ``out`` is left as it was (and removed again if this made it and
    it is empty). A clash (a folder where a file goes, anything but a folder where a folder goes)
    is found before anything moves. ``flag`` names the folder in messages.
    """

    def __init__(self, target: str | Path, owns: Iterable[str] = (), flag: str = "output folder"):
        self.target = check_output_folder(target, flag)
        self.owns = frozenset(self._relative(name) for name in owns)
        self.path = self.target
        self._staging = self.target
        self._created = False
        self._keep = False  # a roll-back that failed left old files in the staging folder

    @staticmethod
    def _relative(name: str) -> str:
        rel = PurePosixPath(name)
        if rel.is_absolute() or not rel.parts or ".." in rel.parts:
            raise InputError(f"an output file must be a path inside the output folder, got {name!r}")
        return str(rel)

    def __enter__(self) -> Path:
        self._created = not self.target.exists()
        self.target.mkdir(parents=True, exist_ok=True)
        clean_stale_staging(self.target)
        prefix = f"{STAGING_PREFIX}{owner_tag()}-"
        self._staging = Path(tempfile.mkdtemp(prefix=prefix, dir=self.target))
        self.path = self._staging / _NEW
        self.path.mkdir()
        return self.path

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        try:
            if exc_type is None:
                self._publish()
        finally:
            self._discard()

    def _publish(self) -> None:
        target, new, old = self.target, self._staging / _NEW, self._staging / _OLD
        files, folders = _entries(new)
        for rel in folders:
            dest = target / rel
            if os.path.lexists(dest) and not _real_folder(dest):
                raise InputError(f"cannot write the folder {dest}: something else of that name is in the way")
        for rel in files:
            if _real_folder(target / rel):
                raise InputError(f"cannot write the file {target / rel}: something else of that name is in the way")
        # Owned files there now, each under real folders: the ones to move aside (a folder is never owned).
        there = [
            rel
            for rel in sorted(self.owns | set(files))
            if all(_real_folder(target / p) for p in map(str, PurePosixPath(rel).parents) if p != ".")
            and os.path.lexists(target / rel)
            and not _real_folder(target / rel)
        ]
        making = [rel for rel in folders if not os.path.lexists(target / rel)]
        plan = {"files": files, "folders": making}
        (self._staging / _PLAN).write_text(json.dumps(plan), encoding="utf-8")
        aside: list[str] = []
        made: list[str] = []
        placed: list[str] = []
        try:
            for rel in there:
                (old / rel).parent.mkdir(parents=True, exist_ok=True)
                os.replace(target / rel, old / rel)
                aside.append(rel)
            for rel in making:
                (target / rel).mkdir()
                made.append(rel)
            for rel in files:
                os.replace(new / rel, target / rel)
                placed.append(rel)
        except BaseException:
            self._roll_back(aside, made, placed)
            raise
        try:
            (self._staging / _DONE).touch()
        except OSError:
            pass  # only a later clean-up reads it, and this process removes the staging folder now

    def _roll_back(self, aside: list[str], made: list[str], placed: list[str]) -> None:
        """Put ``target`` back as it was: the new files back into the stage, the old ones back in place."""
        target, new, old = self.target, self._staging / _NEW, self._staging / _OLD
        failed = False
        for rel in reversed(placed):
            try:
                os.replace(target / rel, new / rel)
            except OSError:
                failed = True
        for rel in reversed(made):
            try:
                (target / rel).rmdir()
            except OSError:
                failed = True
        for rel in reversed(aside):
            try:
                os.replace(old / rel, target / rel)
            except OSError:
                failed = True
        self._keep = failed  # the old files stay in the staging folder for a later run to put back

    def _discard(self) -> None:
        if self._keep:
            return
        shutil.rmtree(self._staging, ignore_errors=True)
        if self._created and self.target.is_dir() and not any(self.target.iterdir()):
            self.target.rmdir()

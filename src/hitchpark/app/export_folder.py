"""An exported package on disk: ``hitchpark export``'s folder, written whole or not at all, and the scratch copy
``hitchpark sil`` builds (the files themselves: :func:`.export.package_files`)."""

from __future__ import annotations

import shutil
from pathlib import Path

from ..checks import InputError
from ..io import StagedFolder
from .export import PACKAGE_FILES

__all__ = ["copy_package", "write_package"]


def write_package(out: str | Path, files: dict[str, str], force: bool = False) -> Path:
    """Write ``files`` into the folder ``out``, whole or not at all (built aside, then published).

    A folder that exists and holds anything is refused (:class:`InputError`) unless ``force``; then the package's
    own files (:data:`PACKAGE_FILES`) are replaced and the rest left alone.
    """
    target = Path(out)
    if target.exists() and not target.is_dir():
        raise InputError(f"--out {target} is a file, not a folder")
    if target.is_dir() and any(target.iterdir()) and not force:
        raise InputError(f"--out {target} is not empty; pass --force to replace the package files in it")
    target.mkdir(parents=True, exist_ok=True)
    staged = StagedFolder(target, PACKAGE_FILES, "--out")
    with staged as folder:
        for name, text in files.items():
            path = folder / name
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text, encoding="utf-8")
    return target


def copy_package(files: dict[str, str], folder: Path) -> None:
    """Write ``files`` into an empty scratch ``folder`` (``hitchpark sil``'s build), no staging."""
    if folder.exists():
        shutil.rmtree(folder)
    for name, text in files.items():
        path = folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")

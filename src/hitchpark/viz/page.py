"""Self-contained HTML pages: ``page.html`` with a style, a script and JSON data inlined, written whole or not at all.

The template, the style and the scripts are package data of :mod:`hitchpark.viz` (real files, read here): the
maneuver viewer (``viewer.js``, :mod:`.viewer`), the sweep's map (``sweep.js``, :mod:`.sweep_html`) and the live
page (``drive.js``, :mod:`.drive`), each after ``common.js``, the helpers they share. A page loads nothing: no
network, no server (but the live page's own), opened from disk.
"""

from __future__ import annotations

import html
import json
import re
from importlib import resources
from pathlib import Path
from typing import Any

from ..checks import InputError
from ..outputs import check_output_file, replacing

__all__ = ["asset", "page", "write_page"]


def asset(name: str) -> str:
    """The text of the package data file ``name`` of :mod:`hitchpark.viz`."""
    return resources.files("hitchpark.viz").joinpath(name).read_text(encoding="utf-8")


def _script_safe(text: str) -> str:
    """Text that cannot close the ``<script>`` element it sits in (JSON and JavaScript read ``<\\/`` as ``</``)."""
    return text.replace("</", "<\\/").replace("<!--", "<\\!--")


def page(script: str, title: str, data: Any) -> str:
    """The page of ``script`` (a package data file) with ``data`` embedded as JSON, titled ``title``."""
    payload = json.dumps(data, separators=(",", ":"), allow_nan=False)
    parts = {
        "{{TITLE}}": html.escape(title),
        "{{STYLE}}": asset("viewer.css"),
        "{{DATA}}": _script_safe(payload),
        "{{SCRIPT}}": _script_safe(asset("common.js") + "\n" + asset(script)),
    }
    # One pass over the template: a value put in is never searched for the other keys.
    return re.sub(r"\{\{[A-Z]+\}\}", lambda m: parts.get(m.group(0), m.group(0)), asset("page.html"))


def write_page(text: str, path: str | Path, force: bool = False, flag: str = "--out") -> Path:
    """Write ``text`` to ``path`` whole or not at all (a temporary file renamed); an existing file only with
    ``force``, else an :class:`InputError` saying so."""
    path = check_output_file(path, flag)
    if path.exists() and not force:
        raise InputError(f"{flag} {path} exists; give --force to replace it, or another --out")
    with replacing(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return path

"""The Python examples of the README and the documentation, run by the test suite as they stand (Sybil).

Each fenced ``python`` block of ``README.md`` and ``docs/**/*.md`` is executed; an example that stops working
fails the suite. Spread over processes (pytest-xdist), the blocks of one file may run in different ones: each
block imports and builds what it uses.
"""

from __future__ import annotations

from sybil import Sybil
from sybil.parsers.markdown import PythonCodeBlockParser

pytest_collect_file = Sybil(
    parsers=[PythonCodeBlockParser()], patterns=["README.md", "docs/*.md", "docs/**/*.md"]
).pytest()

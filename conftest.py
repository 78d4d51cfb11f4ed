"""The Python examples of the README and the documentation, run by the test suite as they stand (Sybil).

Each fenced ``python`` block of ``README.md`` and ``docs/**/*.md`` is executed in order, the blocks of one file
sharing their names; an example that stops working fails the suite.
"""

from __future__ import annotations

from sybil import Sybil
from sybil.parsers.markdown import PythonCodeBlockParser

pytest_collect_file = Sybil(
    parsers=[PythonCodeBlockParser()], patterns=["README.md", "docs/*.md", "docs/**/*.md"]
).pytest()

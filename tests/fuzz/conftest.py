"""Writes the fuzz suite's tally where ``HITCHPARK_FUZZ_REPORT`` says (see fuzz_contract.py)."""

from __future__ import annotations

import json
import os

from fuzz_contract import TALLY


def pytest_sessionfinish(session, exitstatus):
    path = os.environ.get("HITCHPARK_FUZZ_REPORT")
    if path:
        with open(path, "w", encoding="utf-8") as fh:
            json.dump({name: dict(counts) for name, counts in TALLY.items()}, fh, indent=1)

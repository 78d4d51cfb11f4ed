"""Figures and animations. Imports matplotlib lazily; the core never imports this package."""

from __future__ import annotations

__all__ = ["use_headless_backend"]


def use_headless_backend() -> None:
    """Select matplotlib's file-only backend unless a backend has been chosen already."""
    import matplotlib

    if "matplotlib.pyplot" not in __import__("sys").modules:
        matplotlib.use("Agg")

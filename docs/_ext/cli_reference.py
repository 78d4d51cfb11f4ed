"""The ``hitchpark-cli`` directive: the command line's reference, generated from its argparse parsers.

Each subcommand gets a section with its help as argparse prints it, so the page cannot drift from the code.
"""

from __future__ import annotations

import argparse
from typing import Any

from docutils import nodes
from sphinx.util.docutils import SphinxDirective


class CliReference(SphinxDirective):
    has_content = False

    def run(self) -> list[nodes.Node]:
        from hitchpark.cli import build_parser

        parser = build_parser()
        out: list[nodes.Node] = [nodes.literal_block(text=parser.format_help())]
        for action in parser._actions:  # the subcommands' parsers, in the order they were added
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    section = nodes.section(ids=[f"cli-{name}"])
                    section += nodes.title(text=f"hitchpark {name}")
                    section += nodes.literal_block(text=sub.format_help())
                    out.append(section)
        return out


def setup(app: Any) -> dict[str, Any]:
    app.add_directive("hitchpark-cli", CliReference)
    return {"parallel_read_safe": True, "version": "1"}

"""A Sphinx directive that writes the ``motorid`` command line reference from the commands.

``.. motorid-cli::`` renders ``motorid --help`` and every command's (and sub-command's)
``--help`` as a section each. sphinx-click cannot be used: typer ≥ 0.20 builds its commands on
its own copy of click, which sphinx-click does not recognise as click commands.
"""

from __future__ import annotations

from typing import Any

import typer
from docutils import nodes
from docutils.parsers.rst import Directive
from typer.testing import CliRunner

from motorid.cli.app import app

WIDTH = "100"  # columns of the rendered help, wide enough for the option tables


def _help(args: list[str]) -> str:
    result = CliRunner().invoke(app, [*args, "--help"], prog_name="motorid",
                                env={"COLUMNS": WIDTH, "NO_COLOR": "1", "TERM": "dumb"})
    if result.exit_code != 0:
        raise RuntimeError(f"motorid {' '.join(args)} --help failed: {result.output}")
    return "\n".join(line.rstrip() for line in result.output.strip("\n").splitlines())


def _sections(command: Any, path: list[str]) -> list[nodes.Node]:
    title = " ".join(["motorid", *path])
    section = nodes.section(ids=[nodes.make_id(title)], names=[nodes.fully_normalize_name(title)])
    section += nodes.title(text=title)
    section += nodes.literal_block(text=_help(path))
    out: list[nodes.Node] = [section]
    for name, sub in sorted(getattr(command, "commands", {}).items()):
        if not getattr(sub, "hidden", False):
            section += _sections(sub, [*path, name])
    return out


class MotoridCli(Directive):
    """``.. motorid-cli::``: every command's help, nested as the commands are."""

    has_content = False

    def run(self) -> list[nodes.Node]:
        root = typer.main.get_command(app)
        nodes_: list[nodes.Node] = [nodes.literal_block(text=_help([]))]
        for name, sub in sorted(root.commands.items()):
            if not getattr(sub, "hidden", False):
                nodes_ += _sections(sub, [name])
        return nodes_


def setup(sphinx_app: Any) -> dict[str, Any]:
    """Register the directive."""
    sphinx_app.add_directive("motorid-cli", MotoridCli)
    return {"parallel_read_safe": True}

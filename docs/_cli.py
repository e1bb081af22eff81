"""The click command of the ``motorid`` typer application, for sphinx-click's ``.. click::``."""

import typer

from motorid.cli.app import app

click_command = typer.main.get_command(app)

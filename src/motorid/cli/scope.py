"""Placeholder: the `scope` command(s) are being built (owned by one helper)."""

from __future__ import annotations

import typer


def register(app: typer.Typer) -> None:
    """Add this module's commands to the main app (none yet)."""

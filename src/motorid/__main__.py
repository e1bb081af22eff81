"""``python -m motorid`` runs the command-line interface."""

from motorid.cli import entry

entry()

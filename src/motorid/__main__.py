"""``python -m motorid`` runs the command-line interface."""

from motorid.cli.app import entry

entry()

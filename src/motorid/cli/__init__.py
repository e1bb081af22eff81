"""The ``motorid`` command line (typer).

:mod:`.app` holds the commands of the identification half, :mod:`.control` those of the control
half, :mod:`.demo` the bundled example.

The library never imports this package (checked by import-linter in CI).
"""

from motorid.cli.app import app, entry, main

__all__ = ["app", "entry", "main"]

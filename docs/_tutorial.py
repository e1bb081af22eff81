"""A Sphinx extension that runs the tutorial's code while the documentation is built.

When ``tutorial.md`` is read, its ```python blocks run in order in one namespace in a fresh
temporary folder, and each ```bash line starting with ``motorid`` runs through the real entry
point, as ``tests/test_docs.py`` runs them (that test also compares the printed numbers with the
page's expected output). A block that fails stops the build with the block's number; the page
then ends with a note saying it ran. Set ``MOTORID_DOCS_SKIP_TUTORIAL=1`` to skip (drafts).
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import shlex
import sys
import tempfile
import time
from typing import Any

from sphinx.errors import ExtensionError

FENCE = re.compile(r"```(python|bash)\n(.*?)```", flags=re.S)


def _run_cli(line: str) -> None:
    from motorid.cli.app import main

    argv = sys.argv
    sys.argv = shlex.split(line)
    try:
        main()
    except SystemExit as exc:
        if exc.code not in (0, None):
            raise ExtensionError(f"tutorial: `{line}` exited with {exc.code}") from exc
    finally:
        sys.argv = argv


def run_tutorial(text: str) -> float:
    """Run the tutorial's blocks in a fresh folder; return the seconds it took."""
    start = time.perf_counter()
    cwd = os.getcwd()
    namespace: dict[str, Any] = {"__name__": "tutorial"}
    with tempfile.TemporaryDirectory() as folder:
        os.chdir(folder)
        try:
            for i, (kind, body) in enumerate(FENCE.findall(text)):
                if kind == "python":
                    with contextlib.redirect_stdout(io.StringIO()):
                        try:
                            exec(compile(body, f"tutorial block {i + 1}", "exec"), namespace)
                        except Exception as exc:
                            raise ExtensionError(f"tutorial block {i + 1} failed: {exc!r}") from exc
                else:
                    for line in body.splitlines():
                        if line.startswith("motorid "):
                            with contextlib.redirect_stdout(io.StringIO()):
                                _run_cli(line)
        finally:
            os.chdir(cwd)
    return time.perf_counter() - start


def _source_read(app: Any, docname: str, source: list[str]) -> None:
    if docname != "tutorial" or os.environ.get("MOTORID_DOCS_SKIP_TUTORIAL"):
        return
    seconds = run_tutorial(source[0])
    source[0] += (f"\n\n---\n\n*Every code block on this page ran when this documentation was built "
                  f"({seconds:.0f} s).*\n")


def setup(app: Any) -> dict[str, Any]:
    """Register the tutorial's run on reading the page."""
    app.connect("source-read", _source_read)
    return {"parallel_read_safe": True}

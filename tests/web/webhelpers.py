"""Helpers of the web tests (imported by name: the test folder is on sys.path)."""

from __future__ import annotations

import re
from pathlib import Path

from fastapi.testclient import TestClient

#: Where the web tests keep their artefacts (screenshots, timings): a stable path.
ARTEFACTS = Path(__file__).resolve().parents[1] / "artefacts" / "web"


def open_tab(client: TestClient) -> str:
    page = client.get("/")
    assert page.status_code == 200
    return re.search(r'data-tab="([0-9a-f]{32})"', page.text).group(1)


def multipart(field: str, paths: list[Path], names: list[str] | None = None) -> list:
    names = names or [p.name for p in paths]
    return [(field, (n, p.read_bytes(), "text/csv")) for n, p in zip(names, paths, strict=True)]

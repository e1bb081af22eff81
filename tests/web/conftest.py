"""Fixtures of the web tests: an app on a private temporary root, the demo's capture files."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("fastapi", reason="the web extra (fastapi) is not installed: pip install -e '.[web]'")

from fastapi.testclient import TestClient

from motorid.web import WebSettings, create_app

@pytest.fixture
def web_root(tmp_path: Path) -> Path:
    root = tmp_path / "root"
    root.mkdir()
    return root


@pytest.fixture
def make_client(web_root: Path):
    """``make_client(**settings)``: a TestClient (context entered: lifespan run) of a fresh app."""
    clients = []

    def make(**kw) -> TestClient:
        client = TestClient(create_app(WebSettings(temp_root=web_root, **kw)), base_url="http://127.0.0.1")
        client.__enter__()
        clients.append(client)
        return client

    yield make
    for c in clients:
        c.__exit__(None, None, None)


@pytest.fixture
def client(make_client) -> TestClient:
    return make_client()


@pytest.fixture(scope="session")
def demo_files(demo_run) -> list[Path]:
    """The demo's twelve Tektronix files: ALL0000…ALL0005, CH1 and CH2 each."""
    files = sorted(demo_run.folder.glob("ALL000[0-5]/F000[0-5]CH[12].CSV"))
    assert len(files) == 12
    return files

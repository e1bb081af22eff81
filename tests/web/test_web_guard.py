"""The local server answers the local user only (a page the student visits is another site)."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient

from motorid.web import WebSettings, create_app

TOKEN = "s3cret-token"


def test_a_request_under_another_host_name_is_refused(client):
    # DNS rebinding: the attacker's name resolves to 127.0.0.1, the Host header keeps the name
    res = client.get("/", headers={"Host": "evil.example"})
    assert res.status_code == 400 and "not 'evil.example'" in res.text
    assert client.get("/", headers={"Host": "localhost:8765"}).status_code == 200
    assert client.get("/", headers={"Host": "[::1]:8765"}).status_code == 200


def test_a_cross_site_request_changes_nothing(client, demo_run):
    files = [("velocity", ("F0001CH1.CSV", (demo_run.folder / "ALL0001" / "F0001CH1.CSV").read_bytes(), "text/csv")),
             ("velocity", ("F0001CH2.CSV", (demo_run.folder / "ALL0001" / "F0001CH2.CSV").read_bytes(), "text/csv"))]
    res = client.post("/api/identify", files=files, data={"method": "classic"},
                      headers={"Origin": "http://evil.example"})
    assert res.status_code == 403 and "another site" in res.json()["detail"]
    res = client.post("/api/identify", files=files, data={"method": "classic"},
                      headers={"Sec-Fetch-Site": "cross-site"})
    assert res.status_code == 403
    ok = client.post("/api/identify", files=files, data={"method": "classic"},
                     headers={"Origin": "http://127.0.0.1", "Sec-Fetch-Site": "same-origin"})
    assert ok.status_code == 200, ok.text


def test_a_json_endpoint_takes_json_only(client, demo_run):
    model = demo_run.result.identification.model.to_json_text()
    body = '{"model": ' + model + ', "damping": 0.7, "wn": 5, "robust_samples": 0}'
    res = client.post("/api/design", content=body, headers={"Content-Type": "text/plain"})
    assert res.status_code == 415 and "application/json" in res.json()["detail"]
    assert client.post("/api/design", content=body, headers={"Content-Type": "application/json"}).status_code == 200


@pytest.fixture
def guarded(web_root):
    with TestClient(create_app(WebSettings(temp_root=web_root, token=TOKEN)), base_url="http://127.0.0.1") as c:
        yield c


def test_the_token_opens_the_page_once_and_the_cookie_keeps_it(guarded):
    assert guarded.get("/").status_code == 403
    first = guarded.get(f"/?token={TOKEN}")
    assert first.status_code == 200
    assert "motorid_token=" in first.headers["set-cookie"] and "SameSite=Strict" in first.headers["set-cookie"]
    assert guarded.get("/").status_code == 200  # the cookie now


def test_scripts_send_the_token_as_a_query_or_a_bearer(guarded, demo_run):
    model = demo_run.result.identification.model.to_json()
    body = {"model": model, "damping": 0.7, "wn": 5, "robust_samples": 0}
    assert guarded.post("/api/design", json=body).status_code == 403
    assert guarded.post("/api/design", json=body, headers={"Authorization": "Bearer wrong"}).status_code == 403
    assert guarded.post("/api/design", json=body, headers={"Authorization": f"Bearer {TOKEN}"}).status_code == 200
    assert guarded.post(f"/api/design?token={TOKEN}", json=body).status_code == 200

"""A tab is bounded: its files have a quota, and a folder a cleaner removed makes it start over."""

from __future__ import annotations

import shutil

from webhelpers import multipart, open_tab


def test_a_tab_whose_folder_vanished_says_so_and_starts_over(client, demo_files):
    tab = open_tab(client)
    assert client.post(f"/tab/{tab}/upload", files=multipart("files", demo_files[:2])).status_code == 200
    shutil.rmtree(client.app.state.tabs.get(tab).folder)  # a temporary-file cleaner
    res = client.post(f"/tab/{tab}/upload", files=multipart("files", demo_files[:2]))
    assert res.status_code == 422 and "starts over" in res.text
    again = client.post(f"/tab/{tab}/upload", files=multipart("files", demo_files[:2]))
    assert again.status_code == 200, again.text
    assert len(client.app.state.tabs.get(tab).captures) == 1  # the old capture is forgotten, the new one kept


def test_a_tab_keeps_at_most_four_uploads_worth(make_client, demo_files):
    size = sum(f.stat().st_size for f in demo_files[:2])
    client = make_client(max_upload_mb=1.2 * size / 2**20)  # each upload fits, five do not
    tab = open_tab(client)
    codes = [client.post(f"/tab/{tab}/upload", files=multipart("files", demo_files[:2])).status_code
             for _ in range(5)]
    assert codes[:3] == [200, 200, 200] and codes[-1] == 422, codes
    held = client.app.state.tabs.get(tab).stored_bytes()
    assert held <= client.app.state.settings.max_tab_bytes

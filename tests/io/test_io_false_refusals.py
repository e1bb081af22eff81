"""Files that were refused although they are good captures: read now, and right."""

from __future__ import annotations

import numpy as np
import pytest

from motorid.io import read_capture


def _table(sep: str = ",", comma: bool = False, rows: int = 4000) -> str:
    lines = [sep.join(["time_s", "input_V", "velocity_V"])]
    for k in range(-500, rows - 500):
        t, u = k * 1e-3, (5.0 if k >= 0 else 0.0)
        v = 4.5 * (1 - np.exp(-max(k, 0) * 1e-3 / 0.3))
        cells = [f"{t:.4f}", f"{u:.3f}", f"{v:.5f}"]
        lines.append(sep.join(c.replace(".", ",") if comma else c for c in cells))
    return "\n".join(lines) + "\n"


def _check(cap) -> None:
    assert cap.time_s.size == 4000
    assert cap.output_v[-1] == pytest.approx(4.5 * (1 - np.exp(-3.499 / 0.3)), abs=1e-4)


def test_a_utf16_capture_longer_than_the_sniffed_head(tmp_path):
    f = tmp_path / "u16.csv"
    f.write_bytes(("\ufeff" + _table()).encode("utf-16-le"))
    assert f.stat().st_size > 64 * 1024  # the head is cut inside the file: it was cut inside a character
    _check(read_capture(f))


def test_more_than_64_kib_of_leading_comments(tmp_path):
    f = tmp_path / "comments.csv"
    f.write_text("".join(f"# logger preamble line {i} {'x' * 60}\n" for i in range(1200)) + _table())
    _check(read_capture(f))


def test_a_decimal_comma_first_seen_late(tmp_path):
    # whole milliseconds and a velocity of 0 before the step: the first comma is in row 53
    lines = ["t_ms;input_V;velocity_V"]
    for k in range(-50, 3000):
        v = 4.5 * (1 - np.exp(-max(k, 0) / 300.0))
        lines.append(f"{k + 50};{5 if k >= 0 else 0};" + (f"{v:.5f}".replace(".", ",") if k > 0 else "0"))
    f = tmp_path / "comma.csv"
    f.write_text("\n".join(lines) + "\n")
    cap = read_capture(f)
    assert cap.output_v[-1] == pytest.approx(4.5 * (1 - np.exp(-2999 / 300.0)), abs=1e-4)


def test_old_mac_line_ends_read_the_same(tmp_path):
    f = tmp_path / "cr.csv"
    f.write_bytes(_table().replace("\n", "\r").encode())
    _check(read_capture(f))


def test_gaps_in_a_column_no_model_uses_are_a_note_naming_the_column_once(tmp_path):
    lines = _table().splitlines()
    lines[0] += ",notes"
    lines[1:] = [row + ("," + ("nan" if i % 7 == 0 else "1")) for i, row in enumerate(lines[1:])]
    f = tmp_path / "gaps.csv"
    f.write_text("\n".join(lines) + "\n")
    cap = read_capture(f)
    _check(cap)
    note = next(w for w in cap.warnings if "'notes'" in w)
    assert "not finite" in note and "line 2" in note and "gaps.csv" not in note  # the reader's caller names the file

"""Shared helpers for the motorid.io tests (not a conftest: plain functions and constants)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from motorid.capture import Capture, ChannelInfo, ScopeInfo

REPO = Path(__file__).resolve().parents[2]
REAL = REPO.parent / "shared" / "real"
TEK = REAL / "tek-tds2000-format-samples"
HSLU = REAL / "hslu-rtl-dcmotor" / "csv"

TDS2012B = TEK / "TDS2012B_Wazurim-Design2_F0000CH1.CSV"
TDS2014C = TEK / "TDS2014C_AdrianSolo-ECE425L_PWM_ALL0000_F0000CH1.CSV"
TDS2024B = TEK / "TDS2024B_excel-resaved_TheerayutEncoder-senior-project_TEK0000.CSV"


def need(path: Path) -> Path:
    """Skip the test when a real recording is absent (a user's clone has no /work/shared)."""
    if not path.exists():
        pytest.skip(f"real recording not available: {path}")
    return path


def step_capture(
    n: int = 2500,
    dt: float = 4e-3,
    trigger: int = 250,
    scale_in: float = 2.0,
    scale_out: float = 0.5,
    role: str | None = "velocity",
) -> Capture:
    """A synthetic scope capture: a step on CH1, a first-order response on CH2, both on the
    8-bit grid of their V/div (values = integer levels × scale/25)."""
    t = (np.arange(n) - trigger) * dt
    lsb_in, lsb_out = scale_in / 25, scale_out / 25
    u = np.where(t >= 0, np.round(5.92 / lsb_in), 0.0) * lsb_in
    y_true = np.where(t >= 0, 1.5 * (1 - np.exp(-np.maximum(t, 0) / 0.4)), 0.0)
    y = np.round(y_true / lsb_out) * lsb_out
    return Capture(
        source="<test>",
        format="trainer",
        time_s=t,
        output_v=y,
        output_info=ChannelInfo("CH2", "V", scale_out, 0.0, 1.0, 0.0),
        input_v=u,
        input_info=ChannelInfo("CH1", "V", scale_in, 0.0, 10.0, 0.0),
        scope=ScopeInfo("TDS2012C", "C012345", "FV:v24.26", n, 250 * dt, trigger),
        role_hint=role,
    )


def native_lines(path: Path) -> list[str]:
    """The lines of a real sample file, without line endings."""
    return path.read_text().splitlines()


def write_lines(path: Path, lines: list[str], newline: str = "\n") -> Path:
    path.write_bytes((newline.join(lines) + newline).encode())
    return path

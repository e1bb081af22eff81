"""The report's controller section shows a PID design JSON: its gains with units, margins, its
loop's Bode/Nyquist plot and its closed-loop step response on the identified model."""

from __future__ import annotations

import pytest

from motorid.control.pid import PidSettings, design_pid
from motorid.report.assemble import make_report


@pytest.mark.slow  # an end-to-end run of several seconds: the full suite runs it
def test_the_report_shows_a_pid_design(demo_run):
    ident = demo_run.result.identification
    pid = design_pid(ident.model, PidSettings(loop="position", integral=True))
    html = make_report(ident, {}, design=pid.to_json(), title="PID")
    section = html[html.index('id="design"') if 'id="design"' in html else html.index("id=design"):]
    assert "PID on the position, rule simc" in section
    assert "V per V" in section and "phase margin" in section
    assert "loop Bode and Nyquist" in section and "closed loop" in section
    assert "cannot be simulated" not in section

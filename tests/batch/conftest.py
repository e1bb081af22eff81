"""A tiny class for the batch tests: five experiments in the layouts a class hands in.

- ``s00``: the paper's ``ALL0000``–``ALL0002`` triple (roles guessed from the signals);
- ``s01``: loose Tektronix channel files ``F0000CH1.CSV``… (position and velocity, guessed);
- ``s02``: a triple plus a sine validation capture, with a ``manifest.csv`` naming the roles;
- ``s03/run1``: a plain CSV log ``time,input,velocity`` (a nested folder);
- ``bad``: a triple whose velocity file is corrupt (the batch must go on without it).

Each is recorded on the virtual trainer (the ``paper`` preset, its own seed); the truth
(the gain a 5.92 V step shows: linear gain × (1 − offset/step)) is returned for the checks.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

STEP_V = 5.92
GOOD = ("s00", "s01", "s02", "s03/run1")


def _triple(folder: Path, exp, *, validation: bool = False) -> None:
    from motorid.io import write_tds_capture

    folder.mkdir(parents=True, exist_ok=True)
    for i, role in enumerate(("position", "velocity", "current")):
        write_tds_capture(folder, exp.captures[role], index=i)
    if validation:
        write_tds_capture(folder, exp.validation["sine"], index=3)


def make_class(root: Path) -> dict[str, float]:
    """Write the class under ``root``; return each good experiment's true effective DC gain."""
    from motorid.io import write_tds_channel
    from motorid.trainer import run_experiment

    truth = {}
    exps = {name: run_experiment("paper", step_volts=STEP_V, seed=200 + i, validation=(name == "s02"))
            for i, name in enumerate((*GOOD, "bad"))}
    for name, exp in exps.items():
        truth[name] = exp.truth.dc_gain * (1.0 - exp.truth.equivalent_input_offset_v / exp.step_volts)
    _triple(root / "s00", exps["s00"])
    s01 = root / "s01"
    s01.mkdir()
    for i, role in enumerate(("position", "velocity")):
        cap = exps["s01"].captures[role]
        write_tds_channel(s01 / f"F000{i}CH1.CSV", cap.time_s, cap.input_v, cap.input_info, cap.scope)
        write_tds_channel(s01 / f"F000{i}CH2.CSV", cap.time_s, cap.output_v, cap.output_info, cap.scope)
    _triple(root / "s02", exps["s02"], validation=True)
    (root / "s02" / "manifest.csv").write_text(
        "role,path\nposition,ALL0000\nvelocity,ALL0001\ncurrent,ALL0002\nvalidate,ALL0003\n", encoding="utf-8")
    log = root / "s03" / "run1"
    log.mkdir(parents=True)
    cap = exps["s03/run1"].captures["velocity"]
    table = np.column_stack([cap.time_s, cap.input_v, cap.output_v])
    np.savetxt(log / "log.csv", table, delimiter=",", header="time,input,velocity", comments="", fmt="%.6g")
    _triple(root / "bad", exps["bad"])
    broken = root / "bad" / "ALL0001" / "F0001CH2.CSV"
    lines = broken.read_text(encoding="utf-8").splitlines()
    broken.write_text("\n".join(lines[:40] + ["garbage,here,,not,a number"] * 5 + lines[45:]) + "\n",
                      encoding="utf-8")
    return {k: v for k, v in truth.items() if k != "bad"}


@pytest.fixture(scope="package")
def class_root(tmp_path_factory) -> tuple[Path, dict[str, float]]:
    """The class folder (written once for the whole batch test package) and its truth."""
    root = tmp_path_factory.mktemp("class")
    return root, make_class(root)

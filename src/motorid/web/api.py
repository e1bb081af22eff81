"""The JSON API for scripts and graders: ``POST /api/identify``, ``/api/design``, ``/api/simulate``.

Each returns the docs/formats.md JSON of the matching command; a user error is HTTP 422 with
``{"detail": "motorid: error: <the CLI's one line>"}`` (see :mod:`motorid.web.app`).
"""

from __future__ import annotations

import json
import secrets
import shutil
from pathlib import Path
from typing import Any

from fastapi import APIRouter, Request
from starlette.concurrency import run_in_threadpool

from motorid.errors import OptionError, UploadError
from motorid.web.options import design_options, design_pid_options, identify_options, simulate_options
from motorid.web.uploads import as_uploaded, group_captures, receive_form
from motorid.web.work import run_bounded

__all__ = ["router"]

router = APIRouter(prefix="/api")

_ROLES = ("position", "velocity", "current")


async def _json_body(request: Request) -> dict[str, Any]:
    limit = request.app.state.settings.max_upload_bytes
    too_big = f"the request body is more than the limit of {limit / 2**20:.3g} MB (motorid serve --max-upload-mb)"
    declared = request.headers.get("content-length", "")
    if declared.isdigit() and int(declared) > limit:
        raise UploadError(too_big)
    raw = await request.body()
    if len(raw) > limit:
        raise UploadError(too_big)
    try:
        body = json.loads(raw)
    except (ValueError, UnicodeDecodeError) as exc:
        raise OptionError(f"the request body is not JSON ({' '.join(str(exc).split(';')[0].split())})") from None
    except RecursionError:
        raise OptionError("the request body is JSON nested too deeply") from None
    if not isinstance(body, dict):
        raise OptionError("the request body must be a JSON object")
    return body


def _model(body: dict[str, Any]) -> Any:
    from motorid.model import MotorModel

    if "model" not in body:
        raise OptionError('the body needs "model": the model JSON of motorid identify --json')
    return MotorModel.from_json(body["model"], file="model")


@router.post("/identify")
async def api_identify(request: Request) -> dict[str, Any]:
    """Identify a model from uploaded captures (multipart).

    Files come in the fields ``position``, ``velocity``, ``current`` (a field repeats for a
    CH1/CH2 pair; a ``.zip`` of an ``ALLnnnn`` folder is unpacked); the options are plain
    fields named as :func:`motorid.identify`'s and :func:`motorid.read_experiment`'s
    parameters (``method``, ``order``, ``step_volts``, ``delay``…).

    Returns
    -------
    dict
        The model JSON (docs/formats.md).
    """
    settings = request.app.state.settings
    folder = request.app.state.tabs.root / f"api-{secrets.token_hex(8)}"
    try:
        form = await receive_form({k.lower(): v for k, v in request.headers.items()}, request.stream(), folder,
                                  settings.upload_limits())
        read_kw, ident_kw = identify_options(form.fields)
        paths: dict[str, str | list[str]] = {}
        for role in _ROLES:
            caps, ignored = group_captures([f for f in form.files if f.field == role])
            if ignored:
                raise UploadError(f"field {role}: {ignored[0]} is not a capture file: send Tektronix or plain CSV "
                                  "files (.csv, .tsv, .txt), an .xlsx export, or a .zip of an ALLnnnn folder")
            if len(caps) > 1:
                raise UploadError(f"field {role} holds {len(caps)} captures ({', '.join(c.label for c in caps)}): "
                                  "send one capture per field (a CH1/CH2 pair, an ALLnnnn .zip, an .xlsx or a CSV)")
            if caps:
                paths[role] = caps[0].reader_argument()
        stray = sorted({f.field for f in form.files if f.field not in _ROLES})
        if stray:
            raise UploadError(f"files in field {stray[0]!r}: send captures in the fields position, velocity, current")
        if "velocity" not in paths and "position" not in paths:
            raise UploadError("no capture in the fields velocity or position: send at least one of them")
        return await run_bounded(request, settings.work, "the identification", _identify, paths, read_kw, ident_kw,
                                 folder)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def _identify(paths: dict[str, Any], read_kw: dict[str, Any], ident_kw: dict[str, Any], folder: Path) -> dict[str, Any]:
    import motorid as mi
    from motorid.errors import MotorIdError

    try:
        exp = mi.read_experiment(**paths, **read_kw)
        return mi.identify(exp, **ident_kw).to_json()
    except MotorIdError as exc:
        raise as_uploaded(exc, folder) from None


@router.post("/design")
async def api_design(request: Request) -> dict[str, Any]:
    """Design a controller: body ``{"model": <model JSON>, "damping": 0.7, "wn": 5, …}``.

    The keys besides ``model`` are :func:`motorid.design`'s parameters; with ``"pid": true``,
    :func:`motorid.design_pid`'s (``loop``, ``rule``, ``tau_c``, …).

    Returns
    -------
    dict
        The design JSON (docs/formats.md).
    """
    import motorid as mi

    body = await _json_body(request)
    model = _model(body)
    pid = body.get("pid", False)
    if not isinstance(pid, bool):
        raise OptionError(f"pid={pid!r}: give true or false")
    if pid:
        pid_opts = design_pid_options({k: v for k, v in body.items() if k not in ("model", "pid")})
        return (await run_in_threadpool(lambda: mi.design_pid(model, **pid_opts))).to_json()
    opts = design_options({k: v for k, v in body.items() if k not in ("model", "pid")})
    des = await run_in_threadpool(lambda: mi.design(model, **opts))
    return des.to_json()


@router.post("/simulate")
async def api_simulate(request: Request) -> dict[str, Any]:
    """Simulate a design in closed loop: body ``{"model": …, "design": <design JSON>, "duration_s": 3, …}``.

    The keys besides ``model`` and ``design`` are :func:`motorid.simulate`'s parameters.

    Returns
    -------
    dict
        The simulation JSON (``motorid simulate --json``: metrics, warnings, series).
    """
    import motorid as mi
    from motorid.control.design_io import controller_from_json

    body = await _json_body(request)
    model = _model(body)
    if "design" not in body:
        raise OptionError('the body needs "design": the design JSON of motorid design --json or POST /api/design')
    des = controller_from_json(body["design"], file="design")
    opts = simulate_options({k: v for k, v in body.items() if k not in ("model", "design")})
    sim = await run_in_threadpool(lambda: mi.simulate(model, des, **opts))
    return sim.to_json()

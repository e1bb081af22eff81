"""The page: drop zone → inspect table → identify → model → design sliders → downloads.

Each step is an htmx request answered with an HTML fragment (templates/); the tab's state
lives in its :class:`~motorid.web.tabs.Tab`.
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

from fastapi import APIRouter, Request
from fastapi.responses import FileResponse, HTMLResponse, Response
from starlette.concurrency import run_in_threadpool

from motorid.errors import MotorIdError, OptionError, UploadError
from motorid.web.tabs import PAGE_ROLES, Tab
from motorid.web.uploads import as_uploaded, group_captures, receive_form
from motorid.web.work import run_bounded

__all__ = ["router"]

router = APIRouter()

#: Form fields of the identify form besides the ``role_<cid>`` selects.
_IDENTIFY_FIELDS = ("method", "order", "step_volts", "t0", "delay", "segment", "counted_velocity")
#: Files the download buttons serve: name → (media type, what it is).
DOWNLOADS: dict[str, str] = {
    "model.json": "application/json",
    "model.m": "text/plain",
    "design.json": "application/json",
    "report.html": "text/html",
    "controller.c": "text/x-csrc",
    "controller.py": "text/x-python",
    "controller.m": "text/plain",
}
#: The controller code's language by download name.
_CODE = {"controller.c": "c", "controller.py": "python", "controller.m": "matlab"}


def _render(request: Request, name: str, status_code: int = 200, headers: dict[str, str] | None = None,
            **context: Any) -> HTMLResponse:
    templates = request.app.state.templates
    return templates.TemplateResponse(request, name, context, status_code=status_code, headers=headers)


def _tab(request: Request, tab_id: str) -> Tab:
    tab: Tab = request.app.state.tabs.get(tab_id)
    return tab


@router.get("/", response_class=HTMLResponse)
async def index(request: Request) -> HTMLResponse:
    """The page, with a new tab (its own temporary folder)."""
    from motorid import __version__
    from motorid.identification.pipeline import METHODS

    tab = request.app.state.tabs.open()
    s = request.app.state.settings
    return _render(request, "index.html", tab=tab, methods=METHODS, version=__version__,
                   max_upload_mb=s.max_upload_mb, max_files=s.max_files)


@router.post("/tab/{tab_id}/upload", response_class=HTMLResponse)
async def upload(request: Request, tab_id: str) -> HTMLResponse:
    """Store dropped files (zips unpacked), group them into captures and inspect each."""
    from motorid.web.views import default_roles, inspect_capture

    tab = _tab(request, tab_id)
    s = request.app.state.settings
    declared = request.headers.get("content-length", "")
    held = await run_in_threadpool(tab.stored_bytes)
    if held + (int(declared) if declared.isdigit() else 0) > s.max_tab_bytes:
        raise UploadError(f"this tab already holds {held / 2**20:.3g} MB of files and may keep at most "
                          f"{s.max_tab_bytes / 2**20:.3g} MB: clear the captures (or open a new tab) first")
    with tab.lock:
        tab.uploads += 1
        folder = tab.folder / f"upload-{tab.uploads}"
    form = await receive_form({k.lower(): v for k, v in request.headers.items()}, request.stream(), folder,
                              s.upload_limits())
    caps, ignored = group_captures(form.files)
    start = len(tab.captures)
    entries = [await run_in_threadpool(inspect_capture, f"c{start + i}", c, folder) for i, c in enumerate(caps)]
    with tab.lock:
        tab.captures.extend(entries)
        tab.ignored.extend(ignored)
        roles = default_roles(tab.captures)
        tab.roles = {cid: tab.roles.get(cid, role) for cid, role in roles.items()}
        _forget_model(tab)  # a model of other captures is not shown under these
    return _captures(request, tab, clear_model=True)


def _forget_model(tab: Tab) -> None:
    """Drop what depended on the captures: the model, the design, their runs (under ``tab.lock``)."""
    tab.fit, tab.design, tab.simulation = None, None, {}
    tab.mode_maps.clear()


def _captures(request: Request, tab: Tab, *, clear_model: bool = False) -> HTMLResponse:
    from motorid.identification.pipeline import METHODS

    # captures → model → design: new or no captures empty the model panel too (htmx's
    # out-of-band swap), so no older result stays on screen
    return _render(request, "_captures.html", tab=tab, roles=PAGE_ROLES, methods=METHODS, clear_model=clear_model)


@router.post("/tab/{tab_id}/clear", response_class=HTMLResponse)
async def clear(request: Request, tab_id: str) -> HTMLResponse:
    """Forget every uploaded capture (their files are deleted) and the model."""
    tab = _tab(request, tab_id)
    with tab.lock:
        for sub in tab.folder.iterdir():
            shutil.rmtree(sub, ignore_errors=True) if sub.is_dir() else sub.unlink(missing_ok=True)
        tab.reset()
    return _captures(request, tab, clear_model=True)


@router.post("/tab/{tab_id}/identify", response_class=HTMLResponse)
async def identify(request: Request, tab_id: str) -> HTMLResponse:
    """Identify from the captures with the roles of the table and the form's options."""
    from motorid.web.options import identify_options
    from motorid.web.views import model_view, slider_ranges

    tab = _tab(request, tab_id)
    form = await request.form(max_files=0, max_fields=200)
    fields: dict[str, tuple[str, ...]] = {}
    for key, value in form.multi_items():
        if isinstance(value, str):
            fields[key] = (*fields.get(key, ()), value)
    by_id = {e.cid: e for e in tab.captures}
    roles: dict[str, str] = {}
    for key, values in fields.items():
        if key.startswith("role_") and key[5:] in by_id:
            if values[-1] not in PAGE_ROLES:
                raise OptionError(f"role {values[-1]!r}: use one of {', '.join(PAGE_ROLES)}")
            roles[key[5:]] = values[-1]
    opts = {k: v for k, v in fields.items() if k in _IDENTIFY_FIELDS}
    read_kw, ident_kw = identify_options(opts)
    chosen: dict[str, Any] = {}
    for cid, role in roles.items():
        if role in ("position", "velocity", "current"):
            if role in chosen:
                raise OptionError(f"two captures have the role {role} ({chosen[role].files.label}, "
                                  f"{by_id[cid].files.label}): give one of them another role")
            chosen[role] = by_id[cid]
    if "velocity" not in chosen and "position" not in chosen:
        stepless = [e.files.label for e in tab.captures if e.summary is not None and e.summary.step is None]
        why = ""
        if stepless:  # the command line's words for such a file (a closed-loop record, a sine)
            why = (f"; {', '.join(stepless[:3])}{' …' if len(stepless) > 3 else ''} "
                   f"{'has' if len(stepless) == 1 else 'have'} no step in the input channel: identify needs an "
                   "open-loop step (a closed-loop record, a sine or a ramp is not one; motorid validate scores a "
                   "model on any input)")
        raise OptionError("no capture has the role velocity or position: choose the roles in the table" + why)
    with tab.lock:
        tab.roles.update(roles)
        _forget_model(tab)  # a failed identification leaves no older model behind
    paths = {role: entry.files.reader_argument() for role, entry in chosen.items()}
    fit = await run_bounded(request, request.app.state.settings.work, "the identification", _identify, paths,
                            read_kw, ident_kw, tab.folder)
    with tab.lock:
        tab.fit, tab.design, tab.simulation = fit, None, {}
        tab.mode_maps.clear()
    return _render(request, "_model.html", tab=tab, view=await run_in_threadpool(model_view, fit),
                   ranges=slider_ranges(fit.model))


def _identify(paths: dict[str, Any], read_kw: dict[str, Any], ident_kw: dict[str, Any], folder: Path) -> Any:
    import motorid as mi

    try:
        return mi.identify(mi.read_experiment(**paths, **read_kw), **ident_kw)
    except MotorIdError as exc:
        raise as_uploaded(exc, folder) from None


@router.post("/tab/{tab_id}/design", response_class=HTMLResponse)
async def design(request: Request, tab_id: str) -> HTMLResponse:
    """One move of the design sliders: design, closed loop, figure, mode-map marker."""
    tab, dform = await _design_request(request, tab_id)
    view, maps = await run_in_threadpool(_design, tab, dform)
    return _render(request, "_design_result.html", tab=tab, view=view, maps=maps, form=dform,
                   headers={"Server-Timing": f"update;dur={view.elapsed_ms:.1f}, cpu;dur={view.cpu_ms:.1f}"})


async def _design_request(request: Request, tab_id: str) -> tuple[Tab, Any]:
    """The tab of a design-panel request and the panel's form (a slider move or its robustness check)."""
    from motorid.web.views import DesignForm

    tab = _tab(request, tab_id)
    if tab.fit is None:
        raise OptionError("identify a model first (the design panel works on the identified model)")
    form = await request.form(max_files=0, max_fields=50)
    return tab, DesignForm.from_fields({k: v for k, v in form.items() if isinstance(v, str)})


def _canvas(tab: Tab) -> Any:
    """The tab's closed-loop figure, made on first use (kept, redrawn in place)."""
    with tab.lock:
        if tab.canvas is None:
            from motorid.report.figures import ClosedLoopCanvas

            tab.canvas = ClosedLoopCanvas()
        return tab.canvas


def _design(tab: Tab, dform: Any) -> tuple[Any, Any]:
    from motorid.web.modemap import build_mode_maps
    from motorid.web.views import design_update, map_limits, slider_ranges

    assert tab.fit is not None
    model = tab.fit.model
    ranges = slider_ranges(model)
    sat = dform.saturation_v or ranges.rails
    # no level given: the model's default, the one the form showed (and the simulation uses)
    level = dform.level_v if dform.level_v is not None else (ranges.reference.value if ranges.reference else 5.0)
    key = (sat, level)
    with tab.lock:
        maps = tab.mode_maps.get(key)
        if maps is None and level != 0:
            try:
                kp_max, kv_max = map_limits(model, ranges)
                maps = build_mode_maps(model, tab.folder, step_v=abs(level), saturation_v=sat,
                                       kp_max=kp_max, kv_max=kv_max)
            except MotorIdError as exc:
                maps = str(exc)  # the panel says why there is no map
            tab.mode_maps[key] = maps
    view = design_update(model, dform, maps if not isinstance(maps, str) else None, _canvas(tab))
    with tab.lock:
        tab.design, tab.simulation, tab.design_form = view.design, dform.simulate_options(), dform
        tab.shown_run = view.simulation
    return view, maps


@router.post("/tab/{tab_id}/robust", response_class=HTMLResponse)
async def robust(request: Request, tab_id: str) -> HTMLResponse:
    """The shown design checked on the plausible motors (the page asks once a move is shown)."""
    tab, dform = await _design_request(request, tab_id)
    view = await run_in_threadpool(_robust, tab, dform)
    return _render(request, "_robust.html", view=view,
                   headers={"Server-Timing": f"update;dur={view.elapsed_ms:.1f}, cpu;dur={view.cpu_ms:.1f}"})


def _robust(tab: Tab, dform: Any) -> Any:
    from motorid.web.views import robust_update

    assert tab.fit is not None
    with tab.lock:
        shown = tab.shown_run if tab.design_form == dform else None
    view = robust_update(tab.fit.model, dform, _canvas(tab), shown=shown)
    with tab.lock:
        if tab.design_form == dform:  # still the design shown: its download carries the check
            tab.design = view.design
    return view


@router.get("/tab/{tab_id}/download/{name}")
async def download(request: Request, tab_id: str, name: str) -> Response:
    """The model JSON, MATLAB/Octave script, design JSON or HTML report of the tab."""
    tab = _tab(request, tab_id)
    if name not in DOWNLOADS:
        raise OptionError(f"no download {name!r}: use one of {', '.join(DOWNLOADS)}")
    if tab.fit is None:
        raise OptionError("identify a model first: the downloads are the model, its design and the report")
    path = tab.folder / f"motorid-{name}"
    if name == "model.json":
        path.write_text(_uploaded_names(tab.fit.model.to_json_text() + "\n", tab.folder), encoding="utf-8")
    elif name == "model.m":
        path.write_text(_uploaded_names(tab.fit.model.to_matlab(), tab.folder), encoding="utf-8")
    elif name == "design.json":
        if tab.design is None:
            raise OptionError("design a controller first (move a slider in the design panel)")
        path.write_text(tab.design.to_json_text() + "\n", encoding="utf-8")
    elif name in _CODE:
        if tab.design is None or tab.design_form is None:
            raise OptionError("design a controller first (move a slider in the design panel)")
        path.write_text(_controller_code(tab.fit.model, tab.design, tab.design_form, _CODE[name]), encoding="utf-8")
    else:
        validation = [e.files.reader_argument() for e in tab.captures
                      if tab.roles.get(e.cid) == "validation" and e.summary is not None]
        await run_bounded(request, request.app.state.settings.work, "the report", _report, path, tab.fit,
                          tab.design, validation, tab.simulation or None, tab.folder)
        path.write_text(_uploaded_names(path.read_text(encoding="utf-8"), tab.folder), encoding="utf-8")
    return FileResponse(path, media_type=DOWNLOADS[name], filename=path.name)


def _controller_code(model: Any, design: Any, form: Any, language: str) -> str:
    """The design panel's controller as code: sampled every ``dt`` with the panel's rails (as ``design --emit``)."""
    from motorid.control.emit import discretise_design, emit

    dc = discretise_design(model, design, form.dt_s, "zoh", rails=form.saturation_v)
    where = (f"From: motorid serve, the design panel (damping {form.damping:g}, wn {form.wn:g} rad/s"
             + (", integral action" if form.integral else "")
             + (f", observer poles {form.observer_poles}" if form.observer_poles else "") + ")")
    return emit(dc, language, source=where)


def _uploaded_names(text: str, folder: Path) -> str:
    """``text`` with the files named as they were uploaded, not by their place on the server.

    ``ALL0001/F0001CH2.CSV`` instead of ``/tmp/…/tab-…/upload-3/ALL0001/F0001CH2.CSV``.
    """
    import re

    return re.sub(re.escape(str(folder)) + r"[/\\](?:upload-\d+[/\\])?", "", text)


def _report(path: Path, fit: Any, design: Any, validation: list[Any], simulation: dict[str, Any] | None,
            folder: Path) -> None:
    import motorid as mi
    from motorid.io import read_capture

    try:
        # the validation captures as read (a CH1/CH2 pair of any layout), scored in the report
        checks = [read_capture(arg) for arg in validation]
        # the report's closed loop is the run the page showed (its horizon, level and rails)
        mi.write_report(path, fit, design=design, validation=checks, simulation=simulation)
    except MotorIdError as exc:
        raise as_uploaded(exc, folder) from None


@router.post("/tab/{tab_id}/close")
async def close(request: Request, tab_id: str) -> Response:
    """The page is going away (``pagehide`` beacon): delete the tab's folder."""
    request.app.state.tabs.close(tab_id)
    return Response(status_code=204)

"""The app factory.

:func:`create_app` wires the page, the JSON API, the static files, the error mapping and the
temporary folders.

Every :class:`~motorid.errors.MotorIdError` becomes HTTP 422 with the line the command line
prints (``motorid: error: …``): as JSON ``{"detail": …}`` under ``/api``, as an HTML fragment
swapped into the page's error box elsewhere.
"""

from __future__ import annotations

import base64
import html
import tempfile
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from dataclasses import dataclass, field
from pathlib import Path

from fastapi import FastAPI, Request
from fastapi.responses import HTMLResponse, JSONResponse, Response
from fastapi.staticfiles import StaticFiles
from fastapi.templating import Jinja2Templates

from motorid.errors import MotorIdError, OptionError
from motorid.numfmt import roots_text, sig
from motorid.web.guard import LOCAL_HOSTS, LocalOnly
from motorid.web.tabs import TabStore
from motorid.web.uploads import UploadLimits
from motorid.web.work import RequestGoneError, WorkLimits

__all__ = ["WebSettings", "create_app", "error_line"]

_HERE = Path(__file__).resolve().parent
#: A tab keeps at most this many uploads' worth of files (ten 45 MB uploads used to keep 450 MiB).
TAB_QUOTA_UPLOADS = 4


@dataclass(frozen=True, slots=True)
class WebSettings:
    """How the local web app runs.

    Attributes
    ----------
    max_upload_mb : float
        Largest request body [MiB] (``motorid serve --max-upload-mb``).
    max_files : int
        Files in one upload (zip members included).
    max_tabs : int
        Browser tabs kept open at once (the least recently used is closed).
    temp_root : Path or None
        Parent of the server's temporary folder (default: the system's).
    token : str or None
        The secret each request must carry (``?token=``, the page's cookie or ``Authorization:
        Bearer``); None: none (``motorid serve --no-token``, tests).
    hosts : tuple of str
        The ``Host`` names answered (:data:`motorid.web.guard.LOCAL_HOSTS` and the bound address).
    work : WorkLimits
        Time and memory bounds of each identification and report (run in a worker process that
        is stopped when its client leaves).
    """

    max_upload_mb: float = 50.0
    max_files: int = 200
    max_tabs: int = 16
    temp_root: Path | None = None
    token: str | None = None
    hosts: tuple[str, ...] = LOCAL_HOSTS
    work: WorkLimits = field(default_factory=WorkLimits)

    def __post_init__(self) -> None:
        if not (self.max_upload_mb > 0 and self.max_upload_mb <= 4096):
            raise OptionError(f"--max-upload-mb must be in (0, 4096], got {self.max_upload_mb!r}")
        if not 1 <= self.max_files <= 10000:
            raise OptionError(f"the file limit must be 1..10000, got {self.max_files!r}")
        if not 1 <= self.max_tabs <= 1000:
            raise OptionError(f"the tab limit must be 1..1000, got {self.max_tabs!r}")

    @property
    def max_upload_bytes(self) -> int:
        """:attr:`max_upload_mb` in bytes."""
        return int(self.max_upload_mb * 1024 * 1024)

    @property
    def max_tab_bytes(self) -> int:
        """What one tab may keep: four uploads' worth (:data:`TAB_QUOTA_UPLOADS`)."""
        return TAB_QUOTA_UPLOADS * self.max_upload_bytes

    def upload_limits(self) -> UploadLimits:
        """The limits of one upload: the body size, the file count, zips unpacking to at most 4× the body.

        Returns
        -------
        UploadLimits
            For :func:`motorid.web.uploads.receive_form`.
        """
        return UploadLimits(max_bytes=self.max_upload_bytes, max_files=self.max_files,
                            max_unzipped_bytes=4 * self.max_upload_bytes)


def error_line(exc: MotorIdError) -> str:
    """The line the command line prints for ``exc``.

    Parameters
    ----------
    exc : MotorIdError
        A user error.

    Returns
    -------
    str
        ``motorid: error: <message naming the file and the fix>`` on one line.
    """
    return "motorid: error: " + " ".join(str(exc).split())


def create_app(settings: WebSettings | None = None) -> FastAPI:
    """Build the web app.

    Parameters
    ----------
    settings : WebSettings, optional
        Limits and the temporary folder (defaults: 50 MB uploads, 200 files, 16 tabs).

    Returns
    -------
    FastAPI
        Serve it with uvicorn (``motorid serve``) or drive it with ``fastapi.testclient``.
        Its temporary folder is made when it starts and deleted when it stops.
    """
    from motorid.web import api, pages

    settings = settings or WebSettings()

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        root = Path(tempfile.mkdtemp(prefix="motorid-web-", dir=settings.temp_root))
        app.state.tabs = TabStore(root, settings.max_tabs)
        try:
            yield
        finally:
            app.state.tabs.close_all()

    app = FastAPI(title="motorid", lifespan=lifespan, docs_url="/api/docs", redoc_url=None,
                  openapi_url="/api/openapi.json")
    app.state.settings = settings
    templates = Jinja2Templates(directory=str(_HERE / "templates"))
    templates.env.filters["b64"] = lambda data: base64.b64encode(data).decode("ascii")
    # numbers as the terminal writes them: four figures, never "-0", a pair or a double pole once
    templates.env.filters["sig"] = sig
    templates.env.filters["roots"] = lambda values: roots_text(sorted(values, key=lambda p: (p.real, p.imag)))
    app.state.templates = templates
    app.mount("/static", StaticFiles(directory=str(_HERE / "static")), name="static")

    @app.exception_handler(MotorIdError)
    async def _user_error(request: Request, exc: MotorIdError) -> Response:
        line = error_line(exc)
        if request.url.path.startswith("/api/"):
            return JSONResponse({"detail": line}, status_code=422)
        # htmx swaps this into the page's error box (HX-Retarget), whatever the request's target;
        # a failed step empties the panel it would have filled (out of band), so that no older
        # result stays on screen under the error
        stale = ""
        if request.url.path.endswith("/identify"):
            stale = '<section id="model" hx-swap-oob="true"></section>'
        elif request.url.path.endswith("/design"):
            stale = '<div id="design-result" hx-swap-oob="true"></div>'
        return HTMLResponse(f'<p class="error">{html.escape(line)}</p>{stale}', status_code=422,
                            headers={"HX-Retarget": "#errors", "HX-Reswap": "innerHTML"})

    @app.exception_handler(RequestGoneError)
    async def _gone(request: Request, exc: RequestGoneError) -> Response:
        # the client left and its worker was stopped: nobody reads this answer
        return Response(status_code=499)

    app.include_router(api.router)
    app.include_router(pages.router)
    app.add_middleware(LocalOnly, token=settings.token, hosts=settings.hosts)
    return app

"""The local web page of the lab (``motorid serve``).

FastAPI + Jinja2 + htmx, every asset shipped in the package.

   create_app     -- the FastAPI app (page, JSON API, temporary folders)
   WebSettings    -- upload limits, tab limit, temporary folder

Modules: :mod:`.app` (factory, error mapping), :mod:`.pages` (the page's htmx fragments),
:mod:`.api` (``POST /api/identify|design|simulate``), :mod:`.uploads` (streamed multipart,
safe names, safe zips), :mod:`.tabs` (a temporary folder per browser tab), :mod:`.views`
(what the panels show), :mod:`.modemap` (the six-mode map with the design marked),
:mod:`.options` (form fields → the front door's options).

This package sits above :mod:`motorid.frontdoor` and below :mod:`motorid.cli`; it needs the
``web`` extra (``pip install motorid[web]``).
"""

from motorid.web.app import WebSettings, create_app

__all__ = ["WebSettings", "create_app"]

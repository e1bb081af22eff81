"""One temporary folder and one working state per browser tab.

A page load opens a tab (a random id in the page); its uploads, identification, design and
downloads live under ``<root>/tab-<id>/``.  The page's ``pagehide`` beacon closes the tab
(folder deleted); the server deletes the whole root when it stops; the least recently used
tab is closed when more than ``max_tabs`` are open.
"""

from __future__ import annotations

import re
import secrets
import shutil
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from motorid.errors import OptionError

if TYPE_CHECKING:
    from motorid.conditioning.inspect import CaptureSummary
    from motorid.control.design import Design
    from motorid.frontdoor import IdentificationResult
    from motorid.web.uploads import CaptureFiles

__all__ = ["CaptureEntry", "Tab", "TabStore"]

_TAB_ID = re.compile(r"^[0-9a-f]{32}$")
#: Roles a capture can be given on the page (``validation``: scored in the report; ``ignore``).
PAGE_ROLES: tuple[str, ...] = ("position", "velocity", "current", "validation", "ignore")


@dataclass(frozen=True, slots=True)
class CaptureEntry:
    """An uploaded capture as the inspect table shows it.

    Attributes
    ----------
    cid : str
        Its id on the page (``c0``, ``c1``…).
    files : CaptureFiles
        Its stored files.
    summary : CaptureSummary or None
        What ``motorid inspect`` says about it (``None`` when unreadable).
    error : str or None
        Why it could not be read.
    guessed_role : str
        One of :data:`PAGE_ROLES`.
    """

    cid: str
    files: CaptureFiles
    summary: CaptureSummary | None
    error: str | None
    guessed_role: str


@dataclass
class Tab:
    """The working state of one browser tab (mutable: it is the session, not a result)."""

    def reset(self) -> None:
        """Forget the captures, the model and the design (the files are the caller's to remove)."""
        self.captures.clear()
        self.ignored.clear()
        self.roles.clear()
        self.fit = self.design = None
        self.simulation = {}
        self.mode_maps.clear()
        self.canvas = None
        self.design_form = None
        self.shown_run = None

    def stored_bytes(self) -> int:
        """The bytes of the files this tab keeps.

        Returns
        -------
        int
            The sum of its regular files' sizes.
        """
        return sum(p.stat().st_size for p in self.folder.rglob("*") if p.is_file() and not p.is_symlink())

    tab_id: str
    folder: Path
    captures: list[CaptureEntry] = field(default_factory=list)
    ignored: list[str] = field(default_factory=list)
    roles: dict[str, str] = field(default_factory=dict)
    fit: IdentificationResult | None = None
    design: Design | None = None
    simulation: dict[str, Any] = field(default_factory=dict)
    mode_maps: dict[tuple[Any, ...], Any] = field(default_factory=dict)
    uploads: int = 0
    last_seen: float = field(default_factory=time.monotonic)
    lock: threading.RLock = field(default_factory=threading.RLock)
    #: The closed-loop figure kept between slider moves (a ``report.figures.ClosedLoopCanvas``).
    canvas: Any = None
    #: The design panel's inputs of :attr:`design` (a ``views.DesignForm``).
    design_form: Any = None
    #: The closed-loop run shown for :attr:`design_form` (a ``SimulationResult``): the
    #: robustness check redraws it with the plausible motors' band instead of running it again.
    shown_run: Any = None


class TabStore:
    """The open tabs of one server, each with its folder under ``root``.

    Parameters
    ----------
    root : Path
        The server's temporary folder (created if missing).
    max_tabs : int
        Open tabs kept; opening one more closes the least recently used.
    """

    def __init__(self, root: Path, max_tabs: int = 16) -> None:
        self.root = root
        self.max_tabs = max_tabs
        self._tabs: dict[str, Tab] = {}
        self._lock = threading.Lock()
        root.mkdir(parents=True, exist_ok=True)

    def open(self) -> Tab:
        """Open a new tab with an empty folder.

        Returns
        -------
        Tab
            Its id is 32 random hex digits.
        """
        tab_id = secrets.token_hex(16)
        tab = Tab(tab_id, self.root / f"tab-{tab_id}")
        tab.folder.mkdir()
        with self._lock:
            self._tabs[tab_id] = tab
            while len(self._tabs) > self.max_tabs:
                oldest = min(self._tabs.values(), key=lambda t: t.last_seen)
                self._drop(oldest.tab_id)
        return tab

    def get(self, tab_id: str) -> Tab:
        """The open tab ``tab_id``.

        Parameters
        ----------
        tab_id : str
            The id the page holds.

        Returns
        -------
        Tab
            Marked as just seen.

        Raises
        ------
        OptionError
            An unknown or closed tab (the page must be reloaded).
        """
        with self._lock:
            tab = self._tabs.get(tab_id) if _TAB_ID.match(tab_id) else None
        if tab is None:
            raise OptionError("this page's session is closed or unknown (server restarted, or too many tabs): "
                              "reload the page")
        tab.last_seen = time.monotonic()
        if not tab.folder.is_dir():  # a temporary-file cleaner removed it under the running server
            with tab.lock:
                tab.folder.mkdir(parents=True, exist_ok=True)
                tab.reset()
            raise OptionError("this page's files were removed from the server's temporary folder (a cleaner?): "
                              "the page starts over — drop the captures again")
        return tab

    def close(self, tab_id: str) -> bool:
        """Close a tab and delete its folder.

        Parameters
        ----------
        tab_id : str
            The id the page holds.

        Returns
        -------
        bool
            Whether the tab was open.
        """
        with self._lock:
            return self._drop(tab_id)

    def close_all(self) -> None:
        """Close every tab and delete the root folder."""
        with self._lock:
            for tab_id in list(self._tabs):
                self._drop(tab_id)
        shutil.rmtree(self.root, ignore_errors=True)

    def __len__(self) -> int:
        return len(self._tabs)

    def _drop(self, tab_id: str) -> bool:
        tab = self._tabs.pop(tab_id, None)
        if tab is None:
            return False
        shutil.rmtree(tab.folder, ignore_errors=True)
        return True

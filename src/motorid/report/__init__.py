"""The HTML report of an experiment (figures in :mod:`.figures`, the page in :mod:`.html`)."""

__all__ = ["SECTIONS", "ReportInputs", "build_report"]


def __getattr__(name: str):
    # the page (and matplotlib) load on first use: ``motorid.report.summary`` (the text the
    # command line prints) must not pull matplotlib into ``motorid identify``
    if name in __all__:
        from motorid.report import html

        return getattr(html, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

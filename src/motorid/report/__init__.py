"""The HTML report of an experiment (figures in :mod:`.figures`, the page in :mod:`.html`)."""

from motorid.report.html import SECTIONS, ReportInputs, build_report

__all__ = ["SECTIONS", "ReportInputs", "build_report"]
